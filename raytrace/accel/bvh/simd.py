"""The BVH's SIMD tests, which Numba cannot say in Python: a 4-wide box
test and the crossing triangle test for 8 triangles at once (packets of
rays: simd_packets.py).  Each is a Numba intrinsic that emits LLVM IR directly.
"""
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from numba.np.numpy_support import from_dtype

from raytrace.accel.bvh.layout import BOX, WIDTH


def broadcast(builder, vec, x):
    """Scalar x in every lane of vector type ``vec``."""
    v = builder.insert_element(ir.Constant(vec, ir.Undefined), x, ir.Constant(ir.IntType(32), 0))
    return builder.shuffle_vector(v, ir.Constant(vec, ir.Undefined), ir.Constant(
        ir.VectorType(ir.IntType(32), vec.count), [0] * vec.count))


def edge_functions(builder, corners, shear_x, shear_y):
    """intersect._triangle's shear and 2D edge functions, lane by lane and
    operation for operation: ``corners``, each vertex's (x, y, z) less the
    ray's origin on the ray's axes kx, ky, kz.  Returns (e0, e1, e2) and
    the lanes whose signs are mixed (the test's first rejection)."""
    (ax, ay), (bx, by), (cx, cy) = [
        (builder.fsub(x, builder.fmul(shear_x, z)), builder.fsub(y, builder.fmul(shear_y, z)))
        for x, y, z in corners]
    edges = (builder.fsub(builder.fmul(bx, cy), builder.fmul(by, cx)),
             builder.fsub(builder.fmul(cx, ay), builder.fmul(cy, ax)),
             builder.fsub(builder.fmul(ax, by), builder.fmul(ay, bx)))
    zero = ir.Constant(edges[0].type, [0.0] * edges[0].type.count)

    def any_edge(op):
        e0, e1, e2 = [builder.fcmp_ordered(op, e, zero) for e in edges]
        return builder.or_(builder.or_(e0, e1), e2)

    return edges, builder.and_(any_edge("<"), any_edge(">"))


def within_interval(builder, edges, corners, sz, t_min, t_max):
    """intersect._triangle's steps after the edge functions' signs, lane by
    lane and operation for operation: the lanes whose determinant is not 0
    and whose distance lies in t_min < t < t_max (tested scaled first,
    against 0 and t_max * det, then divided out), as the scalar test
    decides them; and each lane's t and 1 / det.  ``corners`` as
    edge_functions takes them; sz, t_min, t_max splatted or per lane."""
    e0, e1, e2 = edges
    (_, _, az), (_, _, bz), (_, _, cz) = corners
    zero = ir.Constant(e0.type, [0.0] * e0.type.count)
    one = ir.Constant(e0.type, [1.0] * e0.type.count)

    def cmp(op, a, b):
        return builder.fcmp_ordered(op, a, b)

    det = builder.fadd(builder.fadd(e0, e1), e2)
    t_scaled = builder.fadd(builder.fadd(builder.fmul(e0, builder.fmul(az, sz)),
                                         builder.fmul(e1, builder.fmul(bz, sz))),
                            builder.fmul(e2, builder.fmul(cz, sz)))
    bound = builder.fmul(t_max, det)
    out_neg = builder.or_(cmp(">", t_scaled, zero), cmp("<=", t_scaled, bound))
    out_pos = builder.or_(cmp("<", t_scaled, zero), cmp(">=", t_scaled, bound))
    out = builder.select(cmp("<", det, zero), out_neg, out_pos)
    inv_det = builder.fdiv(one, det)
    t = builder.fmul(t_scaled, inv_det)
    within = builder.and_(cmp(">", t, t_min), cmp("<", t, t_max))
    return builder.and_(builder.and_(builder.not_(cmp("==", det, zero)), builder.not_(out)),
                        within), t, inv_det


BOX_ARRAY = types.Array(from_dtype(np.dtype(BOX)), 3, "C")


