"""A reference from the motion itself: the true phase moves smoothly in time.

The seed fits its waveforms to samples taken at equal phase steps, which a constant-speed
rotation gives for free. This is the same idea for any smooth trajectory: the measured,
unwrapped phase is a smooth function of time (a cubic spline with knots a couple of signal
periods apart) plus a periodic error of the phase (the interpolation error, a Fourier series
in the phase). The spline is too stiff to follow an error that repeats every period, so
alternating the two fits separates them. Samples too slow for that separation (near
reversals and stops) are left out of the periodic fit.

Real loggers pause, sample unevenly and restart. The recording is cut into gap-free runs
(`motion_segments`): a new run starts where the time step is much longer than usual, where time
does not advance, or where the phase jumps too far between two samples to be unwrapped. Each run
gets its own spline; its phase offset is free, because the waveform fit only needs the phase
within a period. The periodic error is one function of the phase for all runs.
"""

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import LSQUnivariateSpline

from .fourierfit import fit_select

KNOT_PERIODS = 2.0        # knot spacing, in signal periods passed at the run's typical speed
GAP_FACTOR = 4.0          # a time step this many times the median one is a pause: a new run starts
MAX_STEP_PERIODS = 0.25   # a larger phase step between two samples cannot be unwrapped safely
MIN_RUN_PERIODS = 8 * KNOT_PERIODS   # a run must pass this many periods to separate motion from error
MIN_RUN_SAMPLES = 32
TYPICAL_SPEED_PERCENTILE = 90   # the run's speed that sets the knots (a run may start or end slowly)
SLOW_FRACTION = 0.5       # samples slower than this fraction of the run's speed stay out of the periodic fit
MAX_ROUGHNESS_PERIODS = 0.02   # a reference scattering more blurs the 3rd harmonic by > 7 %
NOT_SMOOTH = "the motion strays"
MIN_KNOT_SAMPLES = 6      # samples between two knots (a cubic spline needs more than 4)


class MotionTooSlow(ValueError):
    """The motion gives no phase reference (too slow, too short, too irregular); the message says why."""


@dataclass
class Run:
    start: int      # first sample
    stop: int       # one past the last sample
    periods: float  # signal periods travelled (forward and back)
    reason: str = ""    # why it is not used ("" = used)


def motion_segments(total: np.ndarray, t: np.ndarray) -> tuple[list[Run], dict]:
    """Cut the recording into gap-free runs; `total` is the measured phase in periods (wrapped or not)."""
    dt = np.diff(t)
    step = np.diff(total)
    step = step - np.round(step)                      # the shortest way round, in periods
    positive = dt[dt > 0]
    dt_med = float(np.median(positive)) if len(positive) else 0.0
    pause = dt > GAP_FACTOR * dt_med
    backwards = dt <= 0
    jump = np.abs(step) > MAX_STEP_PERIODS
    cut = np.flatnonzero(pause | backwards | jump) + 1
    edges = np.r_[0, cut, len(t)]
    runs = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        travelled = float(np.abs(step[a:b - 1]).sum()) if b - a > 1 else 0.0
        run = Run(int(a), int(b), travelled)
        if b - a < MIN_RUN_SAMPLES:
            run.reason = f"only {b - a} samples"
        elif travelled < MIN_RUN_PERIODS:
            run.reason = f"passes only {travelled:.1f} signal periods"
        runs.append(run)
    counts = {"pauses": int(pause.sum()), "time_not_advancing": int(backwards.sum()),
              "phase_jumps": int((jump & ~pause & ~backwards).sum()), "median_step_s": dt_med}
    return runs, counts


def _knots(t: np.ndarray, h: float) -> np.ndarray:
    """Interior knots about h apart, thinned so that every interval holds enough samples."""
    candidates = np.arange(t[0] + h, t[-1] - h / 2, h)
    knots, last = [], 0
    for k in candidates:
        i = int(np.searchsorted(t, k))
        if i - last >= MIN_KNOT_SAMPLES and len(t) - i >= MIN_KNOT_SAMPLES:
            knots.append(k)
            last = i
    return np.asarray(knots)


def times(n: int) -> str:
    return {1: "once", 2: "twice"}.get(n, f"{n} times")


def interruptions(counts: dict) -> list[str]:
    """Where the recording breaks into gap-free runs, one phrase a kind (calibrate's report says them too)."""
    parts = []
    if counts["pauses"]:
        parts.append(f"the recording pauses {times(counts['pauses'])}")
    if counts["time_not_advancing"]:
        parts.append(f"its time stamps stand still or go back {times(counts['time_not_advancing'])}")
    if counts["phase_jumps"]:
        parts.append(f"the phase jumps by more than {MAX_STEP_PERIODS} of a period between two samples "
                     f"{times(counts['phase_jumps'])} (too fast for the sample rate)")
    return parts


def _interruptions(counts: dict) -> str:
    parts = interruptions(counts)
    return "; ".join(parts) + "; " if parts else ""


def _too_short(runs: list[Run], counts: dict) -> str:
    best = max(runs, key=lambda r: r.periods)
    return (f"{_interruptions(counts)}each of its {len(runs)} gap-free run(s) passes too few signal periods to "
            f"separate the motion from the interpolation error (at least {MIN_RUN_PERIODS:.0f} are needed; the "
            f"longest passes {best.periods:.1f} in {best.stop - best.start} samples)")


