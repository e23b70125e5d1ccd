"""A second encoder simulator, written apart from `dsp/simulate.py`, and the acceptance flow through the command line.

Acceptance runs `fringe loop CAL.csv --encoder ENC.json --out DIR --validate VAL.csv`, then `fringe correct VAL.csv
--cal DIR/cal` on the bit-exact engine, scored against `ref_deg`, on recordings made by someone else. This module
makes such recordings with its own signal model (its own trajectories, effect shapes and strengths, a coarse code
without misalignment, a reference that runs the other way) and runs exactly that flow, so that the loop is tried on
data it was not tuned to. The floor is `fringe calibrate` + `fringe correct` of the same encoder without the effect.
Vibration and reference lag are artefacts of the reference: they stay in a score against the raw `ref_deg`.

    python -m fringe.tools.crosssim FIRST N [--keep DIR]      one JSON line per recording on stdout
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile

import numpy as np

EFFECTS = ("skew", "eccentric", "drift", "interference", "vibration", "common_gain", "hysteresis", "twin_peak",
           "ref_lag", "none")
LINES = (1, 2, 3, 7, 16, 50, 64, 100, 256, 360, 1000, 2048, 4096)
SAMPLES = 16_384


def draw(seed: int) -> dict:
    """One encoder, trajectory and set of effects (one or two, or none) from wide ranges."""
    r = np.random.default_rng(seed)
    lines = int(r.choice(LINES))
    coarse = 0 if lines == 1 or r.random() < 0.3 else int(np.ceil(np.log2(max(lines, 2)))) + int(r.integers(0, 3))
    fs = float(r.choice([1e3, 5e3, 2e4, 1e5]))
    electrical = float(np.exp(r.uniform(np.log(2 * fs / SAMPLES), np.log(fs / 12))))   # Hz, below overspeed
    effects = [str(e) for e in r.choice(EFFECTS, size=int(r.integers(1, 3)), replace=False) if e != "none"]
    return dict(seed=seed, lines=lines, adc_bits=int(r.integers(10, 17)), coarse_bits=coarse, fs=fs,
                speed=electrical / lines * float(r.choice([-1, 1])),
                trajectory=str(r.choice(["steady", "sweep", "reverse"])), effects=effects,
                strength=float(np.exp(r.uniform(np.log(0.5), np.log(50)))),
                harmonics={k: float(r.normal(0, 0.01)) for k in (2, 3, 5)},
                noise=float(np.exp(r.uniform(np.log(2e-4), np.log(2e-3)))),
                offsets=[float(r.normal(0, 0.01)) for _ in range(2)], gain=float(r.uniform(0.6, 0.85)),
                phase=float(r.normal(0, 0.02)), ratio=float(r.uniform(0.97, 1.03)), tone=float(r.uniform(0.02, 0.4)))


def _trajectory(d: dict, r: np.random.Generator, t: np.ndarray) -> np.ndarray:
    v = d["speed"]
    if d["trajectory"] == "steady":
        return r.uniform() + v * t
    f = r.uniform(0.5, 3) / t[-1] if d["trajectory"] == "sweep" else r.uniform(1, 4) / t[-1]
    if d["trajectory"] == "sweep":
        return r.uniform() + v * t + 0.5 * v / (2 * np.pi * f) * np.sin(2 * np.pi * f * t)
    return r.uniform() + 1.5 * v / (2 * np.pi * f) * np.sin(2 * np.pi * f * t) + 0.3 * v * t


def record(d: dict, effects, seed: int) -> dict[str, np.ndarray]:
    """One recording's columns. Each effect's size is `strength` times the noise's effect on the angle."""
    r = np.random.default_rng(seed)
    n, fs, lines, s = SAMPLES, d["fs"], d["lines"], d["strength"]
    t = np.arange(n) / fs
    theta = _trajectory(d, r, t)                                   # rev
    floor_rev = d["noise"] / d["gain"] / (2 * np.pi * lines)      # the noise's angle error, rev
    speed = np.gradient(theta, t)
    mean_speed = float(np.mean(np.abs(speed)))

    def graduation(th):
        return 2e-6 * np.sin(2 * np.pi * th + 0.3) + 1e-6 * np.cos(4 * np.pi * th)

    ref, th_s, th_c = theta.copy(), theta.copy(), theta.copy()
    gain = np.ones(n)
    off_s, off_c = np.full(n, d["offsets"][0]), np.full(n, d["offsets"][1])
    added = np.zeros((2, n))
    h = dict(d["harmonics"])
    if "skew" in effects:            # the cos channel sampled later
        th_c = np.interp(t + s * floor_rev / mean_speed, t, theta)
    if "eccentric" in effects:       # offsets that follow the place in the revolution
        a = s * d["noise"]
        off_s, off_c = off_s + a * np.cos(2 * np.pi * theta), off_c + a * np.sin(2 * np.pi * theta + 1)
    if "drift" in effects:           # slow offsets, a new course in every recording
        k = r.normal(size=(2, 3))
        for j, off in enumerate((off_s, off_c)):
            off += s * d["noise"] / 2 * sum(k[j, m] * np.sin(np.pi * (m + 1) * t / t[-1] + k[j, m]) for m in range(3))
    if "interference" in effects:    # a fixed frequency on both channels, its phase new in every recording
        added += 0.7 * s * d["noise"] * np.sin(2 * np.pi * d["tone"] * fs * t + r.uniform(0, 2 * np.pi, (2, 1)))
    if "vibration" in effects:       # between encoder and reference
        ref = ref + s * floor_rev * np.sin(np.pi * d["tone"] * fs * t + r.uniform(0, 2 * np.pi))
    if "common_gain" in effects:     # both channels' gain over the revolution
        gain = gain * (1 + min(0.3, 0.01 * s) * np.cos(2 * np.pi * theta + 0.4))
    if "hysteresis" in effects:
        lag = 0.5 * s * floor_rev * np.sign(speed)
        th_s, th_c = th_s - lag, th_c - lag
    if "twin_peak" in effects:       # flat-topped channels
        h[3], h[5] = h[3] + 0.05, h[5] - 0.03
    if "ref_lag" in effects:
        ref = np.interp(t - s * floor_rev / mean_speed, t, ref)

    def wave(p):
        return np.sin(p) + h[2] * np.cos(2 * p) + h[3] * np.sin(3 * p) + h[5] * np.sin(5 * p)

    phase_s = 2 * np.pi * lines * (th_s + graduation(th_s))
    phase_c = 2 * np.pi * lines * (th_c + graduation(th_c)) + d["phase"]
    y_s = off_s + gain * d["gain"] * wave(phase_s) + added[0] + r.normal(0, d["noise"], n)
    y_c = off_c + gain * d["gain"] * d["ratio"] * wave(phase_c + np.pi / 2) + added[1] + r.normal(0, d["noise"], n)
    half = 2 ** (d["adc_bits"] - 1)
    cols = {"t_s": t, "sin": np.clip(np.round(y_s * half), -half, half - 1).astype(np.int64),
            "cos": np.clip(np.round(y_c * half), -half, half - 1).astype(np.int64)}
    if d["coarse_bits"]:
        codes = 2 ** d["coarse_bits"]
        cols["coarse"] = np.floor(np.mod(theta + graduation(theta), 1.0) * codes).astype(np.int64) % codes
    cols["ref_deg"] = np.round(np.mod(77.7 - 360.0 * ref, 360.0), 5)    # the reference runs the other way
    return cols


