"""CAL_DIR: the calibration as JSON (units, provenance) plus the waveform tables as CSV."""

import json
import math
import os

import numpy as np

from .. import __version__
from ..dsp.calibration import CANCELLER_KEYS, Calibration, cancel_gear_offset
from ..dsp.longperiod import FourierSeries
from ..dsp.quadrature import QuadratureCorrection
from ..dsp.waveform import ChannelWaveform, WaveformInverse
from ..encoder import encoder_from_dict
from ..errors import FringeInputError
from ..fixed.trim import MAG_SMOOTH_LOG2_MAX, speed_window_log2
from .dataio import MAX_REF_DEG
from .outputs import atomic_dir, verify_dir

TRACKER_KEYS = ("drift_block_log2", "drift_mu_log2")     # the drift tracker constants a calibration may choose

CAL_JSON = "calibration.json"
WAVE_CSV = "wave_tables.csv"
FORMAT = "fringe-calibration"
VERSION = 1


def to_json_dict(cal: Calibration) -> dict:
    wave = None
    if isinstance(cal.inv_sin, WaveformInverse) and isinstance(cal.inv_cos, WaveformInverse):
        wave = {"table_file": WAVE_CSV, "points": int(cal.inv_sin.values.shape[1]),
                "interpolation": "linear between table points",
                "sin": {"model": cal.waves["sin"].to_dict(), "inverse": cal.inv_sin.to_dict()},
                "cos": {"model": cal.waves["cos"].to_dict(), "inverse": cal.inv_cos.to_dict()}}
    lp = None
    if cal.long_period is not None:
        lp = cal.long_period.to_dict()
        lp.update(units="arcsec", argument="encoder angle in the revolution, rad",
                  meaning="encoder error against the reference; subtracted from the position")
    return {
        "format": FORMAT, "version": VERSION, "fringe_version": __version__,
        "encoder": cal.encoder.to_dict(),
        "provenance": cal.provenance,
        "stages": {
            "waveform": wave,
            "quadrature": cal.quad.to_dict(),
            "coarse": None if cal.coarse_offset_periods is None else
            {"offset_periods": cal.coarse_offset_periods,
             "meaning": "middle of coarse code 0, in signal periods of the fine phase"},
            "long_period": lp,
            "output": {"direction": cal.direction, "zero_deg": cal.zero_deg,
                       "meaning": "angle = direction * corrected encoder angle + zero (degrees)"},
            "status": {"amp_low": cal.amp_low, "amp_high": cal.amp_high,
                       "units": "corrected vector magnitude (1 = unit circle)"},
        },
        "closed_loop": {"adaptive_offset_gain": cal.adaptive, "tracker": cal.tracker, "canceller": cal.canceller,
                        "start_speed_rev_s": cal.start_speed_rev_s,
                        "magnitude_smooth_log2": cal.magnitude_smooth_log2,
                        "speed_window_log2": cal.speed_window_log2,
                        "rev_normalisation": None if cal.rev_norm is None else cal.rev_norm.to_dict(),
                        "angle_terms": [t.to_dict() for t in cal.angle_terms]},
        "skipped": cal.skipped,
        "fit": cal.fit,
    }


def save_calibration(cal: Calibration, out_dir: str, extra_files: dict | None = None, inputs=(),
                     command: str = "fringe calibrate"):
    """Write everything into a temporary folder and move it into place only when complete."""
    with atomic_dir(out_dir, "calibration", inputs, command) as tmp:
        with open(os.path.join(tmp, CAL_JSON), "w", encoding="utf-8") as f:
            json.dump(to_json_dict(cal), f, indent=2, default=_jsonable)
            f.write("\n")
        if isinstance(cal.inv_sin, WaveformInverse):
            write_wave_tables(os.path.join(tmp, WAVE_CSV), cal.inv_sin, cal.inv_cos)
        for name, writer in (extra_files or {}).items():
            writer(os.path.join(tmp, name))


