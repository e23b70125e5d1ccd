"""A randomised population of simulated recordings for the closed loop (issue 9, section 6).

Every recording is drawn from a fixed seed: an encoder (1 to 4096 lines, ADC 10 to 16 bits, with or
without a coarse code), a waveform, a trajectory (steady, sweeps, reversals, slow, fast near the
overspeed limit), and zero to three effect classes, each with a strength drawn log-uniform from 0.5x
to 50x the noise floor's RMS on the angle. The loop is fitted on one recording and validated on another
(new noise, new trajectory of the same kind, a new drift), the way acceptance runs it.

`population_bench` reports naming precision and recall, the validation RMS over the floor for the
float and the bit-exact engine, the targets of the issue and the worst cases with their seeds
(`population_case(seed)` replays one).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..dsp.simulate import ChannelConfig, SimulationConfig, trajectory
from ..encoder import ARCSEC_PER_REV
from ..loop.significance import REVOLUTION_MIN_LINES

SAMPLES = 16_384
STRENGTH_RANGE = (0.5, 50.0)      # effect RMS on the angle, in units of the floor's
TARGET_RATIO = 1.25               # issue 9's target: validation RMS at most this over the floor
START_ROWS = 1024                 # rows after reset left out of the settled ratio (a diagnostic, not the target)
CLASSES = ("rev_offset_gain", "sampling_skew", "hysteresis", "ref_lag", "drift", "amplitude", "tone",
           "interference", "common_gain")
TRAJECTORIES = ("steady", "sweeps", "reversals", "slow", "fast")
#: effects whose correction the bit-exact core does not carry (the float engine does): none since fringe_canceller
FLOAT_ONLY: set[str] = set()


def _log_uniform(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def fit_seed(seed: int) -> int:
    """The simulation seed of a case's fit recording (its validation recording: fit_seed + 1)."""
    return 2 * seed + 1


