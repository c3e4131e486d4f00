"""The binned-SAH BVH built on every thread, node for node the tree the
serial builder (bvh.py) makes.

The top of the tree is built serially until nodes hold at most n / SPLIT
primitives; those nodes' subtrees are independent (each owns its range of
prim_ids), so they are built in parallel, each by the serial loop
(``build_nodes``) into arrays of its own.  They are then copied, in
depth-first order with the top nodes between them, into arrays of the
tree's exact size, which is the serial builder's order: the output is
identical, so the 4-wide collapse, the statistics and the images are too.
A subtree's arrays are freed once copied, so the peak is about the serial
build's (the whole tree once) plus the largest subtree.

Subtrees go to threads largest first, each to the least loaded (LPT
scheduling).  The threads are Python's, each running the serial loop with
the GIL released: a prange kernel measured the same speed and cost 2.7 s
more to compile the first time.
"""
import threading

import numba
import numpy as np
from numba import njit

from ..kernels.jit import BUILD
from .bvh import build_nodes

# Subtrees of at most n / SPLIT primitives are built in parallel: the top
# levels above them are serial passes over every primitive, and smaller
# subtrees balance the threads better.  4, 8 and 16 measured alike at 1M
# and 4.2M triangles (2 threads); 32 and 128 slower.
SPLIT = 8


@njit(**dict(BUILD, nogil=True))
def _build_range(lo, hi, prim_ids, start, end, depth, max_leaf, node_lo, node_hi,
                 node_start, node_count, first, defer, tasks):
    """build_nodes, callable from Python threads (it releases the GIL)."""
    return build_nodes(lo, hi, prim_ids, start, end, depth, max_leaf, node_lo, node_hi,
                       node_start, node_count, first, defer, tasks)


@njit(**BUILD)
def _copy_subtree(node_lo, node_hi, node_start, node_count, row, sub_lo, sub_hi, sub_start,
                  sub_count, n_sub):
    """A subtree built on its own (rows 0:n_sub) into rows row.. of the
    tree, its links moved with it."""
    for i in range(n_sub):
        r = row + i
        for a in range(3):
            node_lo[r, a] = sub_lo[i, a]
            node_hi[r, a] = sub_hi[i, a]
        node_count[r] = sub_count[i]
        node_start[r] = sub_start[i] if sub_count[i] > 0 else sub_start[i] + row


def build_bvh_parallel(lo, hi, max_leaf, threads=None, split=SPLIT):
    """build_bvh_kernel's result (bvh.py), built on ``threads`` threads
    (default: Numba's)."""
    threads = threads or numba.get_num_threads()
    n = lo.shape[0]

    def empty_nodes(rows):   # np.empty: only the rows a build writes cost memory
        return (np.empty((rows, 3)), np.empty((rows, 3)), np.empty(rows, np.int64),
                np.empty(rows, np.int64))
    top = empty_nodes(2 * n - 1)
    prim_ids = np.arange(n)
    tasks = np.empty((n, 4), np.int64)
    n_top, max_depth, n_tasks = _build_range(lo, hi, prim_ids, 0, n, 0, max_leaf, *top, 0,
                                             max(n // split, 1), tasks)
    tasks = tasks[:n_tasks].copy()
    # Largest subtree first, each to the least loaded thread.
    queues = [[] for _ in range(threads)]
    load = [0] * threads
    for k in sorted(range(n_tasks), key=lambda k: tasks[k, 1] - tasks[k, 2]):
        th = load.index(min(load))
        queues[th].append(k)
        load[th] += int(tasks[k, 2] - tasks[k, 1])
    subtrees = [None] * n_tasks
    no_tasks = tasks[:0]

    def work(queue):
        for k in queue:
            s, e, d = (int(x) for x in tasks[k, 1:])
            sub = empty_nodes(2 * (e - s) - 1)
            rows, depth, _ = _build_range(lo, hi, prim_ids, s, e, d, max_leaf, *sub, 0, 0,
                                          no_tasks)
            subtrees[k] = (sub, rows, depth)
    workers = [threading.Thread(target=work, args=(q,)) for q in queues[1:]]
    for w in workers:
        w.start()
    work(queues[0])
    for w in workers:
        w.join()
    # Depth-first rows: the top's nodes in order, a placeholder replaced by
    # its subtree.  A top node's second child is a later top node.
    task_of = dict(zip(tasks[:, 0].tolist(), range(n_tasks)))
    final = np.empty(n_top + 1, np.int64)
    row = 0
    for t in range(n_top):
        final[t] = row
        k = task_of.get(t)
        row += 1 if k is None else subtrees[k][1]
    nodes = empty_nodes(row)
    top_lo, top_hi, top_start, top_count = (a[:n_top] for a in top)
    inner = top_count == 0
    leaf = top_count > 0
    rows = final[:n_top][inner | leaf]
    nodes[0][rows] = top_lo[inner | leaf]
    nodes[1][rows] = top_hi[inner | leaf]
    nodes[3][rows] = top_count[inner | leaf]
    nodes[2][final[:n_top][leaf]] = top_start[leaf]
    nodes[2][final[:n_top][inner]] = final[top_start[inner]]
    del top
    for k in range(n_tasks):
        sub, n_sub, depth = subtrees[k]
        _copy_subtree(*nodes, final[tasks[k, 0]], *sub, n_sub)
        max_depth = max(max_depth, depth)
        subtrees[k] = None           # its memory goes now, not at the end
    return nodes + (prim_ids, max_depth)