@intrinsic
def ray_aabb4(typingctx, node_box, node, br, t_max):
    """Slab test of one ray (its BoxRay br) against the 4 child boxes of BVH
    node ``node``,
    in float32 (<4 x float>: on a 128-bit SIMD unit half the
    micro-operations of <4 x double>, and no widening of the stored boxes).

    ``node_box`` is (m, 6, 4) float32: rows lo x, y, z, hi x, y, z, one
    lane per child.  ``br.nx, ny, nz`` are the rows of the planes the ray
    meets first on each axis (0/3, 1/4, 2/5 by the sign of its inverse
    direction), so no swap is needed: pbrt's dirIsNeg trick, vectorised
    across children as in Dammertz et al. 2008 ("Shallow Bounding Volume
    Hierarchies for Fast SIMD Ray Tracing of Incoherent Rays").

    Conservative, not exact: the entry it returns is at most, and the exit
    it compares with at least, the exact slab distances of the exact ray,
    so it enters every box the ray meets before t_max (and a few more, by
    a few float32 ulps).  The float32 ray constants of accel/bvh/traverse.py's
    ``box_ray`` make that so:

    - ``on*``/``of*``: the origin for the near and the far planes, rounded
      to float32 away from the near plane and towards the far one, so the
      subtraction of a rounded origin can only lower an entry and raise an
      exit;
    - ``in*``/``if*``: the inverse direction for the near and far planes,
      shrunk and grown by BOX32_MARGIN (2^-20: 16 float32 ulps, against at
      most 3 ulps of rounding in the inverse, the subtraction and the
      product), the near one bounded so its products cannot overflow.

    t_max is rounded to the nearest float32, at most half an ulp below it:
    the near margin lowers every entry by far more.  A far product that
    overflows is an infinite exit of the right sign, so it needs no
    bound.  The signs of the subtraction and the product are exact, so an
    exit below 0 is truly behind the ray.  Distances in float32's
    subnormal range round absolutely, by at most 2^-150: the entry is
    lowered and the exit raised by 2^-126 for them.

    A NaN slab distance (the ray in a face plane, 0 * inf) fails both
    comparisons and constrains nothing.  An unused lane (lo = hi = +inf)
    gets an entry of +inf or an exit of -inf on every axis: no ray enters it.

    Returns (mask, the 4 entry distances as float64): bit k of mask set
    where the ray enters child k (one vmovmskps), its distance (at most
    0 where the ray starts inside), inf where the ray misses the box or
    enters beyond t_max.

    LLVM does not vectorise the scalar form of this; the explicit vector
    form is faster, and float32 faster again (docs/benchmarks.md, "BVH").
    """
    fields = tuple(getattr(br, "types", ()))     # BoxRay: 3 rows, 12 float32 constants
    if node_box != BOX_ARRAY or not isinstance(node, types.Integer) or len(fields) != 15 \
            or not all(isinstance(a, types.Integer) for a in fields[:3]) \
            or not all(a == types.float32 for a in fields[3:]) \
            or not isinstance(t_max, types.Float):
        return None
    sig = types.Tuple((types.int64, types.UniTuple(types.float64, WIDTH)))(node_box, node, br,
                                                                           t_max)

    def codegen(context, builder, sig, llargs):
        box = llargs[0]
        parts = [builder.extract_value(llargs[2], k) for k in range(15)]
        node, nx, ny, nz = [context.cast(builder, v, t, types.int64) for v, t in zip(
            [llargs[1]] + parts[:3], (sig.args[1],) + fields[:3])]
        near_o, far_o, near_i, far_i = parts[3:6], parts[6:9], parts[9:12], parts[12:15]
        f32 = ir.FloatType()
        t_max = builder.fptrunc(context.cast(builder, llargs[3], sig.args[3], types.float64),
                                f32)
        data = context.make_array(sig.args[0])(context, builder, value=box).data
        vec = ir.VectorType(f32, WIDTH)
        i64 = ir.IntType(64)
        i32 = ir.IntType(32)

        def splat(x):
            return broadcast(builder, vec, x)

        base = builder.mul(node, ir.Constant(i64, 6 * WIDTH))

        def plane(row):
            p = builder.gep(data, [builder.add(base, builder.mul(row, ir.Constant(i64, WIDTH)))])
            return builder.load(builder.bitcast(p, vec.as_pointer()), align=4)

        t0 = splat(ir.Constant(f32, 0.0))
        t1 = splat(t_max)
        # far row: 3 - nx for x (0 <-> 3), 5 - ny for y (1 <-> 4), 7 - nz for z (2 <-> 5)
        for a, (near, far_sum) in enumerate(((nx, 3), (ny, 5), (nz, 7))):
            far = builder.sub(ir.Constant(i64, far_sum), near)
            tn = builder.fmul(builder.fsub(plane(near), splat(near_o[a])), splat(near_i[a]))
            tf = builder.fmul(builder.fsub(plane(far), splat(far_o[a])), splat(far_i[a]))
            t0 = builder.select(builder.fcmp_ordered(">", tn, t0), tn, t0)
            t1 = builder.select(builder.fcmp_ordered("<", tf, t1), tf, t1)
        subnormal = splat(ir.Constant(f32, 2.0 ** -126))
        t0 = builder.fsub(t0, subnormal)
        t1 = builder.fadd(t1, subnormal)
        inf = splat(ir.Constant(f32, float("inf")))
        # An unused lane (lo = hi = +inf) passes t0 <= t1 at t0 = inf when
        # t_max is inf: only a finite entry is a hit.
        hit = builder.and_(builder.fcmp_ordered("<=", t0, t1), builder.fcmp_ordered("<", t0, inf))
        entry = builder.fpext(builder.select(hit, t0, inf), ir.VectorType(ir.DoubleType(), WIDTH))
        lanes = [builder.extract_element(entry, ir.Constant(i32, k)) for k in range(WIDTH)]
        mask = builder.zext(builder.bitcast(hit, ir.IntType(WIDTH)), i64)
        return context.make_tuple(builder, sig.return_type, [
            mask, context.make_tuple(builder, sig.return_type[1], lanes)])

    return sig, codegen


