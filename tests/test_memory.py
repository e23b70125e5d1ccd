"""Bounded memory of reading a recording and of the diagnose checks (issue 8), and that the blockwise
forms compute what the whole-array forms compute.

The memory test measures peak RSS in a fresh process, above its imports; per row it
must stay within the budget of what is held: 5 float64 columns (40 B/row), the raw phase and the
unwrapped reference of the checks (16 B/row) and one transient column of the range checks (8 B/row),
64 B/row, with 25 % margin. The whole-table reader with whole-array checks took about 216 B/row.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

from fringe.encoder import encoder_from_dict
from fringe.io import dataio, diagnose
from fringe.io.dataio import Measurement, read_measurement, write_csv

SEED = 20261202
ENCODER = {"lines_per_rev": 256, "adc_bits": 12, "coarse_bits": 9}
BUDGET_BYTES_PER_ROW = 1.25 * (5 * 8 + 2 * 8 + 8)


def _recording(path, n, rng):
    """A sound seed-like recording: steady motion with noise, coarse code and reference."""
    t = np.arange(n) / 10_000.0
    rev = rng.uniform(0.01, 0.2) * t + rng.uniform(0, 1)          # revolutions
    phase = 2 * np.pi * 256 * rev
    amp = rng.uniform(800, 1900)
    cols = {"t_s": t, "sin": np.round(amp * np.sin(phase) + rng.normal(0, 2, n)),
            "cos": np.round(amp * np.cos(phase) + rng.normal(0, 2, n)),
            "coarse": np.floor((rev % 1) * 512).astype(np.int64), "ref_deg": (rev % 1) * 360.0}
    write_csv(str(path), cols, ("fringe simulate: memory test",),
              {"t_s": "%.6f", "sin": "%d", "cos": "%d", "coarse": "%d", "ref_deg": "%.9f"})


def test_reader_pieces_give_the_whole_table(tmp_path, monkeypatch):
    """Pieces of a few rows (many of them, CRLF and LF) read exactly what pyarrow's whole-table reader reads."""
    import pyarrow.csv as pacsv

    rng = np.random.default_rng(SEED)
    print("seed", SEED)
    for case in range(6):
        path = tmp_path / f"r{case}.csv"
        _recording(path, int(rng.integers(50, 3000)), rng)
        if case % 2:
            path.write_bytes(path.read_bytes().replace(b"\n", b"\r\n"))
        monkeypatch.setattr(dataio, "READ_ROWS", int(rng.integers(1, 300)))
        m = read_measurement(str(path))
        table = pacsv.read_csv(str(path), read_options=pacsv.ReadOptions(skip_rows=1))
        for name in ("sin", "cos", "ref_deg", "t_s"):
            assert np.array_equal(getattr(m, name), table.column(name).to_numpy()), (case, name)
        assert np.array_equal(m.coarse, table.column("coarse").to_numpy())


def test_unwrap_and_slope_in_blocks(monkeypatch):
    rng = np.random.default_rng(SEED + 1)
    monkeypatch.setattr(diagnose, "BLOCK", int(rng.integers(7, 200)))
    for period in (2 * np.pi, 360.0, 512.0):
        walk = np.cumsum(rng.normal(0, 0.2 * period, int(rng.integers(500, 5000))))
        raw = np.mod(walk, period)
        whole = np.unwrap(raw, period=period)
        blocks = diagnose.unwrap_in_blocks(lambda s, raw=raw: raw[s], len(raw), period)
        np.testing.assert_allclose(blocks, whole, rtol=0, atol=1e-9 * np.abs(whole).max())
        x, y = rng.normal(size=len(raw)), rng.normal(size=len(raw))
        y += 0.7 * x
        a, rest = diagnose._slope(x, y, 2.0)
        slope, icpt = np.polyfit(2.0 * x, y, 1)
        assert a == pytest.approx(slope, rel=1e-12)
        assert rest == pytest.approx(np.sqrt(np.mean((y - slope * 2.0 * x - icpt) ** 2)), rel=1e-12)


def test_checks_in_blocks_name_the_same_jump(monkeypatch):
    """A jump of the reference is found at its row whatever the blocks are."""
    rng = np.random.default_rng(SEED + 2)
    n = 20_000
    rev = 0.05 * np.arange(n) / 10_000.0
    ph = 2 * np.pi * 256 * rev
    ref = rev * 360.0
    at = int(rng.integers(n // 4, 3 * n // 4))
    ref[at:] += 5.0
    meas = Measurement("x.csv", np.round(1500 * np.sin(ph)), np.round(1500 * np.cos(ph)),
                       np.floor(rev * 512).astype(np.int64) % 512, ref, None)
    enc = encoder_from_dict(ENCODER)
    for block in (int(rng.integers(5, 100)), 1 << 18):
        monkeypatch.setattr(diagnose, "BLOCK", block)
        with pytest.raises(Exception, match=f"row {at + 1}: ref_deg jumps by 5"):
            diagnose.check_recording(meas, enc)


PROBE = """
import os, resource, sys
import pyarrow.csv
from fringe.io.dataio import read_measurement, check_signal_scale
from fringe.io.diagnose import check_recording
from fringe.calib.calibrate import check_recording as check_signals
from fringe.encoder import encoder_from_dict
enc = encoder_from_dict({encoder!r})
before = int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
m = read_measurement(sys.argv[1], enc)
check_signals(m, enc)
check_signal_scale(m, enc)
check_recording(m, enc)
# VmHWM, the high-water mark of this process image: ru_maxrss keeps the spawning process's peak across exec
# (Linux carries it over), so a large pytest worker would count as this probe's own peak
peak = [int(x.split()[1]) for x in open("/proc/self/status") if x.startswith("VmHWM:")][0] * 1024
print(before, peak)
"""


def test_reading_and_checks_hold_bounded_memory_per_row(tmp_path):
    """Peak RSS above the imports: the budget per row, and what does not grow with the recording: the
    checks' blocks and statistical samples (about 8 temporaries of 8 B each) and the reader's pieces."""
    rng = np.random.default_rng(SEED + 3)
    n = 900_000
    path = tmp_path / "m.csv"
    _recording(path, n, rng)
    out = subprocess.run([sys.executable, "-c", PROBE.format(encoder=ENCODER), str(path)], check=True,
                         capture_output=True, text=True, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    before, peak = map(int, out.stdout.split()[-2:])
    fixed = 8 * 8 * (diagnose.BLOCK + diagnose.SAMPLE) + 4 * 48 * dataio.READ_ROWS
    print(f"peak RSS {peak / 2**20:.1f} MB, {(peak - before) / n:.1f} B/row above the imports "
          f"(budget {BUDGET_BYTES_PER_ROW:.0f} B/row + {fixed / 2**20:.0f} MB)")
    assert peak - before <= BUDGET_BYTES_PER_ROW * n + fixed
