"""A float32's bits as an int32 and back, for stepping to the neighbouring
float32 without a call (the builders round every node box outwards:
libm's nextafterf, called through Numba, cost 8% of the SAH build).

Each is a Numba intrinsic: one LLVM bitcast.
"""
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


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