def measurements(seed: int, effects=None):
    """Draw `seed`'s encoder and its fit and validation recordings (with `effects`, else the drawn ones) as
    in-memory measurements, for tests of the calibration and the loop without the command line."""
    from ..encoder import Encoder
    from ..io.dataio import Measurement

    d = draw(seed)
    enc = Encoder(d["lines"], d["adc_bits"], d["coarse_bits"])
    out = []
    for k in (1, 2):
        c = record(d, d["effects"] if effects is None else effects, 2 * seed + k)
        out.append(Measurement(f"crosssim-{seed}-{k}", c["sin"].astype(float), c["cos"].astype(float),
                               coarse=c.get("coarse"), ref_deg=c["ref_deg"], t_s=c["t_s"]))
    return enc, *out


def write_csv(cols: dict[str, np.ndarray], path: str):
    with open(path, "w") as f:
        f.write(",".join(cols) + "\n")
        for row in zip(*cols.values(), strict=True):
            f.write(",".join(f"{v:.9g}" if isinstance(v, float) else str(v) for v in row) + "\n")


def _column(path: str, name: str) -> np.ndarray:
    lines = [s for s in open(path) if not s.startswith("#")]
    return np.loadtxt(lines[1:], delimiter=",", ndmin=2)[:, lines[0].strip().split(",").index(name)]


