"""Memory images for ``fringe_table_ram`` (Verilog ``$readmemh``, VHDL ``std.textio``).

Format (read by both HDLs): optional header lines starting with ``//``, then one word per line,
exactly ``ceil(DATA_W/4)`` lower-case hex digits (two's complement fields already packed into
an unsigned word), no address markers. Bank 0 comes first, then bank 1. The writer is
deterministic: the same words and header give the same bytes.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np

__all__ = ["format_hex", "interpolate", "periodic_slopes", "read_hex", "split_words", "write_hex"]


def _check_words(words, data_w: int) -> np.ndarray:
    if not 1 <= data_w <= 64:
        raise ValueError(f"data_w = {data_w} out of range 1..64")
    w = np.asarray(words)
    if w.ndim != 1:
        raise ValueError(f"words: one-dimensional array expected, got shape {w.shape}")
    if w.dtype.kind not in "iuO":
        raise ValueError(f"words: integers expected, got dtype {w.dtype}")
    out = [int(v) for v in w]
    for i, v in enumerate(out):
        if not 0 <= v < (1 << data_w):
            raise ValueError(f"words[{i}] = {v} out of range 0..2^{data_w}-1 (u({data_w}))")
    return np.array(out, dtype=object)


def format_hex(words, data_w: int, header: Iterable[str] = ()) -> str:
    """The text of a memory image: ``// header`` lines, then one hex word per line."""
    w = _check_words(words, data_w)
    digits = (data_w + 3) // 4
    lines = []
    for h in header:
        for part in str(h).splitlines() or [""]:
            lines.append(f"// {part}".rstrip())
    lines.extend(f"{int(v):0{digits}x}" for v in w)
    return "\n".join(lines) + "\n"


def write_hex(path, words, data_w: int, header: Iterable[str] = ()) -> Path:
    """Write a memory image atomically (a temporary file renamed into place); return the path."""
    path = Path(path)
    text = format_hex(words, data_w, header)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="ascii", newline="\n") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def read_hex(path, data_w: int) -> np.ndarray:
    """Read a memory image written by ``write_hex`` (``//`` comments and blank lines skipped)."""
    out = []
    for n, line in enumerate(Path(path).read_text(encoding="ascii").splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("//"):
            continue
        try:
            v = int(s.split()[0], 16)
        except ValueError:
            raise ValueError(f"{path}:{n}: not a hex word: {s!r}") from None
        if v >> data_w:
            raise ValueError(f"{path}:{n}: word {s} wider than {data_w} bits")
        out.append(v)
    return np.array(out, dtype=np.int64 if data_w < 64 else object)


# ---------------------------------------------------------------------------- {slope, value} words
# The interpolated tables (fringe_trim, fringe_drift_observer) store a word {slope, value} per point, both
# s(W), value in the low half; the interpolated value is value + ((slope * frac + 2^(FB-1)) >>> FB).


def periodic_slopes(values) -> np.ndarray:
    """``slope[k] = value[k+1] - value[k]`` along the last axis, periodic: the last point takes value[0]."""
    v = np.asarray(values, dtype=np.int64)
    return np.roll(v, -1, axis=-1) - v


def split_words(words, w: int) -> tuple[np.ndarray, np.ndarray]:
    """``(slope, value)`` as signed int64 from words {slope, value} of two s(w) fields (w <= 31;
    any word is legal)."""
    x = np.asarray(words).astype(np.int64)
    mask, sign = (1 << w) - 1, 1 << (w - 1)
    return (((x >> w) & mask) ^ sign) - sign, ((x & mask) ^ sign) - sign


def interpolate(slope, value, frac, fb: int) -> np.ndarray:
    """``value + ((slope * frac + 2^(fb-1)) >>> fb)`` in int64, the RTL's rounding (fb >= 1)."""
    return value + ((np.asarray(slope, dtype=np.int64) * frac + (1 << (fb - 1))) >> fb)
