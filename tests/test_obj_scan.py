"""The OBJ zero-index check's whole-array scan finds every line the
regex finds, at any chunk size (a run of zeros across a chunk's edge)."""
import numpy as np
import pytest

from raytrace.errors import RaytraceError
from raytrace.scene.formats.mesh import _OBJ_ZERO_INDEX, _zero_tokens, check_obj_indices

TOKENS = [b"f", b"v", b"0", b"-0", b"00", b"+0", b"10", b"01", b"0/1", b"1/0", b"0//2", b"a0", b" ",
          b"\t", b"\n", b"\r\n", b"5"]


def test_scan_finds_what_the_regex_finds():
    rng = np.random.default_rng(1)
    found = 0
    for _ in range(1500):
        data = b"".join(TOKENS[i] for i in rng.integers(0, len(TOKENS), 40))
        want = _OBJ_ZERO_INDEX.search(data) is not None
        found += want
        for chunk in (3, 7, 16, 1 << 24):
            got = any(_OBJ_ZERO_INDEX.match(data, data.rfind(b"\n", 0, s) + 1,
                                            data.find(b"\n", s) % (len(data) + 1))
                      for s in _zero_tokens(data, chunk))
            assert got == want, (data, chunk)
    assert 10 < found < 1490           # both outcomes were tried


@pytest.mark.parametrize("text, line", [(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4),
                                        (b"v 0.0 0 0\nf 1/1 -0/2 3\n", 2), (b"f 00", 1)])
def test_zero_index_named_by_line(text, line):
    with pytest.raises(RaytraceError, match=f"line {line}: face uses vertex index 0"):
        check_obj_indices("m.obj", text)


def test_zero_elsewhere_is_fine():
    check_obj_indices("m.obj", b"v 0 0 0\nvt 0 0\nf 1/0 2/0/0 3//0\nf 10 20 30\n")