def smooth_motion_phase(theta_rad: np.ndarray, t: np.ndarray, harmonics: int = 31,
                        iterations: int = 3) -> tuple[np.ndarray, np.ndarray, dict]:
    """Estimate the true phase from a measured one with a periodic error, run by run.

    Returns the phase (rad; NaN outside the runs used), the mask of samples it is valid for,
    and a summary (runs, pauses, how much of the recording was used).
    """
    theta = np.asarray(theta_rad, float)
    t = np.asarray(t, float)
    runs, counts = motion_segments(theta / (2 * np.pi), t)
    used = [r for r in runs if not r.reason]
    if not used:
        raise MotionTooSlow(_too_short(runs, counts))
    # per run: unwrapped phase (periods), time, speed, knots
    parts = []
    for r in used:
        sl = slice(r.start, r.stop)
        total = np.unwrap(theta[sl]) / (2 * np.pi)
        tr = t[sl]
        speed = np.abs(np.gradient(total, tr))
        v_typ = float(np.percentile(speed, TYPICAL_SPEED_PERCENTILE))
        parts.append({"run": r, "total": total, "t": tr, "fast": speed >= SLOW_FRACTION * v_typ,
                      "knots": _knots(tr, KNOT_PERIODS / v_typ), "v": v_typ})
    while True:           # drop the runs that do not move smoothly, and fit again without them
        warps, resid, info = _separate(parts, harmonics, iterations)
        rough = [float(np.sqrt(np.mean((e - w)[p["fast"]] ** 2))) for p, w, e in zip(parts, warps, resid, strict=True)]
        for p, r in zip(parts, rough, strict=True):
            if r > MAX_ROUGHNESS_PERIODS:
                p["run"].reason = f"{NOT_SMOOTH} {r:.2f} signal periods RMS from a smooth curve"
        if all(r <= MAX_ROUGHNESS_PERIODS for r in rough):
            break
        parts = [p for p in parts if not p["run"].reason]
        if not parts:
            raise MotionTooSlow(f"{_interruptions(counts)}the motion is too irregular: no gap-free run follows a "
                                f"smooth curve in time to within {MAX_ROUGHNESS_PERIODS} of a signal period")
    used = [p["run"] for p in parts]
    phi = np.full(len(t), np.nan)
    valid = np.zeros(len(t), bool)
    for p, w in zip(parts, warps, strict=True):
        r = p["run"]
        phi[r.start:r.stop] = 2 * np.pi * (p["total"] - w)
        valid[r.start:r.stop] = p["fast"]
    skipped_runs = [{"first_row": r.start + 1, "samples": r.stop - r.start, "why": r.reason}
                    for r in runs if r.reason]
    info.update(runs=len(runs), runs_used=len(used), runs_not_smooth=sum(r.reason.startswith(NOT_SMOOTH) for r in runs),
                samples_used=int(valid.sum()),
                fraction_used=float(valid.mean()), periods_used=float(sum(r.periods for r in used)),
                pauses=counts["pauses"], time_not_advancing=counts["time_not_advancing"],
                phase_jumps=counts["phase_jumps"], median_step_s=counts["median_step_s"],
                knot_spacing_periods=KNOT_PERIODS, typical_speed_periods_s=float(np.median([p["v"] for p in parts])),
                runs_skipped=skipped_runs[:20])
    return phi, valid, info


def _separate(parts: list[dict], harmonics: int, iterations: int):
    """Alternate the splines of the runs and the one periodic error they share."""
    warps = [np.zeros_like(p["total"]) for p in parts]
    info = {}
    for _ in range(iterations):
        resid = []
        for p, w in zip(parts, warps, strict=True):
            try:
                spline = LSQUnivariateSpline(p["t"], p["total"] - w, p["knots"], k=3)
            except ValueError:      # scipy's own words would mean nothing to the user
                r = p["run"]
                raise MotionTooSlow(f"the run of rows {r.start + 1}-{r.stop} cannot be fitted by a smooth "
                                    "motion (time stamps too uneven)") from None
            resid.append(p["total"] - spline(p["t"]))
        x = np.concatenate([2 * np.pi * p["total"][p["fast"]] for p in parts])
        y = np.concatenate([r[p["fast"]] for p, r in zip(parts, resid, strict=True)])
        series, n, rms = fit_select(x, y, harmonics)
        series.weights[0] = 0.0          # a constant belongs to the motion, not to the phase error
        warps = [series(2 * np.pi * p["total"]) for p in parts]
        info.update(harmonics=n, residual_rms_periods=rms)
    return warps, resid, info


def motion_roughness(theta_rad: np.ndarray, t: np.ndarray) -> dict:
    """How far a corrected phase strays from smooth motion: per gap-free run, the RMS of the
    unwrapped phase about the same cubic spline as the reference uses (no periodic term), over the
    samples fast enough for the spline not to follow a periodic error. Periods."""
    theta = np.asarray(theta_rad, float)
    runs, _ = motion_segments(theta / (2 * np.pi), np.asarray(t, float))
    sq, n = 0.0, 0
    for r in (r for r in runs if not r.reason):
        total = np.unwrap(theta[r.start:r.stop]) / (2 * np.pi)
        tr = np.asarray(t[r.start:r.stop], float)
        speed = np.abs(np.gradient(total, tr))
        v = float(np.percentile(speed, TYPICAL_SPEED_PERCENTILE))
        spline = LSQUnivariateSpline(tr, total, _knots(tr, KNOT_PERIODS / v), k=3)
        fast = speed >= SLOW_FRACTION * v
        resid = (total - spline(tr))[fast]
        sq, n = sq + float(resid @ resid), n + len(resid)
    return {"rms_periods": float(np.sqrt(sq / n)) if n else float("nan"), "samples": n}
