"""A record of arrays handed to a compiled entry as one word.

Numba's Python wrapper of a kernel called from Python (``BLOCK``) unboxes
each array of its arguments with its own error and clean-up blocks, and
LLVM's passes over that wrapper grow faster than the arrays do: a no-op
entry taking 38 arrays compiles in 0.25 s, 94 in 0.6 s, against 0.14 and
0.23 s taking them as one ``Packed`` (docs/benchmarks.md, "Records as
one word").  A render's stage entries take 60-100 arrays, the ray
queries' blocks 35-40, and each is compiled cold on a first run.

``Packed(record)`` keeps the record (a namedtuple or tuple, nested, of
arrays, numbers, booleans and None) and a table of int64 words: each array's
data address, shape and strides (bytes), each number's value (a float's
bits).  Its Numba type carries the record's type, so ``unpack(packed)``
in a kernel rebuilds the record from the table with exactly the types
Numba gives the record itself: the code below it is the same code,
compiled once for both.  The wrapper unboxes one integer.

The table holds addresses, not references: the Packed keeps its record
(and so the arrays) alive, and is only good in the process that made it
(pickled, it is made again from the record).  Arrays are not to be
replaced in the record while a Packed of it is in use; namedtuples do not
allow it.
"""
import numpy as np
from llvmlite import ir
from numba import typeof, types
from numba.core import cgutils
from numba.extending import (
    NativeValue,
    intrinsic,
    models,
    register_model,
    typeof_impl,
    unbox,
)
from numba.np.arrayobj import populate_array

_WORD = 1 << 64


class Packed:
    """``record`` for a compiled entry taking it as one word (module doc)."""

    __slots__ = ("record", "numba_type", "packed_type", "table", "address")

    def __init__(self, record):
        self.record = record
        words, shape = [], []
        _walk(record, words, shape)
        # Numba's typeof takes 20-30 us an array; the shape of the record
        # (each array's dtype, dimensions and flags, each value's class)
        # names the same types, found again by a dictionary lookup.
        shape = tuple(shape)
        types_ = _TYPES.get(shape)
        if types_ is None:
            numba_type = typeof(record)
            types_ = _TYPES[shape] = (numba_type, PackedType(numba_type))
        self.numba_type, self.packed_type = types_
        self.table = np.array(words, np.int64)
        self.address = self.table.ctypes.data

    def __reduce__(self):
        return Packed, (self.record,)


def _walk(value, out, shape):
    """``value``'s table words appended to ``out``, in unpack's order, and
    what decides its Numba type to ``shape``."""
    if isinstance(value, np.ndarray):
        out.append(value.ctypes.data)
        out.extend(value.shape)
        out.extend(value.strides)
        shape += (value.dtype, value.ndim, value.flags.num)
        return
    shape.append(type(value))
    if isinstance(value, tuple):
        for v in value:
            _walk(v, out, shape)
    elif value is None:
        pass
    elif isinstance(value, (bool, np.bool_)):
        out.append(int(value))
    elif isinstance(value, (int, np.integer)):
        w = int(value) % _WORD           # an unsigned value above 2^63 by its bits
        out.append(w - _WORD if w >= _WORD // 2 else w)
    elif isinstance(value, (float, np.floating)):
        out.append(int(np.float64(value).view(np.int64)))
    else:
        raise TypeError(f"Packed: a record of arrays, numbers, None and tuples, not {type(value)}")


def packed_once(made, key, make, most):
    """made[key], or make() (a Packed) kept there: a thread's records, keyed
    by the identities of the buffers they hold (the Packed keeps those
    alive, so no other takes their ids).  Past ``most`` entries every one
    goes first: a buffer was replaced, and the records holding it are
    dead weight."""
    packed = made.get(key)
    if packed is None:
        if len(made) >= most:
            made.clear()
        packed = made[key] = make()
    return packed


# Numba types of the records packed so far and their PackedTypes, by the
# records' shape (Packed.__init__).
_TYPES = {}


class PackedType(types.Type):
    """Numba's type of a Packed: its record's type, the table's address.
    Made once for each record type (Packed.__init__), its hash kept: a
    call through Numba's dispatcher types and hashes its arguments, and a
    record's type (some hundred nested types) took 12 us to make again and
    9 us to hash, most of a call of a few thousand rays on two threads
    (docs/benchmarks.md, "A query's threads through the compiled entry")."""

    def __init__(self, record_type):
        self.record_type = record_type
        super().__init__(name=f"Packed({record_type})")

    @property
    def key(self):
        return self.record_type

    def __hash__(self):
        h = self.__dict__.get("_hash")
        if h is None:
            h = self.__dict__["_hash"] = hash(self.key)
        return h

    def __getstate__(self):
        # Not the kept hash: pickled into Numba's cache index, it would be
        # another process's (strings hash differently in each).
        return {k: v for k, v in self.__dict__.items() if k != "_hash"}


@register_model(PackedType)
class _PackedModel(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, ir.IntType(64))


@typeof_impl.register(Packed)
def _typeof_packed(val, c):
    return val.packed_type


@unbox(PackedType)
def _unbox_packed(typ, obj, c):
    address = c.pyapi.object_getattr_string(obj, "address")
    value = c.pyapi.long_as_longlong(address)
    c.pyapi.decref(address)
    return NativeValue(value, is_error=c.pyapi.c_api_error())


def _rebuild(context, builder, ty, table, pos):
    """The value of type ``ty`` from the table's words pos[0] on (pos
    advanced past them), as _walk wrote them."""
    i64 = ir.IntType(64)

    def word():
        w = builder.load(builder.gep(table, [ir.Constant(i64, pos[0])]))
        pos[0] += 1
        return w

    if isinstance(ty, types.Array):
        data = builder.inttoptr(word(), context.get_data_type(ty.dtype).as_pointer())
        shape = [word() for _ in range(ty.ndim)]
        strides = [word() for _ in range(ty.ndim)]
        array = context.make_array(ty)(context, builder)
        itemsize = context.get_constant(
            types.intp, context.get_abi_sizeof(context.get_data_type(ty.dtype)))
        intp = context.get_value_type(types.intp)     # typed: a 0-d array has no shape
        populate_array(array, data=data, shape=cgutils.pack_array(builder, shape, intp),
                       strides=cgutils.pack_array(builder, strides, intp), itemsize=itemsize,
                       meminfo=None)
        return array._getvalue()
    if isinstance(ty, types.BaseTuple):
        return context.make_tuple(builder, ty, [_rebuild(context, builder, t, table, pos)
                                                for t in ty.types])
    if isinstance(ty, types.NoneType):
        return context.get_dummy_value()
    if isinstance(ty, types.Boolean):
        return builder.icmp_unsigned("!=", word(), ir.Constant(i64, 0))
    if isinstance(ty, types.Integer):
        return builder.trunc(word(), context.get_value_type(ty)) if ty.bitwidth < 64 else word()
    if isinstance(ty, types.Float):
        value = builder.bitcast(word(), ir.DoubleType())
        return context.cast(builder, value, types.float64, ty)
    raise TypeError(f"unpack: no table words for {ty}")


@intrinsic
def unpack(typingctx, packed):
    """The record of a Packed, its arrays reading the record's memory."""
    if not isinstance(packed, PackedType):
        return None
    sig = packed.record_type(packed)

    def codegen(context, builder, sig, args):
        table = builder.inttoptr(args[0], ir.IntType(64).as_pointer())
        return _rebuild(context, builder, sig.return_type, table, [0])

    return sig, codegen
