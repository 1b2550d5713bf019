"""The layout: every import points down the layers, and long files say why they are long."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "femupdate"

#: The layers, bottom up: a module may import the layers below and its own package's modules
#: of its layer. A dotted name places one module of a package in a layer of its own: the
#: case's model (``problem.case_model``, ``problem.reduced_path``: a case built and simulated)
#: sits below the trials, which simulate it for virtual experiments, and the rest of
#: ``problem`` (the error function over the trials) above them.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "units"),
    ("_optional", "_parallel", "console"),
    ("data", "model", "optimize", "external"),
    ("simulate", "runs"),
    ("case", "evaluation"),
    ("problem.case_model", "problem.reduced_path"),
    ("trials",),
    ("problem",),
    ("inference",),
    ("pipeline",),
    ("paper",),
    ("report",),
    ("cli",),
    ("__main__", "__init__"),
)
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}
#: Longer files must give the reason in their module docstring.
MAX_LINES = 600
REASON = "Why this file is long"


#: What ``femupdate.case`` (schema and validation) may import besides itself: no simulation, no
#: model building for a run (``problem``), nothing above it.
CASE_MAY_IMPORT = {"errors", "units", "data", "model", "optimize"}


def _layer(parts: list[str]) -> str:
    """The layer name of a module given by its parts below ``femupdate``: its package, or
    ``package.module`` where LAYERS names that module."""
    top = parts[0].removesuffix(".py")
    if len(parts) > 1:
        dotted = f"{top}.{parts[1].removesuffix('.py')}"
        if dotted in RANK:
            return dotted
    return top


def _top(module: Path) -> str:
    return _layer(list(module.relative_to(PACKAGE).parts))


def _package(layer: str) -> str:
    return layer.split(".")[0]


def _imports(module: Path) -> list[tuple[int, str]]:
    """(line, layer name) of every femupdate import, lazy ones included."""
    tree = ast.parse(module.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
            if node.module == "femupdate":  # from femupdate import x
                names = [f"femupdate.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "femupdate" and len(parts) > 1:
                found.append((node.lineno, _layer(parts[1:])))
    return found


def test_every_module_has_a_layer() -> None:
    tops = {_top(m) for m in PACKAGE.rglob("*.py")}
    assert tops <= set(RANK), f"modules without a layer: {sorted(tops - set(RANK))}"


def test_imports_only_point_down() -> None:
    upward = []
    for module in sorted(PACKAGE.rglob("*.py")):
        top = _top(module)
        for line, target in _imports(module):
            same_layer = RANK.get(target) == RANK[top] and _package(target) == _package(top)
            if target != top and target in RANK and RANK[target] >= RANK[top] and not same_layer:
                upward.append(f"{module.relative_to(PACKAGE)}:{line} imports femupdate.{target} "
                              f"(layer {RANK[target]} ≥ {RANK[top]})")
    assert not upward, "imports that do not point down the layers:\n" + "\n".join(upward)


def test_the_layer_check_sees_an_upward_import(tmp_path: Path) -> None:
    # The check itself: a lazy import of the report from the pipeline is an upward arrow.
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from femupdate.report.figures import plot_fit\n")
    assert _imports(module) == [(2, "report")]
    assert RANK["report"] > RANK["pipeline"]


def test_the_case_model_sits_below_the_trials_and_the_problem_above() -> None:
    # problem.case_model is a layer of its own: importing it from the trials points down,
    # importing the error function from it would point up.
    assert _layer(["problem", "case_model.py"]) == "problem.case_model"
    assert _layer(["problem", "update.py"]) == "problem"
    assert RANK["case"] < RANK["problem.case_model"] < RANK["trials"] < RANK["problem"]


def test_case_is_schema_and_validation_only() -> None:
    # femupdate.case imports no simulation (simulate, evaluation, external), no model building
    # for a run (problem) and nothing above it; lazy and type-only imports count too.
    found = {f"{m.relative_to(PACKAGE)}:{line} imports femupdate.{target}"
             for m in sorted((PACKAGE / "case").rglob("*.py")) for line, target in _imports(m)
             if _package(target) not in CASE_MAY_IMPORT | {"case"}}
    assert not found, "case imports beyond schema and validation:\n" + "\n".join(sorted(found))
    assert not CASE_MAY_IMPORT & {"simulate", "evaluation", "external", "problem", "trials"}


def test_the_case_check_sees_a_lazy_simulation_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from femupdate.simulate.exact import ExactSimulator\n"
                      "    from femupdate.problem.case_model import CaseModel\n")
    targets = [target for _, target in _imports(module)]
    assert targets == ["simulate", "problem.case_model"]
    assert not {_package(t) for t in targets} <= CASE_MAY_IMPORT


def test_long_files_say_why() -> None:
    unexplained = []
    for module in sorted(PACKAGE.rglob("*.py")):
        text = module.read_text(encoding="utf-8")
        if text.count("\n") > MAX_LINES and REASON not in (ast.get_docstring(ast.parse(text))
                                                          or ""):
            unexplained.append(f"{module.relative_to(PACKAGE)}: {text.count(chr(10))} lines")
    assert not unexplained, (f"files over {MAX_LINES} lines without '{REASON}' in their "
                             "docstring:\n" + "\n".join(unexplained))


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _runtime_imports(path: Path, modules: set[str]) -> set[str]:
    """The femupdate modules ``path`` imports when it runs, lazy imports included (those
    under ``if TYPE_CHECKING:`` are for the type checker only)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(block.test)
                   for stmt in block.body for n in ast.walk(stmt)}
    found = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [f"{node.module}.{a.name}" for a in node.names] + [node.module]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            while name and name not in modules:
                name = name.rpartition(".")[0]
            if name and name != "femupdate":
                found.add(name)
                break
    return found


def test_no_import_cycles() -> None:
    # A module may import its own subpackages' modules (a package's __init__ re-exports);
    # otherwise no chain of imports, lazy ones included, leads back to where it started.
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {m: {d for d in _runtime_imports(p, set(paths)) if d != m
                 and not m.startswith(f"{d}.") and not d.startswith(f"{m}.")}
             for m, p in paths.items()}
    cycles = []

    def visit(module: str, trail: list[str], done: set[str]) -> None:
        for dep in sorted(graph[module]):
            if dep in trail:
                cycles.append(" → ".join([*trail[trail.index(dep):], dep]))
            elif dep not in done:
                visit(dep, [*trail, dep], done)
        done.add(module)

    done: set[str] = set()
    for module in sorted(graph):
        if module not in done:
            visit(module, [module], done)
    assert not cycles, "import cycles:\n" + "\n".join(sorted(set(cycles))[:20])
