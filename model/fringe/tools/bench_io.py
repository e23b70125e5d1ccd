"""`make bench`: reading and writing speed, and the memory the commands hold per input row.

Peak resident memory is measured on the real command line (`fringe calibrate`, `correct`, `loop`)
in a fresh process each, at two recording lengths; the per-row figure is the growth between them,
so the interpreter and its libraries (about 160 MB) do not count as rows.
"""

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from ..dsp import simulate
from ..encoder import Encoder
from ..io.dataio import read_measurement, write_csv

TARGET_BYTES_PER_ROW = 200     # issue 8: calibrate and loop
TARGET_IO_SPEEDUP = 5          # issue 8: against numpy's savetxt/loadtxt row loops of the earlier reader


def _recording(path: str, samples: int, seed: int) -> Encoder:
    cfg = simulate.preset("seed-encoder")
    cfg.samples = samples
    rec = simulate.simulate(cfg, seed=seed)
    cols = {k: rec.columns[k] for k in ("t_s", "sin", "cos", "coarse", "ref_deg")}
    write_csv(path, cols, simulate.describe(cfg, seed), simulate.csv_formats())
    return rec.encoder


def _peak_rss_mb(argv: list[str]) -> tuple[float, float, int]:
    """(peak RSS in MB, seconds, exit status) of one fringe command in a fresh process."""
    probe = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
             "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL); "
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, time.perf_counter() - t, r.returncode)")
    out = subprocess.run([sys.executable, "-c", probe, sys.executable, "-m", "fringe"] + argv,
                         capture_output=True, text=True, check=True).stdout.split()
    return int(out[0]) / 1024, float(out[1]), int(out[2])


def io_speed(folder: str, samples: int) -> dict:
    path = os.path.join(folder, "io.csv")
    enc = _recording(path, samples, 1)
    t0 = time.perf_counter()
    m = read_measurement(path, enc)
    t_read = time.perf_counter() - t0
    ang, status = np.random.default_rng(0).uniform(0, 360, len(m)), np.zeros(len(m), np.int64)
    t0 = time.perf_counter()
    write_csv(os.path.join(folder, "o.csv"), {"angle_deg": ang, "status": status}, ("fringe correct bench",),
              {"angle_deg": "%.9f", "status": "%d"})
    t_write = time.perf_counter() - t0
    t_before = _earlier_read_write(path, os.path.join(folder, "o2.csv"), ang, status)
    return {"rows": len(m), "read_s": round(t_read, 3), "write_s": round(t_write, 3),
            "earlier_read_write_s": round(t_before, 3), "speedup": round(t_before / (t_read + t_write), 1),
            "target_speedup": TARGET_IO_SPEEDUP}


def _earlier_read_write(path, out, ang, status) -> float:
    """The steps of the reader and writer fringe had before (Python loops over the rows, then numpy's
    text parser and savetxt), timed as the baseline of the speed-up."""
    import io

    t0 = time.perf_counter()
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    body = [(i + 1, ln) for i, ln in enumerate(lines[5:], start=5) if ln.strip() and not ln.lstrip().startswith("#")]
    np.loadtxt(io.StringIO("\n".join(b[1] for b in body)), delimiter=",", ndmin=2, comments=None)
    all(b[1].count(",") == 4 for b in body)
    with open(out, "w") as f:
        np.savetxt(f, np.column_stack([ang, status]), fmt=["%.9f", "%d"], delimiter=",")
    return time.perf_counter() - t0


def memory(folder: str, sizes: tuple[int, int]) -> dict:
    """Peak RSS of calibrate, correct and loop at both sizes (the loop on the one recording: it splits it
    into training and validation rows itself), the growth per row between the sizes, and the whole peak
    per row at the larger size."""
    rows = {}
    enc = os.path.join(folder, "enc.json")
    with open(enc, "w") as f:
        f.write('{"lines_per_rev": 256, "adc_bits": 12, "coarse_bits": 9}\n')
    for n in sizes:
        data = os.path.join(folder, f"m{n}.csv")
        _recording(data, n, 1)
        cal = os.path.join(folder, f"cal{n}")
        runs = {"calibrate": ["calibrate", data, "--encoder", enc, "--out", cal],
                "correct": ["correct", data, "--cal", cal, "--out", os.path.join(folder, f"o{n}.csv")],
                "loop": ["loop", data, "--encoder", enc, "--out", os.path.join(folder, f"loop{n}")]}
        rows[n] = {}
        for name, argv in runs.items():
            mb, s, status = _peak_rss_mb(argv)
            rows[n][name] = {"peak_rss_mb": round(mb, 1), "seconds": round(s, 1), "exit": status}
        os.remove(data)     # one recording on disk at a time
    small, large = sizes
    names = ("calibrate", "correct", "loop")
    per_row = {name: round((rows[large][name]["peak_rss_mb"] - rows[small][name]["peak_rss_mb"]) * 2**20
                           / (large - small), 1) for name in names}
    return {"runs": {str(k): v for k, v in rows.items()}, "bytes_per_row_growth": per_row,
            "bytes_per_row_at_largest": {name: round(rows[large][name]["peak_rss_mb"] * 2**20 / large, 1)
                                         for name in names},
            "target_bytes_per_row": TARGET_BYTES_PER_ROW}


def io_and_memory(quick: bool = False) -> dict:
    folder = tempfile.mkdtemp(prefix="fringe-bench-io-", dir=os.getcwd())
    try:
        return {"io": io_speed(folder, 200_000 if quick else 1_000_000),
                "memory": memory(folder, (100_000, 400_000) if quick else (1_000_000, 10_000_000))}
    finally:
        import shutil
        shutil.rmtree(folder, ignore_errors=True)
