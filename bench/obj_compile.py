"""The OBJ reader's kernel compiled cold (docs/benchmarks.md, "OBJ reader"):
run with an empty NUMBA_CACHE_DIR.  A trivial kernel is compiled first, so
Numba's own start-up is not counted.

    NUMBA_CACHE_DIR=$(mktemp -d) python bench/obj_compile.py
"""
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from raytrace.scene.formats.obj import warm_kernel  # noqa: E402


@numba.njit
def _first(a):
    a[0] = 1.0


def main():
    _first(np.zeros(1))
    wall, cpu = time.perf_counter(), time.process_time()
    warm_kernel()
    print(f"OBJ kernel compiled in {time.perf_counter() - wall:.2f} s wall, "
          f"{time.process_time() - cpu:.2f} s CPU")


if __name__ == "__main__":
    main()
