"""Frames and tiles as Dask tasks (the `distributed` extra).

The scene's arrays go to every worker once (scatter, broadcast); a task
gets only its camera (12 floats) and its rows, and sends back 8-bit
rows.  Dask reruns the tasks of a worker that dies, and where the death
took the scattered scene too, the runner sends it again and reruns them;
a task's answer depends only on its arguments, so a rerun changes
nothing in the image.
"""
import contextlib
import itertools
import os
import sys
import threading
import time
from concurrent.futures import CancelledError, Future

import numpy as np

from raytrace.cast.results import RayHits, _Fields
from raytrace.errors import RaytraceError
from raytrace.renderer import interrupt

EXTRA = "pip install 'raytrace[distributed]'"
WAIT_FOR_WORKERS_S = 30      # a scheduler with no workers would wait for ever
CONNECT_S = 10               # Dask retries a refused connection until then
TASKS_PER_WORKER = 4         # in flight at once: enough to hide the round trips
RESCATTERS = 2               # times a task may find its scattered scene lost and rerun


# Memory a local worker process takes: Python, Dask, Numba and the render
# modules imported measured 125 MB (/usr/bin/time, issue 45); the kernels
# loaded and the scene's buffers come on top.
WORKER_BYTES = 256 << 20


def check_worker_count(workers):
    """Refuse more local workers than free memory holds (64 on 2 cores
    passed 4 GB in 30 s while starting): an OptionError with the numbers."""
    from raytrace.scene.formats.mesh import available_memory
    free = available_memory()
    most = max(1, free // WORKER_BYTES)
    if workers > most:
        from raytrace.errors import OptionError
        raise OptionError(f"{workers} workers need about {workers * WORKER_BYTES / 2**30:.1f} GiB; "
                          f"this machine has {free / 2**30:.1f} GiB free, enough for {most}")


def _dask(why):
    try:
        import distributed
    except ImportError:
        raise RaytraceError(f"{why} needs the distributed extra: {EXTRA}") from None
    return distributed


_QUIET_TRACKER = "ignore:resource_tracker:UserWarning"


@contextlib.contextmanager
def connect(workers=None, scheduler=None, warm_up=None):
    """A DaskRunner on a local cluster of ``workers`` processes (started
    here, closed on the way out, Ctrl-C included) or on the running
    scheduler at ``scheduler``; ``warm_up``: as for DaskRunner.  A local
    cluster starts on a thread of its own: entered before the scene loads,
    its start overlaps loading, flattening and building, and the runner
    waits for it where it first needs its client."""
    if workers is not None:
        distributed = _dask("--workers")
        # One Dask thread a worker; the kernel's own threads share the cores.
        threads = max(1, (os.cpu_count() or 1) // workers)
        import warnings
        # After Ctrl-C, multiprocessing's resource tracker (a process that
        # takes this one's -W options when the cluster starts it) cleans up
        # the workers' semaphores and warns that it had to: a second line
        # under "interrupted: no animation written", now and then.
        if _QUIET_TRACKER not in sys.warnoptions:
            sys.warnoptions.append(_QUIET_TRACKER)
        # Its scheduler's HTTP server moves off a busy port 8787 (another
        # Dask's) and says so; nothing for a renderer's user to do.  For the
        # whole process (only the command starts a cluster): catch_warnings,
        # not thread-safe, would race the loading thread's.
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        started = _in_background(lambda: _local_cluster(distributed, workers))
        try:
            yield DaskRunner(started, threads, warm_up)
        finally:
            _close_local(started)
    else:
        from raytrace.frames.dask_address import check_scheduler_address
        scheduler = check_scheduler_address(scheduler)
        distributed = _dask("--scheduler")
        check_handshake(scheduler)
        try:
            client = distributed.Client(scheduler, timeout=CONNECT_S)
        except (OSError, TimeoutError) as exc:
            raise RaytraceError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        with client:
            yield DaskRunner(client, None, warm_up)


def _local_cluster(distributed, workers):
    """(cluster, client) of ``workers`` local processes, started."""
    import logging
    # The workers import Numba and the render kernel's modules as they
    # start, while this process loads and builds the scene, instead of
    # when the scene first reaches them, inside the frames' time.
    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                       processes=True, dashboard_address=None,
                                       # A worker's ERROR lines are tracebacks
                                       # (a lost scheduler as the cluster closes
                                       # on Ctrl-C); a task's failure reaches the
                                       # command as its exception, one line.
                                       silence_logs=logging.CRITICAL,
                                       preload=["raytrace.kernels.waves"])
    try:
        return cluster, distributed.Client(cluster)
    except BaseException:
        cluster.close()
        raise


def _in_background(start):
    """A Future of ``start()``, run on a daemon thread (one that never
    holds up the interpreter's exit)."""
    future = Future()
    future.set_running_or_notify_cancel()

    def run():
        try:
            future.set_result(start())
        except BaseException as exc:  # noqa: BLE001 -- raised where the result is asked for
            future.set_exception(exc)
    threading.Thread(target=run, daemon=True, name="raytrace-cluster-start").start()
    return future


def _close_local(started):
    """Close a local cluster from _in_background once its start is over: a
    Ctrl-C or an error while the scene loaded waits for it, so that none of
    its processes is left behind.  A start that failed has nothing to close
    (its error reached the command where the client was first needed, or
    gives way to the error that ended the command first)."""
    if interrupt.interrupted():
        _quiet_closing()
    try:
        cluster, client = started.result()
    except Exception:  # noqa: BLE001 -- see above
        return
    try:
        client.close()
    finally:
        cluster.close()


def _quiet_closing():
    """Stopping (Ctrl-C, SIGTERM): what the scheduler logs as the cluster
    closes under its tasks (a worker it no longer knows, with a traceback;
    itself, or through asyncio's "Task exception was never retrieved") is
    not news to the user."""
    import logging
    for name in ("distributed", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def check_handshake(scheduler, timeout=None):
    """Connect to ``scheduler`` and exchange Dask's handshake, all within
    ``timeout`` seconds (CONNECT_S), or raise a RaytraceError naming it.
    distributed.Client bounds only the TCP connection: it then waits for
    ever on a peer that answers nothing Dask can read (an HTTP server's
    port), and reads another's bytes as frame sizes (a traceback, or a
    MemoryError after asking for exabytes)."""
    import asyncio

    from distributed.comm import CommClosedError
    from distributed.comm import connect as comm_connect
    from distributed.security import Security
    timeout = CONNECT_S if timeout is None else timeout
    unlike = "(is it a Dask scheduler's address?)"

    async def handshake():
        # Dask retries a refused connection for this long; the handshake
        # gets the rest of the time.  Half, so that Dask's own deadline
        # (a refusal, said as one) comes well before ours on a loaded
        # machine: at 0.8 a test's event loop, starved for 0.2 s of its
        # 1 s, reported a refused port as no answer.
        comm = await comm_connect(scheduler, timeout=0.5 * timeout,
                                  **Security().get_connection_args("client"))
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout))
    except (asyncio.TimeoutError, TimeoutError):
        raise RaytraceError(f"no answer from {scheduler} in {timeout:g} s {unlike}") from None
    except CommClosedError:
        raise RaytraceError(f"{scheduler} closed the connection before Dask's handshake "
                            f"{unlike}") from None
    except OSError as exc:                   # refused, or no such host
        raise RaytraceError(f"cannot reach the Dask scheduler at {scheduler}: "
                            f"{_os_reason(exc)}") from None
    except Exception:  # noqa: BLE001 -- whatever the peer's bytes made Dask's reader raise
        raise RaytraceError(f"{scheduler} answered with something other than Dask's handshake "
                            f"{unlike}") from None