def draw_case(seed: int) -> dict:
    """The recording's configuration, the effect classes and strengths, and the names the loop should give."""
    rng = np.random.default_rng(seed)
    lines = int(round(_log_uniform(rng, 1, 4096)))
    adc = int(rng.integers(10, 17))
    # a coarse code resolves the period: one code a period when the lines are a power of two (its edges follow
    # the periods), at least two otherwise (edges that drift against the periods must stay within half of one)
    least_bits = int(np.ceil(np.log2(lines))) + (1 if lines & (lines - 1) else 0)
    coarse = 0 if lines == 1 or rng.uniform() < 0.5 else min(24, least_bits + int(rng.integers(0, 3)))
    fs = float(max(10_000.0, 5.0 * lines))
    limit = 0.25 * fs / lines                            # the core's overspeed limit, rev/s
    vmax = min(0.8 * limit, 5.0)
    samples = max(SAMPLES, 16 * lines)                  # 1.5 revolutions fit below the speed limit
    duration = samples / fs
    trajectory_kind = TRAJECTORIES[int(rng.integers(len(TRAJECTORIES)))]
    least = 1.5 / duration                               # at least 1.5 revolutions (the long-period fit)
    mean, swing = {
        "steady": (rng.uniform(0.3, 1.0) * vmax, 0.0),
        "sweeps": (0.5 * vmax, 0.4 * vmax),
        "reversals": (max(0.15 * vmax, least), 0.8 * vmax),
        "slow": (max(0.05 * vmax, least), 0.03 * vmax),
        "fast": (0.7 * limit, 0.15 * limit),
    }[trajectory_kind]
    if trajectory_kind != "reversals":
        mean = min(max(mean, least + swing), 0.95 * limit - swing)
    else:
        swing = min(swing, 0.95 * limit - mean)
    gain = rng.uniform(0.5, 0.9)
    h = {n: rng.normal(0, 0.01) for n in (2, 3, 5)}
    sin_ch = ChannelConfig(offset=rng.normal(0, 0.01), gain=gain, phase_rad=rng.normal(0, 0.01),
                           sin_h={1: 1.0, 3: h[3], 5: h[5]}, cos_h={2: h[2]})
    cos_ch = ChannelConfig(offset=rng.normal(0, 0.01), gain=gain * rng.uniform(0.97, 1.03),
                           cos_h={1: 1.0, 3: rng.normal(0, 0.01)}, sin_h={2: rng.normal(0, 0.01)})
    lsb = 2.0 ** (1 - adc)
    noise = max(_log_uniform(rng, 2e-4, 3e-3), 0.5 * lsb)
    period = ARCSEC_PER_REV / lines
    grad = {m: (rng.normal(0, 1e-3 * period), rng.normal(0, 1e-3 * period)) for m in range(1, 5)}
    if coarse == 0 and lines > 1:
        # an incremental encoder does not know its place in the revolution: the declared model does not correct
        # a graduation error there (calibrate says so), so none is simulated and the floor stays the noise
        grad = {}
    cfg = SimulationConfig(lines_per_rev=lines, adc_bits=adc, coarse_bits=coarse, sample_rate_hz=fs, samples=samples,
                           graduation_error=grad, sin_channel=sin_ch, cos_channel=cos_ch, noise_rms=noise,
                           ref_error_arcsec={}, speed_mean_rev_s=mean, speed_swing_rev_s=swing)
    # the floor's RMS on the angle: channel noise (and ADC rounding) over the amplitude
    floor_rad = np.hypot(noise, lsb / np.sqrt(12)) / gain
    k = int(rng.choice([0, 1, 1, 1, 2, 2, 3]))
    classes = sorted(set(rng.choice(CLASSES, size=k, replace=False).tolist())) if k else []
    if coarse == 0 and lines > 1:
        # nor do offsets and gains tied to the place in the revolution repeat between its recordings
        classes = [c for c in classes if c != "rev_offset_gain"]
    fields, expected, strengths = {}, set(), {}
    # a speed effect shows only through the speed's changes (at a constant speed a lag is an offset and a skew a
    # quadrature phase error, both owned by the declared model): its strength is set on the fit recording's
    # speed spread
    _, theta = trajectory(cfg, np.random.default_rng(fit_seed(seed)))
    # (at least a twentieth of the mean speed: a steady trajectory shows none of it, and its lag stays a lag)
    v_std = max(float(np.std(np.diff(theta) * fs)), 0.05 * abs(mean))
    speed_varies = trajectory_kind != "steady"
    for name in classes:
        s_rel = _log_uniform(rng, *STRENGTH_RANGE)
        strengths[name] = round(s_rel, 3)
        s_rad = s_rel * floor_rad                       # effect RMS, rad of fine phase
        s_arcsec = s_rad * period / (2 * np.pi)
        if name == "rev_offset_gain":
            m = int(rng.integers(1, 4))
            o = rng.normal(0, 1, 4)
            o *= s_rad * gain * np.sqrt(2) / np.sqrt(np.sum(o ** 2) / 2)
            fields.update(rev_offset_mod_sin={m: (o[0], o[1])}, rev_offset_mod_cos={m: (o[2], o[3])})
            if lines >= REVOLUTION_MIN_LINES:
                expected.add(name)
        elif name == "sampling_skew":
            # delta = 2 pi lines v tau; the error (delta / 2)(1 - cos 2 phi) has RMS delta / 2 sqrt(3 / 2)
            # (at most half a radian of phase between the channels at the top speed: no constant speed hides more)
            tau = s_rad / (np.pi * lines * max(v_std, 1e-9) * np.sqrt(1.5))
            fields["sampling_skew_s"] = float(min(tau, 0.5 / (2 * np.pi * lines * (abs(mean) + swing))))
            if speed_varies:
                expected.add(name)
        elif name == "hysteresis":
            fields["hysteresis_arcsec"] = 2 * s_arcsec
            if trajectory_kind == "reversals":
                expected.add(name)
        elif name == "ref_lag":
            fields["ref_lag_s"] = float(min(s_arcsec / (max(v_std, 1e-9) * ARCSEC_PER_REV), duration / 20))
            if speed_varies:
                expected.add(name)
        elif name == "drift":
            x = s_rad / 1.35 * gain / 0.8
            fields.update(drift_offset_rms=x, drift_gain_rms=x, drift_timescale_s=duration * rng.uniform(1, 3))
            expected.add(name)
        elif name == "amplitude":
            gm = rng.uniform(0.03, 0.1)
            fields.setdefault("rev_gain_mod", {})[1] = (gm, 0.0)
            fields["harmonic2_per_gain"] = float(2 * s_rad / gm)
            if lines >= REVOLUTION_MIN_LINES:
                expected.add(name)
        elif name == "tone":
            fields.update(vibration_arcsec=np.sqrt(2) * s_arcsec,
                          vibration_hz=_log_uniform(rng, 20 / duration, 0.45 * fs))
            expected.add(name)
        elif name == "interference":
            fields.update(interference_fs=float(min(0.05, np.sqrt(2) * s_rad * gain)),
                          interference_hz=_log_uniform(rng, 20 / duration, 0.45 * fs))
            expected.add(name)
        elif name == "common_gain":     # no angle through atan2; through the tables, see common_gain_shows
            fields.setdefault("rev_gain_mod", {})[2] = (rng.uniform(0.02, 0.1), 0.0)
    plain = cfg
    cfg = dataclasses.replace(cfg, **fields)
    return {"seed": seed, "config": cfg, "plain_config": plain, "classes": classes, "strengths": strengths,
            "expected": expected,
            "floor_arcsec": float(floor_rad * period / (2 * np.pi)),
            "trajectory": trajectory_kind, "lines": lines, "adc_bits": adc, "coarse_bits": coarse}


