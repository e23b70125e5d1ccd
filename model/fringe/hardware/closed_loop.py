"""The closed loop's hardware corrections as the contents of fringe_trim's tables.

`fringe loop` adds corrections in the float pipeline's terms (pipeline.run_float):
- `rev_norm`: per-channel offsets and gains over the revolution, undone on the raw readings;
- `angle_terms`: fitted effects (effects.LIBRARY) subtracted from the output angle.
fringe_trim subtracts, after the period count, `map[dir][sector][phase] + speed * gs[phase] +
mag * ga[phase]` (fine counts, docs/blocks/fringe_trim.md). This module evaluates those three functions from
a calibration, in float, at the tables' points:
- the map holds the angle image of `rev_norm` (the fine-phase error the revolution-dependent
  offsets and gains cause at each sector, obtained by running the calibrated waveform model
  through the correction with and without them), the hysteresis term (direction x revolution)
  and the constant part of the amplitude term;
- gs holds the speed terms (sampling skew): the speed in fine counts per 2^SPEED_LOG2 samples
  becomes rev/s through the recording's sample interval;
- ga holds the magnitude terms, per unit of the CORDIC's magnitude.
Drift is tracked online by the drift tracker (DRIFT = 1): `build_drift_tables` gives its forward waveform
tables and W0/KG registers, and `pipeline.tracked_phase` is the float engine's run of the same equations. Terms
neither block carries are named by `unsupported`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..dsp.calibration import Calibration, static_phase
from ..dsp.effects import MAG_REF, REV_ORDERS, amplitude_shape
from ..encoder import ARCSEC_PER_REV
from ..fixed import trim as trim_mod
from ..fixed.cordic import cordic_gain
from ..fixed.drift import kg_for, make_fwd_table

#: effects whose terms fringe_trim carries (speed terms, magnitude terms, direction x revolution)
TRIM_EFFECTS = ("sampling_skew", "amplitude", "hysteresis")
THETA_POINTS = 4096      # waveform samples per period when the rev_norm map is evaluated


def needs_trim(cal: Calibration) -> bool:
    # hardware/tables.py asks for TRIM = 1 whenever the calibration has closed-loop terms, float-only ones too
    return cal.rev_norm is not None or bool(cal.angle_terms)


def unsupported(cal: Calibration) -> list[str]:
    """Closed-loop corrections of this calibration that the bit-exact core cannot run without.

    Terms marked for the float engine only (FittedEffect.engine == "float": no legal table width carries
    them, or no core block exists for them) are not counted: the core runs the rest of the calibration."""
    from ..dsp.effects import GENERIC_FACTORS, parse_generic

    return [t.name for t in core_terms(cal) if t.name not in TRIM_EFFECTS
            and not (t.name.startswith("generic:") and GENERIC_FACTORS[parse_generic(t.name)[0]])]


def core_terms(cal: Calibration) -> list:
    """The angle terms the bit-exact core carries (the float engine runs them all)."""
    return [t for t in cal.angle_terms if getattr(t, "engine", "core") != "float"]


def float_only(cal: Calibration) -> list[str]:
    """Angle terms that only the float engine runs."""
    return [t.name for t in cal.angle_terms if getattr(t, "engine", "core") == "float"]


@dataclass(frozen=True)
class TrimGrids:
    """Float table contents, fine counts (the encoder's frame: fringe_trim subtracts them)."""

    map: np.ndarray     # (2, 2^MAP_PSI_W, 2^MAP_PHI_W): [dir (0 forward, 1 backward), sector, bin]
    speed: np.ndarray   # (2^MAP_PHI_W,) counts per speed count (fine counts per 2^SPEED_LOG2 samples)
    amp: np.ndarray     # (2^MAP_PHI_W,) counts per CORDIC magnitude unit


def rev_norm_error(cal: Calibration, psi: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Fine-phase error (fraction of a period) that cal.rev_norm removes, at measured phase phi (rad).

    For each revolution angle psi[j]: the calibrated waveforms W(theta) on a dense theta grid,
    de-normalised (W * (1 + gain(psi)) + offset(psi)) as the encoder would give them, run through
    the correction without the normalisation (measured phase) and with it (true phase); the
    difference is resampled at the measured phases `phi`. Shape (len(psi), len(phi)).
    """
    theta = np.linspace(0.0, 2 * np.pi, THETA_POINTS, endpoint=False)
    ws, wc = cal.waves["sin"](theta), cal.waves["cos"](theta)
    # the waveforms over one period, not a stream in time: the interference canceller, an adaptive filter of a
    # stream, has nothing to take out of them (run over the grid it adapted to the waveform's own content, and
    # its per-sample float loop, 7.5 ms a grid, ran once per revolution angle in every trim_config)
    cal = dataclasses.replace(cal, canceller={}) if cal.canceller else cal
    true_frac, _ = static_phase(cal, ws, wc)
    b = cal.rev_norm.basis(np.asarray(psi, float))
    out = np.empty((len(psi), len(phi)))
    for j in range(len(psi)):
        raw = {}
        for kind, w in (("sin", ws), ("cos", wc)):
            off, gain = cal.rev_norm.weights[kind]
            raw[kind] = w * (1.0 + b[j] @ gain) + b[j] @ off
        meas_frac, _ = static_phase(cal, raw["sin"], raw["cos"])
        err = (meas_frac - true_frac + 0.5) % 1.0 - 0.5
        order = np.argsort(meas_frac)
        out[j] = np.interp(np.asarray(phi) / (2 * np.pi), meas_frac[order], err[order], period=1.0)
    return out


IMAGE_PSI_POINTS = 64    # revolution angles and fine phases of rev_norm_image's grid: REV_ORDERS <= 4 and the
IMAGE_PHI_POINTS = 256   # waveform's low orders vary slowly on it (linear interpolation errors below 1e-3 of them)


def rev_norm_image(cal: Calibration, psi: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """rev_norm_error at each sample's own revolution angle psi and measured phase phi (rad), as a fraction of a
    period: the function fringe_trim's map tabulates, interpolated (periodic, bilinear) on a fine grid instead of
    the core's table widths."""
    gp = 2 * np.pi * np.arange(IMAGE_PSI_POINTS) / IMAGE_PSI_POINTS
    gf = 2 * np.pi * np.arange(IMAGE_PHI_POINTS) / IMAGE_PHI_POINTS
    grid = rev_norm_error(cal, gp, gf)
    u = np.mod(np.asarray(psi, float), 2 * np.pi) / (2 * np.pi) * IMAGE_PSI_POINTS
    v = np.mod(np.asarray(phi, float), 2 * np.pi) / (2 * np.pi) * IMAGE_PHI_POINTS
    i0, j0 = np.floor(u).astype(int) % IMAGE_PSI_POINTS, np.floor(v).astype(int) % IMAGE_PHI_POINTS
    i1, j1 = (i0 + 1) % IMAGE_PSI_POINTS, (j0 + 1) % IMAGE_PHI_POINTS
    a, b = u - np.floor(u), v - np.floor(v)
    return ((1 - a) * ((1 - b) * grid[i0, j0] + b * grid[i0, j1]) + a * ((1 - b) * grid[i1, j0] + b * grid[i1, j1]))


def trim_grids(cal: Calibration, rev: int, fine_w: int, map_psi_w: int, map_phi_w: int, speed_log2: int,
               mag_scale: float, sample_interval_s: float) -> TrimGrids:
    """The three tables of fringe_trim in float at their points.

    rev: fine counts per revolution; map rows hold the value at each bin's start (phase k / 2^MAP_PHI_W,
    interpolated in between by the hardware) for the sector's centre; mag_scale: CORDIC magnitude units
    per unit of the float pipeline's magnitude; sample_interval_s: seconds per sample of the recordings
    the speed terms were fitted on.

    The float engine reads its terms at the phase the revolution's offsets and gains leave (cal.rev_norm
    corrected first), the core's map at the measured phase. So the map's terms are tabulated at the
    corrected phase of each (sector, bin): a term of high fine order read at the measured phase differs by
    its slope times that correction (population 9022: offsets of 29" over the revolution under a 9th-order
    phase term, 1.08" of the 1.22" between the core and the float engine). The speed and magnitude tables
    have no sector axis and keep the measured phase; a product's map part (the magnitude reference) follows
    its table, so that the two halves cancel at the reference magnitude as in the float.
    """
    phi = 2 * np.pi * np.arange(1 << map_phi_w) / (1 << map_phi_w)
    psi = 2 * np.pi * (np.arange(1 << map_psi_w) + 0.5) / (1 << map_psi_w)
    counts = cal.direction * rev / ARCSEC_PER_REV       # output-frame arcsec -> encoder-frame fine counts
    grid = np.zeros((2, len(psi), len(phi)))
    gs = np.zeros(len(phi))
    ga = np.zeros(len(phi))
    at = np.broadcast_to(phi, (len(psi), len(phi)))       # the terms' phase at each (sector, bin)
    if cal.rev_norm is not None:
        error = rev_norm_error(cal, psi, phi)
        grid += error[None] * (1 << fine_w)
        at = phi[None, :] - 2 * np.pi * error
    for term in core_terms(cal):
        w = np.asarray(term.weights, float)
        if term.name == "hysteresis":
            for d, sign in ((0, 1.0), (1, -1.0)):
                cols = [np.full_like(psi, sign)]
                for m in range(1, REV_ORDERS + 1):
                    cols += [sign * np.cos(m * psi), sign * np.sin(m * psi)]
                grid[d] += (np.column_stack(cols) @ w)[:, None] * counts
        elif term.name == "sampling_skew":
            # speed (rev/s) = speed counts / rev / (2^SPEED_LOG2 * sample interval)
            per_count = 1.0 / (rev * (1 << speed_log2) * sample_interval_s)
            gs += (w[0] * (1 - np.cos(2 * phi)) + w[1] * np.sin(2 * phi)) * counts * per_count   # effects._skew_cols
            grid += ((w[2] * np.cos(2 * at) + w[3] * np.sin(2 * at)) * counts)[None]            # its static part
        elif term.name == "amplitude":
            h = amplitude_shape(w, phi)
            ga += h * counts / mag_scale
            grid -= (h * counts * MAG_REF)[None, None, :]
        elif term.name.startswith("generic:"):
            _generic_into(term, grid, gs, ga, phi, at, psi, counts, rev, speed_log2, mag_scale, sample_interval_s)
        else:
            raise ValueError(f"fringe_trim cannot carry the closed-loop term '{term.name}'")
    return TrimGrids(grid, gs, ga)


def _generic_into(term, grid, gs, ga, phi, at, psi, counts, rev, speed_log2, mag_scale, sample_interval_s):
    """A term of the general dictionary (effects.generic_design) into fringe_trim's tables: the phase shape
    per factor column, placed in the table that multiplies by that factor; the map's own factors read the
    phase `at` (sector, bin), the tables' the bins' phase `phi` (trim_grids)."""
    from ..dsp.effects import GENERIC_FACTORS, parse_generic, phase_columns

    factor, k, m = parse_generic(term.name)
    if not GENERIC_FACTORS[factor]:
        raise ValueError(f"fringe_trim cannot carry the closed-loop term '{term.name}'")

    def shapes(x):         # (factor column, *x.shape): each factor column's phase shape at the phases x
        cols = np.stack(phase_columns(np.ravel(x), k, constant=factor != "1"), axis=-1)
        w = np.asarray(term.weights, float).reshape(-1, cols.shape[1])    # (factor column, phase column)
        return (cols @ w.T * counts).T.reshape((w.shape[0], *np.shape(x)))
    if factor == "1":
        grid += shapes(at)[0][None]
    elif factor == "direction":
        s = shapes(at)[0]
        grid[0] += s
        grid[1] -= s
    elif factor == "revolution":
        rc = np.column_stack([g(j * psi) for j in range(1, m + 1) for g in (np.cos, np.sin)])
        grid += np.einsum("sf,fsb->sb", rc, shapes(at))[None]
    elif factor == "speed":
        gs += shapes(phi)[0] / (rev * (1 << speed_log2) * sample_interval_s)
    elif factor == "magnitude":
        s = shapes(phi)[0]
        ga += s / mag_scale
        grid -= (s * MAG_REF)[None, None, :]


def mag_scale(cfg) -> float:
    """CORDIC magnitude units per unit of the float magnitude: 2^WAVE_FRAC times the CORDIC gain."""
    return float((1 << (cfg.wave_w - 2)) * cordic_gain(cfg.cordic_stages))


def grids_for(cal: Calibration, cfg) -> TrimGrids:
    dt = cal.provenance.get("sample_interval_s") or 1.0
    return trim_grids(cal, cfg.rev, cfg.fine_w, cfg.trim_map_psi_w, cfg.trim_map_phi_w, cfg.trim_speed_log2,
                      mag_scale(cfg), dt)


def choose_g_shift(grids: TrimGrids, trim_w: int, trim_frac: int) -> int:
    """The largest TRIM_G_SHIFT (1..48) that keeps every gain value within a quarter of s(TRIM_W),
    leaving room for the slopes (a slope is at most twice the largest value)."""
    peak = float(max(np.max(np.abs(grids.speed)), np.max(np.abs(grids.amp))))
    if peak == 0.0:      # no gains: the products are zero, any shift is exact; the largest keeps the budget tight
        return 48
    g = int(np.floor(np.log2((1 << (trim_w - 3)) / peak))) - trim_frac
    return int(min(48, max(1, g)))


MAX_MAP_PSI_W = 8        # fringe_trim's limit
MAX_MAP_WORDS_LOG2 = 14  # TRIM_MAP_PSI_W + TRIM_MAP_PHI_W at most this (RTL: 15): 2 banks x 2 dirs x 2^14 words
SECTOR_BUDGET = 0.1      # the map's sector steps may add this fraction of the noise floor (0.5 % in quadrature)
SECTOR_SHARE = 0.05      # without a noise floor: this fraction of the map's change over the revolution


def sector_error(cal: Calibration, cfg, map_psi_w: int) -> tuple[float, float]:
    """RMS (fine counts) of what the map's sectors leave of its change over the revolution (each sector holds
    its centre's value; four points per sector compared), and the RMS of that change itself."""
    dt = cal.provenance.get("sample_interval_s") or 1.0

    def grid(w):     # (not through a CoreConfig: the finer grid may lie beyond the block's limits)
        return trim_grids(cal, cfg.rev, cfg.fine_w, w, cfg.trim_map_phi_w, cfg.trim_speed_log2, mag_scale(cfg),
                          dt).map
    fine, coarse = grid(map_psi_w + 2), grid(map_psi_w)
    steps = fine - np.repeat(coarse, 4, axis=1)
    change = fine - fine.mean(axis=1, keepdims=True)
    return float(np.sqrt(np.mean(steps ** 2))), float(np.sqrt(np.mean(change ** 2)))


def choose_map_psi_w(cal: Calibration, cfg) -> int:
    """The fewest sectors (from the configured TRIM_MAP_PSI_W up) whose steps stay within the error budget: a tenth of
    the noise floor the closed loop measured (cal.provenance["noise_floor_arcsec"]), else SECTOR_SHARE of the
    map's own change over the revolution. A map that does not change over the revolution keeps the configured
    value."""
    floor = cal.provenance.get("noise_floor_arcsec")
    top = min(MAX_MAP_PSI_W, MAX_MAP_WORDS_LOG2 - cfg.trim_map_phi_w)
    from ..fixed.trim import sector_mapping

    start = min(cfg.trim_map_psi_w, top)
    for w in range(start, max(start, top) + 1):
        try:
            sector_mapping(cfg.lines, cfg.fine_w, w)
        except ValueError:       # no exact multiply-shift for this many sectors: the last that had one
            return max(start, w - 1)
        err, change = sector_error(cal, cfg, w)
        budget = SECTOR_BUDGET * floor * cfg.rev / ARCSEC_PER_REV if floor else SECTOR_SHARE * change
        if err <= budget or change == 0.0:
            return w
    return max(start, top)


def map_changes_over_revolution(cal: Calibration, cfg) -> bool:
    dt = cal.provenance.get("sample_interval_s") or 1.0     # many sectors: no revolution order aliases away
    grid = trim_grids(cal, cfg.rev, cfg.fine_w, MAX_MAP_PSI_W, cfg.trim_map_phi_w, cfg.trim_speed_log2,
                      mag_scale(cfg), dt).map
    return bool(np.max(np.abs(grid - grid[:, :1])) > 1e-9 * max(float(np.max(np.abs(grid))), 1e-300))


MAX_MAP_PHI_W = 10       # fringe_trim's limit (and FINE_W - 1)
BIN_SHARE = 0.02         # the speed and magnitude tables' interpolation may leave this fraction of their own size


def bin_error(cal: Calibration, cfg, map_phi_w: int) -> tuple[float, float, float]:
    """What linear interpolation between 2^MAP_PHI_W bins leaves of the three tables' phase shapes: the map's RMS
    (fine counts), and the speed and magnitude tables' RMS relative to their own RMS (0 when they are empty).
    Compared against a grid four times finer."""
    dt = cal.provenance.get("sample_interval_s") or 1.0

    def grids(w):
        return trim_grids(cal, cfg.rev, cfg.fine_w, cfg.trim_map_psi_w, w, cfg.trim_speed_log2, mag_scale(cfg),
                          dt)
    fine, coarse = grids(map_phi_w + 2), grids(map_phi_w)

    def left(f, c):       # f on the fine grid, c on the coarse one (periodic in the last axis)
        c = np.concatenate([c, c[..., :1]], axis=-1)
        x = np.arange(f.shape[-1]) / 4.0
        i = np.floor(x).astype(int)
        interp = c[..., i] + (x - i) * (c[..., i + 1] - c[..., i])
        return f - interp
    err = float(np.sqrt(np.mean(left(fine.map, coarse.map) ** 2)))
    rel = [float(np.sqrt(np.mean(left(f, c) ** 2)) / np.sqrt(np.mean(f ** 2))) if np.any(f) else 0.0
           for f, c in ((fine.speed, coarse.speed), (fine.amp, coarse.amp))]
    return err, rel[0], rel[1]


def choose_map_phi_w(cal: Calibration, cfg) -> int:
    """The fewest phase bins per period (from the configured TRIM_MAP_PHI_W up to the block's limit) whose linear
    interpolation stays within the error budget: for the map, a tenth of the measured noise floor (as the
    sectors, choose_map_psi_w); for the speed and magnitude tables, BIN_SHARE of their own size. A fine-phase
    term of high order (the phase-domain structure's map) needs many bins, a smooth one few."""
    floor = cal.provenance.get("noise_floor_arcsec")
    top = min(MAX_MAP_PHI_W, cfg.fine_w - 1, MAX_MAP_WORDS_LOG2 - cfg.trim_map_psi_w)
    for w in range(cfg.trim_map_phi_w, max(cfg.trim_map_phi_w, top) + 1):
        err, rel_speed, rel_amp = bin_error(cal, cfg, w)
        budget = SECTOR_BUDGET * floor * cfg.rev / ARCSEC_PER_REV if floor else 0.0
        if (err <= budget or err == 0.0 or (not floor and w == cfg.trim_map_phi_w)) and \
                max(rel_speed, rel_amp) <= BIN_SHARE:
            return w
    return max(cfg.trim_map_phi_w, top)


def balance_map_words(cal: Calibration, cfg):
    """cfg, or with fewer phase bins and more sectors where the map's words (MAX_MAP_WORDS_LOG2) leave the sectors
    over their budget: the bins are chosen first, for the fine-phase shape, and a map that also changes strongly
    over the revolution is then held in too few sectors (development case 9116: 2^8 bins, 2^6 sectors, 0.07" of bins and
    0.70" of sectors; 2^7 and 2^7: 0.29" and 0.35"). Of the pairs with the words all used, the one with the least
    error in quadrature, as long as the speed and magnitude tables' bins stay within BIN_SHARE."""
    floor = cal.provenance.get("noise_floor_arcsec")
    if not floor or cfg.trim_map_psi_w == 0:
        return cfg
    from ..fixed.trim import sector_mapping

    sectors = sector_error(cal, cfg, cfg.trim_map_psi_w)[0]
    if sectors <= SECTOR_BUDGET * floor * cfg.rev / ARCSEC_PER_REV or cfg.trim_map_psi_w == MAX_MAP_PSI_W:
        return cfg
    best = (float(np.hypot(bin_error(cal, cfg, cfg.trim_map_phi_w)[0], sectors)), cfg)
    for phi in range(cfg.trim_map_phi_w - 1, 1, -1):
        psi = min(MAX_MAP_PSI_W, MAX_MAP_WORDS_LOG2 - phi)
        try:
            sector_mapping(cfg.lines, cfg.fine_w, psi)
        except ValueError:
            break
        trial = dataclasses.replace(cfg, trim_map_phi_w=phi, trim_map_psi_w=psi)
        bins, rel_speed, rel_amp = bin_error(cal, trial, phi)
        if max(rel_speed, rel_amp) > BIN_SHARE:
            break
        total = float(np.hypot(bins, sector_error(cal, trial, psi)[0]))
        if total < best[0]:
            best = (total, trial)
        if psi == MAX_MAP_PSI_W:
            break
    return best[1]


MAX_TABLE_W = 24         # the widest table word the blocks accept (fringe_trim TRIM_W, fringe_drift_observer TABLE_W)


def start_speed_counts(cal: Calibration, cfg) -> int:
    """TRIM_START_SPEED: cal.start_speed_rev_s (encoder frame) in fringe_trim's speed units, fine counts per
    2^TRIM_SPEED_LOG2 samples at the calibration's sample interval, within [-REV/2, REV/2 - 1]."""
    dt = cal.provenance.get("sample_interval_s") or 1.0
    v = float(cal.start_speed_rev_s) * cfg.rev * (1 << cfg.trim_speed_log2) * dt
    half = cfg.rev >> 1
    return int(np.clip(round(v), -half, half - 1)) if np.isfinite(v) else 0


def trim_config(cal: Calibration, cfg):
    """cfg with fringe_trim switched on and its table format chosen for this calibration (cfg unchanged
    if the calibration has no closed-loop correction).

    The format follows from the fitted values: at the configured TRIM_W the most fraction bits
    (TRIM_FRAC, from the configured value down to 0) with which every map value and slope fits,
    TRIM_G_SHIFT the largest that keeps the gains in range; a wider TRIM_W (up to 24) only when no fraction fits.
    Every choice is checked by building the tables. ValueError (what does not fit) when nothing does."""
    if not needs_trim(cal):
        return cfg
    if cal.speed_window_log2 is not None:
        cfg = dataclasses.replace(cfg, trim_speed_log2=int(cal.speed_window_log2))
    on = dataclasses.replace(cfg, trim=1, trim_start_speed=start_speed_counts(cal, cfg),
                             trim_mag_smooth_log2=int(cal.magnitude_smooth_log2))
    if not map_changes_over_revolution(cal, on):     # one sector: every word of the map for the phase
        on = dataclasses.replace(on, trim_map_psi_w=0)
    on = dataclasses.replace(on, trim_map_phi_w=choose_map_phi_w(cal, on))
    on = dataclasses.replace(on, trim_map_psi_w=choose_map_psi_w(cal, on))
    on = balance_map_words(cal, on)
    grids = grids_for(cal, on)
    last = None
    for width in range(on.trim_w, max(on.trim_w, MAX_TABLE_W) + 1):
        for frac in range(on.trim_frac, -1, -1):
            trial = dataclasses.replace(on, trim_w=width, trim_frac=frac)
            trial = dataclasses.replace(trial, trim_g_shift=choose_g_shift(grids, width, frac))
            try:
                _quantise_trim(grids, trial.trim_params())
                return trial
            except ValueError as e:
                last = e
    raise ValueError(f"{last}: the closed-loop corrections do not fit fringe_trim's tables at any "
                     f"TRIM_W <= {MAX_TABLE_W}")


@dataclass(frozen=True)
class TrimTables:
    """The quantised tables of one bank (values; trim.pack_words makes the RAM words)."""

    map: np.ndarray
    speed: np.ndarray
    amp: np.ndarray


def build_trim_tables(cal: Calibration, cfg) -> TrimTables:
    """Quantise; ValueError (with what to change) if a table does not fit its width."""
    if unsupported(cal):
        raise ValueError("the bit-exact core does not carry these closed-loop corrections: "
                         + ", ".join(unsupported(cal)) + " (use --engine float)")
    p = cfg.trim_params()
    try:
        return _quantise_trim(grids_for(cal, cfg), p)
    except ValueError as e:
        raise ValueError(f"{e}: the closed-loop corrections do not fit fringe_trim's tables "
                         f"(TRIM_W = {p.trim_w}, TRIM_FRAC = {p.trim_frac}, TRIM_G_SHIFT = {p.g_shift})") from None


def _quantise_trim(grids: TrimGrids, p) -> TrimTables:
    m = trim_mod.make_map_table(lambda d, s, ph: grids.map[d, s], p)
    gs = trim_mod.make_gain_table(lambda ph: grids.speed, p)
    ga = trim_mod.make_gain_table(lambda ph: grids.amp, p)
    return TrimTables(m, gs, ga)


# ---------------------------------------------------------------- the drift tracker (online)

@dataclass(frozen=True)
class DriftTables:
    """The drift tracker's forward tables (values, (2, 2^FWD_W): sin, cos) and its W0 / KG registers (2,)."""

    fwd: np.ndarray
    w0: np.ndarray
    kg: np.ndarray


def channel_waveforms(cal: Calibration):
    """The calibrated channel readings (ADC codes) as functions of the core's fine phase (fraction of a
    period): the phase the CORDIC measures is theta + psi_cos (pipeline.tracked_phase's convention)."""
    if not {"sin", "cos"} <= set(cal.waves):
        raise ValueError("the drift tracker needs the calibrated waveform models (this calibration has none)")
    psi_c = cal.waves["cos"].psi
    return {k: (lambda ph, w=cal.waves[k]: w(2 * np.pi * np.asarray(ph) - psi_c)) for k in ("sin", "cos")}


def tracker_waveforms(cal: Calibration):
    """The channel readings as functions of the phase fringe_drift_observer is given: the CORDIC's, before
    the tables after the arctan. With the per-channel inverse that phase is the true one (channel_waveforms).
    In the phase-table structure the waveform stage is straight, so the CORDIC's phase still carries the
    channels' shape error that the tables after it take out, while the channel models are fitted against the
    true phase: each model is read at the true phase theta and placed at the phase the CORDIC measures for
    those readings. Without this the observer compares the readings with the model a phase error away and
    steers the offsets and gains by it (a 7-line encoder: 62" static, 240" tracked)."""
    waves = channel_waveforms(cal)
    if cal.fit.get("structure") != "phase_table":
        return waves
    theta = np.arange(THETA_POINTS) / THETA_POINTS
    readings = {k: f(theta) for k, f in waves.items()}
    measured, _ = static_phase(dataclasses.replace(cal, adaptive=False, canceller={}), readings["sin"],
                               readings["cos"])
    order = np.argsort(measured)
    at = measured[order]
    return {k: (lambda ph, v=readings[k][order]: np.interp(np.mod(np.asarray(ph, float), 1.0), at, v, period=1.0))
            for k in ("sin", "cos")}


def choose_kg_shift(cal: Calibration, cfg) -> int:
    """The largest KG_SHIFT (1..60) that keeps both KG constants below half of u(KG_W)."""
    p = dataclasses.replace(cfg, drift_kg_shift=1).drift_params()
    # the smaller mean square gives the larger KG
    m2 = min(float(np.mean(make_fwd_table(f, p)[0].astype(float) ** 2)) for f in tracker_waveforms(cal).values())
    # KG = 4/3 2^(KG_SHIFT + GINV_W - 2 - MU_LOG2) / (W m2) < 2^(KG_W - 1) (kg_for)
    shift = int(np.floor(np.log2(2.0 ** (p.kg_w - 1) * p.w * m2 * 3 / 4))) - (p.ginv_w - 2 - p.mu_log2)
    return int(min(60, max(1, shift)))


def drift_config(cal: Calibration, cfg):
    """cfg with the drift tracker switched on for an adaptive calibration, else unchanged.

    The forward tables' format follows from the calibrated waveforms (any ADC width): at the configured
    DRIFT_TABLE_W the most fraction bits (DRIFT_TABLE_FRAC, from the configured value down to 0) with
    which every value, slope and W0 fits; a wider DRIFT_TABLE_W (up to 24) only when none does; then
    KG_SHIFT. Each choice is checked by building the tables; ValueError when nothing fits."""
    if not cal.adaptive:
        return cfg
    on = dataclasses.replace(cfg, drift=1, **cal.tracker)
    last = None
    for width in range(on.drift_table_w, max(on.drift_table_w, MAX_TABLE_W) + 1):
        for frac in range(on.drift_table_frac, -1, -1):
            trial = dataclasses.replace(on, drift_table_w=width, drift_table_frac=frac)
            try:
                trial = dataclasses.replace(trial, drift_kg_shift=choose_kg_shift(cal, trial))
                build_drift_tables(cal, trial)
                return trial
            except ValueError as e:
                last = e
    raise ValueError(f"{last}: the calibrated waveforms do not fit the drift tracker's forward tables at any "
                     f"DRIFT_TABLE_W <= {MAX_TABLE_W}")


def build_drift_tables(cal: Calibration, cfg, pipe_latency: int = 0) -> DriftTables:
    """Forward tables, W0 and KG of a calibration (zero tables for one without waveform models)."""
    p = cfg.drift_params(pipe_latency)
    if not cal.waves:
        raise ValueError("the drift tracker needs the calibrated waveform models")
    fwd, w0, kg = [], [], []
    for f in tracker_waveforms(cal).values():
        v, w = make_fwd_table(f, p)
        fwd.append(v)
        w0.append(w)
        kg.append(kg_for(v, p))
    return DriftTables(np.stack(fwd), np.array(w0, dtype=np.int64), np.array(kg, dtype=np.int64))
