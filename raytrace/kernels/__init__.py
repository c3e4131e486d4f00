"""Numba kernels.  Only contiguous arrays, namedtuples of arrays and scalars
cross into this package; validation and dtype casting happen in the glue."""