def population_case(seed: int) -> dict:
    """Fit on one recording, validate on another; the names, and the validation RMS over the floor
    (the same validation recording without its additive noise, through the same correction) for the
    float and the bit-exact engine. Never raises: an abort is a result."""
    from ..calib.calibrate import calibrate
    from ..calib.evaluate import floor_rms, measurement_of, noise_floor_arcsec, noise_floor_rows
    from ..cli.engines import run_engine
    from ..dsp.simulate import simulate
    from ..hardware.closed_loop import float_only
    from ..loop.evaluation import LoopState, evaluate
    from ..loop.run import run_loop

    case = draw_case(seed)
    cfg = case["config"]
    out = {k: case[k] for k in ("seed", "classes", "strengths", "trajectory", "lines", "adc_bits", "coarse_bits")}
    out["expected"] = sorted(case["expected"])
    t0 = time.perf_counter()
    try:
        fit, val = measurement_of(simulate(cfg, fit_seed(seed))), measurement_of(simulate(cfg, fit_seed(seed) + 1))
        base, state, rep = run_loop(fit, cfg.encoder(), val)
        floor = noise_floor_arcsec(state.cal, cfg, fit_seed(seed) + 1)
        if "common_gain" in case["classes"]:
            # named where it moves the angle through the declared tables and the declared model leaves more than
            # the target over the floor: a change the declared model already meets leaves no residual to name
            # (development 9110, 9135, 9147: declared model at 0.90x the floor); on an encoder of fewer than
            # REVOLUTION_MIN_LINES periods, as for the amplitude class, an amplitude change over the revolution is a
            # waveform that differs from period to period, and its correction is a generic term (9040: 3 lines)
            shows = case["lines"] >= REVOLUTION_MIN_LINES and \
                common_gain_shows(cfg, base.cal, seed, case["floor_arcsec"]) and \
                rep["before"]["rms_arcsec"] > TARGET_RATIO * floor
            expected = set(case["expected"]) | ({"amplitude"} if shows else set())
            out["expected"] = sorted(expected)
        # names only: terms of the general dictionary are corrections without a name, counted apart
        found = {e["name"] for e in rep["effects_added"] if not e["name"].startswith("generic:")}
        out["generic_terms"] = [e["name"] for e in rep["effects_added"] if e["name"].startswith("generic:")]
        model = run_engine("model", state.cal, val, None)
        d, ref_q = noise_floor_rows(state.cal, cfg, fit_seed(seed) + 1,
                                    lambda cal, meas: run_engine("model", cal, meas, None))
        floor_model, floor_settled = floor_rms(d, ref_q), floor_rms(d[START_ROWS:], ref_q)
        r = evaluate(state, val, model).r
        rms_model = float(np.sqrt(np.mean(r ** 2)))
        settled = r[START_ROWS:] - r[START_ROWS:].mean()
        # diagnostic: the same ratio without the rows the online blocks spend settling after reset (the first
        # sample's speed, the drift tracker's and the canceller's first blocks)
        out["model_ratio_settled"] = float(np.sqrt(np.mean(settled ** 2))) / floor_settled
        # the acceptance's floor: the declared model's plain calibration of the same encoder without the drawn
        # effects (fitted on its fit recording, scored on its validation recording, float engine). It does not
        # depend on the loop's correction, as the noise floor above does (the noise through the same correction,
        # which an adaptive block's noise raises or lowers with its constants)
        plain = case["plain_config"]
        plain_fit, plain_val = (measurement_of(simulate(plain, fit_seed(seed) + k)) for k in (0, 1))
        plain_floor = evaluate(LoopState(calibrate(plain_fit, plain.encoder())), plain_val).rms
        out.update(plain_floor_arcsec=plain_floor, before_arcsec=rep["before"]["rms_arcsec"],
                   float_over_plain=rep["after"]["rms_arcsec"] / plain_floor, model_over_plain=rms_model / plain_floor)
        out.update(found=sorted(found), named_right=found == set(out["expected"]),
                   float_ratio=rep["after"]["rms_arcsec"] / floor, model_ratio=rms_model / floor_model,
                   before_ratio=rep["before"]["rms_arcsec"] / floor,
                   rise=rep["after"]["rms_arcsec"] / rep["before"]["rms_arcsec"] - 1.0,
                   floor_arcsec=floor, float_only=float_only(state.cal), abort=None)
    except Exception as e:      # noqa: BLE001 - the population counts aborts instead of stopping
        out.update(found=[], named_right=False, abort=f"{type(e).__name__}: {e}")
    out["seconds"] = round(time.perf_counter() - t0, 2)
    return out