def _jsonable(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


def write_wave_tables(path: str, inv_sin: WaveformInverse, inv_cos: WaveformInverse):
    readings = inv_sin.lo + inv_sin.step * np.arange(inv_sin.values.shape[1])
    data = np.column_stack([readings, inv_sin.values[0], inv_sin.values[1], inv_cos.values[0], inv_cos.values[1]])
    header = ("reading_counts,sin_branch0,sin_branch1,cos_branch0,cos_branch1\n")
    with open(path, "w", encoding="utf-8") as f:
        f.write("# fringe waveform inverse tables: reading (ADC counts) -> ideal value (unit circle)\n")
        for inv in (inv_sin, inv_cos):
            f.write(f"# {inv.kind} branch 1: other reading >= ({inv.kind} reading >= {inv.mid:.6f} ? "
                    f"{inv.threshold_hi:.6f} : {inv.threshold_lo:.6f})\n")
        f.write(header)
        np.savetxt(f, data, fmt="%.12g", delimiter=",")


def _canceller(d, path: str) -> dict:
    """closed_loop.canceller: {} or the tone (Hz), the sample rate (samples/s) and the canceller's constants
    (cancel_gear_offset may be missing: calibrations written before it start the gear shift at 1/2, offset 0)."""
    if not d:
        return {}
    keys = set(CANCELLER_KEYS)
    ok = (isinstance(d, dict) and keys <= set(d) <= keys | {"cancel_gear_offset"}
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in d.values())
          and d["sample_rate_hz"] > 0 and d["tone_hz"] >= 0
          and all(isinstance(d[k], int) for k in ("cancel_block_log2", "cancel_mu_log2")))
    if not ok:
        raise FringeInputError(f"closed_loop.canceller must map {', '.join(CANCELLER_KEYS)} (and optionally "
                               "cancel_gear_offset) to finite numbers (a tone >= 0 Hz, a sample rate > 0, integer "
                               "constants)", path)
    d = {**d, "cancel_gear_offset": cancel_gear_offset(d)}
    offset = d["cancel_gear_offset"]
    if not isinstance(offset, int) or not 0 <= offset < d["cancel_mu_log2"]:
        raise FringeInputError(f"closed_loop.canceller.cancel_gear_offset = {offset} must be an integer "
                               f"0..cancel_mu_log2 - 1 = {d['cancel_mu_log2'] - 1}", path)
    return d


def load_calibration(cal_dir: str) -> Calibration:
    """Read CAL_DIR after checking it is complete and unedited (its manifest's checksums)."""
    path = os.path.join(cal_dir, CAL_JSON)
    verify_dir(cal_dir, "calibration")
    try:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
    except OSError as e:
        raise FringeInputError(f"cannot read: {e.strerror}", path) from None
    except json.JSONDecodeError as e:
        raise FringeInputError(f"not valid JSON: {e.msg}", path, f"line {e.lineno}") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise FringeInputError(f"not a fringe calibration (format is not '{FORMAT}')", path)
    try:
        enc = encoder_from_dict(d["encoder"], path)
        st = d["stages"]
        if st["output"]["direction"] not in (-1, 1):
            raise ValueError(f"direction must be +1 or -1, not {st['output']['direction']!r}")
        cal = Calibration(encoder=enc, quad=QuadratureCorrection.from_dict(st["quadrature"]),
                          direction=int(st["output"]["direction"]), zero_deg=float(st["output"]["zero_deg"]),
                          amp_low=float(st["status"]["amp_low"]), amp_high=float(st["status"]["amp_high"]),
                          skipped=list(d.get("skipped", [])), provenance=d.get("provenance", {}),
                          fit=d.get("fit", {}))
        loop = d.get("closed_loop") or {}
        cal.adaptive = bool(loop.get("adaptive_offset_gain", False))
        tracker = loop.get("tracker") or {}
        if not isinstance(tracker, dict) or \
                not all(k in TRACKER_KEYS and isinstance(v, int) for k, v in tracker.items()):
            raise FringeInputError(f"closed_loop.tracker must map {', '.join(TRACKER_KEYS)} to integers", path)
        cal.tracker = dict(tracker)
        cal.canceller = _canceller(loop.get("canceller") or {}, path)
        start = loop.get("start_speed_rev_s", 0.0)
        if isinstance(start, bool) or not isinstance(start, (int, float)) or not np.isfinite(start):
            raise FringeInputError(f"closed_loop.start_speed_rev_s must be a finite number, not {start!r}", path)
        cal.start_speed_rev_s = float(start)
        smooth = loop.get("magnitude_smooth_log2", 0)
        if isinstance(smooth, bool) or not isinstance(smooth, int) or not 0 <= smooth <= MAG_SMOOTH_LOG2_MAX:
            raise FringeInputError(f"closed_loop.magnitude_smooth_log2 must be an integer 0..{MAG_SMOOTH_LOG2_MAX}, "
                                   f"not {smooth!r}", path)
        cal.magnitude_smooth_log2 = smooth
        window = loop.get("speed_window_log2")
        longest = speed_window_log2(cal.encoder.lines_per_rev)
        if window is not None and (isinstance(window, bool) or not isinstance(window, int)
                                   or not 0 <= window <= longest):
            raise FringeInputError(f"closed_loop.speed_window_log2 must be null or an integer 0..{longest} for "
                                   f"{cal.encoder.lines_per_rev} lines, not {window!r}", path)
        cal.speed_window_log2 = window
        if loop.get("rev_normalisation"):
            from ..dsp.effects import RevNormalisation
            cal.rev_norm = RevNormalisation.from_dict(loop["rev_normalisation"])
        if loop.get("angle_terms"):
            from ..dsp.effects import FittedEffect, known_term
            for t in loop["angle_terms"]:
                if not known_term(t["name"]):
                    raise ValueError(f"unknown closed-loop term '{t['name']}'")
                cal.angle_terms.append(FittedEffect.from_dict(t))
        if st.get("coarse"):
            cal.coarse_offset_periods = float(st["coarse"]["offset_periods"])
        if st.get("long_period"):
            cal.long_period = FourierSeries.from_dict(st["long_period"])
        if st.get("waveform"):
            w = st["waveform"]
            cal.waves = {k: ChannelWaveform.from_dict(w[k]["model"]) for k in ("sin", "cos")}
            if w["table_file"] != WAVE_CSV:
                raise ValueError(f"the waveform table file must be {WAVE_CSV}")
            table = _read_wave_tables(os.path.join(cal_dir, WAVE_CSV))
            if len(table) != int(w["points"]):
                raise FringeInputError(f"holds {len(table)} table rows, {CAL_JSON} says {w['points']}",
                                       os.path.join(cal_dir, WAVE_CSV))
            for k, cols in (("sin", (1, 2)), ("cos", (3, 4))):
                inv = w[k]["inverse"]
                setattr(cal, f"inv_{k}", WaveformInverse(
                    k, float(inv["lo_counts"]), float(inv["step_counts"]),
                    np.vstack([table[:, cols[0]], table[:, cols[1]]]), float(inv["threshold_hi_counts"]),
                    float(inv["threshold_lo_counts"]), float(inv["mid_counts"])))
    except (KeyError, TypeError, ValueError) as e:
        raise FringeInputError(f"calibration is incomplete or damaged ({type(e).__name__}: {e})", path) from None
    _check_values(cal, path)
    return cal


