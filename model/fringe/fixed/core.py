"""Bit-exact model of the whole core (`fringe correct --engine model`).

The blocks' fixed-point twins chained as `rtl/verilog/fringe_core.v` chains the blocks:
waveform tables -> quadrature -> CORDIC -> period count -> long-period table, with the
status word assembled as in docs/architecture.md. `CoreTables` is what the calibration
becomes once quantised (`fringe.hardware.tables.build_tables`): exactly the words and register
values the hardware holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..encoder import ARCSEC_PER_REV
from ..result import AMP_HIGH, AMP_LOW, BANK, CLIP_COS, CLIP_SIN, COARSE_ERR, OVERSPEED, SATURATED
from . import canceller as cancel_mod
from . import cordic as cordic_mod
from . import drift as drift_mod
from . import long_period as lp_mod
from . import period_count as pc_mod
from . import quadrature as quad_mod
from . import trim as trim_mod
from . import wave_lut as wave_mod
from .config import CoreConfig, drift_pipe_latency, long_period_params, period_count_params


@dataclass
class CoreTables:
    """Table contents and register values of one bank."""

    wave_sin: np.ndarray          # (2, 2^WAVE_ADDR_W + 1) s(WAVE_W) values, branch 0/1
    wave_cos: np.ndarray
    branch_sin: tuple[int, int, int]   # (mid, threshold_hi, threshold_lo) as ADC codes: see below
    branch_cos: tuple[int, int, int]
    quad: quad_mod.QuadratureCoefs
    coarse_ofs: int               # fine counts
    lp: np.ndarray                # (2^LP_ADDR_W,) s(LP_W) values, LP_FRAC fraction bits
    zero: int                     # u(POS_W), in [0, REV)
    direction: int                # 1: output runs the other way
    amp_low: int                  # CORDIC magnitude thresholds (mag units)
    amp_high: int
    trim: object | None = None    # hardware.closed_loop.TrimTables of fringe_trim (TRIM = 1), else None
    drift: object | None = None   # hardware.closed_loop.DriftTables of the drift tracker (DRIFT = 1), else None
    cancel_freq: int = 0          # CANCEL_FREQ register: fringe_canceller's NCO word (CANCEL = 1)


def branch_select(own: np.ndarray, other: np.ndarray, regs: tuple[int, int, int]) -> np.ndarray:
    mid, hi, lo = regs
    return (other >= np.where(own >= mid, hi, lo)).astype(np.int64)


@dataclass
class CoreOutput:
    pos: np.ndarray       # u(POS_W) output position (fine counts, after long-period, zero, direction)
    status: np.ndarray    # status word
    phase: np.ndarray     # u(FINE_W) fine phase
    count_pos: np.ndarray  # u(POS_W) position before the long-period stage
    mag: np.ndarray       # CORDIC magnitude


def run_core(t: CoreTables, cfg: CoreConfig, sin: np.ndarray, cos: np.ndarray,
             coarse: np.ndarray | None = None, start_pos: int | None = None,
             start_track: tuple = (False, False, None)) -> CoreOutput:
    """One stream of samples from reset; every output word as the RTL produces it (start_pos,
    start_track: see `run_core_banks`)."""
    return run_core_banks([t], cfg, sin, cos, coarse, np.zeros(len(sin), dtype=np.int64), start_pos, start_track)


def core_latency(cfg: CoreConfig) -> int:
    """LATENCY of rtl/*/fringe_core (and fringe_top): clock enables from in_valid to out_valid.

    The input registers (bank thresholds, branch select) plus the blocks: wave LUT 4, quadrature 5, CORDIC
    CORDIC_STAGES + 2, period count 4, long-period table 8; CORDIC_STAGES + 25 in all, plus fringe_trim's
    LATENCY with TRIM = 1, fringe_canceller's with CANCEL = 1 (in drift_pipe_latency) and the drift tracker's
    normaliser (NORM_LATENCY) with DRIFT = 1 (INPUT_LATENCY and drift_pipe_latency: fixed/config.py). The
    same for COMPACT = 1, which only takes fewer samples: one per ``cfg.clocks_per_sample`` clock enables
    (fixed/config.py, from the CORDIC's ``clocks_per_sample``).
    """
    return ((drift_mod.NORM_LATENCY if cfg.drift else 0) + drift_pipe_latency(cfg)
            + pc_mod.LATENCY + (trim_mod.LATENCY if cfg.trim else 0) + lp_mod.LATENCY)


def run_core_banks(banks: list[CoreTables] | tuple[CoreTables, ...], cfg: CoreConfig, sin: np.ndarray,
                   cos: np.ndarray, coarse: np.ndarray | None, bank: np.ndarray,
                   start_pos: int | None = None, start_track: tuple = (False, False, None)) -> CoreOutput:
    """One stream from reset in which sample i is served by ``banks[bank[i]]`` (bank swaps in
    mid-stream, as fringe_core does: every sample carries its bank through the pipeline).

    The status word carries BANK (bit 7) for samples of bank 1, as the RTL's does; with every
    sample in bank 0 the result equals ``run_core(banks[0], ...)``. The only state of the core
    (the period counter and the previous phase of the overspeed flag) follows the stream, not
    the bank, so each stateless stage is evaluated per bank and selected per sample.

    start_pos resumes a stream in the middle (`CoreStream`): the period counter's position at the
    first sample (with COARSE_W > 0 its output, and start_track the combination's track_lost, track_bad
    and, while no trusted sample had been seen, anchor_m after it (else None), `period_count.track_state`).
    """
    sin = np.asarray(sin, dtype=np.int64)
    cos = np.asarray(cos, dtype=np.int64)
    bank = np.asarray(bank, dtype=np.int64)
    if bank.shape != sin.shape or np.any((bank < 0) | (bank >= len(banks))):
        raise ValueError(f"bank: one index in [0, {len(banks)}) per sample")
    n = len(sin)
    if coarse is None or cfg.coarse_w == 0:
        coarse = np.zeros(n, dtype=np.int64)
    coarse = np.asarray(coarse, dtype=np.int64)
    wl, qp = cfg.wave_lut(), cfg.quadrature()
    # fringe_canceller's NCO and coefficients follow the stream (its NCO word each sample's bank)
    canceller = cancel_mod.CancelStream(cfg.cancel_params()) if cfg.cancel else None

    def pick(values):
        """values[b] computed with bank b -> per-sample selection."""
        out = np.array(values[0], copy=True)
        for b in range(1, len(values)):
            out = np.where(bank == b, values[b], out)
        return out

    def front(ys, yc, bk):
        """The stateless chain from the (normalised) ADC codes to the CORDIC, samples of banks bk."""
        def pick_b(values):
            out = np.array(values[0], copy=True)
            for b in range(1, len(values)):
                out = np.where(bk == b, values[b], out)
            return out

        per = []
        for t in banks:
            xs, cs = wave_mod.wave_lut(ys, branch_select(ys, yc, t.branch_sin), t.wave_sin, wl)
            xc, cc = wave_mod.wave_lut(yc, branch_select(yc, ys, t.branch_cos), t.wave_cos, wl)
            per.append((xs, xc, cs, cc))
        xs, xc, cs, cc = (pick_b([p[k] for p in per]) for k in range(4))
        per = [quad_mod.quadrature(xs, xc, t.quad, qp) for t in banks]
        s_, c_, sat_ = (pick_b([p[k] for p in per]) for k in range(3))
        if canceller is not None:
            c_, s_, csat, ctrack = canceller.run(c_, s_, pick_b([np.full(len(bk), t.cancel_freq) for t in banks]))
            sat_ = sat_ | csat | ctrack
        ph, mg = cordic_mod.cordic(c_, s_, cfg.cordic())
        return cs, cc, sat_, ph, mg

    if cfg.drift:
        # the drift tracker normalises the codes; its state follows the stream, its tables each sample's bank.
        # CLIP_* stay flags of the raw ADC codes; a saturated normalised code is SATURATED.
        dp = cfg.drift_params(drift_pipe_latency(cfg))
        words = np.stack([[drift_mod.pack_words(v, dp) for v in t.drift.fwd] for t in banks])
        parts, done = [], [0]     # drift_run feeds every sample once, in order: keep the chain's outputs

        def phase_of(ys, yc):
            i = done[0]
            done[0] = i + len(ys)
            parts.append(front(ys, yc, bank[i:i + len(ys)]))
            return parts[-1][3]

        r = drift_mod.drift_run(sin, cos, phase_of, dp, words, np.stack([t.drift.w0 for t in banks]),
                                np.stack([t.drift.kg for t in banks]), bank=bank)
        half = 1 << (cfg.adc_w - 1)
        clip_s, clip_c = (sin <= -half) | (sin >= half - 1), (cos <= -half) | (cos >= half - 1)
        if not parts:
            parts.append(front(r.y_sin, r.y_cos, bank))
        _, _, sat, phase, mag = (np.concatenate([x[k] for x in parts]) for k in range(5))
        sat = sat | r.sat.astype(bool)
    else:
        clip_s, clip_c, sat, phase, mag = front(sin, cos, bank)
    pcp = period_count_params(cfg)
    # the combination's track follows the stream, each sample's offset its bank
    coarse_ofs = pick([np.full(n, t.coarse_ofs, dtype=np.int64) for t in banks])
    pos, overspeed, coarse_err = pc_mod.period_count(phase, coarse, coarse_ofs, pcp, start_pos, *start_track)
    trimmed = pos
    if cfg.trim:    # the speed history follows the stream; the tables follow each sample's bank
        trimmed, _, trim_sat = trim_mod.trim(pos, mag, np.stack([t.trim.map for t in banks]),
                                             np.stack([t.trim.speed for t in banks]),
                                             np.stack([t.trim.amp for t in banks]), cfg.trim_params(), bank=bank)
        sat = sat | trim_sat.astype(bool)
    lpp = long_period_params(cfg)
    out = pick([lp_mod.long_period(trimmed, t.lp, t.zero, t.direction, lpp) for t in banks])
    amp_low = pick([np.full(n, t.amp_low, dtype=np.int64) for t in banks])
    amp_high = pick([np.full(n, t.amp_high, dtype=np.int64) for t in banks])
    status = (np.where(clip_s, CLIP_SIN, 0) | np.where(clip_c, CLIP_COS, 0)
              | np.where(mag < amp_low, AMP_LOW, 0) | np.where(mag > amp_high, AMP_HIGH, 0)
              | np.where(overspeed, OVERSPEED, 0) | np.where(coarse_err, COARSE_ERR, 0)
              | np.where(sat, SATURATED, 0) | np.where(bank == 1, BANK, 0)).astype(np.int64)
    return CoreOutput(out, status, phase, pos, mag)


def to_adc_codes(values: np.ndarray, adc_w: int, what: str) -> np.ndarray:
    """Readings in ADC counts -> integer codes (the hardware sees integers)."""
    codes = np.round(np.asarray(values, dtype=float)).astype(np.int64)
    half = 1 << (adc_w - 1)
    if codes.size and (codes.min() < -half or codes.max() > half - 1):
        raise ValueError(f"{what}: readings outside the {adc_w}-bit ADC range")
    return codes


def streams(cfg: CoreConfig) -> bool:
    """Whether `CoreStream` can run this configuration in pieces: the drift tracker and fringe_canceller's
    adaptation carry state over the whole stream."""
    return not (cfg.drift or cfg.cancel)


class CoreStream:
    """`run_core` over a stream given in pieces, with the same output words as one run over the whole
    stream and memory bounded by the largest piece: each piece runs after the last rows of the one
    before (enough for the overspeed flag and fringe_trim's speed window), the period counter resumed
    where they stood. Not for DRIFT = 1 or CANCEL = 1 (`streams`)."""

    def __init__(self, t: CoreTables, cfg: CoreConfig):
        if not streams(cfg):
            raise ValueError("the drift tracker's and fringe_canceller's state spans the whole stream: "
                             "run it in one piece")
        self.t, self.cfg = t, cfg
        # the tail holds every row while there are fewer (fringe_trim's start-up windows count from the reset)
        self.keep = 1 + (cfg.trim_params().window if cfg.trim else 0)
        self.tail = None          # (sin, cos, coarse) of the last rows, the counter position of the first
        # COARSE_W > 0: track_lost, track_bad and (None once a trusted sample was seen) anchor_m after the
        # tail's first row: before the first trusted sample the start-up anchor is state too
        self.track = (False, False, None)

    def run(self, sin, cos, coarse=None) -> tuple[np.ndarray, np.ndarray]:
        """(pos, status) of the next piece (ADC codes)."""
        sin, cos = np.asarray(sin, np.int64), np.asarray(cos, np.int64)
        coarse = np.zeros(len(sin), np.int64) if coarse is None else np.asarray(coarse, np.int64)
        k, start = 0, None
        if self.tail is not None:
            k = len(self.tail[0])
            start = self.tail[3]
            sin, cos, coarse = (np.concatenate([a, b]) for a, b in zip(self.tail[:3], (sin, cos, coarse), strict=True))
        o = run_core(self.t, self.cfg, sin, cos, coarse, start_pos=start, start_track=self.track)
        m = min(self.keep, len(sin))
        if self.cfg.coarse_w and len(sin):
            seen, lost, bad, am = pc_mod.track_state(o.phase, coarse, self.t.coarse_ofs,
                                                     period_count_params(self.cfg), start, *self.track)
            self.track = (bool(lost[-m]), bool(bad[-m]), None if seen[-m] else int(am[-m]))
        self.tail = (sin[-m:], cos[-m:], coarse[-m:], int(o.count_pos[-m]))
        return o.pos[k:], o.status[k:]


def error_budget(t: CoreTables, cfg: CoreConfig, quad_float=None) -> dict:
    """Bound on |model - float engine| per stage and in total, in arcsec of the output angle.

    - waveform tables: `wave_lut.error_budget` (table quantisation and linear interpolation between
      2^WAVE_ADDR_W points), the worse channel, both channels adding; an error dx in a unit-circle
      component moves the angle by at most dx / r (r the corrected magnitude, >= 1/2 unless AMP_LOW);
    - quadrature: `quadrature.error_budget` (rounding and coefficient quantisation), s and c;
    - CORDIC: `cordic.phase_error_bound` at the smallest magnitude that does not raise AMP_LOW;
    - long period: `long_period.error_budget` (interpolation between 2^LP_ADDR_W entries, rounding);
    - output: the position is an integer number of fine counts (1/2 count).
    The float engine's own dense tables are exact to well below these.
    """
    counts_per_rad = (1 << cfg.fine_w) / (2 * math.pi)
    lsb_rad = 2.0 ** -(cfg.wave_w - 2)
    r_min = 0.5                                      # AMP_LOW is set at half the calibrated magnitude
    wl = cfg.wave_lut()
    wave = sum(float(np.max(wave_mod.error_budget(wl, tab))) for tab in (t.wave_sin, t.wave_cos)) * lsb_rad / r_min
    k = quad_float or (1.0, 0.0, 1.0)
    bs, bc = quad_mod.error_budget(cfg.quadrature(), *k)
    quad = (bs + bc) * lsb_rad / r_min
    cp = cfg.cordic()
    r_lsb = r_min * (1 << (cfg.wave_w - 2))
    cordic = float(cordic_mod.phase_error_bound(cp, r_lsb))
    lp = lp_mod.error_budget(long_period_params(cfg), t.lp)
    arcsec_per_count = ARCSEC_PER_REV / cfg.rev
    stages = {"wave_tables": wave * counts_per_rad, "quadrature": quad * counts_per_rad, "cordic": cordic,
              "long_period": lp, "output_rounding": 0.5}
    if cfg.trim and t.trim is not None:
        # fringe_trim against the float functions its tables hold (hardware.closed_loop.trim_grids), at speeds below
        # the overspeed limit (a quarter period per sample) and magnitudes up to AMP_HIGH
        tp = cfg.trim_params()
        stages["trim"] = trim_mod.error_budget(tp, speed_max=float(1 << (cfg.fine_w - 2 + tp.speed_log2)),
                                               mag_max=float(t.amp_high), map_values=t.trim.map,
                                               speed_values=t.trim.speed, amp_values=t.trim.amp)
    out = {name: round(v * arcsec_per_count, 5) for name, v in stages.items()}
    out["total_arcsec"] = round(sum(stages.values()) * arcsec_per_count, 5)
    return out
