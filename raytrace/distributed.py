"""Frames and tiles as Dask tasks (the `distributed` extra).

The scene's arrays go to every worker once (scatter, broadcast); a task
gets only its camera (12 floats) and its rows, and sends back 8-bit
rows.  Dask reruns the tasks of a worker that dies; a task's answer
depends only on its arguments, so a rerun changes nothing in the image.
"""
import contextlib
import os

from .errors import RaytraceError

EXTRA = "pip install 'raytrace[distributed]'"
WAIT_FOR_WORKERS_S = 30      # a scheduler with no workers would wait for ever
TASKS_PER_WORKER = 4         # in flight at once: enough to hide the round trips


def _dask(why):
    try:
        import distributed
    except ImportError:
        raise RaytraceError(f"{why} needs the distributed extra: {EXTRA}") from None
    return distributed


@contextlib.contextmanager
def connect(workers=None, scheduler=None):
    """A DaskRunner on a local cluster of ``workers`` processes (started
    here, closed on the way out, Ctrl-C included) or on the running
    scheduler at ``scheduler``."""
    if workers is not None:
        distributed = _dask("--workers")
        import logging
        # One Dask thread a worker; the kernel's own threads share the cores.
        threads = max(1, (os.cpu_count() or 1) // workers)
        import warnings
        with warnings.catch_warnings():
            # Its scheduler's HTTP server moves off a busy port 8787 (another
            # Dask's) and says so; nothing for a renderer's user to do.
            warnings.filterwarnings("ignore", message="Port .* is already in use")
            cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                               processes=True, dashboard_address=None,
                                               silence_logs=logging.ERROR)
        with cluster, distributed.Client(cluster) as client:
            yield DaskRunner(client, threads)
    else:
        distributed = _dask("--scheduler")
        try:
            client = distributed.Client(scheduler, timeout=WAIT_FOR_WORKERS_S)
        except (OSError, TimeoutError) as exc:
            raise RaytraceError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        with client:
            yield DaskRunner(client, None)


class DaskRunner:
    """Runs tasks on a Dask client's workers; results come back in task order."""

    def __init__(self, client, threads):
        self.client = client
        self.threads = threads       # None: each worker's Numba default (its cores)

    @property
    def workers(self):
        return max(1, len(self.client.scheduler_info()["workers"]))

    def run(self, payload, tasks):
        from .batch import render_tile
        try:
            self.client.wait_for_workers(1, timeout=WAIT_FOR_WORKERS_S)
        except TimeoutError:
            raise RaytraceError(f"no Dask workers joined the scheduler in "
                                f"{WAIT_FOR_WORKERS_S} s") from None
        shared = self.client.scatter(payload, broadcast=True, hash=False)
        window = TASKS_PER_WORKER * self.workers
        futures = []
        try:
            for cam, frame, y0, y1 in tasks:
                futures.append(self.client.submit(render_tile, shared, self.threads, cam, frame,
                                                  y0, y1, pure=False))
                if len(futures) >= window:
                    yield self._result(futures.pop(0))
            while futures:
                yield self._result(futures.pop(0))
        finally:
            for f in futures:
                f.cancel()

    @staticmethod
    def _result(future):
        try:
            return future.result()
        except RaytraceError:
            raise
        except Exception as exc:       # a worker's failure, said in one line
            from distributed.scheduler import KilledWorker
            if isinstance(exc, KilledWorker):
                raise RaytraceError("Dask workers died running a tile, more often than Dask "
                                    "retries a task") from None
            raise RaytraceError(f"a Dask worker failed: {type(exc).__name__}: {exc}"
                                + (" (is raytrace installed on the workers?)"
                                   if isinstance(exc, ImportError) else "")) from None
