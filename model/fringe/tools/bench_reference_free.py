"""Reference-free quality on the shared real recordings that have no reference (`make bench`).

Without a reference instrument the error cannot be measured directly; two figures stand in:

- a recording with time stamps (servoproject_optical): how rough the corrected angle is against
  smooth motion, run by run (`smoothmotion.motion_roughness`), on held-out runs: the calibration is
  fitted on alternate pairs of gap-free runs (each pair holds both directions) and judged on the
  others. Before: the ellipse (conic) alone; after: the full reference-free calibration.
- with the reference hidden, the RM44 recordings check the shape path against their reference.
- a recording sorted by phase (nmm_interferometer): the harmonics of the corrected Lissajous
  figure's radius, on held-out rows (odd rows, calibrated on even ones), and the phase correction the
  figure's shape implied.
The roughness contains the sensor's noise and whatever does not repeat with the phase (drift of
offsets and gains), which no static correction removes.
"""

import os

import numpy as np

from ..calib.calibrate import calibrate, ellipse_only
from ..dsp.fourierfit import fit_select
from ..dsp.smoothmotion import motion_roughness, motion_segments
from ..encoder import Encoder
from ..engine.pipeline import fine_phase
from ..io.dataio import Measurement

SERVO = os.path.join("servoproject_optical", "optEncTestData.txt")
SERVO_OFFSET = 8192            # the logger writes unsigned codes around mid-range
NMM = "nmm_interferometer"
NMM_FRINGE_NM = 316.4          # one signal period: lambda / 2 of the NMM-1's HeNe laser
ENCODER_16BIT = Encoder(lines_per_rev=1, adc_bits=16)
RADIUS_HARMONICS = 16
RM44 = "rm44_hall_vs_tonic"
RM44_SCALE = 4096              # stored as (ADC - 2048) / 4096 of a 12-bit ADC
RM44_ENCODER = Encoder(lines_per_rev=1, adc_bits=12)


def servo_measurement(path: str) -> Measurement:
    """optEncTestData.txt: time_s, A, B, firmware index, cost; A and B as signed codes."""
    d = np.loadtxt(path)
    return Measurement(path, d[:, 1] - SERVO_OFFSET, d[:, 2] - SERVO_OFFSET, t_s=d[:, 0])


def nmm_measurement(path: str) -> Measurement:
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    return Measurement(path, d[:, 0].astype(float), d[:, 1].astype(float))


