"""Python threads for the builders' nogil kernels (the BVH build, big
meshes' boxes and corners): each job on a thread of its own, the first on
the calling thread, and a job's error (MemoryError, say) raised by the
caller, not lost in a thread."""
import threading


def run_on_threads(jobs):
    """Run ``jobs`` (callables) at once, one a thread; returns when all are
    done, raising the first error any of them raised."""
    failed = []

    def run(job):
        try:
            job()
        except BaseException as exc:  # noqa: BLE001 -- handed to the caller below
            failed.append(exc)
    workers = [threading.Thread(target=run, args=(job,)) for job in jobs[1:]]
    for w in workers:
        w.start()
    if jobs:
        run(jobs[0])
    for w in workers:
        w.join()
    if failed:
        raise failed[0]


def runs(n, threads):
    """[start, end) of ``threads`` near-equal runs of range(n)."""
    cuts = [n * k // threads for k in range(threads + 1)]
    return list(zip(cuts[:-1], cuts[1:]))