def common_gain_shows(cfg: SimulationConfig, cal, seed: int, floor_arcsec: float) -> bool:
    """Whether a common gain change moves the angle through the calibrated tables by at least half the noise
    floor (noise-free fit recording with and without it). atan2 alone would not see it, but the per-channel
    waveform inverse assumes the amplitude it was calibrated at: then it is an amplitude-dependent error."""
    from ..calib.evaluate import measurement_of
    from ..dsp.position import wrap
    from ..dsp.simulate import simulate
    from ..engine.pipeline import run_float

    gain_mod = {k: v for k, v in cfg.rev_gain_mod.items() if k != 2}
    angles = []
    for c in (cfg, dataclasses.replace(cfg, rev_gain_mod=gain_mod)):
        m = measurement_of(simulate(dataclasses.replace(c, noise_rms=0.0), fit_seed(seed)))
        angles.append(run_float(cal, m.sin, m.cos, m.coarse, m.t_s).angle_deg)
    d = wrap((angles[0] - angles[1]) / 360.0) * ARCSEC_PER_REV
    return bool(np.std(d) >= 0.5 * floor_arcsec)


def _share(flags) -> float | None:
    flags = list(flags)
    return round(float(np.mean(flags)), 4) if flags else None


def summarise(cases: list[dict]) -> dict:
    ok = [c for c in cases if not c["abort"]]
    tp = sum(len(set(c["found"]) & set(c["expected"])) for c in ok)
    fp = sum(len(set(c["found"]) - set(c["expected"])) for c in ok)
    fn = sum(len(set(c["expected"]) - set(c["found"])) for c in ok)
    correctable = [c for c in ok if not set(c["classes"]) & FLOAT_ONLY]
    clean = [c for c in ok if not c["expected"] and set(c["classes"]) <= {"common_gain"}]

    def dist(key, rows):
        x = np.array([c[key] for c in rows])
        return {q: round(float(np.quantile(x, p)), 3) for q, p in (("median", 0.5), ("p90", 0.9), ("p95", 0.95),
                                                                   ("max", 1.0))} if len(x) else {}

    per_class = {}
    for name in CLASSES:
        rows = [c for c in ok if name in c["classes"]]
        per_class[name] = {"recordings": len(rows), "named_right": _share(c["named_right"] for c in rows),
                           "model_within_1.25": _share(c["model_ratio"] <= TARGET_RATIO for c in rows)}
    worst = sorted(ok, key=lambda c: -c["model_ratio"])[:8]
    return {
        "recordings": len(cases), "aborts": [{"seed": c["seed"], "abort": c["abort"]} for c in cases if c["abort"]],
        "naming": {"precision": round(tp / max(tp + fp, 1), 4), "recall": round(tp / max(tp + fn, 1), 4),
                   "right_names_share": _share(c["named_right"] for c in ok), "target_share": 0.95},
        "float_over_floor": dist("float_ratio", ok), "model_over_floor": dist("model_ratio", ok),
        # the same without the first START_ROWS rows after reset: how much of the shortfall is start-up
        "model_over_floor_settled": dist("model_ratio_settled", [c for c in ok if "model_ratio_settled" in c]),
        "start_rows": START_ROWS,
        # against the plain calibration of the same encoder without the effects (as acceptance scores it)
        "model_over_plain_floor": dist("model_over_plain", [c for c in ok if "model_over_plain" in c]),
        "model_within_1.25_of_plain_floor": _share(c["model_over_plain"] <= TARGET_RATIO for c in ok
                                                   if "model_over_plain" in c),
        "correctable_model_within_1.25": _share(c["model_ratio"] <= TARGET_RATIO for c in correctable),
        "correctable_target": 0.95,
        "clean_rise_within_2pct": _share(c["rise"] <= 0.02 for c in clean), "clean_target": 0.98,
        "clean_recordings": len(clean), "per_class": per_class,
        "worst": [{k: c[k] for k in ("seed", "classes", "strengths", "trajectory", "lines", "adc_bits", "expected",
                                     "found", "float_ratio", "model_ratio")} for c in worst],
        "wrong_names": [{k: c[k] for k in ("seed", "classes", "strengths", "trajectory", "lines", "expected", "found")}
                        for c in ok if not c["named_right"]][:20],
        "with_generic_terms": _share(bool(c.get("generic_terms")) for c in ok),
        "seconds_per_recording": round(float(np.mean([c["seconds"] for c in cases])), 2) if cases else None,
    }


