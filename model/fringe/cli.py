"""The `fringe` command line (spec section 3)."""

import argparse
import json
import os
import sys

import numpy as np

from .errors import FringeInputError

ENGINES = ("model", "float", "verilog", "vhdl")


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise FringeInputError(message, "fringe " + self.prog.split()[-1] if " " in self.prog else "fringe")


def _positive_int(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="fringe", description="Signal correction for sin/cos (moire-fringe) encoders.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("simulate", help="write a simulated measurement")
    s.add_argument("--preset", required=True, help="encoder preset, e.g. seed-encoder")
    s.add_argument("--out", required=True, help="DATA.csv to write")
    s.add_argument("--encoder-out", help="also write the encoder description (JSON)")
    s.add_argument("--seed", type=int, default=1, help="random seed (trajectory and noise)")
    s.add_argument("--samples", type=_positive_int, help="number of samples (default: the preset's)")

    c = sub.add_parser("calibrate", help="fit the correction")
    c.add_argument("data", help="measured DATA.csv")
    c.add_argument("--encoder", required=True, help="encoder description ENC.json")
    c.add_argument("--out", required=True, help="CAL_DIR to write")
    c.add_argument("--plots", action="store_true", help="also write PNG plots into CAL_DIR")

    r = sub.add_parser("correct", help="run data through the correction")
    r.add_argument("data", help="DATA.csv")
    r.add_argument("--cal", required=True, help="CAL_DIR from fringe calibrate")
    r.add_argument("--out", required=True, help="OUT.csv to write")
    r.add_argument("--engine", choices=ENGINES, default="model",
                   help="model: bit-exact model of the RTL (default); float: floating-point reference; "
                        "verilog/vhdl: the RTL in simulation")

    lp = sub.add_parser("loop", help="closed loop: find what the declared model misses, add it, report")
    lp.add_argument("data", help="DATA.csv with ref_deg")
    lp.add_argument("--encoder", required=True, help="encoder description ENC.json")
    lp.add_argument("--out", required=True, help="DIR to write (report.md, report.json, cal/)")
    lp.add_argument("--validate", help="a second recording to judge each effect on (default: interleaved half)")

    m = sub.add_parser("rom", help="write the ROM images for synthesis")
    m.add_argument("cal", help="CAL_DIR from fringe calibrate")
    m.add_argument("--out", required=True, help="folder to write")
    m.add_argument("--format", default="mem", help="comma-separated: mem,mif,coe,vhdl (default mem)")
    for name, what in (("wave-addr-w", "waveform table address bits per branch"),
                       ("wave-w", "waveform table width"), ("fine-w", "fine phase bits per period"),
                       ("cordic-stages", "CORDIC iterations"), ("lp-addr-w", "long-period table address bits")):
        m.add_argument(f"--{name}", type=_positive_int, help=f"{what} (default: the calibration's core.json)")
    return p


def cmd_simulate(a) -> int:
    from . import simulate
    from .dataio import write_csv

    cfg = simulate.preset(a.preset)
    if a.samples:
        cfg.samples = a.samples
    rec = simulate.simulate(cfg, seed=a.seed)
    cols = {k: rec.columns[k] for k in ("t_s", "sin", "cos", "coarse", "ref_deg") if k in rec.columns}
    if a.encoder_out:
        _check_writable(a.encoder_out)
    write_csv(a.out, cols, simulate.describe(cfg, a.seed), simulate.csv_formats())
    if a.encoder_out:
        from .dataio import atomic_output
        with atomic_output(a.encoder_out) as f:
            json.dump(rec.encoder.to_dict(), f, indent=2)
            f.write("\n")
    print(f"wrote {a.out}: {cfg.samples} samples, preset {a.preset}, seed {a.seed}")
    return 0


def _check_writable(path):
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise FringeInputError("output folder does not exist", path)


def cmd_calibrate(a) -> int:
    from .calibrate import calibrate
    from .calstore import save_calibration
    from .dataio import read_measurement
    from .encoder import load_encoder
    from .engines import core_files

    enc = load_encoder(a.encoder)
    meas = read_measurement(a.data, enc)
    cal = calibrate(meas, enc)
    extra = core_files(cal, f"fringe calibrate {a.data} --encoder {a.encoder} --out {a.out}")
    if a.plots:
        from .report import calibration_plots
        extra.update(calibration_plots(cal, meas))
    save_calibration(cal, a.out, extra)
    print(summary_text(cal, meas))
    print(f"wrote {a.out}/")
    return 0


def summary_text(cal, meas) -> str:
    from .metrics import error_arcsec, error_figures
    from .pipeline import run_float

    lines = []
    q = cal.quad
    lines.append(f"quadrature: phase error {np.degrees(q.alpha_rad) * 3600:.1f}\" (electrical), "
                 f"gain ratio {q.gain_ratio:.5f}")
    if cal.coarse_offset_periods is not None:
        lines.append(f"coarse code: middle of code 0 at {cal.coarse_offset_periods:.4f} periods")
    if cal.long_period is not None:
        lines.append(f"long period: {cal.long_period.n} harmonics (BIC); direction {cal.direction:+d}, "
                     f"zero {cal.zero_deg:.6f} deg")
    for s in cal.skipped:
        lines.append(f"skipped: {s}")
    if meas.ref_deg is not None:
        res = run_float(cal, meas.sin, meas.cos, meas.coarse, meas.t_s)
        err = error_arcsec(res.angle_deg, meas.ref_deg)
        fig = error_figures(err, res.frac, res.position / cal.encoder.lines_per_rev)
        lines.append(f"on the calibration data: RMS {fig.rms_arcsec:.3f}\", interpolation {fig.interp_pp_arcsec:.3f}\" "
                     f"p-p, long period {fig.lp_pp_arcsec:.3f}\" p-p")
    return "\n".join(lines)


def cmd_correct(a) -> int:
    from .calstore import load_calibration
    from .dataio import read_measurement, write_csv
    from .engines import run_engine

    cal = load_calibration(a.cal)
    meas = read_measurement(a.data, cal.encoder)
    _check_writable(a.out)
    res = run_engine(a.engine, cal, meas, a.cal)
    write_csv(a.out, {"angle_deg": res.angle_deg, "status": res.status},
              (f"fringe correct --engine {a.engine}: {a.data} with {a.cal}",),
              {"angle_deg": "%.9f", "status": "%d"})
    msg = f"wrote {a.out}: {len(meas)} rows, engine {a.engine}"
    flagged = int(np.count_nonzero(res.status & 0x7F))
    if flagged:
        msg += f"; {flagged} samples carry fault flags"
    if meas.ref_deg is not None:
        from .metrics import error_arcsec
        err = error_arcsec(res.angle_deg, meas.ref_deg)
        msg += f"; error against ref_deg: RMS {np.sqrt(np.mean(err ** 2)):.3f}\", p-p {np.ptp(err):.3f}\""
    print(msg)
    return 0


def cmd_loop(a) -> int:
    from .dataio import read_measurement
    from .encoder import load_encoder
    from .loop import run_loop, write_outputs

    enc = load_encoder(a.encoder)
    train = read_measurement(a.data, enc)
    val = read_measurement(a.validate, enc) if a.validate else None
    base, state, report = run_loop(train, enc, val)
    write_outputs(base, state, report, train, val, a.out)
    b, f = report["before"], report["after"]
    print(f"declared model: RMS {b['rms_arcsec']:.3f}\"; with the added effects: RMS {f['rms_arcsec']:.3f}\" "
          f"(noise floor {report['noise_floor_arcsec']:.3f}\", on {report['validation']})")
    for e in report["effects_added"]:
        print(f"added {e['name']} ({e['correction']}): {e['evidence']}; "
              f"{e['rms_before_arcsec']:.3f}\" -> {e['rms_after_arcsec']:.3f}\"")
    for e in report["effects_rejected"]:
        print(f"not kept {e['name']}: {e['why_not_kept']}")
    print(f"wrote {a.out}/report.md, report.json, cal/")
    return 0


def cmd_rom(a) -> int:
    from .calstore import load_calibration
    from .engines import core_config, write_core_roms

    cal = load_calibration(a.cal)
    formats = [f.strip() for f in a.format.split(",") if f.strip()]
    overrides = {k: getattr(a, k) for k in ("wave_addr_w", "wave_w", "fine_w", "cordic_stages", "lp_addr_w")
                 if getattr(a, k) is not None}
    cfg = core_config(cal, a.cal, **overrides)
    command = f"fringe rom {a.cal} --out {a.out} --format {','.join(formats)}" + "".join(
        f" --{k.replace('_', '-')} {v}" for k, v in overrides.items())
    files = write_core_roms(cal, cfg, a.out, formats, command)
    print(f"wrote {a.out}/: {', '.join(files)}")
    return 0


COMMANDS = {"simulate": cmd_simulate, "calibrate": cmd_calibrate, "correct": cmd_correct, "rom": cmd_rom,
            "loop": cmd_loop}


def main(argv=None) -> int:
    try:
        args = build_parser().parse_args(argv)
        return COMMANDS[args.command](args)
    except FringeInputError as e:
        print(f"fringe: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fringe: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
