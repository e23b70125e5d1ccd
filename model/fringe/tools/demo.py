"""`make demo`: the main job end to end on the built-in seed encoder.

Simulates two recordings of the seeds' encoder (new trajectory and noise for the second),
calibrates on the first, corrects the second, and prints the error before and after next to
the seeds' own method and an ellipse-only correction. Plots go to OUT/.
"""

import os
import sys

from ..calib.calibrate import ellipse_only, seed_method, uncorrected
from ..calib.report import error_plot, lissajous_plot
from ..cli import cli
from ..cli.engines import run_engine
from ..dsp.metrics import error_arcsec, error_figures
from ..encoder import load_encoder
from ..engine.pipeline import run_float
from ..io.calstore import load_calibration
from ..io.dataio import read_measurement


def run(cmd: list[str]):
    print("$ fringe " + " ".join(cmd), flush=True)
    status = cli.main(cmd)
    if status:
        sys.exit(status)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = argv[0] if argv else "out/demo"
    os.makedirs(out, exist_ok=True)
    p = lambda name: os.path.join(out, name)  # noqa: E731

    run(["simulate", "--preset", "seed-encoder", "--out", p("calibration.csv"), "--encoder-out", p("encoder.json"),
         "--seed", "1"])
    run(["simulate", "--preset", "seed-encoder", "--out", p("validation.csv"), "--seed", "2"])
    run(["calibrate", p("calibration.csv"), "--encoder", p("encoder.json"), "--out", p("cal"), "--plots"])
    run(["correct", p("validation.csv"), "--cal", p("cal"), "--out", p("corrected.csv")])

    enc = load_encoder(p("encoder.json"))
    cal = load_calibration(p("cal"))
    train = read_measurement(p("calibration.csv"), enc)
    val = read_measurement(p("validation.csv"), enc)
    methods = {"uncorrected": uncorrected(cal, val), "ellipse only (Heydemann)": ellipse_only(cal, train),
               "seed 001+000 method": seed_method(cal, train), "fringe (float)": cal,
               "fringe (bit-exact core)": "model"}
    print("\nError on the validation recording against ref_deg (arcsec; systematic parts are bin means):")
    print(f"{'method':28s} {'RMS':>8s} {'p-p':>8s} {'interp p-p':>11s} {'long-period p-p':>16s}")
    curves = {}
    for name, c in methods.items():
        if c == "model":
            res = run_engine("model", cal, val, p("cal"))
        else:
            res = run_float(c, val.sin, val.cos, val.coarse, val.t_s)
        err = error_arcsec(res.angle_deg, val.ref_deg)
        f = error_figures(err, res.frac, res.position / enc.lines_per_rev)
        print(f"{name:28s} {f.rms_arcsec:8.2f} {f.pp_arcsec:8.2f} {f.interp_pp_arcsec:11.2f} {f.lp_pp_arcsec:16.2f}")
        if name in ("uncorrected", "fringe (bit-exact core)"):
            curves[name] = (err, res.frac, res.position / enc.lines_per_rev)
    print("(seed 001 reports 162.5\" -> 47.5\" p-p interpolation error; seed 000 +45/-17.5\" -> +10/-8.75\")")
    error_plot(p("error_before_after.png"), curves)
    lissajous_plot(p("lissajous.png"), cal, val.sin, val.cos)
    print(f"\nplots: {p('error_before_after.png')}, {p('lissajous.png')}; calibration: {p('cal')}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
