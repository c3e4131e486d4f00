"""A float32's bits as an int32 and back, for stepping to the neighbouring
float32 without a call (the builders round every node box outwards:
libm's nextafterf, called through Numba, was a visible share of the SAH build).

The two conversions are Numba intrinsics, one LLVM bitcast each.
"""
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from raytrace.kernels.jit import BUILD_STEP


@intrinsic
def f32_bits(typingctx, x):
    """The IEEE 754 bits of float32 ``x`` as an int32."""
    if x != types.float32:
        return None

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.IntType(32))

    return types.int32(x), codegen


@intrinsic
def f32_from_bits(typingctx, bits):
    """The float32 whose IEEE 754 bits are int32 ``bits``."""
    if bits != types.int32:
        return None

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.FloatType())

    return types.float32(bits), codegen


# Inlined in Numba's IR: compiled as a function of its own, it added to the
# builder's cold compile more than it saves.
@njit(**dict(BUILD_STEP, inline="always"))
def f32_next(f, up):
    """The float32 after float32 ``f`` (up) or before it, as np.nextafter
    toward +inf or -inf: one more or one less in its bits' magnitude, and
    +-2^-149 from a zero of either sign."""
    if f == 0.0:
        return f32_from_bits(np.int32(1 if up else -(2**31 - 1)))    # 0x80000001: -2^-149
    bits = np.int64(f32_bits(f))
    bits += 1 if (f > 0.0) == up else -1
    return f32_from_bits(np.int32(bits))
