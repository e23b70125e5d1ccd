"""Bit-exact model of ``fringe_drift_normaliser``: the front half of the drift tracker (``drift.py``).

Mirrors ``rtl/verilog/fringe_drift_normaliser.v`` and ``rtl/vhdl/fringe_drift_normaliser.vhd`` (contract in
``docs/blocks/fringe_drift_normaliser.md``). Per channel k in {sin, cos}, with the state ``(OFF_k, GINV_k)``::

    y_k = ((raw_k * 2^OFS_FRAC - OFF_k) * GINV_k + 2^(OFS_FRAC + GINV_W - 3)) >>> (OFS_FRAC + GINV_W - 2)
    saturated to s(ADC_W); norm_sat = either channel saturated

The state starts at OFF = 0, GINV = unity (2^(GINV_W - 2)) and becomes block j's update (the pending update
of ``fringe_drift_observer``, if the block updated) from input sample ``(j+1)B + D`` on: D = 0 with HOLD = 1
(that sample waits for the update: in_ready), D = B/2 with HOLD = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import check_integers, check_range

__all__ = ["NAME", "LATENCY", "NormaliserParams", "StateParams", "apply_points", "check_state_params", "normalise",
           "normaliser_run"]

NAME = "fringe_drift_normaliser"
#: Enabled clocks from in_valid to norm_valid in the RTL.
LATENCY = 5


def check_state_params(block: str, p) -> None:
    """The limits of the parameters both halves of the tracker share (the state's widths, the block and HOLD), in
    the order of the HDL's checks, with ``block``'s name in the messages."""
    check_range(block, "ADC_W", p.adc_w, 4, 24)
    check_range(block, "BLOCK_LOG2", p.block_log2, 4, 12)
    check_range(block, "OFS_FRAC", p.ofs_frac, 0, 8)
    if p.adc_w + p.ofs_frac > 32:
        raise ValueError(f"{block}: ADC_W + OFS_FRAC = {p.adc_w + p.ofs_frac} exceeds 32")
    check_range(block, "GINV_W", p.ginv_w, 8, 24)
    check_range(block, "HOLD", p.hold, 0, 1)


class StateParams:
    """The derived constants of the state and of the blocks (needs adc_w, block_log2, ofs_frac, ginv_w, hold):
    shared by NormaliserParams, ObserverParams and DriftParams."""

    adc_w: int
    block_log2: int
    ofs_frac: int
    ginv_w: int
    hold: int

    @property
    def b(self) -> int:
        """B: samples per block, 2^BLOCK_LOG2."""
        return 1 << self.block_log2

    @property
    def d(self) -> int:
        """D: the application delay after a block's end: 0 with HOLD = 1, B/2 samples with HOLD = 0."""
        return 0 if self.hold else 1 << (self.block_log2 - 1)

    @property
    def ofs_w(self) -> int:
        """Width of OFF: ADC_W + OFS_FRAC."""
        return self.adc_w + self.ofs_frac

    @property
    def unity(self) -> int:
        """GINV of gain 1: 2^(GINV_W-2)."""
        return 1 << (self.ginv_w - 2)

    @property
    def norm_shift(self) -> int:
        """OFS_FRAC + GINV_W - 2."""
        return self.ofs_frac + self.ginv_w - 2

    def reset_state(self) -> tuple[int, int, int, int]:
        """(OFF_sin, OFF_cos, GINV_sin, GINV_cos) after a reset: 0, 0, unity, unity."""
        return (0, 0, self.unity, self.unity)


@dataclass(frozen=True)
class NormaliserParams(StateParams):
    """The HDL parameters (same names upper case, same limits and messages; USER_W is the HDL's only)."""

    adc_w: int = 14          # ADC code width, 4..24
    block_log2: int = 8      # B = 2^BLOCK_LOG2 samples per update block, 4..12
    ofs_frac: int = 4        # fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
    ginv_w: int = 18         # width of GINV (GINV_W - 2 fraction bits), 8..24
    hold: int = 1            # 1: updates apply at the block boundary (the input waits: in_ready); 0: D = B/2 later

    def __post_init__(self) -> None:
        check_integers(NAME, self, ("adc_w", "block_log2", "ofs_frac", "ginv_w", "hold"))
        check_state_params(NAME, self)

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameter / generic map (without USER_W)."""
        return {"ADC_W": self.adc_w, "BLOCK_LOG2": self.block_log2, "OFS_FRAC": self.ofs_frac, "GINV_W": self.ginv_w,
                "HOLD": self.hold}


def normalise(raw_sin, raw_cos, state, params: StateParams):
    """``(y_sin, y_cos, sat)`` of raw codes with one state ``(off_sin, off_cos, ginv_sin, ginv_cos)``."""
    p = params
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    rnd = 1 << (p.norm_shift - 1)
    out = []
    sat = None
    for raw, off, g in ((raw_sin, state[0], state[2]), (raw_cos, state[1], state[3])):
        y = ((np.asarray(raw, dtype=np.int64) << p.ofs_frac) - off) * g
        y += rnd
        y >>= p.norm_shift
        s = (y < lo) | (y > hi)
        out.append(np.clip(y, lo, hi))
        sat = s if sat is None else sat | s
    return out[0], out[1], sat


def apply_points(blocks: int, params: StateParams) -> np.ndarray:
    """The input samples ``(j+1)B + D`` (j = 0 .. blocks-1) from which block j's update applies."""
    return (np.arange(blocks, dtype=np.int64) + 1) * params.b + params.d


def normaliser_run(raw_sin, raw_cos, states, params: StateParams):
    """Bit-exact ``fringe_drift_normaliser`` over a stream of accepted samples from a reset.

    ``states`` (blocks + 1, 4): row 0 the reset state, row j+1 the state after block j (the observer's pending
    update, or row j when block j did not update; ``DriftResult.states``), applied from sample
    ``apply_points(...)[j]`` on. Returns ``(y_sin, y_cos, sat, state_index)``, int64 per sample (state_index: the
    row each sample used)."""
    p = params
    rs = np.asarray(raw_sin, dtype=np.int64)
    rc = np.asarray(raw_cos, dtype=np.int64)
    st = np.asarray(states, dtype=np.int64).reshape(-1, 4)
    n = rs.size
    sidx = np.searchsorted(apply_points(st.shape[0] - 1, p), np.arange(n, dtype=np.int64), side="right")
    ys = np.empty(n, dtype=np.int64)
    yc = np.empty(n, dtype=np.int64)
    sat = np.empty(n, dtype=np.int64)
    for k in np.unique(sidx):
        m = sidx == k
        ys[m], yc[m], sat[m] = normalise(rs[m], rc[m], tuple(int(x) for x in st[k]), p)
    return ys, yc, sat, sidx.astype(np.int64)

