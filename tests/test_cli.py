"""The command line: good runs, and every kind of bad input (one line, exit 2, no output left)."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from cli_runs import simulate_pair

from fringe.cli.cli import main

HEADER = "t_s,sin,cos,coarse,ref_deg"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return simulate_pair(tmp_path_factory.mktemp("cli"), 30000, 30000)


def test_simulate_calibrate_correct(workdir, capsys):
    d = workdir
    assert main(["calibrate", str(d / "a.csv"), "--encoder", str(d / "enc.json"), "--out", str(d / "cal")]) == 0
    assert (d / "cal" / "calibration.json").is_file() and (d / "cal" / "wave_tables.csv").is_file()
    cal = json.loads((d / "cal" / "calibration.json").read_text())
    assert cal["stages"]["long_period"]["units"] == "arcsec" and cal["provenance"]["samples"] == 30000
    assert main(["correct", str(d / "b.csv"), "--cal", str(d / "cal"), "--out", str(d / "out.csv"),
                 "--engine", "float"]) == 0
    out = np.genfromtxt(d / "out.csv", delimiter=",", names=True, skip_header=1)
    assert len(out) == 30000 and set(out.dtype.names) >= {"angle_deg", "status"}
    assert np.all((out["angle_deg"] >= 0) & (out["angle_deg"] < 360))


def test_python_dash_m_and_console_script(workdir):
    for cmd in ([sys.executable, "-m", "fringe", "--help"],
                [os.path.join(os.path.dirname(sys.executable), "fringe"), "--help"]):
        r = subprocess.run(cmd, capture_output=True, text=True)
        assert r.returncode == 0 and "calibrate" in r.stdout


def _write(path, text):
    path.write_text(text)
    return str(path)


def _rows(d, n=100):
    t = np.arange(n) * 1e-3
    ph = np.linspace(0, 6 * np.pi, n)
    return "\n".join(f"{t[i]},{int(1500 * np.sin(ph[i]))},{int(1500 * np.cos(ph[i]))},0,{i * 0.1}"
                     for i in range(n))


BAD_DATA = {
    "misspelled column": (lambda d: "t_s,sinn,cos\n" + "0,1,2\n" * 100,
                          r"missing required column\(s\) sin.*'sinn' looks like 'sin'"),
    "non-numeric cell": (lambda d: HEADER + "\n" + _rows(d).replace("\n", "\n0,abc,1,0,0\n", 1),
                         r"line 3: column 'sin': not a number: 'abc'"),
    "nan": (lambda d: HEADER + "\n" + _rows(d) + "\n1,nan,1,0,0\n", r"line 102: column 'sin': nan is not a finite"),
    "inf": (lambda d: HEADER + "\n" + _rows(d) + "\n1,1,inf,0,0\n", r"line 102: column 'cos': inf is not a finite"),
    "empty file": (lambda d: "", "empty file"),
    "header only": (lambda d: HEADER + "\n", "no data rows"),
    "too few samples": (lambda d: HEADER + "\n" + _rows(d, 10), "too few samples: 10"),
    "ragged row": (lambda d: HEADER + "\n" + _rows(d) + "\n1,2\n", r"line 102: has 2 fields, the header has 5"),
    "out of ADC range": (lambda d: HEADER + "\n" + _rows(d) + "\n1,5000,1,0,0\n", r"line 102: column 'sin': 5000"),
    "no motion": (lambda d: HEADER + "\n" + "\n".join(f"{i},100,200,0,0" for i in range(200)), "no signal"),
    "less than a period": (lambda d: HEADER + "\n" + "\n".join(
        f"{i},{int(1500 * np.sin(i / 400))},{int(1500 * np.cos(i / 400))},0,0" for i in range(300)),
        "full signal period"),
    "clipped": (lambda d: HEADER + "\n" + "\n".join(
        f"{i},{int(np.clip(2600 * np.sin(i / 5), -2048, 2047))},{int(1500 * np.cos(i / 5))},0,0"
        for i in range(400)), "clipped at the ADC limits"),
}


@pytest.mark.parametrize("case", sorted(BAD_DATA))
def test_bad_data_file(workdir, tmp_path, capsys, case):
    make, pattern = BAD_DATA[case]
    data = _write(tmp_path / "bad.csv", make(tmp_path))
    out = tmp_path / "cal"
    status = main(["calibrate", data, "--encoder", str(workdir / "enc.json"), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and err.startswith("fringe: ") and "Traceback" not in err
    assert "bad.csv" in err
    import re
    assert re.search(pattern, err), err
    assert not out.exists()
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".tmp")]


def test_recording_shorter_than_a_revolution_with_ref_is_calibrated_without_the_long_period(workdir, tmp_path,
                                                                                            capsys):
    """Part of a revolution gives no long-period table, but the reference still gives the waveforms' phase: the
    calibration is written, and says what it skipped (it was refused before)."""
    lines = (workdir / "a.csv").read_text().splitlines()
    body = [ln for ln in lines if not ln.startswith("#")]
    data = _write(tmp_path / "short.csv", "\n".join(body[:3000]) + "\n")
    status = main(["calibrate", data, "--encoder", str(workdir / "enc.json"), "--out", str(tmp_path / "cal")])
    out = capsys.readouterr().out
    assert status == 0 and "skipped: long-period correction: the recording covers only" in out, out
    saved = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    assert any("long-period correction" in s for s in saved["skipped"])


BAD_ENCODERS = {
    "zero lines": ({"lines_per_rev": 0, "adc_bits": 12}, "'lines_per_rev' must be an integer >= 1"),
    "adc too wide": ({"lines_per_rev": 256, "adc_bits": 40}, "'adc_bits' must be an integer from 4 to 24"),
    "coarse too narrow": ({"lines_per_rev": 256, "adc_bits": 12, "coarse_bits": 7}, "cannot number 256 periods"),
    "negative full scale": ({"lines_per_rev": 1, "adc_bits": 12, "full_scale": -0.5},
                            "'full_scale' must be a positive"),
    "missing key": ({"adc_bits": 12}, "missing required key 'lines_per_rev'"),
    "unknown key": ({"lines_per_rev": 1, "adc_bits": 12, "line_per_rev": 3}, "unknown key"),
    "float lines": ({"lines_per_rev": 2.5, "adc_bits": 12}, "'lines_per_rev' must be an integer"),
    "not json": ("{lines_per_rev: 1", "not valid JSON"),
}


@pytest.mark.parametrize("case", sorted(BAD_ENCODERS))
def test_bad_encoder_json(workdir, tmp_path, capsys, case):
    content, pattern = BAD_ENCODERS[case]
    enc = _write(tmp_path / "enc.json", content if isinstance(content, str) else json.dumps(content))
    status = main(["calibrate", str(workdir / "a.csv"), "--encoder", enc, "--out", str(tmp_path / "cal")])
    err = capsys.readouterr().err
    assert status == 2 and pattern in err and "enc.json" in err and err.count("\n") == 1
    assert not (tmp_path / "cal").exists()


@pytest.mark.parametrize("argv,pattern", [
    (["simulate", "--preset", "nope", "--out", "x.csv"], "unknown preset 'nope'"),
    (["simulate", "--preset", "seed-encoder", "--out", "x.csv", "--samples", "0"], "must be >= 1"),
    (["correct", "missing.csv", "--cal", "no-such-cal", "--out", "x.csv"], "calibration folder not found"),
    (["calibrate", "missing.csv", "--encoder", "missing.json", "--out", "c"], "cannot read encoder description"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_command_lines(tmp_path, capsys, monkeypatch, argv, pattern):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert pattern in err and err.count("\n") == 1
    assert not (tmp_path / "x.csv").exists()


def test_correct_refuses_data_for_another_encoder(workdir, tmp_path, capsys):
    """Readings that do not fit the calibration's ADC are refused before anything is written."""
    assert main(["calibrate", str(workdir / "a.csv"), "--encoder", str(workdir / "enc.json"),
                 "--out", str(tmp_path / "cal")]) == 0
    data = _write(tmp_path / "wide.csv", "sin,cos\n" + "30000,1\n" * 10)
    assert main(["correct", data, "--cal", str(tmp_path / "cal"), "--out", str(tmp_path / "o.csv")]) == 2
    assert "outside the 12-bit ADC range" in capsys.readouterr().err
    assert not (tmp_path / "o.csv").exists()


