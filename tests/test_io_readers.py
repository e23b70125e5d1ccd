"""Property-based tests and a time-boxed fuzz run of the recording and encoder readers (hypothesis).

A valid file reads back exactly what was written, whatever its layout; any other file either reads or
raises FringeInputError (the CLI's one line, exit 2), never another exception. FRINGE_FUZZ_EXAMPLES
sets how many inputs each fuzz test tries (default: a few hundred, seconds in CI).
"""

import json
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fringe.encoder import encoder_from_dict
from fringe.errors import FringeInputError
from fringe.io.dataio import read_measurement

EXAMPLES = int(os.environ.get("FRINGE_FUZZ_EXAMPLES", "300"))
COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
COLUMNS = ("sin", "cos", "coarse", "ref_deg", "t_s", "extra")


@st.composite
def layouts(draw):
    """A valid recording in any of the layouts the spec allows."""
    names = draw(st.permutations(COLUMNS).map(lambda p: [c for c in p if c in ("sin", "cos")
                                                         or draw(st.booleans())]))
    n = draw(st.integers(1, 40))
    ints = st.integers(-2048, 2047)
    cols = {}
    for c in names:
        if c in ("sin", "cos"):
            cols[c] = draw(st.lists(ints, min_size=n, max_size=n))
        elif c == "coarse":
            cols[c] = draw(st.lists(st.integers(0, 511), min_size=n, max_size=n))
        elif c == "t_s":
            steps = draw(st.lists(st.floats(1e-6, 10.0), min_size=n, max_size=n))
            cols[c] = list(np.cumsum(steps))
        else:
            cols[c] = draw(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=n, max_size=n))
    return {"names": names, "cols": cols, "comments": draw(st.lists(st.text("abc: 123", max_size=10), max_size=3)),
            "blank_before": draw(st.integers(0, 2)), "crlf": draw(st.booleans()), "bom": draw(st.booleans()),
            "spaces": draw(st.booleans())}


def render(lay) -> bytes:
    nl = "\r\n" if lay["crlf"] else "\n"
    sep = ", " if lay["spaces"] else ","
    lines = [f"# {c}" for c in lay["comments"]] + [""] * lay["blank_before"] + [sep.join(lay["names"])]
    n = len(lay["cols"]["sin"])
    for i in range(n):
        lines.append(sep.join(repr(float(lay["cols"][c][i])) if isinstance(lay["cols"][c][i], float)
                              else str(lay["cols"][c][i]) for c in lay["names"]))
    text = nl.join(lines) + nl
    return (b"\xef\xbb\xbf" if lay["bom"] else b"") + text.encode()


@settings(max_examples=max(50, EXAMPLES // 3), **COMMON)
@given(lay=layouts())
def test_a_valid_layout_reads_back_exactly(tmp_path, lay):
    path = tmp_path / "rec.csv"
    path.write_bytes(render(lay))
    m = read_measurement(str(path))
    for c in ("sin", "cos", "coarse", "ref_deg", "t_s"):
        got = getattr(m, c)
        if c in lay["names"]:
            assert np.array_equal(got, np.asarray(lay["cols"][c], float)), c
        else:
            assert got is None
    assert m.comments == tuple(c.strip() for c in lay["comments"])


JUNK = st.sampled_from(["", " ", "nan", "inf", "-inf", "1e999", "abc", "0x10", "1,2", '"3"', "#", "1e308", "-0",
                        "\t", "\x00", "é", "٣", "1_000", "--1", "+5", ".", "1.5e", "NULL", "true"])


@st.composite
def mutated(draw):
    """A valid file with cells, lines and bytes broken at random."""
    lay = draw(layouts())
    lines = render(lay).decode().splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 4))):
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(["cell", "drop", "dup", "truncate", "junkline", "bytes"]))
        if op == "cell":
            cells = lines[i].rstrip("\r\n").split(",")
            cells[draw(st.integers(0, len(cells) - 1))] = draw(JUNK)
            lines[i] = ",".join(cells) + "\n"
        elif op == "drop":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        elif op == "truncate":
            lines[i] = lines[i][: draw(st.integers(0, len(lines[i])))]
        elif op == "junkline":
            lines.insert(i, draw(st.text(max_size=20)) + "\n")
        else:
            raw = bytearray(lines[i].encode())
            if raw:
                raw[draw(st.integers(0, len(raw) - 1))] = draw(st.integers(0, 255))
            lines[i] = raw.decode("latin-1")
    return "".join(lines).encode("latin-1", "replace")


@settings(max_examples=EXAMPLES, **COMMON)
@given(data=mutated())
def test_fuzz_a_broken_recording_is_read_or_refused_in_one_line(tmp_path, data):
    path = tmp_path / "rec.csv"
    path.write_bytes(data)
    try:
        m = read_measurement(str(path))
    except FringeInputError as e:
        assert "\n" not in str(e)
        return
    assert np.isfinite(m.sin).all() and np.isfinite(m.cos).all() and len(m.sin) == len(m.cos) > 0
    if m.t_s is not None:
        assert (np.diff(m.t_s) > 0).all()


JSON_VALUES = st.recursive(st.none() | st.booleans() | st.integers(-10**30, 10**30) | st.floats() | st.text(max_size=5),
                           lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                                       max_size=3), max_leaves=6)
KEYS = st.sampled_from(["lines_per_rev", "adc_bits", "coarse_bits", "full_scale", "offset_binary", "written_by",
                        "lines", "adc"])


@settings(max_examples=EXAMPLES, **COMMON)
@given(d=st.dictionaries(KEYS, JSON_VALUES | st.integers(-3, 70), max_size=6) | JSON_VALUES)
def test_fuzz_an_encoder_description_is_valid_or_refused(d):
    try:
        enc = encoder_from_dict(json.loads(json.dumps(d)) if _json_ok(d) else d, "enc.json")
    except FringeInputError as e:
        assert str(e).startswith("enc.json") and "\n" not in str(e)
        return
    assert enc.lines_per_rev >= 1 and 4 <= enc.adc_bits <= 24 and (1 << enc.coarse_bits) >= enc.lines_per_rev \
        or enc.coarse_bits == 0


def _json_ok(d) -> bool:
    try:
        json.dumps(d, allow_nan=False)
        return True
    except (ValueError, TypeError):
        return False


@pytest.mark.parametrize("text", ["", "\ufeff", "#only a comment\n", "sin,cos\n", "\ufeffsin,cos\n1,2\n",
                                  "sin;cos\n1;2\n", "sin,cos\n1,2,3\n", "sin,cos\n\n\n", "sin,cos\n1,\n"])
def test_edge_files(tmp_path, text):
    path = tmp_path / "rec.csv"
    path.write_text(text, encoding="utf-8")
    try:
        m = read_measurement(str(path))
    except FringeInputError as e:
        assert "\n" not in str(e) and "rec.csv" in str(e)
        return
    assert text.lstrip("\ufeff").startswith("sin,cos") and len(m) == 1
