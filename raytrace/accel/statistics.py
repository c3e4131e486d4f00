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
    counts = np.asarray(counts)
    if not len(counts):
        return {"leaves": 0}
    hist = np.histogram(counts, bins=list(LEAF_BINS) + [np.inf])[0]
    return {
        "leaves": int(len(counts)),
        "max_depth": int(np.max(depths)),
        "mean_leaf_depth": float(np.mean(depths)),
        "primitives_per_leaf_mean": float(np.mean(counts)),
        "primitives_per_leaf_max": int(np.max(counts)),
        "leaf_size_histogram": dict(zip(LEAF_BIN_LABELS, (int(h) for h in hist))),
    }


def half_area(lo, hi):
    e = np.maximum(np.asarray(hi) - np.asarray(lo), 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]
