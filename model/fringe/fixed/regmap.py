"""Register map of the core: the calibration values that are not tables.

One register file per bank, REG_W = 32 bits per word, two's complement for signed values
(sign-extended to 32 bits in the image). The same list drives the ROM image (`regs.mem`),
the HDL's register decode (fringe_core, through the constants `sim/hdlgen.py` writes into
rtl/*/fringe_pkg.*) and the documentation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import CoreConfig

REG_W = 32


@dataclass(frozen=True)
class Reg:
    index: int
    name: str
    signed: bool
    width: str        # width as an expression of the configuration (for the docs)
    meaning: str


REGISTERS = (
    Reg(0, "K_SS", True, "COEF_W", "quadrature gain s' <- (xs - OFS_S)"),
    Reg(1, "K_SC", True, "COEF_W", "quadrature gain s' <- (xc - OFS_C)"),
    Reg(2, "K_CC", True, "COEF_W", "quadrature gain c' <- (xc - OFS_C)"),
    Reg(3, "OFS_S", True, "WAVE_W", "sine offset after the waveform table"),
    Reg(4, "OFS_C", True, "WAVE_W", "cosine offset after the waveform table"),
    Reg(5, "MID_S", True, "ADC_W+1", "sine table branch: branch_s = cos >= (sin >= MID_S ? THR_HI_S : THR_LO_S)"),
    Reg(6, "THR_HI_S", True, "ADC_W+1", "cosine threshold of the sine branch when sin >= MID_S"),
    Reg(7, "THR_LO_S", True, "ADC_W+1", "cosine threshold of the sine branch when sin < MID_S"),
    Reg(8, "MID_C", True, "ADC_W+1", "cosine table branch: branch_c = sin >= (cos >= MID_C ? THR_HI_C : THR_LO_C)"),
    Reg(9, "THR_HI_C", True, "ADC_W+1", "sine threshold of the cosine branch when cos >= MID_C"),
    Reg(10, "THR_LO_C", True, "ADC_W+1", "sine threshold of the cosine branch when cos < MID_C"),
    Reg(11, "COARSE_OFS", True, "POS_W+1", "middle of coarse code 0, fine counts"),
    Reg(12, "ZERO", False, "POS_W", "output zero, fine counts in [0, REV)"),
    Reg(13, "DIR", False, "1", "1: output runs the other way"),
    Reg(14, "AMP_LOW", False, "WAVE_W+1", "AMP_LOW flag below this CORDIC magnitude"),
    Reg(15, "AMP_HIGH", False, "WAVE_W+1", "AMP_HIGH flag above this CORDIC magnitude"),
    # the drift tracker (DRIFT = 1, docs/drift.md); 0 otherwise
    Reg(16, "W0_S", True, "ADC_W+DRIFT_TABLE_FRAC", "drift tracker: mean of the calibrated sine waveform"),
    Reg(17, "W0_C", True, "ADC_W+DRIFT_TABLE_FRAC", "drift tracker: mean of the calibrated cosine waveform"),
    Reg(18, "KG_S", False, "DRIFT_KG_W", "drift tracker: sine gain-loop constant"),
    Reg(19, "KG_C", False, "DRIFT_KG_W", "drift tracker: cosine gain-loop constant"),
    # fringe_canceller (CANCEL = 1, docs/blocks/fringe_canceller.md); 0 otherwise
    Reg(20, "CANCEL_FREQ", False, "32", "interference canceller: NCO word, tone frequency / sample rate x 2^32"),
)
N_REGS = 32       # words per bank (21..31 reserved, written as 0)

#: configuration write port: cfg_wr_addr[19:16] selects the address space (the ROM image written there),
#: cfg_wr_addr[15:0] the word within one bank; spaces 4..6 exist with TRIM = 1, 7 and 8 with DRIFT = 1
SPACES = {"regs": 0, "wave_sin": 1, "wave_cos": 2, "long_period": 3, "trim_map": 4, "trim_speed": 5,
          "trim_amp": 6, "drift_fwd_sin": 7, "drift_fwd_cos": 8}
CFG_ADDR_W = 20   # cfg_wr_addr bits
SPACE_LSB = 16    # cfg_wr_addr bit where the space number starts
CTRL_WORD = 0x80  # word of the register space: writing bit CTRL_SWAP = 1 swaps the banks
CTRL_SWAP = 0
#: fringe_regs' latency in clock edges (it has no clock enable): a configuration write taken at edge n lands at
#: edge n + LATENCY (two registered decode steps, the table strobes out after edge n + 1), and a CTRL swap flips
#: active_bank at that same edge, in step with the writes
LATENCY = 2


def widths(cfg: CoreConfig) -> dict[str, int]:
    w = {"COEF_W": cfg.coef_w, "WAVE_W": cfg.wave_w, "ADC_W+1": cfg.adc_w + 1, "POS_W+1": cfg.pos_w + 1,
         "POS_W": cfg.pos_w, "1": 1, "WAVE_W+1": cfg.wave_w + 1,
         "ADC_W+DRIFT_TABLE_FRAC": cfg.adc_w + cfg.drift_table_frac, "DRIFT_KG_W": cfg.drift_kg_w, "32": 32}
    return {r.name: w[r.width] for r in REGISTERS}


def register_words(values: dict[str, int], cfg: CoreConfig) -> np.ndarray:
    """Range-check each value against its field and return the 32-bit words of one bank."""
    wid = widths(cfg)
    words = np.zeros(N_REGS, dtype=np.int64)
    for r in REGISTERS:
        v, w = int(values[r.name]), wid[r.name]
        lo, hi = (-(1 << (w - 1)), (1 << (w - 1)) - 1) if r.signed else (0, (1 << w) - 1)
        if not lo <= v <= hi:
            raise ValueError(f"register {r.name} = {v} does not fit {'s' if r.signed else 'u'}({w}) [{lo}, {hi}]")
        words[r.index] = v & ((1 << REG_W) - 1)
    return words
