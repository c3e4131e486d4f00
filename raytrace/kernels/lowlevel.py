"""What the kernels need that Numba cannot say in Python: an array in the
caller's stack frame, a 4-wide box test in SIMD, the first step of the
triangle test for 4 triangles at once, and an atomic counter.

Both are Numba intrinsics that emit LLVM IR directly.
"""
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array
from numba.np.numpy_support import from_dtype

from ..accel.bvh import BOX, WIDTH
from .intersect import BOX_FAR_SCALE


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


_BOX_ARRAY = types.Array(from_dtype(np.dtype(BOX)), 3, "C")


@intrinsic
def ray_aabb4(typingctx, node_box, node, nx, ny, nz, ox, oy, oz, ix, iy, iz, t_max):
    """Slab test of one ray against the 4 child boxes of BVH node ``node``.

    ``node_box`` is (m, 6, 4) float32: rows lo x, y, z, hi x, y, z, one
    lane per child, each row widened to <4 x double> as it is loaded
    (exactly), so the arithmetic is float64's.  ``nx, ny, nz`` are the rows
    of the planes the ray meets first on each axis (0/3, 1/4, 2/5 by the
    sign of its inverse direction), so no swap is needed: pbrt's dirIsNeg
    trick, vectorised across children as in Dammertz et al. 2008 ("Shallow
    Bounding Volume Hierarchies for Fast SIMD Ray Tracing of Incoherent
    Rays").

    Returns (mask, the 4 entry distances): bit k of mask set where the ray
    enters child k (one vmovmskpd), its distance clamped to 0, inf where the
    ray misses the box or enters beyond t_max.  The arithmetic is ray_aabb's operation
    for operation (the same products, the same Ize far-bound widening), so
    every lane gives ray_aabb's answer: a NaN slab distance (the ray lies in
    a face plane, 0 * inf) fails both comparisons and constrains nothing,
    which is what ray_aabb's explicit NaN check does.  An unused lane holds
    lo = hi = +inf, which every ray misses on any axis.

    LLVM does not vectorise the scalar form of this (measured: all scalar
    vmulsd); the explicit <4 x double> code measured 1.2x faster BVH queries.
    """
    args = (node_box, node, nx, ny, nz, ox, oy, oz, ix, iy, iz, t_max)
    if node_box != _BOX_ARRAY or not all(isinstance(a, types.Integer) for a in args[1:5]) \
            or not all(isinstance(a, types.Float) for a in args[5:]):
        return None
    sig = types.Tuple((types.int64, types.UniTuple(types.float64, WIDTH)))(*args)

    def codegen(context, builder, sig, llargs):
        box, node, nx, ny, nz, ox, oy, oz, ix, iy, iz, t_max = [
            context.cast(builder, v, t, to) for v, t, to in zip(
                llargs, sig.args, (sig.args[0],) + (types.int64,) * 4 + (types.float64,) * 7)]
        data = context.make_array(sig.args[0])(context, builder, value=box).data
        f64 = ir.DoubleType()
        vec = ir.VectorType(f64, WIDTH)
        stored = ir.VectorType(context.get_value_type(sig.args[0].dtype), WIDTH)
        i64 = ir.IntType(64)
        i32 = ir.IntType(32)

        def splat(x):
            v = ir.Constant(vec, ir.Undefined)
            for k in range(WIDTH):
                v = builder.insert_element(v, x, ir.Constant(i32, k))
            return v

        base = builder.mul(node, ir.Constant(i64, 6 * WIDTH))

        def plane(row):
            p = builder.gep(data, [builder.add(base, builder.mul(row, ir.Constant(i64, WIDTH)))])
            row = builder.load(builder.bitcast(p, stored.as_pointer()), align=4)
            return builder.fpext(row, vec)

        widen = splat(ir.Constant(f64, BOX_FAR_SCALE))
        t0 = splat(ir.Constant(f64, 0.0))
        t1 = splat(t_max)
        # far row: 3 - nx for x (0 <-> 3), 5 - ny for y (1 <-> 4), 7 - nz for z (2 <-> 5)
        for o, inv, near, far_sum in ((ox, ix, nx, 3), (oy, iy, ny, 5), (oz, iz, nz, 7)):
            o, inv = splat(o), splat(inv)
            far = builder.sub(ir.Constant(i64, far_sum), near)
            tn = builder.fmul(builder.fsub(plane(near), o), inv)
            tf = builder.fmul(builder.fmul(builder.fsub(plane(far), o), inv), widen)
            t0 = builder.select(builder.fcmp_ordered(">", tn, t0), tn, t0)
            t1 = builder.select(builder.fcmp_ordered("<", tf, t1), tf, t1)
        inf = splat(ir.Constant(f64, float("inf")))
        # An unused lane (lo = hi = +inf) passes t0 <= t1 at t0 = inf when
        # t_max is inf: only a finite entry is a hit.
        hit = builder.and_(builder.fcmp_ordered("<=", t0, t1), builder.fcmp_ordered("<", t0, inf))
        entry = builder.select(hit, t0, inf)
        lanes = [builder.extract_element(entry, ir.Constant(i32, k)) for k in range(WIDTH)]
        mask = builder.zext(builder.bitcast(hit, ir.IntType(WIDTH)), i64)
        return context.make_tuple(builder, sig.return_type, [
            mask, context.make_tuple(builder, sig.return_type[1], lanes)])

    return sig, codegen