@intrinsic
def box_ray_f32(typingctx, ox, oy, oz, ix, iy, iz, near_limit, margin, bounded):
    """ray_aabb4's float32 constants of a ray, the three axes at once in
    SIMD (in scalar code this set-up cost as much as the float32 test
    saved, docs/design.md): the near-plane origins x, y, z, the far-plane
    origins, the near inverses, the far inverses.

    The origin o is rounded to o32, within half an ulp; o32 +- (|o32| *
    2^-23 + 2^-149), at least a whole ulp away (subnormal too), is above
    and below o.  The near plane takes the one above where the inverse
    direction is positive (the near plane is then lo: a larger origin
    lowers lo - o) and the one below where it is negative; the far plane
    the other.  The near inverse is the inverse shrunk by ``margin`` and
    cut to ``near_limit`` in magnitude (infinite ones stay: a zero
    direction component's test is exact); the far one grown by ``margin``.

    Where ``bounded`` is false, or an inverse direction is below 2^-100
    (float32 would flush it, or its products, to zero, and an unused lane's
    0 * inf would then constrain nothing), the distances cannot be bounded:
    the constants that enter every used lane instead, origins +-FLT_MAX
    and inverses +inf: (b - FLT_MAX) * inf is -inf or NaN for any finite
    or -inf b, (b + FLT_MAX) * inf +inf or NaN, and an unused lane's +inf
    near plane +inf.  A tree past the range may hold +inf in a used lane's
    hi: its rays then take the near planes from rows lo (accel/bvh/traverse.py).
    Chosen by selects, not a branch: a branch in the set-up cost 5-8%.
    """
    floats = (ox, oy, oz, ix, iy, iz, near_limit, margin)
    if not all(isinstance(a, types.Float) for a in floats) \
            or not isinstance(bounded, types.Boolean):
        return None
    sig = types.UniTuple(types.float32, 12)(*floats, bounded)

    def codegen(context, builder, sig, llargs):
        f64, f32 = ir.DoubleType(), ir.FloatType()
        i32 = ir.IntType(32)
        v64, v32 = ir.VectorType(f64, 4), ir.VectorType(f32, 4)
        i64x4, i32x4 = ir.VectorType(ir.IntType(64), 4), ir.VectorType(i32, 4)
        args = [context.cast(builder, v, t, types.float64) for v, t in zip(llargs, sig.args[:8])]
        o_s, inv_s, (limit, margin) = args[0:3], args[3:6], args[6:8]

        def vector(xs, pad):
            v = ir.Constant(v64, [0.0] * 4)
            for k, x in enumerate(xs + [ir.Constant(f64, pad)]):
                v = builder.insert_element(v, x, ir.Constant(i32, k))
            return v

        def fabs(v, ity, mask):
            return builder.bitcast(builder.and_(builder.bitcast(v, ity),
                                                ir.Constant(ity, [mask] * 4)), v.type)

        o = builder.fptrunc(vector(o_s, 0.0), v32)
        inv = vector(inv_s, 1.0)
        step = builder.fadd(builder.fmul(fabs(o, i32x4, 0x7FFFFFFF),
                                         ir.Constant(v32, [2.0 ** -23] * 4)),
                            ir.Constant(v32, [2.0 ** -149] * 4))
        up, down = builder.fadd(o, step), builder.fsub(o, step)
        negative = builder.fcmp_ordered("<", inv, ir.Constant(v64, [0.0] * 4))
        near_o = builder.select(negative, down, up)
        far_o = builder.select(negative, up, down)
        one = broadcast(builder, v64, ir.Constant(f64, 1.0))
        margin = broadcast(builder, v64, margin)
        near = builder.fmul(inv, builder.fsub(one, margin))
        far = builder.fmul(inv, builder.fadd(one, margin))
        size = fabs(near, i64x4, 0x7FFFFFFFFFFFFFFF)
        limit = broadcast(builder, v64, limit)
        cut = builder.and_(builder.fcmp_ordered(">", size, limit),
                           builder.fcmp_ordered("<", size, ir.Constant(v64, [float("inf")] * 4)))
        sign = builder.and_(builder.bitcast(near, i64x4), ir.Constant(i64x4, [1 << 63] * 4))
        near = builder.select(cut, builder.bitcast(builder.or_(builder.bitcast(limit, i64x4),
                                                               sign), v64), near)
        vanishing = builder.fcmp_ordered("<", size, ir.Constant(v64, [2.0 ** -100] * 4))
        bounded = builder.and_(
            context.cast(builder, llargs[8], sig.args[8], types.boolean),
            builder.icmp_unsigned("==", builder.bitcast(vanishing, ir.IntType(4)),
                                  ir.Constant(ir.IntType(4), 0)))
        bounded = broadcast(builder, ir.VectorType(ir.IntType(1), 4), bounded)
        big = float(np.finfo(np.float32).max)
        columns = [builder.select(bounded, v, ir.Constant(v32, [x] * 4)) for v, x in (
            (near_o, big), (far_o, -big), (builder.fptrunc(near, v32), float("inf")),
            (builder.fptrunc(far, v32), float("inf")))]
        out = [builder.extract_element(v, ir.Constant(i32, k)) for v in columns for k in range(3)]
        return context.make_tuple(builder, sig.return_type, out)

    return sig, codegen


