"""The posterior's console tables: 80 columns, every number whole, intervals whose ends differ."""

from __future__ import annotations

import io

from rich.console import Console

from femupdate.inference.records import LaplaceRecord, Marginal, PosteriorRecord
from femupdate.pipeline.posterior.console import (
    interval_digits,
    number,
    print_laplace,
    print_posterior,
)

#: The viscous bridge's marginals as a narrow posterior gives them (E's interval 0.24 % wide)
BRIDGE = {"E": (2.0965e11, 1.6e8, 2.0940e11, 2.0991e11), "kp1": (1.234e8, 9.1e7, 2.1e7, 4.6e8),
          "kp2": (320411.0, 1.3e3, 318123.0, 322456.0), "kp3": (1.9003e6, 4.1e3, 1.8935e6,
                                                               1.9071e6),
          "kp4": (450123.0, 900.0, 448650.0, 451599.0), "c1": (5.01, 0.05, 4.93, 5.09),
          "c2": (400.2, 3.1, 395.1, 405.3), "c3": (3001.0, 12.0, 2981.0, 3021.0),
          "c4": (6.001, 0.4, 5.3, 6.6)}


def _marginal(q50: float, sd: float, q05: float, q95: float) -> Marginal:
    return Marginal(mean=q50, sd=sd, q05=q05, q50=q50, q95=q95)


def _render(print_it, *args) -> str:  # type: ignore[no-untyped-def]
    buffer = io.StringIO()
    print_it(*args, Console(file=buffer, width=80, color_system=None))
    return buffer.getvalue()


def test_interval_digits_tell_the_ends_apart() -> None:
    assert interval_digits(1.0, 2.0) == 4
    assert interval_digits(1.2001e6, 1.2009e6) == 5  # 1.200e+06 vs 1.201e+06, one more
    assert [number(v, 5) for v in (1.2001e6, 1.2009e6, 1.0, 1500.0)] == [
        "1.2001e+06", "1.2009e+06", "1.0000", "1500.0"]
    assert interval_digits(3.0, 3.0) == 4 and interval_digits(float("nan"), 1.0) == 4


def test_the_posterior_table_fits_80_columns_with_every_number_whole() -> None:
    params = {n: _marginal(*v) for n, v in BRIDGE.items()}
    record = PosteriorRecord(
        method="tmcmc", error_model="neff", samples=4000, seed=0, nfev=25_000, wall_s=20.0,
        reached=True, message="β = 1 reached", log_evidence=-1234.5, ess=1500.0,
        names=list(params), params=params, runs=4,
        ess_params={n: 1500.0 + i for i, n in enumerate(params)},
        rhat={n: 1.001 for n in params},
        frequencies_hz={"f1": _marginal(24.123456, 0.01, 24.10, 24.14)})
    text = _render(print_posterior, record)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= 80
    assert "…" not in text
    e_row = next(line for line in lines if line.strip().startswith("E "))
    assert "2.094e+11" in e_row and "2.099e+11" in e_row  # its ends, told apart
    assert all(any(line.strip().startswith(f"{n} ") for line in lines) for n in params)


def test_the_laplace_table_fits_80_columns_with_intervals_told_apart() -> None:
    params = {n: _marginal(*v) for n, v in BRIDGE.items()}
    record = LaplaceRecord(error_model="neff", names=list(params), params=params, nfev=37)
    text = _render(print_laplace, record, {n: v[0] for n, v in BRIDGE.items()})
    assert max(len(line) for line in text.splitlines()) <= 80 and "…" not in text
    assert "[2.094e+11, 2.099e+11]" in text
