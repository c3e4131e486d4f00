"""The SIMD tests of packets of rays (accel/bvh/packet.py), which Numba
cannot say in Python: PACKET rays' boxes against a node's 4 children, a
triangle against PACKET rays, and the packet's rows made from its rays.
Each is a Numba intrinsic that emits LLVM IR directly.
"""
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from raytrace.accel.bvh.layout import WIDTH
from raytrace.accel.bvh.simd import BOX_ARRAY, VERTICES, broadcast, edge_functions, within_interval
from raytrace.kernels.lowlevel import PACKET

_F32_ROW = types.Array(types.float32, 1, "C")


def _packet_row(builder, data, k, vec, first=0):
    """Row k of a packet's rows (PACKET values from k * PACKET on) as one
    vector of type ``vec``: its values from the row's ``first`` on (an
    LLVM int64, or 0)."""
    p = builder.gep(data, [builder.add(ir.Constant(ir.IntType(64), k * PACKET), first)
                           if isinstance(first, ir.Value) else
                           ir.Constant(ir.IntType(64), k * PACKET + first)])
    return builder.load(builder.bitcast(p, vec.as_pointer()), align=4)


@intrinsic
def packet_aabb4(typingctx, node_box, node, nx, ny, nz, consts, t_far):
    """ray_aabb4 for a packet of PACKET rays at once: the rays in SIMD
    lanes, one <PACKET x float> per box plane and child (Wald, Slusallek,
    Benthin & Wagner 2001, "Interactive Rendering with Coherent Ray
    Tracing": a packet shares the node's loads and the traversal's
    branches).  Each ray's arithmetic is ray_aabb4's, operation for
    operation, so a ray enters exactly the boxes its own test enters.

    The rays share their near rows ``nx, ny, nz`` (the packet's caller
    checks).  ``consts``: 12 rows of PACKET float32, each ray's box_ray
    constants (near origins x, y, z, far origins, near inverses, far
    inverses); ``t_far``: each ray's far bound, already float32.

    Returns (masks, nearest entries), a value per child: bit r of a
    child's mask set where ray r enters it; its nearest entry (float64) the
    least over the rays entering it (inf if none).
    """
    args = (node_box, node, nx, ny, nz, consts, t_far)
    if node_box != BOX_ARRAY or not all(isinstance(a, types.Integer) for a in args[1:5]) \
            or consts != _F32_ROW or t_far != _F32_ROW:
        return None
    sig = types.Tuple((types.UniTuple(types.int64, WIDTH),
                       types.UniTuple(types.float64, WIDTH)))(*args)

    def codegen(context, builder, sig, llargs):
        box, node, nx, ny, nz = [context.cast(builder, v, t, to) for v, t, to in zip(
            llargs[:5], sig.args[:5], (sig.args[0],) + (types.int64,) * 4)]
        f32 = ir.FloatType()
        i64 = ir.IntType(64)
        i32 = ir.IntType(32)
        vec = ir.VectorType(f32, PACKET)
        data = context.make_array(sig.args[0])(context, builder, value=box).data
        rows = context.make_array(sig.args[5])(context, builder, value=llargs[5]).data
        far = context.make_array(sig.args[6])(context, builder, value=llargs[6]).data

        consts = [_packet_row(builder, rows, k, vec) for k in range(12)]
        t_far = _packet_row(builder, far, 0, vec)
        base = builder.mul(node, ir.Constant(i64, 6 * WIDTH))
        axes = [(nx, 3), (ny, 5), (nz, 7)]
        near_rows = [builder.mul(a, ir.Constant(i64, WIDTH)) for a, _ in axes]
        far_rows = [builder.mul(builder.sub(ir.Constant(i64, s), a), ir.Constant(i64, WIDTH))
                    for a, s in axes]
        zero = ir.Constant(vec, [0.0] * PACKET)
        subnormal = ir.Constant(vec, [2.0 ** -126] * PACKET)
        inf = ir.Constant(vec, [float("inf")] * PACKET)
        masks = []
        nearest = []
        for child in range(WIDTH):
            def plane(r, child=child):
                p = builder.gep(data, [builder.add(base, builder.add(r, ir.Constant(i64, child)))])
                return broadcast(builder, vec, builder.load(p))
            t0, t1 = zero, t_far
            for a in range(3):
                tn = builder.fmul(builder.fsub(plane(near_rows[a]), consts[a]), consts[6 + a])
                tf = builder.fmul(builder.fsub(plane(far_rows[a]), consts[3 + a]), consts[9 + a])
                t0 = builder.select(builder.fcmp_ordered(">", tn, t0), tn, t0)
                t1 = builder.select(builder.fcmp_ordered("<", tf, t1), tf, t1)
            t0 = builder.fsub(t0, subnormal)
            t1 = builder.fadd(t1, subnormal)
            hit = builder.and_(builder.fcmp_ordered("<=", t0, t1), builder.fcmp_ordered("<", t0, inf))
            masks.append(builder.zext(builder.bitcast(hit, ir.IntType(PACKET)), i64))
            # The least entry of the rays entering: halve the lanes until one.
            m = builder.select(hit, t0, inf)
            width = PACKET
            while width > 1:
                width //= 2
                hi = builder.shuffle_vector(m, ir.Constant(vec, ir.Undefined), ir.Constant(
                    ir.VectorType(i32, PACKET), list(range(width, 2 * width)) + [0] * (PACKET - width)))
                m = builder.select(builder.fcmp_ordered("<", hi, m), hi, m)
            nearest.append(builder.fpext(builder.extract_element(m, ir.Constant(i32, 0)),
                                         ir.DoubleType()))
        return context.make_tuple(builder, sig.return_type, [
            context.make_tuple(builder, sig.return_type[0], masks),
            context.make_tuple(builder, sig.return_type[1], nearest)])

    return sig, codegen


