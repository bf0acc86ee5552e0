"""Explicit fused multiply-adds and 8-lane vectors for the kernels: the same bits on every CPU.

``fastmath`` would let LLVM contract ``a * b + c`` into an FMA where the CPU has one and reorder
sums to fit its vector width, so a result would depend on the machine. Here both are explicit:

- ``fma(a, b, c)``: LLVM's ``llvm.fma.f64``, one rounding of a·b + c; a CPU with FMA runs the
  instruction, any other (``NUMBA_CPU_NAME=generic``) the C library's correctly rounded ``fma``:
  the same result everywhere.
- ``Vec``: eight float64 lanes (``<8 x double>``). The lanes are independent outputs: a sum over
  poses runs in eight partial sums (lane l takes poses l, l + 8, …, each in order) joined in a
  fixed tree (``vsum``), whatever the hardware's vector width (one 512-bit register, two of 256,
  four of 128, or scalars): the order is the program's, not the CPU's.

Imported only when the kinematics kernels compile (it imports numba): kernel modules refer to
these names through ``compile.simd_intrinsic`` stand-ins. Arrays given to ``vload``/``vstore``
must be C-contiguous float64; ``i`` is a flat element index, and the eight elements from it must
lie inside the array.
"""

from __future__ import annotations

from typing import Any

from llvmlite import ir
from numba.core import cgutils, types
from numba.core.extending import intrinsic, models, register_model

from sescid.kinematics._kernels.gram import LANES

_F64 = ir.DoubleType()
_VEC = ir.VectorType(_F64, LANES)
_I32 = ir.IntType(32)


class Vec(types.Type):
    """Eight float64 lanes in one LLVM vector."""

    def __init__(self) -> None:
        super().__init__(name=f"Vec{LANES}xf64")


vec = Vec()


@register_model(Vec)
class _VecModel(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _VEC)


def _address(context, builder, arrty, arr, i):
    data = context.make_array(arrty)(context, builder, arr).data
    return builder.bitcast(builder.gep(data, [i]), _VEC.as_pointer())


@intrinsic
def vload(typingctx, arr, i):
    """The 8 elements arr.flat[i : i + 8] as a vector."""

    def codegen(context, builder, sig, args):
        return builder.load(_address(context, builder, sig.args[0], args[0], args[1]), align=8)

    return vec(arr, i), codegen


@intrinsic
def vstore(typingctx, arr, i, v):
    """arr.flat[i : i + 8] = v."""

    def codegen(context, builder, sig, args):
        builder.store(args[2], _address(context, builder, sig.args[0], args[0], args[1]), align=8)
        return context.get_dummy_value()

    return types.none(arr, i, v), codegen


@intrinsic
def vzero(typingctx):
    """A vector of +0.0."""

    def codegen(context, builder, sig, args):
        return ir.Constant(_VEC, [0.0] * LANES)

    return vec(), codegen


@intrinsic
def vsplat(typingctx, x):
    """X in every lane."""

    def codegen(context, builder, sig, args):
        one = builder.insert_element(ir.Constant(_VEC, ir.Undefined), args[0], ir.Constant(_I32, 0))
        mask = ir.Constant(ir.VectorType(_I32, LANES), [0] * LANES)
        return builder.shuffle_vector(one, ir.Constant(_VEC, ir.Undefined), mask)

    return vec(types.float64), codegen


def _llvm_fn(builder, name: str, n_args: int, ty=_VEC):
    """LLVM's function ``name`` of ``n_args`` arguments of type ``ty`` (and its result), declared
    in the builder's module."""
    return cgutils.get_or_insert_function(builder.module, ir.FunctionType(ty, [ty] * n_args), name)


@intrinsic
def vfma(typingctx, a, b, c):
    """a·b + c lane by lane, each rounded once (``llvm.fma``)."""

    def codegen(context, builder, sig, args):
        return builder.call(_llvm_fn(builder, f"llvm.fma.v{LANES}f64", 3), args)

    return vec(vec, vec, vec), codegen


