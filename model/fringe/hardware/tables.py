"""A float calibration quantised for the core: the tables and register values of one bank (`CoreTables`),
and the bit-exact model run on a calibration with the float engine's result type."""

from __future__ import annotations

import math

import numpy as np

from ..dsp.calibration import Calibration
from ..dsp.waveform import WaveformInverse
from ..encoder import ARCSEC_PER_REV
from ..fixed import cordic as cordic_mod
from ..fixed import long_period as lp_mod
from ..fixed import quadrature as quad_mod
from ..fixed import wave_lut as wave_mod
from ..fixed.canceller import freq_word
from ..fixed.config import CoreConfig, drift_pipe_latency, long_period_params
from ..fixed.core import CoreTables, run_core, to_adc_codes
from ..result import Result
from .closed_loop import build_drift_tables, build_trim_tables


def _ceil_code(v: float) -> int:
    """`adc >= v` for integer codes is `adc >= ceil(v)`."""
    return int(math.ceil(v - 1e-9))


def branch_registers(inv: WaveformInverse) -> tuple[int, int, int]:
    """The top's branch select: branch = other >= (own >= MID ? THR_HI : THR_LO)."""
    return _ceil_code(inv.mid), _ceil_code(inv.threshold_hi), _ceil_code(inv.threshold_lo)


def build_tables(cal: Calibration, cfg: CoreConfig) -> CoreTables:
    """Quantise a float calibration for the hardware; ValueError if something does not fit."""
    if not isinstance(cal.inv_sin, WaveformInverse) or not isinstance(cal.inv_cos, WaveformInverse):
        raise ValueError("the bit-exact core needs waveform tables (this calibration has none)")
    wl = cfg.wave_lut()
    wave = {k: wave_mod.make_table(lambda codes, b, inv=inv: inv.value_at(codes, b), wl)
            for k, inv in (("sin", cal.inv_sin), ("cos", cal.inv_cos))}
    q = cal.quad
    quad = quad_mod.quantise_coefs(q.k_ss, q.k_sc, q.k_cc, q.ofs_s, q.ofs_c, cfg.quadrature())
    coarse_ofs = round((cal.coarse_offset_periods or 0.0) * (1 << cfg.fine_w))
    lpp = long_period_params(cfg)
    if cal.long_period is not None:
        counts = cfg.rev / ARCSEC_PER_REV
        lp = lp_mod.make_table(lambda pos: cal.long_period(2 * np.pi * pos / cfg.rev) * counts, lpp)
    else:
        lp = np.zeros(1 << cfg.lp_addr_w, dtype=np.int64)
    zero = round(cal.zero_deg / 360.0 * cfg.rev) % cfg.rev
    gain = cordic_mod.cordic_gain(cfg.cordic_stages) * (1 << (cfg.wave_w - 2))
    trim = None
    if cfg.trim:
        trim = build_trim_tables(cal, cfg)
    elif cal.rev_norm is not None or cal.angle_terms:
        raise ValueError("this calibration carries closed-loop corrections: the core needs TRIM = 1")
    drift = None
    if cfg.drift:
        drift = build_drift_tables(cal, cfg, drift_pipe_latency(cfg))
    elif cal.adaptive:
        raise ValueError("this calibration tracks drift online: the core needs DRIFT = 1")
    cancel_freq = 0
    if cfg.cancel and cal.canceller:
        cancel_freq = freq_word(cal.canceller["tone_hz"], cal.canceller["sample_rate_hz"])
    elif cal.canceller:
        raise ValueError("this calibration cancels interference online: the core needs CANCEL = 1")
    return CoreTables(wave["sin"], wave["cos"], branch_registers(cal.inv_sin), branch_registers(cal.inv_cos),
                      quad, coarse_ofs, lp, zero, 1 if cal.direction < 0 else 0,
                      round(cal.amp_low * gain), round(cal.amp_high * gain), trim, drift, cancel_freq)


def run_model(cal: Calibration, cfg: CoreConfig, sin, cos, coarse=None, tables: CoreTables | None = None) -> Result:
    """The bit-exact engine with the float engine's result type (angle in degrees)."""
    t = tables or build_tables(cal, cfg)
    o = run_core(t, cfg, to_adc_codes(sin, cfg.adc_w, "sin"), to_adc_codes(cos, cfg.adc_w, "cos"), coarse)
    mag_unit = cordic_mod.cordic_gain(cfg.cordic_stages) * (1 << (cfg.wave_w - 2))
    return Result(angle_deg=o.pos * (360.0 / cfg.rev), status=o.status, frac=o.phase / float(1 << cfg.fine_w),
                  position=o.count_pos / float(1 << cfg.fine_w), magnitude=o.mag / mag_unit)