def _os_reason(exc):
    """The system's words under Dask's wrappers ("Connection refused"), or
    Dask's own ("Timed out trying to connect ...")."""
    inner = exc
    while inner is not None:
        if getattr(inner, "strerror", None):
            return inner.strerror
        inner = inner.__cause__ or inner.__context__
    return str(exc)


class DaskRunner:
    """Runs tasks on a Dask client's workers; results come back in task order.

    ``warm_up(scene, opts)``: (payload, camera) of a tiny scene whose
    render kernel is the one ``scene`` will use (cli/warmup.py's
    worker_payload); with it, ``warm`` has each worker render an empty band
    of it, compiling or loading that kernel, while this process flattens
    the scene and builds its structure.  The tiles queue behind it."""

    def __init__(self, client, threads, warm_up=None):
        # A Client, or a Future of (cluster, client) still starting (connect's).
        self._client = client
        self.threads = threads       # None: each worker's Numba default (its cores)
        self.scatter_s = 0.0
        self.warm_up = warm_up
        self.warm_here_s = 0.0
        self._warming = []

    @property
    def client(self):
        if isinstance(self._client, Future):
            self._client = self._client.result()[1]
        return self._client

    def warm(self, scene, opts):
        """Send the warm-up to every worker now; it runs on each as its first task."""
        if self.warm_up is None:
            return
        t0 = time.perf_counter()
        payload, cam = self.warm_up(scene, opts)
        # The builder's load (or compile) moves here from prepare's: still compile time.
        self.warm_here_s = time.perf_counter() - t0
        for address in self.client.scheduler_info()["workers"]:
            self._warming.append((address, self.client.submit(
                _warm_worker, payload, self.threads, cam, workers=[address],
                allow_other_workers=False, pure=False)))

    def warmed(self):
        """{worker: seconds} of every warm-up sent, None for one that has not
        finished (a worker still compiling when the others had rendered
        every tile, or one that died), which is cancelled."""
        out = {}
        for address, f in self._warming:
            if f.done() and f.status == "finished":
                out[address] = f.result()[1]
            else:
                out[address] = None
                f.cancel()
        self._warming = []
        return out

    @property
    def workers(self):
        return max(1, len(self.client.scheduler_info()["workers"]))

    def run(self, payload, tasks):
        try:
            self.client.wait_for_workers(1, timeout=WAIT_FOR_WORKERS_S)
        except TimeoutError:
            raise RaytraceError(f"no Dask workers joined the scheduler in "
                                f"{WAIT_FOR_WORKERS_S} s") from None
        t0 = time.perf_counter()
        self._scatter(payload)
        # Sending the scene; the first time, also each worker's import of
        # raytrace and Numba to unpickle it: start-up, timed apart.
        self.scatter_s = time.perf_counter() - t0
        workers = self.workers
        window = TASKS_PER_WORKER * workers
        group = _group_size(len(tasks), tasks.tallest, payload, workers)
        untaken = iter(tasks)         # batch.Tasks: made as they are submitted
        futures = []      # (future, its tiles, the scatter it was given)
        try:
            while tiles := list(itertools.islice(untaken, group)):
                futures.append(self._submit(tiles))
                if len(futures) >= window:
                    yield from self._result(payload, *futures.pop(0))
            while futures:
                yield from self._result(payload, *futures.pop(0))
        finally:
            for f, _, _ in futures:
                f.cancel()

    def _scatter(self, payload):
        try:
            self._shared = self.client.scatter(payload, broadcast=True, hash=False)
        except Exception as exc:           # the workers could not take the scene's buffers
            raise _failure(exc) from None

    def _submit(self, tiles):
        shared = self._shared
        return (self.client.submit(_render_tiles, shared, self.threads, tiles, pure=False),
                tiles, shared)

    def _result(self, payload, future, tiles, shared):
        for attempt in range(RESCATTERS + 1):
            try:
                return future.result()
            except RaytraceError:
                raise
            except CancelledError as exc:
                # A worker's death can take the scattered scene with it and
                # cancel the tasks that need it, even broadcast to every
                # worker (dask/distributed#3149): send it again, once for all
                # the tasks that had the lost copy, and run these tiles again.
                if attempt == RESCATTERS:
                    raise _failure(exc) from None
                if self._shared is shared:
                    self._scatter(payload)
                future, tiles, shared = self._submit(tiles)
            except Exception as exc:
                raise _failure(exc) from None


