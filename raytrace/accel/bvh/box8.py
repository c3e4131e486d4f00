"""Box rows for the SAH builder (accel/bvh/build.py), grown 8 lanes at a time.

A primitive's box is one 32-byte float32 row: lo x, y, z, 0, then -hi x,
y, z, 0.  With hi negated, one 8-lane minimum grows both corners of a box
by another (a bin, a node), where the scalar form took six minima and
maxima, each a load and a store waiting on the last (docs/benchmarks.md,
"BVH").

Each lane is ``b if b < a else a``, Numba's ``min(a, b)``, so a NaN
(a centroid of -inf + inf) is ignored as the scalar builder ignored it,
and -min(-hi) is max(hi) exactly: the builder's trees stay bit for bit
the same.  The intrinsics emit LLVM IR directly, as simd.py's do.
"""
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

LANES = 8
HALF = LANES // 2     # lanes of lo (x, y, z, 0); -hi follows


def _row_pointer(context, builder, arrty, arr, row):
    """Pointer to row ``row`` of a C-contiguous (m, LANES) float32 array,
    as <LANES x float>*."""
    a = context.make_array(arrty)(context, builder, arr)
    zero = context.get_constant(types.intp, 0)
    p = cgutils.get_item_pointer(context, builder, arrty, a, [row, zero])
    return builder.bitcast(p, ir.VectorType(ir.FloatType(), LANES).as_pointer())


def _rows_ok(*arrs):
    return all(isinstance(a, types.Array) and a.dtype == types.float32 and a.ndim == 2
               and a.layout == "C" for a in arrs)


def _halves(builder, row):
    """(lo, -hi) of a loaded <LANES x float> box row, as two <HALF x float>."""
    i32 = ir.IntType(32)
    return [builder.shuffle_vector(row, row, ir.Constant(ir.VectorType(i32, HALF),
                                                         list(range(s, s + HALF))))
            for s in (0, HALF)]


def _grow(dst, i, src, k, centroids):
    """The typing and code of grow_box (centroids False) and grow_centroids."""
    if not (_rows_ok(dst, src) and isinstance(i, types.Integer)
            and isinstance(k, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        dty, ity, sty, kty = sig.args
        pd = _row_pointer(context, builder, dty, args[0],
                          context.cast(builder, args[1], ity, types.intp))
        b = builder.load(_row_pointer(context, builder, sty, args[2],
                                      context.cast(builder, args[3], kty, types.intp)), align=4)
        if centroids:
            lo, nhi = _halves(builder, b)
            c = builder.fsub(lo, nhi)     # lo + hi, bit for bit
            b = builder.shuffle_vector(c, builder.fneg(c), ir.Constant(
                ir.VectorType(ir.IntType(32), LANES), list(range(LANES))))
        a = builder.load(pd, align=4)
        builder.store(builder.select(builder.fcmp_ordered("<", b, a), b, a), pd, align=4)
        return context.get_dummy_value()

    return types.none(dst, i, src, k), codegen


@intrinsic
def grow_box(typingctx, dst, i, src, k):
    """dst[i] = min(dst[i], src[k]), lane by lane: box row i of dst grown
    by box row k of src."""
    return _grow(dst, i, src, k, centroids=False)


@intrinsic
def grow_centroids(typingctx, dst, i, src, k):
    """dst[i] = min(dst[i], (c, -c)), c = lo + hi of box row k of src
    (twice its centroid): row i of dst, a box of such sums in the same
    form, grown by it."""
    return _grow(dst, i, src, k, centroids=True)


@intrinsic
def find_bins(typingctx, bin_of, row, boxes, p, ox, oy, oz, sx, sy, sz, last):
    """bin_of[row, a] = the bin of box row p's centroid on axis a, for the
    3 axes at once: min(int((0.5 (lo + hi) - origin) * scale), last), or 0
    where the axis's scale is 0 (not binned) or the centroid is NaN.  Lane
    for lane the scalar form's arithmetic (lo + hi in float32, the rest in
    float64, truncated to int64), so the bins are the same; the scalar form
    cost about a third of the SAH build (1M triangles)."""
    if not (_rows_ok(boxes) and isinstance(bin_of, types.Array) and bin_of.dtype == types.int8
            and bin_of.ndim == 2 and bin_of.layout == "C"
            and all(isinstance(x, types.Float) for x in (ox, oy, oz, sx, sy, sz))
            and all(isinstance(x, types.Integer) for x in (row, p, last))):
        return None
    sig = types.none(bin_of, row, boxes, p, ox, oy, oz, sx, sy, sz, last)

    def codegen(context, builder, sig, args):
        i32, f64 = ir.IntType(32), ir.DoubleType()
        row = context.cast(builder, args[1], sig.args[1], types.intp)
        p = context.cast(builder, args[3], sig.args[3], types.intp)
        b = builder.load(_row_pointer(context, builder, sig.args[2], args[2], p), align=4)
        lo, nhi = _halves(builder, b)
        vec = ir.VectorType(f64, HALF)
        i64v = ir.VectorType(ir.IntType(64), HALF)

        def lanes(values, types_):
            v = ir.Constant(vec, [0.0] * HALF)
            for k, (x, t) in enumerate(zip(values, types_)):
                v = builder.insert_element(v, context.cast(builder, x, t, types.float64),
                                           ir.Constant(i32, k))
            return v
        origin = lanes(args[4:7], sig.args[4:7])
        scale = lanes(args[7:10], sig.args[7:10])
        centre = builder.fmul(builder.fpext(builder.fsub(lo, nhi), vec),
                              ir.Constant(vec, [0.5] * HALF))
        # Clamped to [0, last] before the conversion, so it is defined for
        # every value (LLVM's fptosi of NaN or of an out-of-range value is
        # poison): a NaN centroid (a box from -inf to +inf) takes bin 0, as
        # x86's conversion gave it; any finite value, the bin truncation
        # then min(., last) gives.
        x = builder.fmul(builder.fsub(centre, origin), scale)
        last = builder.sitofp(context.cast(builder, args[10], sig.args[10], types.int64), f64)
        last = builder.insert_element(ir.Constant(vec, ir.Undefined), last, ir.Constant(i32, 0))
        last = builder.shuffle_vector(last, last, ir.Constant(ir.VectorType(i32, HALF), [0] * HALF))
        x = builder.select(builder.fcmp_ordered(">", x, ir.Constant(vec, [0.0] * HALF)), x,
                           ir.Constant(vec, [0.0] * HALF))
        x = builder.select(builder.fcmp_ordered("<", x, last), x, last)
        k = builder.fptosi(x, i64v)
        k = builder.select(builder.fcmp_ordered("==", scale, ir.Constant(vec, [0.0] * HALF)),
                           ir.Constant(i64v, [0] * HALF), k)
        a = context.make_array(sig.args[0])(context, builder, args[0])
        zero = context.get_constant(types.intp, 0)
        out = cgutils.get_item_pointer(context, builder, sig.args[0], a, [row, zero])
        for axis in range(3):
            builder.store(builder.trunc(builder.extract_element(k, ir.Constant(i32, axis)),
                                        ir.IntType(8)),
                          builder.gep(out, [ir.Constant(ir.IntType(64), axis)]))
        return context.get_dummy_value()

    return sig, codegen
