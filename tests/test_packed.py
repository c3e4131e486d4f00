"""Records handed to compiled entries as one word (kernels/packed.py)."""
import pickle
from collections import namedtuple

import numpy as np
from numba import njit, typeof

from raytrace.kernels.packed import Packed, PackedType, unpack

Inner = namedtuple("Inner", ["rows", "flag", "scale"])
Record = namedtuple("Record", ["a", "inner", "count", "big", "half", "none", "strided", "fixed",
                               "scalar"])


def _record():
    fixed = np.arange(6.0).reshape(2, 3)
    fixed.flags.writeable = False
    return Record(a=np.arange(5, dtype=np.int64),
                  inner=Inner(rows=np.arange(12.0).reshape(4, 3), flag=True, scale=0.1),
                  count=-7, big=np.uint64(2 ** 64 - 3), half=np.float32(1.5), none=None,
                  strided=np.arange(20.0)[::3], fixed=fixed, scalar=np.array(2.5))


@njit
def _echo(p):
    r = unpack(p)
    r.a[1] = 42          # written through: the record's own memory
    return (r.a.sum(), r.inner.rows[3, 2], r.inner.flag, r.inner.scale, r.count, r.big,
            r.half, r.strided[2], r.strided.shape[0], r.fixed[1, 0], r.scalar[()])


@njit
def _same_types(p, record):
    r = unpack(p)
    return r.inner.rows.shape[0] + record.inner.rows.shape[0]


def test_unpack_gives_the_records_arrays_and_values_exactly():
    record = _record()
    got = _echo(Packed(record))
    assert record.a[1] == 42
    assert got == (record.a.sum(), 11.0, True, 0.1, -7, 2 ** 64 - 3, 1.5, 6.0, 7, 3.0, 2.5)


def test_the_unpacked_record_has_the_records_own_numba_type():
    """So the code below an entry is the same compiled code whichever way
    the record came: one signature for the helper the two paths call."""
    record = _record()
    packed = Packed(record)
    assert typeof(packed) == PackedType(typeof(record))
    assert _same_types(packed, record) == 8
    sig = _same_types.signatures[0]
    assert sig[0].record_type == sig[1]


def test_a_record_of_another_shape_gets_its_own_type():
    """The type is found again by the record's shape (dtypes, dimensions,
    flags): a change in any of them is another type, never a stale one."""
    record = _record()
    base = Packed(record).numba_type
    assert Packed(record._replace(a=np.arange(5.0))).numba_type == typeof(
        record._replace(a=np.arange(5.0)))
    assert Packed(record._replace(a=np.arange(5.0))).numba_type != base
    fortran = np.asfortranarray(np.arange(12.0).reshape(4, 3))
    changed = record._replace(inner=record.inner._replace(rows=fortran))
    assert Packed(changed).numba_type == typeof(changed) != base
    assert Packed(_record()).numba_type is base


def test_a_packed_record_pickles_as_its_record_and_is_made_again():
    record = _record()
    copy = pickle.loads(pickle.dumps(Packed(record)))
    # Its own table and type (unpickled arrays are writeable again).
    assert copy.table.ctypes.data == copy.address != Packed(record).address
    assert copy.numba_type == typeof(copy.record)
    assert np.array_equal(copy.record.inner.rows, record.inner.rows)
    assert _echo(copy)[1] == 11.0


def test_only_arrays_numbers_none_and_tuples_pack():
    import pytest
    with pytest.raises(TypeError, match="not <class 'str'>"):
        Packed((np.zeros(2), "text"))


def test_a_record_type_has_one_packed_type_whose_kept_hash_is_not_pickled():
    """typeof of every Packed of one record type is one PackedType, made
    once, its hash kept (Numba's dispatcher types and hashes its arguments
    at each call: made and hashed again, a record's type cost 20 us); the
    kept hash stays out of its pickle, which Numba's cache index holds and
    another process, whose strings hash differently, reads."""
    first, second = typeof(Packed(_record())), typeof(Packed(_record()))
    assert first is second and hash(first) == hash(first.key)
    assert "_hash" in first.__dict__ and "_hash" not in first.__getstate__()
    assert b"_hash" not in pickle.dumps(first)
    assert pickle.loads(pickle.dumps(first)) is first