VERTICES = types.Array(types.float64, 2, "C")


CROSSING_LANES = 8    # crossing_mask's lanes: two chunks of 4 columns
# The fields of a ray the leaf tests (crossing_mask, leaf_hits) read: axes,
# then floats.
_LEAF_RAY_FIELDS = ("kx", "ky", "kz", "okx", "oky", "okz", "sx", "sy", "sz", "t_min")


def _leaf_test_types(leaf_tris, slots, ray, t_max):
    """The typing a leaf test shares: (the places of the ray's fields,
    the integer arguments' types: slots then axes, the floats' types), or
    None where the arguments do not fit."""
    names = getattr(ray, "fields", ())
    if not all(f in names for f in _LEAF_RAY_FIELDS):
        return None
    place = [names.index(f) for f in _LEAF_RAY_FIELDS]
    ints = tuple(slots) + tuple(ray.types[j] for j in place[:3])
    floats = tuple(ray.types[j] for j in place[3:]) + (t_max,)
    if leaf_tris != VERTICES or not all(isinstance(a, types.Integer) for a in ints) \
            or not all(isinstance(a, types.Float) for a in floats):
        return None
    return place, ints, floats


def _leaf_test_values(context, builder, sig, llargs, n_slots, place, ints, floats, vec):
    """The values a leaf test's code starts from: (leaf_tris's data
    pointer and row stride, the slots, the ray's axes kx, ky, kz as
    int64s, its origin okx, oky, okz, shear sx, sy, sz, t_min and t_max
    splatted over ``vec``)."""
    rows = context.make_array(sig.args[0])(context, builder, value=llargs[0])
    stride = builder.extract_value(rows.shape, 1)
    ray = llargs[1 + n_slots]
    values = [*llargs[1:1 + n_slots], *(builder.extract_value(ray, j) for j in place),
              llargs[2 + n_slots]]
    n_ints = n_slots + 3
    whole = [context.cast(builder, v, t, types.int64) for v, t in zip(values[:n_ints], ints)]
    splat = [broadcast(builder, vec, context.cast(builder, v, t, types.float64))
             for v, t in zip(values[n_ints:], floats)]
    return rows.data, stride, whole[:n_slots], whole[n_slots:], splat