_F64_ROW = types.Array(types.float64, 1, "C")


# packet_triangle's rays at once: half a packet.  Most leaves a packet
# tests at 118k triangles and more are entered by rays of one half only
# (70-85% of the suite's shadow and camera rays), which now skip the other;
# at 1k, where most hold rays of both halves, two half tests are no slower
# than one <16 x double> test (docs/benchmarks.md, "Half a packet's
# triangle test").
HALF = PACKET // 2


@intrinsic
def packet_triangle(typingctx, leaf_tris, k, kx, ky, kz, fields, far, half):
    """The watertight triangle test (intersect._triangle, not the crossing
    variant) of the triangle in slot k of the tree's ``leaf_tris`` (its
    corners, row 3 * corner + axis: accel/bvh/layout.py) against rays
    half * HALF .. half * HALF + HALF - 1 of a packet at once, in
    <HALF x double>, where the rays share their axes kx, ky, kz: each
    lane's arithmetic is the scalar test's, operation for operation (no
    fused multiply-adds), so a lane hits exactly where the scalar test
    hits.  Read from the slot, not
    through prim_ids from the geometry's vertices: the corners' loads do
    not wait on the id's.

    ``fields``: the packet's rows (accel/bvh/packet.py), of which rows 9-15
    are each ray's sx, sy, sz, okx, oky, okz and t_min; ``far``: each ray's
    t_max.  Returns the mask of the rays that hit, as bits of the whole
    packet; the scalar test gives a hit's distance and barycentrics.
    """
    ints = (k, kx, ky, kz, half)
    if leaf_tris != VERTICES or not all(isinstance(a, types.Integer) for a in ints) \
            or fields != _F64_ROW or far != _F64_ROW:
        return None
    sig = types.int64(leaf_tris, k, kx, ky, kz, fields, far, half)

    def codegen(context, builder, sig, llargs):
        i64 = ir.IntType(64)
        f64 = ir.DoubleType()
        vec = ir.VectorType(f64, HALF)
        corners_ary = context.make_array(sig.args[0])(context, builder, value=llargs[0])
        data = corners_ary.data
        stride = builder.extract_value(corners_ary.shape, 1)
        k, kx, ky, kz = [context.cast(builder, llargs[1 + j], sig.args[1 + j], types.int64)
                         for j in range(4)]
        rows = context.make_array(sig.args[5])(context, builder, value=llargs[5]).data
        far_data = context.make_array(sig.args[6])(context, builder, value=llargs[6]).data

        first = builder.mul(context.cast(builder, llargs[7], sig.args[7], types.int64),
                            ir.Constant(i64, HALF))
        sx, sy, sz, okx, oky, okz, t_min = [_packet_row(builder, rows, j, vec, first)
                                            for j in range(9, 16)]
        t_max = _packet_row(builder, far_data, 0, vec, first)

        def coordinate(corner, axis, origin):
            row = builder.add(ir.Constant(i64, 3 * corner), axis)
            x = builder.load(builder.gep(data, [builder.add(builder.mul(row, stride), k)]))
            return builder.fsub(broadcast(builder, vec, x), origin)

        corners = [(coordinate(c, kx, okx), coordinate(c, ky, oky), coordinate(c, kz, okz))
                   for c in range(3)]
        edges, mixed = edge_functions(builder, corners, sx, sy)
        keep = builder.and_(builder.not_(mixed),
                            within_interval(builder, edges, corners, sz, t_min, t_max)[0])
        return builder.shl(builder.zext(builder.bitcast(keep, ir.IntType(HALF)), i64), first)

    return sig, codegen


