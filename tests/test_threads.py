"""raytrace.kernels.threads: every job runs, on threads of its own, and an error in
any of them reaches the caller."""
import threading

import pytest

from raytrace.kernels.threads import run_on_threads, runs


def test_every_job_runs_the_first_on_the_calling_thread():
    seen = []
    run_on_threads([lambda k=k: seen.append((k, threading.current_thread().name))
                    for k in range(3)])
    assert sorted(k for k, _ in seen) == [0, 1, 2]
    assert dict(seen)[0] == threading.current_thread().name
    assert len({name for _, name in seen}) == 3


@pytest.mark.parametrize("which", [0, 2])
def test_a_jobs_error_is_raised_by_the_caller(which):
    done = []

    def job(k):
        if k == which:
            raise MemoryError("job failed")
        done.append(k)
    with pytest.raises(MemoryError, match="job failed"):
        run_on_threads([lambda k=k: job(k) for k in range(3)])
    assert sorted(done) == [k for k in range(3) if k != which]   # the others still ran


@pytest.mark.parametrize("n, threads", [(0, 2), (1, 2), (10, 3), (7, 7), (1_000_003, 2)])
def test_runs_cover_the_range_in_order(n, threads):
    r = runs(n, threads)
    assert len(r) == threads and r[0][0] == 0 and r[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(r, r[1:]))
    assert max(e - s for s, e in r) - min(e - s for s, e in r) <= 1


def test_workers_are_kept_between_calls_and_a_forked_child_starts_its_own():
    import os
    names = []
    for _ in range(3):
        run_on_threads([lambda: None, lambda: names.append(threading.current_thread().name)])
    assert len(set(names)) == 1                # one worker, kept
    pid = os.fork()
    if pid == 0:                               # the parent's worker is not in the child
        got = []
        run_on_threads([lambda: None, lambda: got.append(1)])
        os._exit(0 if got == [1] else 3)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


def test_an_idle_worker_holds_nothing_of_its_last_job():
    """A worker waiting for work keeps no reference to the job it ran: a
    job's arrays (a build's, a mesh's corners) are freed when the caller
    drops them, not when the worker next gets work."""
    import gc
    import weakref

    class Payload:
        pass
    held = [Payload(), Payload()]
    gone = [weakref.ref(p) for p in held]
    run_on_threads([lambda p=p: None for p in held])
    del held
    gc.collect()
    assert [ref() for ref in gone] == [None, None]
