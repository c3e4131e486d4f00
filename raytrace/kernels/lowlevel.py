"""What the kernels need that Numba cannot say in Python: an array in the
caller's stack frame, a population count, trailing- and leading-zero
counts, a 64 x 64 -> 128-bit product, a double from its bits, eight
bytes loaded as one word, an atomic counter, a prefetch and rows of a
buffer indexed from an offset.  The
BVH's SIMD tests live beside it (raytrace/accel/bvh/simd.py).

Each is a Numba intrinsic that emits LLVM IR directly.
"""
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array

PACKET = 16   # rays a packet: a <16 x float> is one AVX-512 register (docs/history.md)

@intrinsic
def frame_array(typingctx, size, dtype):
    """A (size,) array in the calling function's stack frame (alloca).

    No heap allocation and no meminfo, so no reference counting; it must not
    outlive the function that creates it (it is only passed down).
    """
    if not isinstance(size, types.IntegerLiteral) or not isinstance(dtype, types.NumberClass):
        return None
    arrty = types.Array(dtype.instance_type, 1, "C")

    def codegen(context, builder, sig, args):
        n = size.literal_value
        elt = context.get_value_type(dtype.instance_type)
        itemsize = context.get_abi_sizeof(elt)
        data = cgutils.alloca_once(builder, elt, size=n)
        ary = context.make_array(arrty)(context, builder)
        intp = context.get_value_type(types.intp)
        populate_array(ary, data=data, shape=[ir.Constant(intp, n)],
                       strides=[ir.Constant(intp, itemsize)],
                       itemsize=ir.Constant(intp, itemsize), meminfo=None)
        return ary._getvalue()

    return arrty(size, dtype), codegen


@intrinsic
def row_window(typingctx, buffer, first, rows):
    """Rows ``first`` .. ``first + rows - 1`` of a (first + rows, 3)
    float64 array whose rows from ``first`` on are held in 1-D ``buffer``
    (3 values a row): a C array whose data pointer lies ``first`` rows
    before buffer's, so that a chunk of a call's rays kept in a thread's
    buffer is indexed by the call's row numbers.  Its rows below ``first``
    are not memory: only rows first .. are to be read or written (Numba
    checks no bounds)."""
    if not (isinstance(buffer, types.Array) and buffer.ndim == 1 and buffer.dtype == types.float64
            and isinstance(first, types.Integer) and isinstance(rows, types.Integer)):
        return None
    arrty = types.Array(types.float64, 2, "C")

    def codegen(context, builder, sig, args):
        intp = context.get_value_type(types.intp)
        buf = context.make_array(sig.args[0])(context, builder, args[0])
        start = context.cast(builder, args[1], sig.args[1], types.intp)
        count = context.cast(builder, args[2], sig.args[2], types.intp)
        # Not inbounds: the pointer lies before the buffer (never read there).
        data = builder.gep(buf.data, [builder.mul(start, ir.Constant(intp, -3))])
        ary = context.make_array(arrty)(context, builder)
        populate_array(ary, data=data, shape=[builder.add(start, count), ir.Constant(intp, 3)],
                       strides=[ir.Constant(intp, 24), ir.Constant(intp, 8)],
                       itemsize=ir.Constant(intp, 8), meminfo=None)
        return ary._getvalue()

    return arrty(buffer, first, rows), codegen


@intrinsic
def popcount(typingctx, x):
    """The number of set bits of an integer (llvm.ctpop: one popcnt)."""
    if not isinstance(x, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[0], sig.args[0], types.int64)
        ctpop = builder.module.declare_intrinsic("llvm.ctpop", [ir.IntType(64)])
        return builder.call(ctpop, [value])

    return types.int64(x), codegen


def _zero_count(name):
    """Codegen of a 64-bit zero count, LLVM's ``name`` (cttz, ctlz): its
    count for zero defined (64), not poison."""
    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[0], sig.args[0], types.uint64)
        i64, i1 = ir.IntType(64), ir.IntType(1)
        count = cgutils.get_or_insert_function(builder.module, ir.FunctionType(i64, [i64, i1]),
                                               name)
        return builder.call(count, [value, ir.Constant(i1, 0)])
    return codegen