def test_correct_runs_a_calibration_with_the_canceller_in_one_piece(workdir, capsys):
    """A calibration whose core carries fringe_canceller (as `fringe loop` writes for interference): the
    canceller's state spans the whole stream, so `correct` runs the recording in one piece, with the rows of the
    bit-exact model over the whole recording (streamed in pieces, the model refused it: nothing was written)."""
    import dataclasses

    from fringe.calib.calibrate import calibrate
    from fringe.cli.engines import run_engine
    from fringe.encoder import load_encoder
    from fringe.hardware.corefiles import core_files
    from fringe.io.calstore import save_calibration
    from fringe.io.dataio import read_measurement

    d = workdir
    enc = load_encoder(str(d / "enc.json"))
    meas = read_measurement(str(d / "a.csv"), enc)
    cal = calibrate(meas, enc)
    cal = dataclasses.replace(cal, canceller={"tone_hz": 1234.5, "sample_rate_hz": 10_000.0, "cancel_block_log2": 4,
                                              "cancel_mu_log2": 6})
    save_calibration(cal, str(d / "cal_cancel"), core_files(cal, "test"))
    assert main(["correct", str(d / "b.csv"), "--cal", str(d / "cal_cancel"), "--out", str(d / "out_cancel.csv")]) == 0
    out = np.genfromtxt(d / "out_cancel.csv", delimiter=",", names=True, skip_header=1)
    whole = run_engine("model", cal, read_measurement(str(d / "b.csv"), enc), str(d / "cal_cancel"))
    assert np.array_equal(out["status"], whole.status)
    assert np.allclose(out["angle_deg"], whole.angle_deg, atol=1e-9)