def _check_values(cal: Calibration, path: str):
    """Values a calibration cannot hold, refused by name (an edited calibration.json whose manifest was written
    anew): non-finite numbers, an angle beyond any plausible zero, status thresholds out of order, a waveform
    table that does not step forward, a coarse offset beyond the revolution."""
    def bad(field, problem):
        raise FringeInputError(f"{field} {problem}: the calibration is damaged or edited; write it anew", path)

    if not (np.isfinite(cal.zero_deg) and abs(cal.zero_deg) <= MAX_REF_DEG):   # an angle, as a ref_deg is
        bad("stages.output.zero_deg", f"= {cal.zero_deg!r} is not a plausible angle in degrees")
    if not (np.isfinite(cal.amp_low) and np.isfinite(cal.amp_high) and 0 <= cal.amp_low < cal.amp_high):
        bad("stages.status", f"amp_low = {cal.amp_low!r}, amp_high = {cal.amp_high!r} must be finite with "
                             "0 <= amp_low < amp_high")
    q = cal.quad.to_dict()
    for k, v in q.items():
        if isinstance(v, float) and not np.isfinite(v):
            bad(f"stages.quadrature.{k}", f"= {v!r} is not a finite number")
    c = cal.coarse_offset_periods
    if c is not None and not (np.isfinite(c) and abs(c) <= cal.encoder.lines_per_rev):
        bad("stages.coarse.offset_periods", f"= {c!r} is beyond the revolution's {cal.encoder.lines_per_rev} "
                                            "periods")
    for k in ("sin", "cos"):
        inv = getattr(cal, f"inv_{k}", None)
        if isinstance(inv, WaveformInverse):
            numbers = (inv.lo, inv.step, inv.threshold_hi, inv.threshold_lo, inv.mid)
            if not (all(np.isfinite(numbers)) and inv.step > 0):
                bad(f"stages.waveform.{k}.inverse", "must hold finite numbers and a step_counts > 0")


def _read_wave_tables(path: str) -> np.ndarray:
    try:
        with open(path, encoding="utf-8") as f:
            rows = [ln for ln in f if ln.strip() and not ln.startswith("#")]
        t = np.loadtxt(rows[1:], delimiter=",", ndmin=2)
    except OSError as e:
        raise FringeInputError(f"cannot read: {e.strerror}", path) from None
    except (ValueError, IndexError):
        t = np.empty((0, 0))
    if t.ndim != 2 or t.shape[1] != 5 or len(t) < 2 or not np.isfinite(t).all():
        raise FringeInputError("waveform table damaged: expected a header and 5 numeric columns", path)
    return t