# A Dask task's scheduling and transfer cost more than a small tile's render
# (docs/benchmarks.md): several small tiles go in one task, up to this many
# pixel samples, while each worker still gets TASKS_PER_WORKER tasks.
TASK_SAMPLES = 1 << 20


def _group_size(n_tasks, tallest, payload, workers):
    """How many consecutive tiles (of ``n_tasks``, at most ``tallest`` rows
    each) make one Dask task."""
    width, spp = payload.width, payload.spp
    if not n_tasks or not isinstance(width, int) or not isinstance(spp, int):
        return 1
    samples = max(1, tallest * width * spp)
    by_size = max(1, TASK_SAMPLES // samples)
    by_balance = max(1, n_tasks // (TASKS_PER_WORKER * workers))
    return min(by_size, by_balance)


def _warm_worker(payload, threads, cam):
    """One worker's warm-up task: an empty band through the tiles' own
    function, so exactly their kernel loads or compiles: (the worker, its
    seconds).  Quiet: the command has said what compiles."""
    from raytrace.frames.batch import render_tile
    from raytrace.renderer.firstrun import set_quiet
    set_quiet(True)
    tile = render_tile(payload, threads, cam, 0, 0, 0)
    return tile.worker, tile.compile_s


def _render_tiles(payload, threads, tasks):
    """One Dask task: its tiles in order (batch.render_tile each)."""
    from raytrace.frames.batch import render_tile
    return [render_tile(payload, threads, cam, frame, y0, y1) for cam, frame, y0, y1 in tasks]


def _failure(exc):
    """A worker's failure, said in one line."""
    from distributed.scheduler import KilledWorker
    if isinstance(exc, KilledWorker):
        return RaytraceError("Dask workers died running a tile, more often than Dask retries a task")
    text = str(exc).splitlines()[0] if str(exc) else ""
    missing = isinstance(exc, ImportError) or "No module named" in text
    return RaytraceError(f"a Dask worker failed: {type(exc).__name__}: {text}"
                         + (" (is raytrace installed on the workers?)" if missing else ""))


# One record a ray for the hits of a block: every field of RayHits in one
# map_blocks call, so the rays of a block are cast once, not once a field.
HIT_RECORD = np.dtype([("t", "f8"), ("geometry_id", "i8"), ("prim_id", "i8"), ("u", "f8"),
                       ("v", "f8"), ("normal", "f8", (3,)), ("point", "f8", (3,))])


def _hits_block(origins, directions, scene, t_min, t_max):
    from raytrace.kernels.jitconfig import KERNEL_LOCK
    out = np.empty(len(origins), dtype=HIT_RECORD)
    if len(origins):
        with KERNEL_LOCK:           # Dask's threads would launch kernels at once
            hits = scene.cast_rays(origins, directions, t_min, t_max)
            for name in HIT_RECORD.names:
                out[name] = hits[name]
    return out


def _occluded_block(origins, directions, scene, t_min, t_max):
    from raytrace.kernels.jitconfig import KERNEL_LOCK
    if not len(origins):
        return np.zeros(0, bool)
    with KERNEL_LOCK:
        return scene.occluded(origins, directions, t_min, t_max)


def _ray_blocks(scene, origins, directions, why):
    """The rays as (n, 3) Dask arrays chunked by rows only (each block whole
    rays), and the scene, built here and shared by every block's task."""
    try:
        import dask
        import dask.array as da
    except ImportError:
        raise RaytraceError(f"{why} needs the distributed extra: {EXTRA}") from None
    from raytrace.cast.rayscene import RayScene
    if not isinstance(scene, RayScene):
        raise RaytraceError(f"scene: expected a RayScene, got {type(scene).__name__}")
    o, d = da.asarray(origins), da.asarray(directions)
    if o.ndim != 2 or o.shape[1] != 3 or d.shape != o.shape:
        raise RaytraceError(f"origins and directions must both be (n, 3) arrays, "
                            f"got {o.shape} and {d.shape}")
    d = d.rechunk({0: o.chunks[0], 1: 3})
    o = o.rechunk({1: 3})
    scene._built()                  # once, here: each worker gets the structure, not the job
    return da, o, d, dask.delayed(scene, pure=True)


class DaskHits(_Fields):
    """RayHits' fields (t, geometry_id, prim_id, u, v, normal, point) as
    lazy Dask arrays, read as a RayHits' are (``h.t``, ``h["t"]``,
    ``h.hit``, ``h.items()``); ``compute()`` gives them all as NumPy arrays
    in one DaskHits, from one pass over the blocks."""
    FIELDS = RayHits.FIELDS
    ALIASES = RayHits.ALIASES

    def __init__(self, fields):
        self.__dict__.update(fields)

    @property
    def hit(self):
        return self.geometry_id >= 0

    @property
    def object_id(self):
        return self.geometry_id

    def compute(self, **kwargs):
        import dask
        return DaskHits(dict(zip(self.FIELDS, dask.compute(*self.values(), **kwargs))))

    def __repr__(self):
        return f"DaskHits({len(self.t)} rays)"


def cast_rays(scene, origins, directions, t_min=0.0, t_max=float("inf")):
    """Closest hits of a Dask array of rays against a RayScene, block by
    block (map_blocks): a DaskHits, the fields of RayHits as lazy Dask
    arrays (t, geometry_id, prim_id, u, v, normal, point).  Compute them on
    any Dask scheduler; billions of rays never need to fit in one memory."""
    da, o, d, shared = _ray_blocks(scene, origins, directions, "cast_rays on Dask arrays")
    records = da.map_blocks(_hits_block, o, d, shared, t_min, t_max, drop_axis=1,
                            dtype=HIT_RECORD, meta=np.empty(0, HIT_RECORD))
    return DaskHits({name: records[name] for name in HIT_RECORD.names})


def occluded(scene, origins, directions, t_min=0.0, t_max=float("inf")):
    """RayScene.occluded for a Dask array of rays: a lazy (n,) boolean
    Dask array, block by block."""
    da, o, d, shared = _ray_blocks(scene, origins, directions, "occluded on Dask arrays")
    return da.map_blocks(_occluded_block, o, d, shared, t_min, t_max, drop_axis=1, dtype=bool,
                         meta=np.empty(0, bool))
