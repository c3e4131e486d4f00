"""Typed reading of parsed TOML tables, with errors that name the file and
the key: ``scene.toml: objects[2].radius: expected a number, got 'big'``."""
import math

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import MAX_COORD


def _shown(value):
    if isinstance(value, dict):
        return "a table"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def shown_number(value):
    """A number as a message shows it: whole numbers in full (1048576, not
    1.04858e+06), a float's shortest repr, an integer too long to read by
    its number of digits."""
    if isinstance(value, int):
        if value.bit_length() > 80:      # str() of a few thousand digits is refused
            return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
        return str(value)
    value = float(value)
    if value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(value)


def _range(lo, hi, value):
    lo_s, hi_s, v = (None if x is None else shown_number(x) for x in (lo, hi, value))
    if hi is None:
        return f"must be at least {lo_s}, got {v}"
    if lo is None:
        return f"must be at most {hi_s}, got {v}"
    return f"must be between {lo_s} and {hi_s}, got {v}"


class Fields:
    """One table of a file: checks its keys and reads typed values.

    ``where`` is the table's position ("camera", "objects[2]"), "" at the top.
    """

    def __init__(self, file, where, table, allowed):
        self.file, self.where, self.table = file, where, table
        if not isinstance(table, dict):
            self.fail(None, f"expected a table, got {_shown(table)}")
        unknown = [k for k in table if k not in allowed]
        if unknown:
            self.fail(unknown[0], f"unknown key (expected one of: {', '.join(allowed)})")

    def path(self, key):
        if key is None:
            return self.where
        return f"{self.where}.{key}" if self.where else key

    def fail(self, key, problem):
        where = self.path(key)
        raise RaytraceError(f"{self.file}: {where}: {problem}" if where else f"{self.file}: {problem}")

    def has(self, key):
        return key in self.table

    def _get(self, key, default, required):
        if key in self.table:
            return self.table[key], True
        if required:
            self.fail(None, f"missing key '{key}'")
        return default, False

    def number(self, key, default=None, required=False, lo=None, hi=None, positive=False):
        value, given = self._get(key, default, required)
        if not given:
            return value
        return self.check_number(key, value, lo, hi, positive)

    def check_number(self, key, value, lo=None, hi=None, positive=False):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"expected a number, got {_shown(value)}")
        try:
            value = float(value)
        except OverflowError:           # an integer past any float
            self.fail(key, f"beyond {MAX_COORD:g}, got {shown_number(value)}")
        if not math.isfinite(value):
            self.fail(key, f"expected a finite number, got {value}")
        if abs(value) > MAX_COORD:
            self.fail(key, f"beyond {MAX_COORD:g} (products of such values overflow), "
                           f"got {shown_number(value)}")
        if positive and not value > 0:
            self.fail(key, f"must be positive, got {shown_number(value)}")
        if lo is not None and value < lo or hi is not None and value > hi:
            self.fail(key, _range(lo, hi, value))
        return value

    def integer(self, key, default=None, required=False, lo=None, hi=None):
        value, given = self._get(key, default, required)
        if not given:
            return value
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f"expected an integer, got {_shown(value)}")
        if lo is not None and value < lo or hi is not None and value > hi:
            self.fail(key, _range(lo, hi, value))
        return value

    def boolean(self, key, default=None):
        value, given = self._get(key, default, False)
        if given and not isinstance(value, bool):
            self.fail(key, f"expected true or false, got {_shown(value)}")
        return value

    def string(self, key, default=None, required=False, choices=None):
        value, given = self._get(key, default, required)
        if not given:
            return value
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_shown(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(choices)}, got {value!r}")
        return value

    def numbers(self, key, n, default=None, required=False, lo=None, nonzero=False):
        """A list of n numbers, as a tuple of floats."""
        value, given = self._get(key, default, required)
        if not given:
            return value
        if not isinstance(value, list) or len(value) != n:
            self.fail(key, f"expected a list of {n} numbers, got {_shown(value)}")
        out = tuple(self.check_number(f"{key}[{i}]", x, lo=lo) for i, x in enumerate(value))
        if nonzero and not any(out):
            self.fail(key, "must not be all zeros")
        if nonzero and not math.hypot(*out) >= 1e-150:
            self.fail(key, f"too short to give a direction (length {math.hypot(*out):g})")
        return out

    def vec3(self, key, default=None, required=False, nonzero=False):
        return self.numbers(key, 3, default, required, nonzero=nonzero)

    def color(self, key, default=None, required=False):
        return self.numbers(key, 3, default, required, lo=0.0)

    def scale3(self, key):
        """A positive number (uniform) or three positive numbers."""
        value = self.table.get(key, 1.0)
        if isinstance(value, list):
            return tuple(self.check_number(f"{key}[{i}]", x, positive=True)
                         for i, x in enumerate(self.numbers(key, 3)))
        s = self.check_number(key, value, positive=True)
        return (s, s, s)

    def tables(self, key):
        """An array of tables ([[key]] in TOML), as a list."""
        value = self.table.get(key, [])
        if not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
            self.fail(key, f"expected an array of tables ([[{key}]]), got {_shown(value)}")
        return value
