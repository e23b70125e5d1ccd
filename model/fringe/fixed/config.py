"""The one description of a core configuration.

It feeds the bit-exact model, the ROM generator, the HDL parameters of the top and the test
IDs, so widths and table sizes are written once.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..encoder import ARCSEC_PER_REV, Encoder
from . import long_period as lp_mod
from . import period_count as pc_mod
from . import quadrature as quad_mod
from . import wave_lut as wave_mod
from .canceller import LATENCY as CANCEL_LATENCY
from .canceller import CancelParams
from .cordic import CordicParams
from .drift import DriftParams
from .period_count import PositionWidths
from .quadrature import QuadratureParams
from .trim import TrimParams, speed_window_log2
from .wave_lut import WaveLutParams

WAVE_LSB_ARCSEC = 2.0   # default table width: one LSB of a waveform table moves the angle by at most this
# (and one LSB of a quadrature gain, and one count of the fine phase: few lines a revolution widen all three)
TRIM_FIELDS = ("trim", "trim_speed_log2", "trim_map_psi_w", "trim_map_phi_w", "trim_w", "trim_frac", "trim_g_shift",
               "trim_start_speed", "trim_mag_smooth_log2")
DRIFT_FIELDS = ("drift", "drift_block_log2", "drift_mu_log2", "drift_ofs_frac", "drift_ginv_w", "drift_fwd_w",
                "drift_table_w", "drift_table_frac", "drift_kg_w", "drift_kg_shift", "drift_hold")
CANCEL_FIELDS = ("cancel", "cancel_lut_w", "cancel_c_w", "cancel_block_log2", "cancel_mu_log2", "cancel_a_frac",
                 "cancel_a_w", "cancel_gear_offset")

#: The parameters/generics of fringe_core and fringe_top (both HDLs) and of sim/synth_wrap.v, in declaration
#: order, with their meaning and limits: the CoreConfig fields (upper case), the index mappings derived from
#: them and the init files. `sim/hdlgen.py` writes the HDL declarations and maps from this table; the
#: defaults are those of CoreConfig() (`hdl_parameter_defaults`).
HDL_PARAMETER_DOCS = {
    "ADC_W": "ADC code width (signed), 4..24",
    "LINES": "signal periods per revolution, 1..2^20 (POS_W = clog2(LINES) + FINE_W <= 31)",
    "COARSE_W": "coarse code bits, 0 = none (periods are counted); else 2^COARSE_W >= LINES, <= FINE_W-2",
    "WAVE_ADDR_W": "waveform table address bits per branch, 2..min(ADC_W-1, 15)",
    "WAVE_W": "waveform table / quadrature data width, 8..31",
    "COEF_W": "quadrature gain width (COEF_W-2 fraction bits), 8..27",
    "FINE_W": "fine phase bits per signal period, 8..30",
    "CORDIC_STAGES": "CORDIC micro-rotations, 4..32",
    "CORDIC_GUARD": "extra fraction bits inside the CORDIC, 0..8",
    "COMPACT": "1 = time-multiplexed: one sample per CORDIC_STAGES clocks, iterated CORDIC (same words)",
    "LP_ADDR_W": "long-period table entries per revolution = 2^LP_ADDR_W, <= 16",
    "LP_W": "long-period table value/slope width, <= 32",
    "LP_FRAC": "fraction bits of the long-period correction (fine counts)",
    "LP_IF": "interpolation fraction bits of the long-period table",
    "LP_RECIP": "long-period index multiplier (long_period.index_mapping; < 2^31 in VHDL)",
    "LP_SHIFT": "long-period index shift (long_period.index_mapping)",
    "TRIM": "1 = fringe_trim between the period count and the long-period table (docs/blocks/fringe_trim.md)",
    "TRIM_SPEED_LOG2": "speed window 2^TRIM_SPEED_LOG2 samples, 0..8",
    "TRIM_MAP_PSI_W": "2^TRIM_MAP_PSI_W error-map sectors per revolution, 0..8",
    "TRIM_MAP_PHI_W": "2^TRIM_MAP_PHI_W error-map bins per period, 2..min(10, FINE_W-1); "
                      "TRIM_MAP_PSI_W + TRIM_MAP_PHI_W <= 15",
    "TRIM_W": "trim table value/slope width, 8..24",
    "TRIM_FRAC": "fraction bits of the trim (fine counts), 0..16",
    "TRIM_G_SHIFT": "right shift of the speed and magnitude products, 1..48",
    "TRIM_SECT_RECIP": "sector multiplier (trim.sector_mapping; < 2^31 in VHDL)",
    "TRIM_SECT_SHIFT": "sector shift (trim.sector_mapping)",
    "TRIM_START_SPEED": "speed of the first sample after reset (no window yet), fine counts per "
                        "2^TRIM_SPEED_LOG2 samples, -REV/2..REV/2-1",
    "TRIM_MAG_SMOOTH_LOG2": "the magnitude terms take the magnitude's running average over ~2^TRIM_MAG_SMOOTH_LOG2 "
                            "samples, 0 (the sample's own)..12",
    "DRIFT": "1 = the drift tracker normalises the ADC codes in front of everything (docs/drift.md)",
    "DRIFT_BLOCK_LOG2": "samples per tracker block = 2^DRIFT_BLOCK_LOG2, 4..12 (>= 7 in the core with DRIFT_HOLD = 0)",
    "DRIFT_MU_LOG2": "final tracker step 2^-DRIFT_MU_LOG2 per update (gear shift from 1), 0..8",
    "DRIFT_OFS_FRAC": "fraction bits of the tracked offsets, 0..8",
    "DRIFT_GINV_W": "tracked inverse gains u(DRIFT_GINV_W), 8..24",
    "DRIFT_FWD_W": "2^DRIFT_FWD_W bins of the forward waveform tables, 2..10",
    "DRIFT_TABLE_W": "forward table value/slope width, 8..24",
    "DRIFT_TABLE_FRAC": "fraction bits of the forward tables and W0_S/W0_C, 0..12",
    "DRIFT_KG_W": "KG_S/KG_C width, 8..24",
    "DRIFT_KG_SHIFT": "right shift of the gain-loop product, 1..60",
    "DRIFT_HOLD": "1 = tracker updates apply at the block boundary, in_ready holds the input until ready; "
                  "0 = half a block later, no hold",
    "CANCEL": "1 = fringe_canceller between the quadrature and the CORDIC (docs/blocks/fringe_canceller.md)",
    "CANCEL_LUT_W": "2^CANCEL_LUT_W entries of the canceller's sine table, 4..12",
    "CANCEL_C_W": "canceller sine table value width, 8..18",
    "CANCEL_BLOCK_LOG2": "samples per canceller update = 2^CANCEL_BLOCK_LOG2, 4..12",
    "CANCEL_MU_LOG2": "final canceller step 2^-CANCEL_MU_LOG2 per block, 1..12",
    "CANCEL_A_FRAC": "fraction bits of the canceller coefficients, 0..12",
    "CANCEL_A_W": "canceller coefficient width, 8..min(32, WAVE_W + CANCEL_A_FRAC)",
    "CANCEL_GEAR_OFFSET": "the canceller's gear shift starts this many gears lower, 0..CANCEL_MU_LOG2-1",
    "REGS_INIT": "$readmemh image of the registers, 2 x 32 words of 32 bits",
    "WAVE_SIN_INIT": "$readmemh image of the sine table, both banks",
    "WAVE_COS_INIT": "$readmemh image of the cosine table, both banks",
    "LP_INIT": "$readmemh image of the long-period table, both banks",
    "TRIM_MAP_INIT": "$readmemh image of the trim map, both banks (TRIM = 1)",
    "TRIM_SPEED_INIT": "$readmemh image of the trim speed table, both banks (TRIM = 1)",
    "TRIM_AMP_INIT": "$readmemh image of the trim magnitude table, both banks (TRIM = 1)",
    "DRIFT_FWD_SIN_INIT": "$readmemh image of the drift sine forward table, both banks (DRIFT = 1)",
    "DRIFT_FWD_COS_INIT": "$readmemh image of the drift cosine forward table, both banks (DRIFT = 1)",
    "CANCEL_LUT_INIT": "$readmemh image of the canceller's sine table (CANCEL = 1; canceller.sine_table)",
}
#: the 64-bit (Verilog) multipliers of the index mappings
HDL_WIDE_PARAMETERS = ("LP_RECIP", "TRIM_SECT_RECIP")

#: CoreConfig fields renamed since configurations were first saved (CAL_DIR/core.json): old name -> new name.
#: fringe_trim's fields took their block's prefix, as the drift and canceller ones have (issue 10).
RENAMED_FIELDS = {"speed_log2": "trim_speed_log2", "map_psi_w": "trim_map_psi_w", "map_phi_w": "trim_map_phi_w",
                  "g_shift": "trim_g_shift"}


def current_field_names(saved: dict) -> dict:
    """A saved configuration (the "config" of a core.json, any version) under today's field names
    (RENAMED_FIELDS); the values are unchanged. ValueError when it names one field under both names."""
    if not isinstance(saved, dict):
        raise ValueError(f"the configuration is a {type(saved).__name__}, not an object")
    out = dict(saved)
    for old, new in RENAMED_FIELDS.items():
        if old in out:
            if new in out:
                raise ValueError(f"'{old}' and '{new}' name one field ({new}); keep '{new}'")
            out[new] = out.pop(old)
    return out


@dataclass(frozen=True)
class CoreConfig(PositionWidths):
    adc_w: int = 12            # ADC_W: ADC code width (signed), 4..24
    lines: int = 256           # LINES: signal periods per revolution, any integer >= 1
    coarse_w: int = 9          # COARSE_W: coarse code width, 0 = none (periods are counted)
    wave_addr_w: int = 8       # WAVE_ADDR_W: waveform table address bits per branch (< ADC_W)
    wave_w: int = 18           # WAVE_W: waveform table / quadrature data width (WAVE_W-2 fraction bits)
    coef_w: int = 18           # COEF_W: quadrature gain width (COEF_W-2 fraction bits)
    fine_w: int = 16           # FINE_W: fine phase bits per signal period
    cordic_stages: int = 18    # CORDIC_STAGES: CORDIC iterations (>= FINE_W+1 for full precision)
    cordic_guard: int = 3      # CORDIC_GUARD: extra fraction bits inside the CORDIC
    compact: int = 0           # COMPACT: 1 = one sample per clocks_per_sample clocks, iterated CORDIC (same words)
    lp_addr_w: int = 8         # LP_ADDR_W: long-period table entries per revolution = 2^LP_ADDR_W
    lp_w: int = 18             # LP_W: long-period table value/slope width
    lp_frac: int = 4           # LP_FRAC: fraction bits of the long-period correction (fine counts)
    lp_if: int = 8             # LP_IF: interpolation fraction bits of the long-period table
    # fringe_trim (closed-loop corrections, docs/blocks/fringe_trim.md); TRIM = 0: not built, no latency
    trim: int = 0              # TRIM: 1 = fringe_trim between the period count and the long-period table
    trim_speed_log2: int = 5   # TRIM_SPEED_LOG2: speed = position change over 2^TRIM_SPEED_LOG2 samples
    trim_map_psi_w: int = 6    # TRIM_MAP_PSI_W: 2^TRIM_MAP_PSI_W error-map sectors per revolution
    trim_map_phi_w: int = 5    # TRIM_MAP_PHI_W: 2^TRIM_MAP_PHI_W error-map bins per signal period
    trim_w: int = 18           # TRIM_W: trim table value/slope width
    trim_frac: int = 4         # TRIM_FRAC: fraction bits of the trim (fine counts)
    trim_g_shift: int = 24     # TRIM_G_SHIFT: right shift of the speed and magnitude products
    trim_start_speed: int = 0  # TRIM_START_SPEED: the first sample's speed after reset (the calibration's mean speed)
    trim_mag_smooth_log2: int = 0   # TRIM_MAG_SMOOTH_LOG2: magnitude averaged over ~2^k samples for the magnitude terms
    # the drift tracker (the closed loop's online offset/gain tracker: fringe_drift_normaliser and
    # fringe_drift_observer, docs/drift.md); DRIFT = 0: not built
    drift: int = 0             # DRIFT: 1 = the tracker normalises the ADC codes in front of everything
    drift_block_log2: int = 8  # DRIFT_BLOCK_LOG2: samples per tracker update = 2^DRIFT_BLOCK_LOG2 (>= 7 in the core)
    drift_mu_log2: int = 1     # DRIFT_MU_LOG2: final tracker step 2^-DRIFT_MU_LOG2 per update (gear shift from 1)
    drift_ofs_frac: int = 4    # DRIFT_OFS_FRAC: fraction bits of the tracked offsets (ADC codes)
    drift_ginv_w: int = 18     # DRIFT_GINV_W: tracked inverse gains u(DRIFT_GINV_W), DRIFT_GINV_W-2 fraction bits
    drift_fwd_w: int = 8       # DRIFT_FWD_W: 2^DRIFT_FWD_W bins of the forward waveform tables
    drift_table_w: int = 18    # DRIFT_TABLE_W: forward table value/slope width
    drift_table_frac: int = 4  # DRIFT_TABLE_FRAC: fraction bits of the forward tables (ADC codes)
    drift_kg_w: int = 18       # DRIFT_KG_W: gain-loop constants u(DRIFT_KG_W)
    drift_kg_shift: int = 40   # DRIFT_KG_SHIFT: right shift of the gain-loop product
    drift_hold: int = 1        # DRIFT_HOLD: 1 = updates apply at the block boundary (in_ready holds the input)
    # fringe_canceller (the interference canceller, docs/blocks/fringe_canceller.md); CANCEL = 0: not built
    cancel: int = 0            # CANCEL: 1 = fringe_canceller between the quadrature and the CORDIC
    cancel_lut_w: int = 10     # CANCEL_LUT_W: 2^CANCEL_LUT_W sine table entries per turn
    cancel_c_w: int = 16       # CANCEL_C_W: sine table value width
    cancel_block_log2: int = 4  # CANCEL_BLOCK_LOG2: samples per update = 2^CANCEL_BLOCK_LOG2
    cancel_mu_log2: int = 6    # CANCEL_MU_LOG2: final step 2^-CANCEL_MU_LOG2 per block (gear shift from 1/2)
    cancel_a_frac: int = 4     # CANCEL_A_FRAC: fraction bits of the coefficients (data LSBs)
    cancel_a_w: int = 20       # CANCEL_A_W: coefficient width
    cancel_gear_offset: int = 0  # CANCEL_GEAR_OFFSET: the gear shift starts this many gears lower

    def __post_init__(self) -> None:
        """The limits fringe_core checks at elaboration, its blocks' and its own (rtl/*/fringe_core.*), with the
        HDL's messages: ValueError names the first one this configuration breaks. fringe_trim and the drift
        tracker's halves are checked when they are built (TRIM = 1, DRIFT = 1), their timing with the core's
        PIPE_LATENCY. The core's
        own checks of LINES, LP_ADDR_W, LP_W, WAVE_W and ADC_W are implied by its blocks' narrower ranges."""
        if self.compact not in (0, 1):
            raise ValueError(f"fringe_core: COMPACT = {self.compact} must be 0 or 1")
        self.wave_lut(), self.quadrature(), self.cordic(), long_period_params(self), period_count_params(self)
        if self.pos_w > 31:
            raise ValueError(f"fringe_core: POS_W = clog2(LINES) + FINE_W = {self.pos_w} > 31: registers are 32-bit")
        if self.wave_addr_w + 1 > 16:
            raise ValueError(f"fringe_core: WAVE_ADDR_W = {self.wave_addr_w}: a table bank must fit the 16-bit word "
                             "address")
        if self.trim not in (0, 1):
            raise ValueError(f"fringe_core: TRIM = {self.trim} must be 0 or 1")
        map_w = self.trim_map_psi_w + self.trim_map_phi_w
        if self.trim and map_w > 15:
            raise ValueError(f"fringe_core: TRIM_MAP_PSI_W + TRIM_MAP_PHI_W = {map_w} > 15: a trim map bank must fit "
                             "the 16-bit word address")
        if self.drift not in (0, 1):
            raise ValueError(f"fringe_core: DRIFT = {self.drift} must be 0 or 1")
        if self.cancel not in (0, 1):
            raise ValueError(f"fringe_core: CANCEL = {self.cancel} must be 0 or 1")
        if self.trim:
            self.trim_params()
        if self.cancel:
            self.cancel_params()
        if self.drift:
            self.drift_params(drift_pipe_latency(self))

    @classmethod
    def for_encoder(cls, enc: Encoder, **overrides) -> CoreConfig:
        """Defaults that fit the encoder and a small FPGA.

        Tables of 2^min(ADC_W-1, 8..10) points per branch; table values 3 bits wider than the ADC
        (13 fraction bits for a 12-bit ADC, so their rounding stays below the ADC's); gains of 16
        bits, so every quadrature product is one 16x16 DSP (the iCE40 UP5K has eight); a CORDIC of
        FINE_W + 1 stages. Encoders of few lines, where a radian of fine phase is a large angle, get wider
        table values, gains and fine phase, each so that one unit of its last bit moves the angle by at most
        WAVE_LSB_ARCSEC (a 1-line encoder: 19-bit values and gains, a 20-bit phase of 1.24"; at 16 lines and
        more nothing changes). `make bench` reports what these cost against 18-bit datapaths.
        """
        # table values and gains: one unit of their last bit moves the angle by at most WAVE_LSB_ARCSEC (a relative
        # error e of either moves it by up to e radians of fine phase); values 3 bits finer than the ADC
        arcsec_per_rad = ARCSEC_PER_REV / (2 * math.pi * enc.lines_per_rev)
        angle_bits = math.ceil(math.log2(arcsec_per_rad / WAVE_LSB_ARCSEC)) + 2
        wave_w = min(31, max(15, enc.adc_bits + 3, angle_bits))
        # the fine phase: a count of at most WAVE_LSB_ARCSEC (16 bits from 16 lines on). The period count needs
        # COARSE_W <= FINE_W - 2: a fine coarse code gets a finer phase; an encoder of more than 2^15 lines gets a
        # coarser one, so that a position stays within the 32-bit registers (POS_W <= 31): at 2^20 lines a period
        # is 1.24", and 2^-11 of one 0.0006"
        lines_w = max(0, (enc.lines_per_rev - 1).bit_length())
        count_bits = math.ceil(math.log2(ARCSEC_PER_REV / enc.lines_per_rev / WAVE_LSB_ARCSEC))
        fine_w = overrides.get("fine_w", max(min(max(cls.fine_w, count_bits), 31 - lines_w), enc.coarse_bits + 2, 8))
        if "fine_w" not in overrides and lines_w + fine_w > 31 and enc.coarse_bits:
            raise ValueError(f"a coarse code of {enc.coarse_bits} bits needs FINE_W >= {enc.coarse_bits + 2}, and "
                             f"{enc.lines_per_rev} lines then need a position of {lines_w + fine_w} bits: the core's "
                             "registers hold 31 (clog2(lines_per_rev) + coarse_bits must be at most 29)")
        base = dict(adc_w=enc.adc_bits, lines=enc.lines_per_rev, coarse_w=enc.coarse_bits,
                    wave_addr_w=min(enc.adc_bits - 1, max(8, enc.adc_bits - 4), 10),
                    wave_w=wave_w, coef_w=min(27, max(16, enc.adc_bits + 2, angle_bits)), fine_w=fine_w,
                    cordic_stages=fine_w + 1, trim_speed_log2=speed_window_log2(enc.lines_per_rev))
        base.update(overrides)
        return cls(**base)

    def wave_lut(self) -> WaveLutParams:
        return WaveLutParams(self.adc_w, self.wave_addr_w, self.wave_w)

    def quadrature(self) -> QuadratureParams:
        return QuadratureParams(self.wave_w, self.coef_w)

    def cordic(self) -> CordicParams:
        return CordicParams(in_w=self.wave_w, fine_w=self.fine_w, stages=self.cordic_stages,
                            guard=self.cordic_guard, iterative=self.compact)

    @property
    def clocks_per_sample(self) -> int:
        """Clock enables from one accepted sample to the next at full speed (in_ready / s_axis_tready is 0 in
        between): 1 for the pipelined core; with COMPACT = 1 the iterated CORDIC's, CORDIC_STAGES (>= 4, the
        shared quadrature multiplier's SHARED_MIN_CLOCKS). The latency (fixed/core.py core_latency) and every
        output word are the same for both."""
        return self.cordic().clocks_per_sample

    @property
    def samples_per_clock(self) -> float:
        """Throughput in samples per clock at full speed, 1 / clocks_per_sample."""
        return 1.0 / self.clocks_per_sample

    def trim_params(self) -> TrimParams:
        """fringe_trim's parameters: the TRIM_* fields under the block's own names."""
        return TrimParams(lines=self.lines, fine_w=self.fine_w, amp_w=self.wave_w + 1,
                          speed_log2=self.trim_speed_log2, map_psi_w=self.trim_map_psi_w,
                          map_phi_w=self.trim_map_phi_w, trim_w=self.trim_w, trim_frac=self.trim_frac,
                          g_shift=self.trim_g_shift, start_speed=self.trim_start_speed,
                          mag_smooth_log2=self.trim_mag_smooth_log2)

    def drift_params(self, pipe_latency: int = 0) -> DriftParams:
        """The drift tracker's parameters (fringe_drift_observer's, fringe_drift_normaliser's among them);
        pipe_latency: clock enables from the normaliser's outputs to the observer's inputs in the core
        (`drift_pipe_latency`)."""
        return DriftParams(adc_w=self.adc_w, fine_w=self.fine_w, block_log2=self.drift_block_log2,
                           mu_log2=self.drift_mu_log2, ofs_frac=self.drift_ofs_frac, ginv_w=self.drift_ginv_w,
                           fwd_w=self.drift_fwd_w, table_w=self.drift_table_w, table_frac=self.drift_table_frac,
                           kg_w=self.drift_kg_w, kg_shift=self.drift_kg_shift, pipe_latency=pipe_latency,
                           hold=self.drift_hold)

    def cancel_params(self) -> CancelParams:
        return CancelParams(wave_w=self.wave_w, lut_w=self.cancel_lut_w, c_w=self.cancel_c_w,
                            block_log2=self.cancel_block_log2, mu_log2=self.cancel_mu_log2,
                            a_frac=self.cancel_a_frac, a_w=self.cancel_a_w, gear_offset=self.cancel_gear_offset)

    def hdl_parameters(self) -> dict[str, int]:
        """Parameters/generics of fringe_core and fringe_top (with the long-period index mapping)."""
        p = {f.name.upper(): getattr(self, f.name) for f in dataclasses.fields(self)
             if f.name not in TRIM_FIELDS + DRIFT_FIELDS + CANCEL_FIELDS}
        p["LP_RECIP"], p["LP_SHIFT"] = lp_mod.index_mapping(self.lines, self.fine_w, self.lp_addr_w, self.lp_if)
        if self.trim:     # without fringe_trim its parameters are not passed (the HDL defaults stand)
            p.update({name.upper(): getattr(self, name) for name in TRIM_FIELDS})
            tp = self.trim_params()
            p["TRIM_SECT_RECIP"], p["TRIM_SECT_SHIFT"] = tp.recip, tp.shift
        if self.drift:    # likewise the drift tracker's
            p.update({name.upper(): getattr(self, name) for name in DRIFT_FIELDS})
        if self.cancel:   # and fringe_canceller's
            p.update({name.upper(): getattr(self, name) for name in CANCEL_FIELDS})
        return p

    def hdl_parameter_defaults(self) -> dict[str, int | str]:
        """Every HDL parameter of HDL_PARAMETER_DOCS with this configuration's value (the trim, drift and
        canceller ones too, whatever TRIM, DRIFT and CANCEL are; init files empty)."""
        p = {f.name.upper(): getattr(self, f.name) for f in dataclasses.fields(self)}
        p.update(self.hdl_parameters())
        tp = self.trim_params()
        p["TRIM_SECT_RECIP"], p["TRIM_SECT_SHIFT"] = tp.recip, tp.shift
        return {k: p.get(k, "") for k in HDL_PARAMETER_DOCS}

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @property
    def test_id(self) -> str:
        return (f"adc{self.adc_w}-L{self.lines}-c{self.coarse_w}-f{self.fine_w}" + ("-compact" if self.compact else "")
                + ("-cancel" if self.cancel else ""))


def long_period_params(cfg: CoreConfig) -> lp_mod.LongPeriodParams:
    return lp_mod.LongPeriodParams(cfg.lines, cfg.fine_w, cfg.lp_addr_w, cfg.lp_w, cfg.lp_frac, cfg.lp_if)


def period_count_params(cfg: CoreConfig) -> pc_mod.PeriodCountParams:
    return pc_mod.PeriodCountParams(cfg.fine_w, cfg.lines, cfg.coarse_w)


#: Clock enables of fringe_core's own input registers (bank thresholds, branch select), see core_latency().
INPUT_LATENCY = 2


def drift_pipe_latency(cfg: CoreConfig) -> int:
    """Clock enables from fringe_drift_normaliser's outputs to fringe_drift_observer's inputs in the core: the
    input registers, the waveform tables, the quadrature, the canceller (CANCEL = 1) and the CORDIC (PIPE_LATENCY)."""
    return (INPUT_LATENCY + wave_mod.LATENCY + quad_mod.LATENCY + (CANCEL_LATENCY if cfg.cancel else 0)
            + cfg.cordic().latency)
