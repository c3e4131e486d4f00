"""kernels/entry.py: an Entry calls the compiled version of its own
arguments' types, also where the process holds several versions (a
version of other types would read the arrays as those types)."""
import numpy as np
from numba import njit

from raytrace.kernels.entry import Entry


@njit(cache=False)
def _first_twice(a):
    return a[0] * 2


def test_each_entry_takes_its_own_arguments_version_among_several():
    floats, ints = np.array([1.5]), np.array([7], np.int64)
    by_floats, by_ints = Entry(_first_twice), Entry(_first_twice)
    assert by_floats(floats) == 3.0           # one version so far: that one
    assert by_ints(ints) == 14                # a second version, by the dispatcher
    assert len(_first_twice.overloads) == 2
    for _ in range(2):                        # then through the entry points
        assert by_ints(ints) == 14 and by_floats(floats) == 3.0
    assert by_ints.call is not _first_twice and by_ints.call is not by_floats.call
    # A later Entry of either types finds its version too.
    again = Entry(_first_twice)
    assert again(floats) == 3.0 and again(floats) == 3.0 and again.call is by_floats.call