def _lanewise(name: str, op: str, doc: str) -> Any:
    """The intrinsic ``name(a, b)``: the IRBuilder's ``op`` (fmul, fadd, …) lane by lane, one
    IEEE operation per lane (correctly rounded: the scalar operation's bits)."""

    def typer(typingctx, a, b):
        def codegen(context, builder, sig, args):
            return getattr(builder, op)(args[0], args[1])

        return vec(vec, vec), codegen

    typer.__name__ = typer.__qualname__ = name
    typer.__doc__ = doc
    return intrinsic(typer)


vmul = _lanewise("vmul", "fmul", "a·b lane by lane.")
vadd = _lanewise("vadd", "fadd", "A + b lane by lane.")
vsub = _lanewise("vsub", "fsub", "A − b lane by lane.")
vdiv = _lanewise("vdiv", "fdiv", "A / b lane by lane.")


@intrinsic
def vsum(typingctx, v):
    """The lanes' sum in a fixed tree: ((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7))."""

    def codegen(context, builder, sig, args):
        lane = [builder.extract_element(args[0], ir.Constant(_I32, i)) for i in range(LANES)]
        a = builder.fadd(builder.fadd(lane[0], lane[4]), builder.fadd(lane[2], lane[6]))
        b = builder.fadd(builder.fadd(lane[1], lane[5]), builder.fadd(lane[3], lane[7]))
        return builder.fadd(a, b)

    return types.float64(vec), codegen


@intrinsic
def fma(typingctx, a, b, c):
    """a·b + c rounded once (``llvm.fma.f64``): the FMA instruction where the CPU has one, the C
    library's correctly rounded ``fma`` elsewhere."""
    if not all(isinstance(t, types.Float) for t in (a, b, c)):
        return None

    def codegen(context, builder, sig, args):
        vals = [
            context.cast(builder, v, t, types.float64) for v, t in zip(args, sig.args, strict=True)
        ]
        return builder.call(_llvm_fn(builder, "llvm.fma.f64", 3, _F64), vals)

    return types.float64(a, b, c), codegen


@intrinsic
def vsqrt(typingctx, a):
    """√a lane by lane (``llvm.sqrt``, correctly rounded: ``math.sqrt``'s bits in a kernel)."""

    def codegen(context, builder, sig, args):
        return builder.call(_llvm_fn(builder, f"llvm.sqrt.v{LANES}f64", 1), [args[0]])

    return vec(vec), codegen


@intrinsic
def vneg(typingctx, a):
    """−a lane by lane (the sign flipped: exact)."""

    def codegen(context, builder, sig, args):
        return builder.fneg(args[0])

    return vec(vec), codegen


@intrinsic
def vabsmax(typingctx, m, a):
    """max(m, |a|) lane by lane (``llvm.maxnum`` of ``llvm.fabs``: exact, a NaN never wins)."""

    def codegen(context, builder, sig, args):
        fabs = _llvm_fn(builder, f"llvm.fabs.v{LANES}f64", 1)
        fmax = _llvm_fn(builder, f"llvm.maxnum.v{LANES}f64", 2)
        return builder.call(fmax, [args[0], builder.call(fabs, [args[1]])])

    return vec(vec, vec), codegen


@intrinsic
def vmaxlane(typingctx, v):
    """The largest lane (exact: max does not round, so any order gives it)."""

    def codegen(context, builder, sig, args):
        fmax = _llvm_fn(builder, "llvm.maxnum.f64", 2, _F64)
        out = builder.extract_element(args[0], ir.Constant(_I32, 0))
        for i in range(1, LANES):
            out = builder.call(fmax, [out, builder.extract_element(args[0], ir.Constant(_I32, i))])
        return out

    return types.float64(vec), codegen


@intrinsic
def vabs(typingctx, a):
    """|a| lane by lane (exact)."""

    def codegen(context, builder, sig, args):
        return builder.call(_llvm_fn(builder, f"llvm.fabs.v{LANES}f64", 1), [args[0]])

    return vec(vec), codegen
