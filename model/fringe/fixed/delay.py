"""Bit-exact model of ``fringe_delay``: a valid bit and a data word delayed by DEPTH clock enables.

Mirrors ``rtl/verilog/fringe_delay.v`` and ``rtl/vhdl/fringe_delay.vhd`` (document:
docs/blocks/fringe_delay.md; test: tb/test_fringe_delay.py). Clock by clock, for DEPTH >= 1:

- a clock with ``ce = 1`` shifts ``in_data`` into the data stages and ``in_valid`` into the valid
  stages; ``ce = 0`` freezes both; ``rst`` (synchronous, wins over ce) clears every valid stage and
  leaves the data stages alone (they still shift when ce = 1);
- so after a clock the output is the input of the DEPTH-th latest clock with ``ce = 1`` (this one
  included), and it is valid if that input was and no reset came since (that clock included);
- DEPTH = 0 is a wire: the output is the input, whatever clk, rst and ce do.

The model is vectorised over a stream of clocks and starts in the state a reset leaves: no valid word
in flight, the data stages not loaded yet (the RTL's power-up contents are undefined: ``None``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import check_int

__all__ = ["NAME", "DelayParams", "delay", "delayed"]

NAME = "fringe_delay"


@dataclass(frozen=True)
class DelayParams:
    """Parameters of ``fringe_delay`` (same names, limits and messages as the HDL)."""

    width: int   # WIDTH: data bits, >= 1
    depth: int   # DEPTH: stages (clock enables of delay), >= 0; 0 = a wire

    def __post_init__(self) -> None:
        check_int(NAME, "WIDTH", self.width)
        check_int(NAME, "DEPTH", self.depth)
        if self.width < 1:
            raise ValueError(f"{NAME}: WIDTH = {self.width} must be >= 1")
        if self.depth < 0:
            raise ValueError(f"{NAME}: DEPTH = {self.depth} must be >= 0")


def _bits(name: str, v, n: int | None = None) -> np.ndarray:
    """v as a one-dimensional bool array of 0/1 values (of length n if given)."""
    a = np.asarray(v)
    if a.ndim != 1 or (n is not None and a.size != n):
        raise ValueError(f"{NAME}: {name}: one value per clock expected, got shape {a.shape}")
    if a.size and (a.dtype.kind not in "biu" or not np.isin(a, (0, 1)).all()):
        raise ValueError(f"{NAME}: {name}: 0 or 1 expected")
    return a.astype(bool)


def _source(ce: np.ndarray, depth: int) -> np.ndarray:
    """Per clock, the clock whose input the last stage holds after it (-1: not loaded yet)."""
    if depth == 0:
        return np.arange(ce.size)
    enabled = np.flatnonzero(ce)
    k = np.cumsum(ce) - depth             # index in `enabled` of the clock that fed the last stage
    src = np.full(ce.size, -1)
    src[k >= 0] = enabled[k[k >= 0]]
    return src


def delayed(data, ce, depth: int) -> np.ndarray:
    """The data path alone: after each clock, the ``data`` of the DEPTH-th latest clock with ce = 1
    (``data`` itself for DEPTH = 0); an object array of ints, ``None`` where the stages are not loaded yet."""
    ce = _bits("ce", ce)
    words = np.asarray(data, dtype=object)
    if words.shape != ce.shape:
        raise ValueError(f"{NAME}: data: one value per clock expected, got shape {words.shape}")
    src = _source(ce, depth)
    out = np.full(ce.size, None, dtype=object)
    out[src >= 0] = words[src[src >= 0]]
    return out


def delay(in_valid, in_data, ce, rst, params: DelayParams) -> tuple[np.ndarray, np.ndarray]:
    """``(out_valid, out_data)`` after each clock of a stream that starts right after a reset.

    Args:
        in_valid, ce, rst: 0/1 per clock (what the ports hold at that clock's rising edge).
        in_data: u(WIDTH) words per clock (Python ints or an integer array).
        params: the block parameters.

    Returns:
        out_valid (bool) and out_data (object array of ints, ``None`` where the data stages are not
        loaded yet) after each clock's edge; for DEPTH = 0 the inputs themselves.
    """
    in_valid = _bits("in_valid", in_valid)
    n = in_valid.size
    ce, rst = _bits("ce", ce, n), _bits("rst", rst, n)
    words = np.asarray(in_data, dtype=object)
    if words.shape != (n,):
        raise ValueError(f"{NAME}: in_data: one value per clock expected, got shape {words.shape}")
    for i, v in enumerate(words):
        if not isinstance(v, (int, np.integer)) or not 0 <= v < (1 << params.width):
            raise ValueError(f"{NAME}: in_data[{i}] = {v!r} out of range u(WIDTH) = 0..2^{params.width}-1")
    if params.depth == 0:
        return in_valid.copy(), words.copy()
    src = _source(ce, params.depth)
    last_rst = np.maximum.accumulate(np.where(rst, np.arange(n), -1)) if n else np.zeros(0, int)
    out_valid = (src >= 0) & in_valid[np.maximum(src, 0)] & (last_rst < src)
    return out_valid, delayed(words, ce, params.depth)
