"""The large shear-building case of ``examples/large/make_case.py``: its text and truth, for
the example script, the reduced path's tests and ``benchmarks/reduced_case.py``.

A uniform building of ``storeys`` floors of 1 kg with storey stiffnesses in ``groups``
parameters (consecutive storeys share one), ``k0 = 64 n²`` N/m at the nominal point (first
mode near 2 Hz, modes about 4 Hz apart at every size), Rayleigh damping (α = 0.4 1/s,
β = 5e-4 s), absolute accelerations at floors n/3, 2n/3 and n.
"""

from __future__ import annotations

__all__ = ["case_text", "sensor_floors", "stiffness", "truth"]


def stiffness(storeys: int) -> float:
    """The nominal storey stiffness (N/m): first mode near 2 Hz at every size."""
    return 64.0 * storeys * storeys


def sensor_floors(storeys: int) -> list[int]:
    """The instrumented floors (1-based): n/3, 2n/3 and the roof."""
    return [max(storeys // 3, 1), max(2 * storeys // 3, 1), storeys]


def truth(storeys: int, groups: int) -> dict[str, float]:
    """Truth values of the groups' stiffnesses: 0.8 to 1.2 of nominal, alternating."""
    k0 = stiffness(storeys)
    return {f"k{g + 1}": float(f"{k0 * (0.8 + 0.4 * ((7 * g) % groups) / max(groups - 1, 1)):.4g}")
            for g in range(groups)}


def _wrapped(items: list[str], indent: str = "  ") -> str:
    lines = [", ".join(items[i:i + 12]) for i in range(0, len(items), 12)]
    return "[\n" + ",\n".join(indent + line for line in lines) + ",\n]"


def case_text(storeys: int, groups: int, *, name: str | None = None, method: str | None = None,
              data_directory: str = "data") -> str:
    """The case file's text."""
    k0 = stiffness(storeys)
    names = [f'"k{i * groups // storeys + 1}"' for i in range(storeys)]
    params = "\n".join(
        f'[[parameters]]\nname = "k{g + 1}"\nlower = {0.5 * k0:.6g}\nupper = {1.5 * k0:.6g}\n'
        for g in range(groups))
    outputs = "\n".join(
        f'[[data.outputs]]\nfile = "floors.csv"\ncolumn = "a{f}"\nnode = "F{f}"\ndof = "ux"\n'
        for f in sensor_floors(storeys))
    simulation = "" if method is None else f'[simulation]\nmethod = "{method}"\n\n'
    return f"""\
# A {storeys}-storey shear building with {groups} storey-stiffness parameters, made by
# examples/large/make_case.py. A linear model this large takes the reduced path by default
# (its lowest modes, sparse; docs/large-models.md).
[case]
name = "{name or f'shear-building-{storeys}'}"

[model.shear_building]
masses = {_wrapped(['1.0'] * storeys)}
stiffnesses = {_wrapped(names)}

[model.rayleigh]
alpha = 0.4
beta = 5e-4

{params}
[data]
format = "csv"
directory = "{data_directory}"
time_column = "t"
input = {{ file = "table.csv", column = "table" }}

{outputs}
[objective]
quantity = "acceleration"

{simulation}[search]
method = "multistart-lm"
runs = 2
max_evals = 1000
seed = 22
"""
