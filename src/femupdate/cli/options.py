"""The command line's shared options and their checks, run before any work (typer callbacks), and
the small readers of option values."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.text import Text

from femupdate.errors import ConfigError

if TYPE_CHECKING:
    from femupdate.case import Case


console = Console(markup=False)


def _inputs() -> Any:
    """femupdate.cli.checks, imported when an option is checked: it loads the case schema, which
    ``femupdate --help`` does not need."""
    import femupdate.cli.checks

    return femupdate.cli.checks


def _path_check(check_name: str, flag: str) -> Any:
    """A typer callback running ``femupdate.cli.checks.<check_name>(flag, value)`` on a path given,
    before any work."""
    def check(value: Path | None) -> Path | None:
        if value is not None:
            getattr(_inputs(), check_name)(flag, value)
        return value
    return check


def _output_file(flag: str) -> Any:
    """A typer callback checking an output file before any work."""
    return _path_check("check_output_file", flag)


def _output_dir(flag: str) -> Any:
    """A typer callback checking an output folder before any work."""
    return _path_check("check_output_dir", flag)


def _input_dir(flag: str) -> Any:
    """A typer callback checking that a folder to read from exists."""
    def check(value: Path | None) -> Path | None:
        if value is not None and not value.is_dir():
            what = "is a file, not a folder" if value.exists() else "does not exist"
            raise ConfigError(f"{flag}: {value} {what} (allowed: the folder that holds the "
                              "data files)")
        return value
    return check


def _search_limit(field: str, flag: str) -> Any:
    """A typer callback holding an override to the case file's range of [search] field."""
    def check(value: int | None) -> int | None:
        from femupdate.case.overrides import check_search_override

        check_search_override(field, value, flag)
        return value
    return check


def _seed_check(flag: str) -> Any:
    """A typer callback holding a seed of a command without a case's [search] (synth, the
    benchmarks) to the range of every seed."""
    def check(value: int | None) -> int | None:
        from femupdate.case.fields import field_range
        from femupdate.case.schema import Search

        rng = field_range(Search.model_fields["seed"])
        if value is not None and not rng.contains(value):
            raise ConfigError(f"{flag}: got {value!r} (allowed: {rng.describe()})")
        return value
    return check


JsonOption = Annotated[
    Path | None, typer.Option("--json", help="Write machine-readable results to this file.",
                              callback=_output_file("--json"))
]


#: The options of the commands that run a case's searches or sampler (run, posterior).
SchedulerOption = Annotated[str | None, typer.Option(
    help="Dask scheduler address, e.g. tcp://host:8786 (extra 'dask').")]
QuietOption = Annotated[bool, typer.Option(help="No progress bar.")]
LogJsonOption = Annotated[Path | None, typer.Option(
    help="Append JSON lines (one per chunk and run event) to this file.",
    callback=_output_file("--log-json"))]
CaseWorkersOption = Annotated[int | None, typer.Option(
    "--workers", min=1, help="Parallel worker processes (default: the case's [search] "
    "workers).", callback=_search_limit("workers", "--workers"))]

WorkersOption = Annotated[
    int, typer.Option("--workers", min=1, callback=_search_limit("workers", "--workers"),
                      help="Parallel worker processes for the benchmark's "
                      "runs (its cases have no [search] workers of their own).")
]


def say(message: str, style: str | None = None, *, out: Console | None = None,
        whole: bool = False) -> None:
    """Print ``message`` as written (no markup), wrapped at spaces to the console's width;
    ``whole``: unwrapped (a command to copy)."""
    (out or console).print(Text(message, style=style or ""), soft_wrap=whole)


def _write_json(path: Path | None, data: Any) -> None:
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, allow_nan=True) + "\n")
    say(f"wrote {path}")


def _fmt(value: float | None, spec: str = ",.0f") -> str:
    return "–" if value is None else format(value, spec)


CaseArgument = Annotated[Path, typer.Argument(help="The case file (TOML).", exists=False)]


def _load(path: Path):
    from femupdate.case import load_case

    return load_case(path)


def _posterior_limit(field: str, flag: str) -> Any:
    """A typer callback holding an override to the range of [posterior] field."""
    def check(value: int | None) -> int | None:
        from femupdate.case.fields import field_range
        from femupdate.case.posterior_section import PosteriorSection

        rng = field_range(PosteriorSection.model_fields[field])
        if value is not None and not rng.contains(value):
            raise ConfigError(f"{flag}: got {value!r} (allowed: {rng.describe()}, as "
                              f"[posterior] {field} in a case file)")
        return value
    return check


def _json_object(flag: str, text: str | None) -> dict[str, Any] | None:
    """A JSON object given inline or as a file (None when not given); ConfigError otherwise."""
    if text is None:
        return None
    raw = _inputs().json_source(text)
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{flag}: {text!r} is neither a JSON file nor a JSON object "
                          f"({exc}) (allowed: a JSON object {{name: value}}, or a file holding "
                          "one)") from None
    if not isinstance(data, dict):
        got = "null" if data is None else type(data).__name__
        raise ConfigError(f"{flag}: expected a JSON object {{name: value}}, got {got} (allowed: "
                          "a JSON object, or a file holding one)")
    return data


def _read_params(flag: str, text: str, case: Case) -> dict[str, float]:
    """Values of every parameter of ``case`` from a JSON object, a JSON file, or a
    summary.json (its best run); ConfigError naming the flag, the parameter and what is
    allowed otherwise."""
    from femupdate.case.checks import check_parameter_values

    data = _json_object(flag, text)
    assert data is not None
    if isinstance(data.get("best"), dict) and "params" in data["best"]:
        data = data["best"]["params"]
    return check_parameter_values(data, case.parameter_names, what=flag)


def _outside_bounds(case: Case, values: dict[str, float]) -> list[str]:
    """The values outside the case's bounds, in words (field, value, bounds)."""
    out = []
    for i, p in enumerate(case.parameters):
        value = values[p.name]
        if not p.lower <= value <= p.upper:
            side = "lower" if value < p.lower else "upper"
            out.append(f"{p.name} = {value:g} is outside its bounds [{p.lower:g}, "
                       f"{p.upper:g}] (parameters[{i}].{side})")
    return out


def _warn_outside_bounds(flag: str, case: Case, values: dict[str, float]) -> None:
    """Say which given values lie outside the case's bounds (no update of it would give
    them)."""
    for problem in _outside_bounds(case, values):
        say(f"warning: {flag}: {problem} in {case.label}", "yellow")