_VERTICES = types.Array(types.float64, 2, "C")


@intrinsic
def edge_mask4(typingctx, v0, v1, v2, r0, r1, r2, r3, kx, ky, kz, okx, oky, okz, sx, sy):
    """The watertight triangle test's first step (intersect._triangle: the
    vertices moved to the ray's origin, permuted by kx, ky, kz and sheared,
    then the three 2D edge functions) for the triangles in rows r0..r3 of
    the (n, 3) vertex arrays v0, v1, v2 at once, in <4 x double>.

    Returns a 4-bit mask: bit j is clear where triangle rj's edge functions
    have mixed signs, the test's first rejection (the ray's line passes
    outside the triangle), and set otherwise.  Each lane's arithmetic is
    the scalar test's, operation for operation (no fused multiply-adds), so
    a lane is rejected exactly where the scalar test rejects it; a set bit
    still needs the full test.
    """
    arrays, ints, floats = (v0, v1, v2), (r0, r1, r2, r3, kx, ky, kz), (okx, oky, okz, sx, sy)
    if any(a != _VERTICES for a in arrays) or not all(isinstance(a, types.Integer) for a in ints) \
            or not all(isinstance(a, types.Float) for a in floats):
        return None
    sig = types.int64(*arrays, *ints, *floats)

    def codegen(context, builder, sig, llargs):
        i64 = ir.IntType(64)
        i32 = ir.IntType(32)
        vec = ir.VectorType(ir.DoubleType(), 4)
        data = [context.make_array(sig.args[k])(context, builder, value=llargs[k]).data
                for k in range(3)]
        rows = [builder.mul(context.cast(builder, llargs[3 + j], sig.args[3 + j], types.int64),
                            ir.Constant(i64, 3)) for j in range(4)]
        axes = [context.cast(builder, llargs[7 + a], sig.args[7 + a], types.int64)
                for a in range(3)]
        okx, oky, okz, sx, sy = [context.cast(builder, llargs[10 + k], sig.args[10 + k],
                                              types.float64) for k in range(5)]

        def splat(x):
            v = ir.Constant(vec, ir.Undefined)
            for j in range(4):
                v = builder.insert_element(v, x, ir.Constant(i32, j))
            return v

        def coordinate(vertices, axis):
            """Component ``axis`` of the 4 triangles' vertex, one per lane."""
            v = ir.Constant(vec, ir.Undefined)
            for j in range(4):
                p = builder.gep(vertices, [builder.add(rows[j], axis)])
                v = builder.insert_element(v, builder.load(p), ir.Constant(i32, j))
            return v

        origin = [splat(okx), splat(oky), splat(okz)]
        shear_x, shear_y = splat(sx), splat(sy)
        corners = []
        for vertices in data:
            x, y, z = [builder.fsub(coordinate(vertices, axes[a]), origin[a]) for a in range(3)]
            corners.append((builder.fsub(x, builder.fmul(shear_x, z)),
                            builder.fsub(y, builder.fmul(shear_y, z))))
        (ax, ay), (bx, by), (cx, cy) = corners
        edges = (builder.fsub(builder.fmul(bx, cy), builder.fmul(by, cx)),
                 builder.fsub(builder.fmul(cx, ay), builder.fmul(cy, ax)),
                 builder.fsub(builder.fmul(ax, by), builder.fmul(ay, bx)))
        zero = ir.Constant(vec, [0.0] * 4)

        def any_edge(op):
            e0, e1, e2 = [builder.fcmp_ordered(op, e, zero) for e in edges]
            return builder.or_(builder.or_(e0, e1), e2)

        keep = builder.not_(builder.and_(any_edge("<"), any_edge(">")))
        return builder.zext(builder.bitcast(keep, ir.IntType(4)), i64)

    return sig, codegen


_CLOCK = types.Array(types.int64, 1, "C")


@intrinsic
def take_ticket(typingctx, clock):
    """Atomically add 1 to clock[0] and return its value before: threads
    taking tickets from one clock each get a different number, 0, 1, 2, ...
    (LLVM's atomicrmw add, monotonic: only the count must be exact, and the
    end of the parallel region orders everything the threads wrote)."""
    if clock != _CLOCK:
        return None

    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, value=args[0]).data
        return builder.atomic_rmw("add", data, ir.Constant(ir.IntType(64), 1), "monotonic")

    return types.int64(clock), codegen
