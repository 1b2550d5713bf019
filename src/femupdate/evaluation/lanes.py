"""The friction recurrence for several points at once, one point per lane of a SIMD vector.

The central-difference recurrence with friction (:func:`femupdate.evaluation.central._kernel`)
is a long chain of scalar operations per step, and numba's LLVM vectorises none of its forms
(over the modes or over the points: it cannot rule out that the arrays overlap, or finds no
seed). A batch of points runs the same operations on different numbers, so here they are
written as LLVM IR on ``<L x double>`` vectors, lane q holding point q, through a numba
intrinsic (:func:`friction_intrinsic`): L points cost little more than one (4 points in 1.1 ms
against 1.04 ms for one, friction bridge, 47,680 steps).

One point runs the same IR with ``L = 1`` (scalar ``double``): every lane computes exactly what
the one-lane kernel computes, so a batch gives the single calls' values bit for bit.

Layout: every coefficient array has the lanes last (``modal`` (3, n, L), ``yf`` and ``pf``
(n_f, n, L), ``limit`` (n_f, L), ``po`` (n_out, n, L), ``eta0`` (2, n, L)), C-contiguous, so
that a coefficient of all lanes is one vector load; the outputs go to ``y`` (L, n_out,
n_samples). With ``L = 1`` these are the arrays of :class:`femupdate.evaluation.central.
CentralWork` reshaped, without a copy.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic

from femupdate.simulate._common import DIVERGENCE_LIMIT

__all__ = ["LANES", "LaneWork", "friction_intrinsic", "lane_work", "to_lane"]

#: Points per vector: four doubles (AVX2). Eight measured no faster per point here.
LANES = 4

#: As the compiled kernels' fastmath: contraction into FMAs and reassociation, no 'nnan'/'ninf'
#: (the divergence check must see NaN).
_FLAGS = ("contract", "reassoc")

#: Codes of the output quantity (as central.RELATIVE_ACCELERATION, …).
_DISPLACEMENT = 1
_ABSOLUTE_ACCELERATION = 2


class LaneWork(NamedTuple):
    """The coefficients and outputs of ``LANES`` points, lanes last (see the module doc)."""

    modal: np.ndarray  # (3, n, L)
    yf: np.ndarray  # (n_f, n, L)
    pf: np.ndarray  # (n_f, n, L)
    limit: np.ndarray  # (n_f, L)
    po: np.ndarray  # (n_out, n, L)
    eta0: np.ndarray  # (2, n, L)
    y: np.ndarray  # (L, n_out, n_samples)
    rows: np.ndarray  # (L,) int64: the row of a batch's last group in each lane, -1: none


def lane_work(n: int, n_friction: int, n_out: int, n_samples: int) -> LaneWork:
    """Zeroed buffers for ``LANES`` points (a lane never filled then runs zeros, quickly)."""
    lanes = LANES
    return LaneWork(
        modal=np.zeros((3, n, lanes)), yf=np.zeros((n_friction, n, lanes)),
        pf=np.zeros((n_friction, n, lanes)), limit=np.zeros((n_friction, lanes)),
        po=np.zeros((n_out, n, lanes)), eta0=np.zeros((2, n, lanes)),
        y=np.zeros((lanes, n_out, n_samples)), rows=np.full(lanes, -1, dtype=np.int64),
    )


class _Builder:
    """Vector arithmetic on ``L`` lanes (``L = 1``: plain doubles) for one IR builder."""

    def __init__(self, builder: ir.IRBuilder, lanes: int) -> None:
        self.b = builder
        self.lanes = lanes
        self.f64 = ir.DoubleType()
        self.type = ir.VectorType(self.f64, lanes) if lanes > 1 else self.f64
        self.i64 = ir.IntType(64)
        self.i32 = ir.IntType(32)

    def load(self, base: ir.Value, offset: int) -> ir.Value:
        """The L doubles at element ``offset`` of the double pointer ``base``."""
        ptr = self.b.gep(base, [ir.Constant(self.i64, offset)])
        return self.b.load(self.b.bitcast(ptr, self.type.as_pointer()), align=8)

    def splat(self, x: ir.Value) -> ir.Value:
        """A double in every lane."""
        if self.lanes == 1:
            return x
        v = self.b.insert_element(ir.Constant(self.type, ir.Undefined), x,
                                  ir.Constant(self.i32, 0))
        mask = ir.Constant(ir.VectorType(self.i32, self.lanes), [0] * self.lanes)
        return self.b.shuffle_vector(v, ir.Constant(self.type, ir.Undefined), mask)

    def lane(self, v: ir.Value, q: int) -> ir.Value:
        return v if self.lanes == 1 else self.b.extract_element(v, ir.Constant(self.i32, q))

    def mul(self, x: ir.Value, y: ir.Value) -> ir.Value:
        return self.b.fmul(x, y, flags=_FLAGS)

    def add(self, x: ir.Value, y: ir.Value) -> ir.Value:
        return self.b.fadd(x, y, flags=_FLAGS)

    def sub(self, x: ir.Value, y: ir.Value) -> ir.Value:
        return self.b.fsub(x, y, flags=_FLAGS)

    def total(self, terms: list[ir.Value]) -> ir.Value:
        """``terms[0] + terms[1] + …``, left to right."""
        acc = terms[0]
        for t in terms[1:]:
            acc = self.add(acc, t)
        return acc

    def max(self, x: ir.Value, y: ir.Value) -> ir.Value:
        """``x if x > y else y``: one ``maxpd``."""
        return self.b.select(self.b.fcmp_ordered(">", x, y), x, y)

    def min(self, x: ir.Value, y: ir.Value) -> ir.Value:
        return self.b.select(self.b.fcmp_ordered("<", x, y), x, y)

    def fabs(self, x: ir.Value) -> ir.Value:
        name = f"llvm.fabs.v{self.lanes}f64" if self.lanes > 1 else "llvm.fabs.f64"
        fn = cgutils.get_or_insert_function(self.b.module, ir.FunctionType(self.type, [self.type]),
                                            name)
        return self.b.call(fn, [x])


def friction_intrinsic(n: int, n_friction: int, n_out: int, substeps: int,
                       lanes: int) -> Callable[..., Any]:
    """A numba intrinsic ``kernel(ag, h, quantity, r_out, modal, yf, pf, limit, po, eta0, y)
    -> int64`` running the friction recurrence of ``lanes`` points (n modes, n_f elements with
    force or zero rows, n_out outputs, ``substeps`` per sample), the bit mask of the lanes that
    diverged as its value.

    Per lane, the arithmetic of :func:`femupdate.evaluation.central._kernel` (the element law
    on the elastic deformation, the modal update, the outputs at each sample's first substep),
    its sums associated otherwise. Once every lane has diverged the remaining samples are
    skipped. The arrays must be C-contiguous float64 of the sizes given (refused at typing
    otherwise, for layout and type).
    """

    @intrinsic
    def kernel(typingctx: Any, ag: Any, h: Any, quantity: Any, r_out: Any, modal: Any, yf: Any,
               pf: Any, limit: Any, po: Any, eta0: Any, y: Any) -> tuple[Any, Callable]:
        arrays = (ag, r_out, modal, yf, pf, limit, po, eta0, y)
        if not all(isinstance(a, types.Array) and a.layout == "C" and a.dtype == types.float64
                   for a in arrays):
            raise TypingError("friction lanes: the arrays must be C-contiguous float64")
        sig = types.int64(ag, h, quantity, r_out, modal, yf, pf, limit, po, eta0, y)

        def codegen(context: Any, builder: ir.IRBuilder, signature: Any, args: Any) -> ir.Value:
            data = [context.make_array(ty)(context, builder, value).data
                    if isinstance(ty, types.Array) else value
                    for ty, value in zip(signature.args, args, strict=True)]
            ag_, h_, quantity_, r_out_, modal_, yf_, pf_, limit_, po_, eta0_, y_ = data
            n_samples = builder.extract_value(
                context.make_array(signature.args[0])(context, builder, args[0]).shape, 0)
            return _emit(_Builder(builder, lanes), n, n_friction, n_out, substeps, ag_, h_,
                         quantity_, r_out_, modal_, yf_, pf_, limit_, po_, eta0_, y_,
                         n_samples)

        return sig, codegen

    return kernel


def _emit(v: _Builder, n: int, nf: int, n_out: int, substeps: int, ag: ir.Value,
          h: ir.Value, quantity: ir.Value, r_out: ir.Value, modal: ir.Value, yf: ir.Value,
          pf: ir.Value, limit: ir.Value, po: ir.Value, eta0: ir.Value, y: ir.Value,
          n_samples: ir.Value) -> ir.Value:
    """The IR of :func:`friction_intrinsic`'s kernel; returns the mask of diverged lanes."""
    b, L, i64 = v.b, v.lanes, v.i64
    ca = [v.load(modal, i * L) for i in range(n)]
    cb = [v.load(modal, (n + i) * L) for i in range(n)]
    cg = [v.load(modal, (2 * n + i) * L) for i in range(n)]
    deform = [[v.load(yf, (e * n + i) * L) for i in range(n)] for e in range(nf)]
    push = [[v.load(pf, (e * n + i) * L) for i in range(n)] for e in range(nf)]
    lim = [v.load(limit, e * L) for e in range(nf)]
    neg_lim = [b.fneg(x) for x in lim]
    out_coef = [[v.load(po, (o * n + i) * L) for i in range(n)] for o in range(n_out)]
    u = [cgutils.alloca_once_value(b, v.load(eta0, i * L)) for i in range(n)]
    p = [cgutils.alloca_once_value(b, v.load(eta0, (n + i) * L)) for i in range(n)]
    zero = v.splat(ir.Constant(v.f64, 0.0))
    s = [cgutils.alloca_once_value(b, zero) for _ in range(nf)]
    bad_type = ir.IntType(L)
    bad = cgutils.alloca_once_value(b, ir.Constant(bad_type, 0))  # bit q: lane q diverged
    all_bad = ir.Constant(bad_type, (1 << L) - 1)
    inv_h2 = b.fdiv(ir.Constant(v.f64, 1.0), b.fmul(h, h))
    two = v.splat(ir.Constant(v.f64, 2.0))
    limit_div = v.splat(ir.Constant(v.f64, DIVERGENCE_LIMIT))

    def substep(at: ir.Value, k: ir.Value, ak: ir.Value, at_sample: bool) -> None:
        cur = [b.load(x) for x in u]
        prev = [b.load(x) for x in p]
        t = []
        for e in range(nf):  # w: deformation, t: elastic deformation, s: slip offset
            w = v.total([v.mul(deform[e][i], cur[i]) for i in range(n)])
            te = v.min(v.max(v.sub(w, b.load(s[e])), neg_lim[e]), lim[e])
            b.store(v.sub(w, te), s[e])
            t.append(te)
        at_v = v.splat(at)
        new = []
        for i in range(n):
            force = v.total([v.mul(push[e][i], t[e]) for e in range(nf)])
            linear = v.add(v.sub(v.mul(ca[i], cur[i]), v.mul(cb[i], prev[i])),
                           v.mul(cg[i], at_v))
            new.append(v.sub(linear, force))
        if at_sample:
            _outputs(v, n, n_out, new, cur, prev, out_coef, two, inv_h2, quantity, r_out, ak, y,
                     k, n_samples)
            ok = b.fcmp_ordered("<", v.total([v.fabs(x) for x in new]), limit_div)
            diverged = b.bitcast(b.not_(ok), bad_type) if L > 1 else b.not_(ok)
            b.store(b.or_(b.load(bad), diverged), bad)
        for i in range(n):
            b.store(cur[i], p[i])
            b.store(new[i], u[i])

    with cgutils.for_range(b, n_samples) as loop:
        k = loop.index
        with b.if_then(b.icmp_unsigned("!=", b.load(bad), all_bad)):
            ak = b.load(b.gep(ag, [k]))
            last = b.icmp_signed("==", k, b.sub(n_samples, ir.Constant(i64, 1)))
            ak_next = b.load(b.gep(ag, [b.select(last, k, b.add(k, ir.Constant(i64, 1)))]))
            step = b.fdiv(b.fsub(ak_next, ak), ir.Constant(v.f64, float(substeps)))
            substep(ak, k, ak, True)
            with b.if_then(b.not_(last)), cgutils.for_range(
                    b, ir.Constant(i64, substeps - 1)) as inner:
                j = b.sitofp(b.add(inner.index, ir.Constant(i64, 1)), v.f64)
                substep(b.fadd(ak, b.fmul(j, step)), k, ak, False)
    return b.zext(b.load(bad), i64)


def _outputs(v: _Builder, n: int, n_out: int, new: list[ir.Value], cur: list[ir.Value],
             prev: list[ir.Value], out_coef: list[list[ir.Value]], two: ir.Value,
             inv_h2: ir.Value, quantity: ir.Value, r_out: ir.Value, ak: ir.Value, y: ir.Value,
             k: ir.Value, n_samples: ir.Value) -> None:
    """Each lane's outputs at sample k into y[q, o, k]: displacement, or the acceleration as
    a second difference (relative, or absolute with ``r_out[o] · a_g``)."""
    b, i64 = v.b, v.i64
    for o in range(n_out):
        displacement = b.icmp_signed("==", quantity, ir.Constant(quantity.type, _DISPLACEMENT))
        with b.if_else(displacement) as (then, otherwise):
            with then:
                value = v.total([v.mul(out_coef[o][i], cur[i]) for i in range(n)])
                _store_lanes(v, value, y, o, n_out, k, n_samples)
            with otherwise:
                second = v.total([
                    v.mul(out_coef[o][i], v.add(v.sub(new[i], v.mul(two, cur[i])), prev[i]))
                    for i in range(n)])
                value = v.mul(second, v.splat(inv_h2))
                absolute = b.icmp_signed("==", quantity,
                                         ir.Constant(quantity.type, _ABSOLUTE_ACCELERATION))
                base = b.fmul(b.load(b.gep(r_out, [ir.Constant(i64, o)])), ak)
                value = b.select(absolute, v.add(value, v.splat(base)), value)
                _store_lanes(v, value, y, o, n_out, k, n_samples)


def _store_lanes(v: _Builder, value: ir.Value, y: ir.Value, o: int, n_out: int, k: ir.Value,
                 n_samples: ir.Value) -> None:
    b = v.b
    for q in range(v.lanes):
        row = b.mul(ir.Constant(v.i64, q * n_out + o), n_samples)
        b.store(v.lane(value, q), b.gep(y, [b.add(row, k)]))


@njit(cache=True)
def to_lane(work: Any, lanes: LaneWork, q: int) -> None:
    """One prepared point's coefficients (a ``central.CentralWork``) into lane ``q``."""
    lanes.modal[:, :, q] = work.modal
    lanes.yf[:, :, q] = work.yf
    lanes.pf[:, :, q] = work.pf
    lanes.limit[:, q] = work.limit
    lanes.po[:, :, q] = work.po
    lanes.eta0[:, :, q] = work.eta0