@intrinsic
def trailing_zeros(typingctx, x):
    """The number of zero bits below the lowest set bit of a 64-bit integer
    (llvm.cttz: one tzcnt); 64 for zero."""
    if not isinstance(x, types.Integer):
        return None
    return types.int64(x), _zero_count("llvm.cttz.i64")


@intrinsic
def leading_zeros(typingctx, x):
    """The number of zero bits above the highest set bit of a 64-bit
    integer (llvm.ctlz: one lzcnt); 64 for zero."""
    if not isinstance(x, types.Integer):
        return None
    return types.int64(x), _zero_count("llvm.ctlz.i64")


@intrinsic
def wide_product(typingctx, a, b):
    """The 128-bit product of two uint64 as (high, low) uint64 halves (one
    mul on x86-64): Python's integers would say a * b, Numba's wrap."""
    if not (a == types.uint64 and b == types.uint64):
        return None
    pair = types.UniTuple(types.uint64, 2)

    def codegen(context, builder, sig, args):
        i64, i128 = ir.IntType(64), ir.IntType(128)
        product = builder.mul(builder.zext(args[0], i128), builder.zext(args[1], i128))
        high = builder.trunc(builder.lshr(product, ir.Constant(i128, 64)), i64)
        return context.make_tuple(builder, pair, [high, builder.trunc(product, i64)])

    return pair(a, b), codegen


@intrinsic
def double_from_bits(typingctx, bits):
    """The float64 whose IEEE bits are the uint64 ``bits`` (a bitcast)."""
    if bits != types.uint64:
        return None

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(bits), codegen


@intrinsic
def load_word(typingctx, arr, i):
    """Bytes i .. i + 7 of a 1-D uint8 array as one little-endian uint64
    (one unaligned load): a loop looking for a byte tests eight at a time.
    The caller keeps i + 8 within the array."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.dtype == types.uint8
            and isinstance(i, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        index = context.cast(builder, args[1], sig.args[1], types.intp)
        word = builder.bitcast(builder.gep(data, [index]), ir.IntType(64).as_pointer())
        return builder.load(word, align=1)

    return types.uint64(arr, i), codegen


@intrinsic
def prefetch(typingctx, arr, i):
    """Ask for the cache line of element i of a 1-D array to be loaded
    (llvm.prefetch, for reading, kept in every cache level): a loop whose
    next reads are random (a hash table's slots) starts them early.  A hint
    only: any i is safe, the line is never read here."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and isinstance(i, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        index = context.cast(builder, args[1], sig.args[1], types.intp)
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]), "llvm.prefetch.p0")
        builder.call(fn, [builder.bitcast(builder.gep(data, [index]), i8p), ir.Constant(i32, 0),
                          ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return types.none(arr, i), codegen


_CLOCK = types.Array(types.int64, 1, "C")


def _fetch_add(context, builder, clock_type, clock, index, amount):
    """LLVM's atomicrmw add of int64 ``amount`` to clock[index], monotonic:
    only the count must be exact, and the end of the parallel region orders
    everything the threads wrote.  Returns the value before."""
    data = context.make_array(clock_type)(context, builder, value=clock).data
    slot = builder.gep(data, [ir.Constant(ir.IntType(64), index)])
    return builder.atomic_rmw("add", slot, amount, "monotonic")


@intrinsic
def take_ticket(typingctx, clock):
    """Atomically add 1 to clock[0] and return its value before: threads
    taking tickets from one clock each get a different number, 0, 1, 2, ..."""
    if clock != _CLOCK:
        return None

    def codegen(context, builder, sig, args):
        return _fetch_add(context, builder, sig.args[0], args[0], 0,
                          ir.Constant(ir.IntType(64), 1))

    return types.int64(clock), codegen


@intrinsic
def take_rows(typingctx, clock, amount):
    """Atomically add ``amount`` to clock[1] and return its value before:
    threads taking runs of rows from one clock each get runs that do not
    overlap (list_intersections' slabs of hit rows; clock[0] is
    take_ticket's)."""
    if clock != _CLOCK or not isinstance(amount, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        size = context.cast(builder, args[1], sig.args[1], types.int64)
        return _fetch_add(context, builder, sig.args[0], args[0], 1, size)

    return types.int64(clock, amount), codegen