def alternate_run_pairs(meas: Measurement, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Masks of two halves made of alternate pairs of gap-free runs."""
    runs, _ = motion_segments(theta / (2 * np.pi), meas.t_s)
    first = np.zeros(len(meas), bool)
    for i, r in enumerate(runs):
        first[r.start:r.stop] = (i // 2) % 2 == 0
    return first, ~first


def _rough_deg(cal, meas: Measurement) -> float:
    frac, _ = fine_phase(cal, meas.sin, meas.cos)
    return 360.0 * motion_roughness(2 * np.pi * frac, meas.t_s)["rms_periods"]


def servo_figures(path: str) -> dict:
    meas = servo_measurement(path)
    conic = ellipse_only(calibrate(meas, ENCODER_16BIT), meas)
    theta, _ = fine_phase(conic, meas.sin, meas.cos)
    fit_half, judge_half = alternate_run_pairs(meas, 2 * np.pi * theta)
    train, val = meas.subset(fit_half), meas.subset(judge_half)
    cal = calibrate(train, ENCODER_16BIT)
    ellipse = ellipse_only(cal, train)
    before, after = _rough_deg(ellipse, val), _rough_deg(cal, val)
    return {"recording": SERVO, "samples": len(meas), "fit_samples": len(train), "judged_samples": len(val),
            "phase_reference": cal.provenance.get("phase_reference"),
            "wave_harmonics": cal.fit.get("wave_harmonics"),
            "roughness_ellipse_only_deg_el": before, "roughness_corrected_deg_el": after,
            "improvement": before / after, "target_improvement": 2.0, "meets_target": before / after >= 2.0,
            "meaning": "RMS of the corrected phase about smooth motion, per gap-free run, held-out runs, "
                       "electrical degrees"}


def radius_harmonics(cal, meas: Measurement) -> dict[int, float]:
    """Relative amplitude of each harmonic of the corrected figure's radius, against its phase."""
    frac, mag = fine_phase(cal, meas.sin, meas.cos)
    series, _, _ = fit_select(2 * np.pi * frac, mag / np.median(mag) - 1.0, RADIUS_HARMONICS,
                              n_fixed=RADIUS_HARMONICS)
    w, h = series.weights, RADIUS_HARMONICS
    return {m: float(np.hypot(w[m], w[h + m])) for m in range(1, h + 1)}


def nmm_figures(path: str) -> dict:
    meas = nmm_measurement(path)
    rows = np.arange(len(meas))
    train, val = meas.subset(rows % 2 == 0), meas.subset(rows % 2 == 1)
    cal = calibrate(train, ENCODER_16BIT)
    before, after = radius_harmonics(ellipse_only(cal, train), val), radius_harmonics(cal, val)
    f_cal, _ = fine_phase(cal, val.sin, val.cos)
    f_ell, _ = fine_phase(ellipse_only(cal, train), val.sin, val.cos)
    shift = np.angle(np.exp(2j * np.pi * (f_cal - f_ell)))
    shift -= np.angle(np.mean(np.exp(1j * shift)))
    # what per-channel tables cannot invert: the correction run on its own fitted (noise-free) curve
    grid = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    f_model, _ = fine_phase(cal, cal.waves["sin"](grid), cal.waves["cos"](grid))
    model_err = np.angle(np.exp(1j * (2 * np.pi * f_model - grid)))
    model_err -= np.angle(np.mean(np.exp(1j * model_err)))
    pick = (4, 8)
    return {"recording": os.path.join(NMM, os.path.basename(path)), "samples": len(meas),
            "radius_harmonics_ellipse_only_pct": {m: 100 * before[m] for m in pick},
            "radius_harmonics_corrected_pct": {m: 100 * after[m] for m in pick},
            "largest_residual_harmonic_pct": 100 * max(after[m] for m in range(3, RADIUS_HARMONICS + 1)),
            "largest_ellipse_only_harmonic_pct": 100 * max(before[m] for m in range(3, RADIUS_HARMONICS + 1)),
            "phase_correction_pp_nm": float(np.ptp(shift) / (2 * np.pi) * NMM_FRINGE_NM),
            "tables_own_curve_error_pp_nm": float(np.ptp(model_err) / (2 * np.pi) * NMM_FRINGE_NM),
            "meaning": "radius harmonics of the corrected Lissajous figure (% of the radius), held-out odd "
                       "rows; the phase correction the figure's shape implies (nm p-p); the error the tables leave "
                       "on their own fitted curve (nm p-p: a channel that is not monotone between its extremes "
                       "cannot be inverted by its own table)"}


def _rms_against(cal, meas: Measurement, ref_rad: np.ndarray) -> float:
    """RMS angle error against a reference (deg), after its zero and, as the encoder does not know
    it, its direction."""
    frac, _ = fine_phase(cal, meas.sin, meas.cos)
    best = np.inf
    for direction in (1, -1):
        e = np.angle(np.exp(1j * (direction * 2 * np.pi * frac - ref_rad)))
        e -= np.angle(np.mean(np.exp(1j * e)))
        best = min(best, float(np.degrees(np.sqrt(np.mean(e * e)))))
    return best


def rm44_without_reference(path: str) -> dict:
    """A check of the shape reference on a sensor with a reference: the RM44 file calibrated with its
    reference column hidden (one period per revolution, no t_s: the shape path), then judged against it.
    The error left is mostly mechanical (eccentricity), which no signal-only correction can see."""
    d = np.genfromtxt(path, delimiter=",", names=True)
    meas = Measurement(path, d["bsin"] * RM44_SCALE, d["bcos"] * RM44_SCALE)
    ref = 2 * np.pi * d["ref_angle_rev"]
    cal = calibrate(meas, RM44_ENCODER)
    return {"recording": os.path.join(RM44, os.path.basename(path)),
            "phase_reference": cal.fit["phase_reference"]["method"],
            "rms_ellipse_only_deg": _rms_against(ellipse_only(cal, meas), meas, ref),
            "rms_shape_corrected_deg": _rms_against(cal, meas, ref)}


def reference_free_bench(shared_data_dir: str) -> dict:
    """Every shared real recording without a reference; recordings absent from the folder are left out."""
    out = {"servo": None, "nmm": [], "not_applicable": {
        "mechaduino_as5047": "angle readings only, no sin/cos channels",
        "rm44_hall_vs_tonic": "has a reference (bench_real); here only as a check of the shape path with the "
                              "reference hidden"}, "rm44_reference_hidden": []}
    servo = os.path.join(shared_data_dir, SERVO)
    if os.path.exists(servo):
        out["servo"] = servo_figures(servo)
    nmm_dir = os.path.join(shared_data_dir, NMM)
    if os.path.isdir(nmm_dir):
        out["nmm"] = [nmm_figures(os.path.join(nmm_dir, f)) for f in sorted(os.listdir(nmm_dir))
                      if f.endswith("_sincos.csv")]
    rm44_dir = os.path.join(shared_data_dir, RM44)
    if os.path.isdir(rm44_dir):
        out["rm44_reference_hidden"] = [rm44_without_reference(os.path.join(rm44_dir, f))
                                        for f in sorted(os.listdir(rm44_dir)) if "_xs_" in f]
    return out


def reference_free_markdown(result: dict) -> str:
    """The bench's figures as markdown tables (for results/bench.md)."""
    lines = []
    sv = result.get("servo")
    if sv:
        met = "met" if sv["meets_target"] else "NOT met"
        lines += ["| servo (held-out runs) | ellipse only | corrected | improvement | target |",
                  "|---|---|---|---|---|",
                  f"| roughness about smooth motion (deg el, RMS) | {sv['roughness_ellipse_only_deg_el']:.3f} | "
                  f"{sv['roughness_corrected_deg_el']:.3f} | {sv['improvement']:.2f}x | "
                  f"{sv['target_improvement']:.0f}x {met} |", ""]
    if result.get("nmm"):
        lines += ["| NMM axis (held-out rows) | radius 4th: ellipse -> corrected (%) | 8th (%) | largest left (%) "
                  "| phase correction (nm p-p) | tables' own error (nm p-p) |", "|---|---|---|---|---|---|"]
        for f in result["nmm"]:
            b, a = f["radius_harmonics_ellipse_only_pct"], f["radius_harmonics_corrected_pct"]
            lines.append(f"| {os.path.basename(f['recording'])} | {b[4]:.3f} -> {a[4]:.3f} | "
                         f"{b[8]:.3f} -> {a[8]:.3f} | {f['largest_residual_harmonic_pct']:.3f} | "
                         f"{f['phase_correction_pp_nm']:.2f} | {f['tables_own_curve_error_pp_nm']:.3f} |")
        lines.append("")
    rm = result.get("rm44_reference_hidden")
    if rm:
        better = sum(r["rms_shape_corrected_deg"] <= r["rms_ellipse_only_deg"] for r in rm)
        shape = [r["rms_shape_corrected_deg"] for r in rm]
        ellipse = [r["rms_ellipse_only_deg"] for r in rm]
        lines += [f"RM44 with the reference hidden (shape path): better than the ellipse alone on {better} of "
                  f"{len(rm)}; RMS error {min(shape):.3f}-{max(shape):.3f} deg (ellipse alone "
                  f"{min(ellipse):.3f}-{max(ellipse):.3f})", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    import json
    import sys

    result = reference_free_bench(sys.argv[1] if len(sys.argv) > 1 else "../shared/data")
    print(json.dumps(result, indent=2))
    print(reference_free_markdown(result))