def rms_arcsec(corrected_csv: str, recording_csv: str) -> float:
    """RMS of angle_deg against ref_deg, the constant zero offset removed."""
    e = np.deg2rad(_column(corrected_csv, "angle_deg") - _column(recording_csv, "ref_deg"))
    e = np.angle(np.exp(1j * (e - np.angle(np.mean(np.exp(1j * e))))))
    e = np.rad2deg(e - e.mean()) * 3600.0
    return float(np.sqrt(np.mean(e * e)))


def _fringe(*args) -> str:
    """Run the command line; '' on success, else its last line of stderr."""
    p = subprocess.run([sys.executable, "-m", "fringe", *map(str, args)], capture_output=True, text=True)
    return "" if p.returncode == 0 else (p.stderr.strip().splitlines() or [f"exit {p.returncode}"])[-1]


def case(seed: int, keep: str | None = None) -> dict:
    """One recording pair through the acceptance flow; a failure of a command is a result."""
    d = draw(seed)
    out = {k: d[k] for k in ("seed", "effects", "lines", "adc_bits", "coarse_bits", "trajectory", "fs")}
    out["strength"] = round(d["strength"], 2)
    work = tempfile.mkdtemp(prefix=f"crosssim-{seed}-", dir=keep)
    with open(os.path.join(work, "enc.json"), "w") as f:
        json.dump({k: d[k] for k in ("adc_bits", "coarse_bits")} | {"lines_per_rev": d["lines"]}, f)
    p = {name: os.path.join(work, name) for name in ("enc.json", "clean_cal.csv", "clean_val.csv", "cal.csv",
                                                      "val.csv", "floorcal", "floor.csv", "loop", "after.csv")}
    try:
        for tag, effects in (("clean_", []), ("", d["effects"])):
            write_csv(record(d, effects, 2 * seed + 1), p[tag + "cal.csv"])
            write_csv(record(d, effects, 2 * seed + 2), p[tag + "val.csv"])
        steps = [("floor", ("calibrate", p["clean_cal.csv"], "--encoder", p["enc.json"], "--out", p["floorcal"])),
                 ("floor", ("correct", p["clean_val.csv"], "--cal", p["floorcal"], "--out", p["floor.csv"])),
                 ("loop", ("loop", p["cal.csv"], "--encoder", p["enc.json"], "--out", p["loop"], "--validate",
                           p["val.csv"])),
                 ("correct", ("correct", p["val.csv"], "--cal", os.path.join(p["loop"], "cal"), "--out",
                              p["after.csv"]))]
        for what, args in steps:
            err = _fringe(*args)
            if err:
                out[f"{what}_error"] = err
                break
        else:
            floor, after = rms_arcsec(p["floor.csv"], p["clean_val.csv"]), rms_arcsec(p["after.csv"], p["val.csv"])
            with open(os.path.join(p["loop"], "report.json")) as f:
                report = json.load(f)
            out.update(floor_arcsec=round(floor, 3), after_arcsec=round(after, 3), ratio=round(after / floor, 3),
                       names=[e["name"] for e in report["effects_added"]])
    finally:     # its own temporary folder, also when interrupted
        if keep is None:
            subprocess.run(["rm", "-rf", work], check=False)
    return out


def main(argv=None):
    a = argparse.ArgumentParser(prog="fringe.tools.crosssim", description=__doc__.splitlines()[0])
    a.add_argument("first", type=int)
    a.add_argument("n", type=int)
    a.add_argument("--keep", help="keep each recording's folder under this folder")
    args = a.parse_args(argv)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(128 + signal.SIGTERM))   # a kill still removes the folder
    for seed in range(args.first, args.first + args.n):
        print(json.dumps(case(seed, args.keep)), flush=True)


if __name__ == "__main__":
    main()
