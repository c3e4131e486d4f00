"""Python threads for the nogil kernels: every parallel kernel (ray
queries, the render, the builders) is a thread's share compiled as a
function of its own and run on this many threads at once, where Numba's
``prange`` would compile a parallel wrapper around it for each type of
its arguments (seconds each: its gufunc unpacks every array of the scene
and the structure).  Each job runs on a thread of its own, the first on
the calling thread, and a job's error (MemoryError, say) is raised by the
caller, not lost in a thread.

Worker threads are kept between calls (starting one costs more than a
small query), as daemons, so a Ctrl-C that ends the command never waits
for a thread's share to finish."""
import functools
import itertools
import os
import queue
import threading

_idle = []                # workers waiting for a job: their inboxes
_idle_lock = threading.Lock()
_numbers = itertools.count(1)


def _forget_workers():
    """In a forked child: the parent's workers are not there."""
    global _idle_lock
    _idle.clear()
    _idle_lock = threading.Lock()


os.register_at_fork(after_in_child=_forget_workers)


def _work(inbox):
    while True:
        job, done, failed = inbox.get()
        try:
            job()
        except BaseException as exc:  # noqa: BLE001 -- handed to the caller
            failed.append(exc)
        # An idle worker holds nothing: the job's arrays (a build's, a
        # mesh's corners) are freed when the caller drops them.
        job = None
        with _idle_lock:
            _idle.append(inbox)
        done.release()


def _worker():
    """An idle worker's inbox, or a new worker's."""
    with _idle_lock:
        if _idle:
            return _idle.pop()
    inbox = queue.SimpleQueue()
    threading.Thread(target=_work, args=(inbox,), daemon=True,
                     name=f"raytrace-kernel-{next(_numbers)}").start()
    return inbox


def run_on_threads(jobs):
    """Run ``jobs`` (callables) at once, one a thread; returns when all are
    done, raising the first error any of them raised."""
    if len(jobs) == 1:       # a small call: no thread to wake or wait for
        jobs[0]()
        return
    failed = []
    done = threading.Semaphore(0)
    for job in jobs[1:]:
        _worker().put((job, done, failed))
    if jobs:
        try:
            jobs[0]()
        except BaseException as exc:  # noqa: BLE001 -- raised below, after the others
            failed.append(exc)
    for _ in jobs[1:]:
        done.acquire()
    if failed:
        raise failed[0]


def run_rows(block, args, cnt_rows, clock):
    """``block(*args, cnt_rows[b], clock)`` for each counter row b at once,
    one a thread: a batch kernel whose threads take chunks by ticket from
    ``clock`` (kernels/cast.py)."""
    run_on_threads([functools.partial(block, *args, row, clock) for row in cnt_rows])


def runs(n, threads):
    """[start, end) of ``threads`` near-equal runs of range(n)."""
    cuts = [n * k // threads for k in range(threads + 1)]
    return list(zip(cuts[:-1], cuts[1:]))
