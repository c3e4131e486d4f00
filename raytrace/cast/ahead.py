"""A first ray query's compiles split over two processes (kernels/ahead.py):
the query's kernel (its types are known before the build: each
structure's ``empty`` layout, and its counting layout's) and the
structure's builder, which this process needs before it builds.  The
shorter goes to the second process: the kernel where it is the shorter
(one-ray closest and any-hit kernels, the point queries', every query on
a structure other than the BVH), while this one compiles the builder and
builds; else the builder, while this one compiles the kernel (the BVH's
packet, counting and listing kernels), adopted before it builds.

For every query RayScene has a kernel for, only on a first run: no kernel
of that query, of any structure, in the cache (a glob), or a first
closest or any-hit query of a structure whose builder compiles long
(Structure.first_rays_ahead: the kd-tree after another structure).  Once
a process: a RayScene's first query.
"""
from raytrace.kernels import ahead

_KEY = "query"
# The kernels' cache index names (kernels/cast.py's, and the point
# queries' in accel/bvh/points.py; Numba drops a qualified name's "<"
# and ">").
_INDEX = {"closest": "cast._closest_kernel.locals.block-*.nbi",
          "occluded": "cast._occluded_kernel.locals.block-*.nbi",
          "count": "cast._counts_block-*.nbi",
          "list": "cast._listing_block-*.nbi",
          "points": "points._points_block-*.nbi"}
# While the second process runs: "query", what it compiles (a query's
# kernel, or "builder"); "here", precompile.main's arguments where this
# process compiles the query's kernel (before_build).
_pending = {}


def start(accel, query, n_rays):
    """Start the second process for a first ``query`` (a key of _INDEX) on
    ``accel`` of ``n_rays`` rays, unless its kernel is cached: compiling
    the kernel, or, where the kernel is the longer compile (_long_kernel),
    the structure's builder while this process compiles the kernel
    (before_build)."""
    if not ahead.worthwhile(_KEY):
        return
    from raytrace.accel.registry import get
    from raytrace.kernels.cachedir import kernel_cached
    if kernel_cached(_INDEX[query]) and (query == "points" or not get(accel).first_rays_ahead()):
        return
    from raytrace.cast.ordering import ORDER_MIN
    from raytrace.kernels.cast import PACKET_MIN
    packets = int(n_rays >= PACKET_MIN)
    here = get(accel).long_query_kernels and _long_kernel(query, packets)
    job = "builder" if here else query
    # A call that may be put in order (cast/ordering.py): its kernels too.
    ahead.launch(_KEY, "raytrace.cast.precompile", [accel, job, packets,
                                                     int(n_rays >= ORDER_MIN)])
    if ahead.pending(_KEY):
        _pending["query"] = job
        if here:
            _pending["here"] = (accel, query, packets == 1)


def _long_kernel(query, packets):
    """Whether the query's kernel is one that compiles longer than the
    builder on a structure with ``long_query_kernels`` (the registry's):
    counting, listing, and closest or any hit with packets; not the
    one-ray kernels nor the point queries' (docs/benchmarks.md, "First
    queries of every kind")."""
    return query in ("count", "list") or bool(packets and query in ("closest", "occluded"))


def before_build():
    """Where this process compiles the first query's kernel itself (start),
    compile it now, for the structure's empty layout, while the second
    process compiles the builder; then adopt the builder."""
    here = _pending.pop("here", None)
    if here is None:
        return
    from raytrace.cast.precompile import main
    main(*here)
    wait("builder")


def wait(query):
    """Wait for the second process, if one compiles ``query``'s kernel, and
    adopt what it compiled.  A query of another kind goes on meanwhile
    (RayScene.signed_distance on a structure other than the BVH: the
    point query compiles here while the count's kernel compiles there)."""
    if _pending.get("query") == query:
        del _pending["query"]
        ahead.wait(_KEY)


def cancel():
    """Stop the second process, if one runs (the build failed)."""
    _pending.clear()
    ahead.stop(_KEY)
