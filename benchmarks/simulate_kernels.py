"""Median time per simulation of each integrator on a 10-DOF bridge-like system.

    python benchmarks/simulate_kernels.py [--repeat N] [--threads {1,default,both}]

4,768 samples at dt = 1/1035 s (the paper's record), outputs at the three pier DOFs:
exact (modal first-order-hold filters), central differences with 10 substeps, Newmark (average
acceleration) at the sample rate and with 10 substeps, and the friction version (nonlinear
central differences, 47,680 substeps). Preparation (per system: eigen/LU decompositions) and the
run (per input) are timed separately. BLAS threads matter for the small dense algebra of
preparation on a 2-core machine (pitfalls §1): ``--threads both`` times with the default and with
one BLAS thread (threadpoolctl).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from contextlib import nullcontext

import numpy as np
from scipy.signal import butter, sosfiltfilt
from threadpoolctl import threadpool_limits

from femupdate.model.system import FrictionElements, System
from femupdate.simulate import exact as exact_module
from femupdate.simulate import prepare

DT = 1.0 / 1035.0
N_SAMPLES = 4768
OUTPUTS = [2, 4, 6]


def bridge_like(friction: bool = False) -> System:
    """The 10-DOF bridge-like system of tests/simulate/bridge_like.py (same numbers)."""
    n, L, ei, rho_a = 10, 1.0, 1.0e4, 40.0
    ke = (ei / L**3) * np.array(
        [[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
         [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]]
    )  # fmt: skip
    me = (rho_a * L / 420.0) * np.array(
        [[156, 22 * L, 54, -13 * L], [22 * L, 4 * L**2, 13 * L, -3 * L**2],
         [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L**2, -22 * L, 4 * L**2]]
    )  # fmt: skip
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    for e in range(4):
        K[2 * e : 2 * e + 4, 2 * e : 2 * e + 4] += ke
        M[2 * e : 2 * e + 4, 2 * e : 2 * e + 4] += me
    for d in (0, 2, 4, 6, 8):
        M[d, d] += 20.0
    for d, k in zip((0, 8, 2, 4, 6), (1e9, 1e9, 2e5, 1.5e6, 3e5), strict=True):
        K[d, d] += k
    r = np.zeros(n)
    r[0::2] = 1.0
    C = np.zeros((n, n))
    fr = None
    if friction:
        fr = FrictionElements(
            dof_i=np.array([1, 9, 2, 4, 6], dtype=np.int64),
            dof_j=np.full(5, -1, dtype=np.int64),
            k_r=np.array([2e3, 2e3, 1e5, 5e5, 1e5]),
            f_u=np.array([2.0, 2.0, 20.0, 100.0, 20.0]),
        )
    else:
        for d, c in zip((1, 9, 2, 4, 6), (5.0, 5.0, 150.0, 1500.0, 150.0), strict=True):
            C[d, d] += c
    return System(M=M, C=C, K=K, r=r, friction=fr)


def median_ms(fn: Callable[[], object], repeat: int) -> float:
    fn()  # warm-up (numba compiles or loads its cache)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30)
    parser.add_argument("--threads", choices=["1", "default", "both"], default="both")
    args = parser.parse_args()
    rng = np.random.default_rng(2010)
    sos = butter(4, 40.0, fs=1.0 / DT, output="sos")
    ag = sosfiltfilt(sos, rng.standard_normal(N_SAMPLES))
    ag *= 2.0 / np.max(np.abs(ag))
    linear, frictional = bridge_like(), bridge_like(friction=True)
    cases = [
        ("exact", linear, dict(method="exact")),
        ("central_difference, 10 substeps", linear, dict(method="central_difference", substeps=10)),
        ("newmark, 1 substep", linear, dict(method="newmark")),
        ("newmark, 10 substeps", linear, dict(method="newmark", substeps=10)),
        ("nonlinear (linear system), 10 substeps", linear, dict(method="nonlinear", substeps=10)),
        ("nonlinear friction, 10 substeps", frictional, dict(method="nonlinear", substeps=10)),
    ]
    modes = {"1": [1], "default": [None], "both": [None, 1]}[args.threads]
    print(f"10-DOF bridge-like system, {N_SAMPLES} samples, dt = 1/1035 s, outputs {OUTPUTS}")
    print(f"median of {args.repeat} runs, ms per simulation")
    for limit in modes:
        label = "default BLAS threads" if limit is None else "1 BLAS thread"
        ctx = nullcontext() if limit is None else threadpool_limits(limits=limit)
        with ctx:
            print(f"\n[{label}]")
            print(f"{'integrator':42s} {'prepare':>9s} {'run':>9s} {'both':>9s}")
            for name, system, kw in cases:
                sim = prepare(system, DT, outputs=OUTPUTS, **kw)
                t_prep = median_ms(lambda s=system, k=kw: prepare(s, DT, outputs=OUTPUTS, **k),
                                   args.repeat)  # fmt: skip
                t_run = median_ms(lambda s=sim: s.run(ag), args.repeat)
                t_both = median_ms(
                    lambda s=system, k=kw: prepare(s, DT, outputs=OUTPUTS, **k).run(ag),
                    args.repeat,
                )
                print(f"{name:42s} {t_prep:9.3f} {t_run:9.3f} {t_both:9.3f}")
            sim = prepare(linear, DT, method="exact")
            t_all = median_ms(lambda s=sim: s.run(ag), args.repeat)
            print(f"{'exact, all 10 DOFs output':42s} {'':9s} {t_all:9.3f}")
            # the matrix-exponential path, taken for defective systems: force it to time it
            saved = exact_module.MAX_EIGVEC_CONDITION
            exact_module.MAX_EIGVEC_CONDITION = 0.0
            try:
                t_prep = median_ms(lambda: prepare(linear, DT, outputs=OUTPUTS), args.repeat)
                sim = prepare(linear, DT, outputs=OUTPUTS)
                t_run = median_ms(lambda s=sim: s.run(ag), args.repeat)
            finally:
                exact_module.MAX_EIGVEC_CONDITION = saved
            print(f"{'exact, expm fallback (forced)':42s} {t_prep:9.3f} {t_run:9.3f}")


if __name__ == "__main__":
    main()
