"""Bit-exact model of ``fringe_split_mul``: the exact product p = a * b, LATENCY clock enables later.

Mirrors ``rtl/verilog/fringe_split_mul.v`` and ``rtl/vhdl/fringe_split_mul.vhd`` (document:
docs/blocks/fringe_split_mul.md; test: tb/test_fringe_split_mul.py). The RTL cuts the operands into
chunks of LO_W bits and adds the partial products in LATENCY - 1 stages; the sum is exact, so the
word does not depend on LO_W or on how the terms are grouped: p is ``a * b`` as s(A_W + B_W) when
either operand is signed, else u(A_W + B_W) (it always fits). ce = 0 freezes every stage; no reset.
The timing is that of fringe_delay's data path (``delay.delayed``): after a clock, p is the product
of the operands of the LATENCY-th latest clock with ce = 1 (LATENCY = 1: the registered partial
products summed without a register, still one clock enable).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .delay import delayed
from .limits import check_integers

__all__ = ["NAME", "SplitMulParams", "split_mul"]

NAME = "fringe_split_mul"


@dataclass(frozen=True)
class SplitMulParams:
    """Parameters of ``fringe_split_mul`` (same names, limits and messages as the HDL)."""

    a_w: int        # A_W: width of a, >= 1
    a_signed: int   # A_SIGNED: 1 (non-zero): a is two's complement, 0: unsigned
    b_w: int        # B_W: width of b, >= 1
    b_signed: int   # B_SIGNED: 1 (non-zero): b is two's complement, 0: unsigned
    latency: int    # LATENCY: clock enables from a, b to p, >= 1 (1: p is not registered)
    lo_w: int       # LO_W: bits of a low chunk, >= 1 (the word does not depend on it)

    def __post_init__(self) -> None:
        check_integers(NAME, self, ("a_w", "a_signed", "b_w", "b_signed", "latency", "lo_w"))
        if min(self.a_w, self.b_w, self.lo_w, self.latency) < 1:
            raise ValueError(f"{NAME}: A_W = {self.a_w}, B_W = {self.b_w}, LO_W = {self.lo_w}, "
                             f"LATENCY = {self.latency} must be >= 1")

    @property
    def p_w(self) -> int:
        """Width of p, A_W + B_W (holds the product exactly)."""
        return self.a_w + self.b_w


def _operand(name: str, v, w: int, is_signed: bool) -> np.ndarray:
    """v as an object array of ints, each checked to be an s(w) (is_signed) or u(w) value."""
    lo, hi = (-(1 << (w - 1)), (1 << (w - 1)) - 1) if is_signed else (0, (1 << w) - 1)
    x = np.asarray(v, dtype=object)
    if x.ndim != 1:
        raise ValueError(f"{NAME}: {name}: one value per clock expected, got shape {x.shape}")
    for i, e in enumerate(x):
        if not isinstance(e, (int, np.integer)) or not lo <= e <= hi:
            raise ValueError(f"{NAME}: {name}[{i}] = {e!r} out of range {'su'[not is_signed]}({w}) = {lo}..{hi}")
    return np.array([int(e) for e in x], dtype=object)


def split_mul(a, b, ce, params: SplitMulParams) -> np.ndarray:
    """p after each clock: an object array of ints (``a * b`` of the operands of the LATENCY-th latest
    clock with ce = 1, signed if either operand is), ``None`` before LATENCY clocks with ce = 1.

    Args:
        a, b: the operands per clock, as values: s(A_W) / s(B_W) when signed, else u(A_W) / u(B_W).
        ce: 0/1 per clock.
        params: the block parameters.
    """
    x = _operand("a", a, params.a_w, bool(params.a_signed))
    y = _operand("b", b, params.b_w, bool(params.b_signed))
    if x.shape != y.shape:
        raise ValueError(f"{NAME}: a and b differ in length ({x.size}, {y.size})")
    return delayed(x * y, ce, params.latency)