def population_bench(n: int = 200, seed: int = 9000, workers: int = 1) -> dict:
    """n recordings from seeds seed .. seed + n - 1 (printed in the report: population_case(seed) replays one)."""
    seeds = list(range(seed, seed + n))
    t0 = time.perf_counter()
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(workers) as pool:
            cases = list(pool.map(population_case, seeds))
    else:
        cases = [population_case(s) for s in seeds]
    out = summarise(cases)
    out.update(first_seed=seed, samples_per_recording=SAMPLES, workers=workers,
               wall_seconds=round(time.perf_counter() - t0, 1))
    return out


def _run_loop_child(csv: str, enc: str, out: str) -> tuple[float, float]:
    """Wall seconds and peak RSS (bytes) of `fringe loop` in a fresh process (its own rusage: os.wait4)."""
    import os
    import subprocess
    import sys

    t0 = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-m", "fringe", "loop", csv, "--encoder", enc, "--out", out],
                             stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = status
    seconds = time.perf_counter() - t0
    if status:
        raise RuntimeError(f"fringe loop failed on {csv} (status {status})")
    return seconds, usage.ru_maxrss * 1024.0


def loop_speed(samples: int = 1_000_000, small: int = 20_000) -> dict:
    """`fringe loop` on a simulated recording of `samples` rows (the seed encoder): wall time, peak RSS, and the
    RSS per input row both in all and above a `small`-row run (the interpreter and libraries are fixed costs).
    Target of issue 8/9: at most 200 bytes per input row, 1 M rows within 60 s."""
    import os
    import tempfile

    from ..cli.cli import main

    with tempfile.TemporaryDirectory(prefix="fringe-loop-speed-") as tmp:
        runs = {}
        for rows in (small, samples):
            csv, enc = os.path.join(tmp, f"a{rows}.csv"), os.path.join(tmp, "e.json")
            if main(["simulate", "--preset", "seed-encoder", "--samples", str(rows), "--out", csv, "--encoder-out", enc,
                     "--seed", "3"]) != 0:
                raise RuntimeError("simulate failed")
            runs[rows] = _run_loop_child(csv, enc, os.path.join(tmp, f"loop{rows}"))
    (_, rss_small), (t_big, rss_big) = runs[small], runs[samples]
    return {"rows": samples, "seconds": round(t_big, 1), "peak_rss_mb": round(rss_big / 2 ** 20, 1),
            "bytes_per_row": round(rss_big / samples, 1),
            "bytes_per_row_above_small_run": round((rss_big - rss_small) / (samples - small), 1),
            "targets": {"seconds": 60, "bytes_per_row": 200}}
