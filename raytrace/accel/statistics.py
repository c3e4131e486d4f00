"""Shared arithmetic of the structure statistics (pbrt's statistics are the
model: named, grouped, with units); each structure's module computes its
own from its layout."""
import numpy as np

# Leaf-size histogram bins: 0 (empty), 1, 2, 3, 4, 5-8, 9-16, 17+.
LEAF_BINS = (0, 1, 2, 3, 4, 5, 9, 17)
LEAF_BIN_LABELS = ("0", "1", "2", "3", "4", "5-8", "9-16", "17+")


def memory(layout, n_prims):
    """Bytes of the layout's arrays, in all and per primitive."""
    total = int(sum(a.nbytes for a in layout if isinstance(a, np.ndarray)))
    return {"memory_bytes": total,
            "bytes_per_primitive": total / n_prims if n_prims else 0.0}


def leaves(counts, depths):
    """Statistics of leaves with the given primitive counts and depths."""
    counts = np.asarray(counts, np.int64)
    if not len(counts):
        return {"leaves": 0}
    return leaf_histograms(np.bincount(counts), np.bincount(np.asarray(depths, np.int64)))


def leaf_histograms(by_count, by_depth):
    """leaves' statistics from two histograms: by_count[k] leaves hold k
    primitives, by_depth[d] leaves lie at depth d (a structure whose
    leaves are lanes of its nodes counts them without listing them)."""
    n = int(by_count.sum())
    if not n:
        return {"leaves": 0}
    ks, ds = np.arange(len(by_count)), np.arange(len(by_depth))
    edges = list(LEAF_BINS) + [len(by_count)]
    hist = [int(by_count[a:max(a, b)].sum()) for a, b in zip(edges, edges[1:])]
    return {
        "leaves": n,
        "max_depth": int(ds[by_depth > 0].max()),
        "mean_leaf_depth": float((ds * by_depth).sum() / n),
        "primitives_per_leaf_mean": float((ks * by_count).sum() / n),
        "primitives_per_leaf_max": int(ks[by_count > 0].max()),
        "leaf_size_histogram": dict(zip(LEAF_BIN_LABELS, hist)),
    }


def half_area(lo, hi):
    e = np.maximum(np.asarray(hi) - np.asarray(lo), 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]
