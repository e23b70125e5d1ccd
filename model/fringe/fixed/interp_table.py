"""Bit-exact model of ``fringe_interp_table`` (document: docs/blocks/fringe_interp_table.md; test:
tb/test_fringe_interp_table.py). The blocks that use the primitive have their own models in this
package, built on the same ``interpolate``.

result = value + ((slope * frac + 2^(FB-1)) >>> FB) + 2^(ROUND_SHIFT-1) (the last term only when
ROUND_SHIFT > 0), as s(OUT_W): modulo 2^OUT_W, read back signed.
"""

from __future__ import annotations

from .table_ram import interpolate

__all__ = ["LATENCY", "field", "interp_result", "latency"]

LATENCY = 4   # clock enables from rd_addr/frac to result (PIECE_W = 0)


def latency(piece_w: int = 0) -> int:
    """LATENCY of the HDL: 4 clock enables, 5 with PIECE_W > 0 (each RAM piece registered, then the
    registered select)."""
    return LATENCY + (1 if piece_w > 0 else 0)


def field(word: int, lsb: int, w: int) -> int:
    """The signed w-bit field of ``word`` starting at bit ``lsb``."""
    v = (word >> lsb) & ((1 << w) - 1)
    return v - (1 << w) if v >> (w - 1) else v


def interp_result(word: int, frac: int, w: int, fb: int, out_w: int, round_shift: int) -> int:
    """The result for a table word {slope, value} (two s(w) fields) and a fraction u(fb)."""
    r = int(interpolate(field(word, w, w), field(word, 0, w), frac, fb))
    if round_shift > 0:
        r += 1 << (round_shift - 1)
    return field(r & ((1 << out_w) - 1), 0, out_w)