@intrinsic
def packet_rays(typingctx, origins, dirs, i0, tree_bounded, box_range, near_limit, margin, fields,
                axes, consts):
    """make_ray and box_ray (kernels/ray.py, accel/bvh/traverse.py) for rays
    i0 .. i0 + PACKET - 1 at once, in <PACKET x double>: each lane's arithmetic
    and choices are the scalar functions', operation for operation, so the
    rows hold the same bits.  Writes rows 0-14 of ``fields`` (ox, oy, oz,
    dx, dy, dz, the inverses, sx, sy, sz, okx, oky, okz), ``axes`` (kx, ky,
    kz) and ``consts`` (box_ray_f32's 12 rows).  ``tree_bounded``: the
    tree's box_bound within ``box_range`` (BOX32_RANGE); ``near_limit``
    (NEAR_LIMIT) and ``margin`` (BOX32_MARGIN) as box_ray passes them.

    Returns the rays' shared near rows (nx, ny, nz), or (-1, -1, -1) where
    they differ (some rays within the float32 test's range, some not).
    The caller has checked that the rays' directions share their signs."""
    if origins != VERTICES or dirs != VERTICES or not isinstance(i0, types.Integer) \
            or not isinstance(tree_bounded, types.Boolean) \
            or not all(isinstance(a, types.Float) for a in (box_range, near_limit, margin)) \
            or fields != _F64_ROW or axes != types.Array(types.int64, 1, "C") \
            or consts != _F32_ROW:
        return None
    sig = types.UniTuple(types.int64, 3)(origins, dirs, i0, tree_bounded, box_range, near_limit,
                                         margin, fields, axes, consts)

    def codegen(context, builder, sig, llargs):
        n = PACKET
        i64, i32, i1 = ir.IntType(64), ir.IntType(32), ir.IntType(1)
        f64, f32 = ir.DoubleType(), ir.FloatType()
        vd, vf = ir.VectorType(f64, n), ir.VectorType(f32, n)
        vi, vb = ir.VectorType(i64, n), ir.VectorType(i1, n)
        o_data = context.make_array(sig.args[0])(context, builder, value=llargs[0]).data
        d_data = context.make_array(sig.args[1])(context, builder, value=llargs[1]).data
        start = builder.mul(context.cast(builder, llargs[2], sig.args[2], types.int64),
                            ir.Constant(i64, 3))
        tree_ok = context.cast(builder, llargs[3], sig.args[3], types.boolean)
        box_range, limit, margin = [context.cast(builder, llargs[k], sig.args[k], types.float64)
                                    for k in (4, 5, 6)]
        out_f, out_k, out_c = [context.make_array(sig.args[k])(context, builder,
                                                               value=llargs[k]).data
                               for k in (7, 8, 9)]

        def const(ty, x):
            return ir.Constant(ty, [x] * n)

        def columns(data):
            block = builder.load(builder.bitcast(builder.gep(data, [start]),
                                                 ir.VectorType(f64, 3 * n).as_pointer()), align=8)
            return [builder.shuffle_vector(block, ir.Constant(block.type, ir.Undefined),
                                           ir.Constant(ir.VectorType(i32, n),
                                                       list(range(a, 3 * n, 3))))
                    for a in range(3)]

        def store(data, row, v):
            p = builder.gep(data, [ir.Constant(i64, row * n)])
            builder.store(v, builder.bitcast(p, v.type.as_pointer()), align=4)

        def fabs(v):
            ity = ir.VectorType(i64, n)
            return builder.bitcast(builder.and_(builder.bitcast(v, ity),
                                                const(ity, 0x7FFFFFFFFFFFFFFF)), vd)

        def fabs32(v):
            ity = ir.VectorType(i32, n)
            return builder.bitcast(builder.and_(builder.bitcast(v, ity), const(ity, 0x7FFFFFFF)),
                                   vf)

        def pick(k, xs):
            """xs[k] lane by lane, k in 0..2."""
            return builder.select(builder.icmp_signed("==", k, const(vi, 0)), xs[0],
                                  builder.select(builder.icmp_signed("==", k, const(vi, 1)),
                                                 xs[1], xs[2]))

        o = columns(o_data)
        d = columns(d_data)
        one = const(vd, 1.0)
        inv = [builder.fdiv(one, x) for x in d]
        ax, ay, az = [fabs(x) for x in d]
        gt = builder.fcmp_ordered
        kz = builder.select(gt(">", ax, ay),
                            builder.select(gt(">", ax, az), const(vi, 0), const(vi, 2)),
                            builder.select(gt(">", ay, az), const(vi, 1), const(vi, 2)))
        kx = builder.add(kz, const(vi, 1))
        kx = builder.select(builder.icmp_signed("==", kx, const(vi, 3)), const(vi, 0), kx)
        ky = builder.add(kx, const(vi, 1))
        ky = builder.select(builder.icmp_signed("==", ky, const(vi, 3)), const(vi, 0), ky)
        dkz = pick(kz, d)
        swap = gt("<", dkz, const(vd, 0.0))
        kx, ky = builder.select(swap, ky, kx), builder.select(swap, kx, ky)
        sx = builder.fdiv(pick(kx, d), dkz)
        sy = builder.fdiv(pick(ky, d), dkz)
        sz = pick(kz, inv)
        rows = o + d + inv + [sx, sy, sz, pick(kx, o), pick(ky, o), pick(kz, o)]
        for r, v in enumerate(rows):
            store(out_f, r, v)
        for r, v in enumerate((kx, ky, kz)):
            store(out_k, r, v)

        # box_ray: the tree's and the origin's reach ...
        reach = builder.select(gt(">", fabs(o[1]), fabs(o[0])), fabs(o[1]), fabs(o[0]))
        reach = builder.select(gt(">", fabs(o[2]), reach), fabs(o[2]), reach)
        bounded = builder.and_(gt("<=", reach, broadcast(builder, vd, box_range)),
                               broadcast(builder, vb, tree_ok))
        # ... and box_ray_f32's constants, axis by axis.
        scale_near = builder.fsub(one, broadcast(builder, vd, margin))
        scale_far = builder.fadd(one, broadcast(builder, vd, margin))
        limit_v = broadcast(builder, vd, limit)
        sign = const(vi, 1 << 63)
        near_o, far_o, near_i, far_i = [], [], [], []
        usable = bounded
        for a in range(3):
            o32 = builder.fptrunc(o[a], vf)
            step = builder.fadd(builder.fmul(fabs32(o32), const(vf, 2.0 ** -23)),
                                const(vf, 2.0 ** -149))
            up, down = builder.fadd(o32, step), builder.fsub(o32, step)
            negative = gt("<", inv[a], const(vd, 0.0))
            near_o.append(builder.select(negative, down, up))
            far_o.append(builder.select(negative, up, down))
            near = builder.fmul(inv[a], scale_near)
            far_i.append(builder.fmul(inv[a], scale_far))
            size = fabs(near)
            cut = builder.and_(gt(">", size, limit_v), gt("<", size, const(vd, float("inf"))))
            signed_limit = builder.bitcast(builder.or_(
                builder.bitcast(limit_v, vi), builder.and_(builder.bitcast(near, vi), sign)), vd)
            near_i.append(builder.select(cut, signed_limit, near))
            usable = builder.and_(usable, builder.not_(gt("<", size, const(vd, 2.0 ** -100))))
        big = float(np.finfo(np.float32).max)
        out = ([builder.select(usable, v, const(vf, big)) for v in near_o]
               + [builder.select(usable, v, const(vf, -big)) for v in far_o]
               + [builder.select(usable, builder.fptrunc(v, vf), const(vf, float("inf")))
                  for v in near_i + far_i])
        for r, v in enumerate(out):
            store(out_c, r, v)

        # Near rows: from the signs where every ray is bounded, rows lo
        # where none is, and none shared otherwise.
        mask = builder.bitcast(bounded, ir.IntType(n))
        every = builder.icmp_unsigned("==", mask, ir.Constant(ir.IntType(n), (1 << n) - 1))
        none = builder.icmp_unsigned("==", mask, ir.Constant(ir.IntType(n), 0))
        result = []
        for a, (lo, hi) in enumerate(((0, 3), (1, 4), (2, 5))):
            neg = builder.fcmp_ordered("<", builder.extract_element(inv[a], ir.Constant(i32, 0)),
                                       ir.Constant(f64, 0.0))
            signed = builder.select(neg, ir.Constant(i64, hi), ir.Constant(i64, lo))
            result.append(builder.select(every, signed, builder.select(
                none, ir.Constant(i64, lo), ir.Constant(i64, -1))))
        return context.make_tuple(builder, sig.return_type, result)

    return sig, codegen


