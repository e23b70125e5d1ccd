"""The recordings (and calibration) the command-line tests start from, written by the command line itself."""

from fringe.cli.cli import main


def simulate_pair(d, fit_samples: int, check_samples: int, calibrate: bool = False):
    """Into folder d: seed-encoder recordings a.csv (seed 1, its encoder in enc.json) and b.csv (seed 2);
    with calibrate, a.csv's calibration in d/cal. Returns d."""
    assert main(["simulate", "--preset", "seed-encoder", "--out", str(d / "a.csv"), "--encoder-out",
                 str(d / "enc.json"), "--samples", str(fit_samples), "--seed", "1"]) == 0
    assert main(["simulate", "--preset", "seed-encoder", "--out", str(d / "b.csv"), "--samples", str(check_samples),
                 "--seed", "2"]) == 0
    if calibrate:
        assert main(["calibrate", str(d / "a.csv"), "--encoder", str(d / "enc.json"), "--out", str(d / "cal")]) == 0
    return d