def _corner_lanes(builder, coordinate, axes, origin):
    """Each corner's coordinates on the ray's axes, less its origin:
    [[x, y, z] of corner 0, 1, 2], as edge_functions takes them."""
    return [[builder.fsub(coordinate(c, a), o) for a, o in zip(axes, origin)] for c in range(3)]


@intrinsic
def crossing_mask(typingctx, leaf_tris, k, k2, ray, t_max):
    """The crossing triangle test (intersect._triangle with ``crossing``)
    of one ray (a CrossingRay or ListingRay: its watertight constants and
    t_min) against 8 triangles at once, in <8 x double>: columns k ..
    k + 3 and k2 .. k2 + 3 of ``leaf_tris`` (accel/bvh/build.py's CountingBVH:
    row 3 * corner + axis), two contiguous loads of 4 a row, no gather.
    Two chunks, so that two small leaves share a test.

    Returns two 8-bit masks, hits in bits 0-7 (lanes k.., then k2..) and
    "unsure" in bits 8-15:
    - a lane whose three edge functions share a strict sign takes the
      scalar test's remaining steps (det, the scaled distance against 0
      and t_max * det, t = t_scaled * (1 / det) against t_min and t_max),
      each lane operation for operation as the scalar test (no fused
      multiply-adds), so its hit bit is set exactly where the scalar test
      hits;
    - a lane with mixed signs is a miss, as in the scalar test;
    - any other lane (an edge function exactly 0, where the crossing rule
      decides which triangle owns the edge, or NaN: a column that holds
      no triangle) is unsure: the caller runs the scalar test on it.
    """
    typed = _leaf_test_types(leaf_tris, (k, k2), ray, t_max)
    if typed is None:
        return None
    place, ints, floats = typed
    sig = types.int64(leaf_tris, k, k2, ray, t_max)
    lanes = CROSSING_LANES

    def codegen(context, builder, sig, llargs):
        i64 = ir.IntType(64)
        chunk = ir.VectorType(ir.DoubleType(), lanes // 2)
        vec = ir.VectorType(ir.DoubleType(), lanes)
        both = ir.Constant(ir.VectorType(ir.IntType(32), lanes), list(range(lanes)))
        data, stride, chunks, axes, splat = _leaf_test_values(context, builder, sig, llargs, 2,
                                                              place, ints, floats, vec)
        okx, oky, okz, sx, sy, sz, t_min, t_max = splat

        def coordinate(corner, axis):
            """Component ``axis`` of the 8 triangles' corner, one per lane."""
            row = builder.mul(builder.add(ir.Constant(i64, 3 * corner), axis), stride)
            halves = [builder.load(builder.bitcast(builder.gep(data, [builder.add(row, c)]),
                                                   chunk.as_pointer()), align=8)
                      for c in chunks]
            return builder.shuffle_vector(halves[0], halves[1], both)

        corners = _corner_lanes(builder, coordinate, axes, (okx, oky, okz))
        edges, mixed = edge_functions(builder, corners, sx, sy)
        zero = ir.Constant(vec, [0.0] * lanes)

        def every_edge(op):
            e0, e1, e2 = [builder.fcmp_ordered(op, e, zero) for e in edges]
            return builder.and_(builder.and_(e0, e1), e2)

        strict = builder.or_(every_edge(">"), every_edge("<"))
        hit = builder.and_(strict, within_interval(builder, edges, corners, sz, t_min, t_max)[0])
        unsure = builder.and_(builder.not_(mixed), builder.not_(strict))
        bits = ir.IntType(lanes)
        return builder.or_(builder.zext(builder.bitcast(hit, bits), i64),
                           builder.shl(builder.zext(builder.bitcast(unsure, bits), i64),
                                       ir.Constant(i64, lanes)))

    return sig, codegen


LEAF_LANES = 4    # leaf_hits's lanes: the slots of a leaf of MAX_LEAF


@intrinsic
def leaf_hits(typingctx, leaf_tris, k, ray, t_max):
    """The triangle test (intersect._triangle without ``crossing``) of one
    ray (a Ray: its watertight constants and t_min) against the triangles
    in slots k .. k + 3 of ``leaf_tris`` (layout.BVH), in <4 x double>,
    each lane operation for operation as the scalar test (no fused
    multiply-adds), so a lane hits exactly where the scalar test hits, at
    the same t, b1, b2.

    Returns (mask, t, b1, b2): hits in bits 0-3; in bits 4-7 the lanes
    whose determinant is NaN, a sphere's or a padding column (the caller
    runs test_prim on them; a triangle there, of coordinates past float64's
    range, the scalar test misses too); t, b1, b2 as 4-tuples.
    """
    typed = _leaf_test_types(leaf_tris, (k,), ray, t_max)
    if typed is None:
        return None
    place, ints, floats = typed
    lanes = types.UniTuple(types.float64, LEAF_LANES)
    sig = types.Tuple((types.int64, lanes, lanes, lanes))(leaf_tris, k, ray, t_max)

    def codegen(context, builder, sig, llargs):
        i32, i64 = ir.IntType(32), ir.IntType(64)
        vec = ir.VectorType(ir.DoubleType(), LEAF_LANES)
        data, stride, (k,), axes, splat = _leaf_test_values(context, builder, sig, llargs, 1,
                                                            place, ints, floats, vec)
        okx, oky, okz, sx, sy, sz, t_min, t_max = splat

        def coordinate(corner, axis):
            """Component ``axis`` of the 4 triangles' corner, one per lane."""
            row = builder.mul(builder.add(ir.Constant(i64, 3 * corner), axis), stride)
            p = builder.gep(data, [builder.add(row, k)])
            return builder.load(builder.bitcast(p, vec.as_pointer()), align=8)

        corners = _corner_lanes(builder, coordinate, axes, (okx, oky, okz))
        edges, mixed = edge_functions(builder, corners, sx, sy)
        within, t, inv_det = within_interval(builder, edges, corners, sz, t_min, t_max)
        hit = builder.and_(builder.not_(mixed), within)
        unsure = builder.fcmp_unordered("uno", inv_det, inv_det)    # NaN where det is
        bits = ir.IntType(LEAF_LANES)
        mask = builder.or_(builder.zext(builder.bitcast(hit, bits), i64),
                           builder.shl(builder.zext(builder.bitcast(unsure, bits), i64),
                                       ir.Constant(i64, LEAF_LANES)))
        outs = [mask]
        for v in (t, builder.fmul(edges[1], inv_det), builder.fmul(edges[2], inv_det)):
            outs.append(context.make_tuple(builder, lanes, [
                builder.extract_element(v, ir.Constant(i32, j)) for j in range(LEAF_LANES)]))
        return context.make_tuple(builder, sig.return_type, outs)

    return sig, codegen
