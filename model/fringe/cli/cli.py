"""The `fringe` command line (spec section 3)."""

import argparse
import json
import os
import signal
import sys
import warnings

import numpy as np

from ..errors import FringeInputError
from ..io import outputs
from ..result import FAULTS

ENGINES = ("model", "float", "verilog", "vhdl")


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # main prints 'fringe: ' before it: name the subcommand only ("fringe: simulate: ...")
        raise FringeInputError(message, self.prog.split()[-1] if " " in self.prog else None)


def _positive_int(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def _seed(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if not 0 <= v < 1 << 63:
        raise argparse.ArgumentTypeError(f"must be from 0 to 2^63-1, got {v}")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="fringe", description="Signal correction for sin/cos (moire-fringe) encoders.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("simulate", help="write a simulated measurement")
    s.add_argument("--preset", required=True, help="encoder preset, e.g. seed-encoder")
    s.add_argument("--out", required=True, help="DATA.csv to write")
    s.add_argument("--encoder-out", help="also write the encoder description (JSON)")
    s.add_argument("--seed", type=_seed, default=1, help="random seed (trajectory and noise), 0 .. 2^63-1")
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
    from ..dsp import simulate
    from ..io.dataio import check_memory, write_csv
    from ..io.outputs import atomic_output, check_output_file

    check_output_file(a.out, "simulate", form="CSV")
    if a.encoder_out:
        if os.path.realpath(a.encoder_out) == os.path.realpath(a.out):
            raise FringeInputError("--encoder-out names the same file as --out: give the encoder description "
                                   "(JSON) its own name", a.encoder_out)
        check_output_file(a.encoder_out, "simulate", inputs=(a.out,), form="JSON")
    cfg = simulate.preset(a.preset)
    if a.samples:
        cfg.samples = a.samples
    check_memory(cfg.samples, SIMULATE_BYTES_PER_SAMPLE, "too many samples", "--samples")
    rec = simulate.simulate(cfg, seed=a.seed)
    cols = {k: rec.columns[k] for k in ("t_s", "sin", "cos", "coarse", "ref_deg") if k in rec.columns}
    write_csv(a.out, cols, simulate.describe(cfg, a.seed), simulate.csv_formats())
    if a.encoder_out:
        with atomic_output(a.encoder_out, "simulate") as f:
            json.dump({**rec.encoder.to_dict(), "written_by": f"fringe simulate --preset {a.preset} --seed {a.seed}"},
                      f, indent=2)
            f.write("\n")
    print(f"wrote {a.out}: {cfg.samples} samples, preset {a.preset}, seed {a.seed}")
    return 0


SIMULATE_BYTES_PER_SAMPLE = 400   # the simulator's arrays and the CSV text, per sample


def check_inputs(files=(), cal_dir=None):
    """The inputs, before the outputs are checked: a folder given for a file, or a folder that is not a
    calibration, is named as such (not as an --out inside the folder 'this command reads')."""
    from ..io.outputs import verify_dir

    if cal_dir is not None:
        verify_dir(cal_dir, "calibration")
    for what, path in files:
        if path == "":
            raise FringeInputError(f"the {what} name is empty", path)
        if path is not None and os.path.isdir(path):     # a missing file is named by its reader
            raise FringeInputError(f"is a folder: give the {what} itself", path)


def _read_for_calibration(path, enc):
    """The recording, refused early when its signals cannot be calibrated (too short, dead, clipped) or
    when it disagrees with the encoder description (diagnose)."""
    from ..calib.calibrate import check_recording as check_signals
    from ..io.dataio import check_channels, check_signal_scale, read_measurement
    from ..io.diagnose import check_recording

    meas = read_measurement(path, enc)
    check_signals(meas, enc)
    check_channels(meas)
    check_signal_scale(meas, enc)
    check_recording(meas, enc)
    return meas


FIT_ROWS_MAX = 1_000_000   # calibration fits on at most this many rows: memory stays bounded
FIT_BLOCKS = 64            # taken as this many evenly spaced runs of consecutive rows


def fitting_rows(meas):
    """A long recording is fitted on FIT_BLOCKS evenly spaced runs of consecutive rows, FIT_ROWS_MAX in all:
    every part of the motion is represented and the noise is averaged far below the floor, while memory
    does not grow with the recording. Without t_s the runs keep their row numbers as time, so that the
    smooth-motion reference sees the gaps between them."""
    n = len(meas)
    if n <= FIT_ROWS_MAX:
        return meas
    sub = meas.runs(FIT_ROWS_MAX, FIT_BLOCKS)
    sub.row_lines = None
    sub.full_rows = n
    return sub


def _note_fitting_rows(cal, meas):
    full = getattr(meas, "full_rows", None)
    if full:
        cal.provenance.update(samples=full, samples_fitted=len(meas))
        cal.skipped.append(f"fitted on {len(meas)} of the {full} rows ({FIT_BLOCKS} evenly spaced runs of "
                           "consecutive rows): a longer recording adds no accuracy, only memory")


def load_core_encoder(path: str):
    """The encoder description at ``path``, refused (naming the file) when no core configuration can hold its
    geometry: known before a fit rather than after it."""
    from ..encoder import load_encoder
    from ..fixed.config import CoreConfig

    enc = load_encoder(path)
    try:
        CoreConfig.for_encoder(enc)
    except ValueError as e:
        raise FringeInputError(f"no core configuration holds this encoder: {e}", path) from None
    return enc


def cmd_calibrate(a) -> int:
    from ..calib.calibrate import calibrate
    from ..hardware.corefiles import core_files
    from ..io.calstore import save_calibration
    from ..io.outputs import check_output_dir

    inputs = (a.data, a.encoder)
    check_inputs((("encoder description", a.encoder), ("data file", a.data)))
    check_output_dir(a.out, "calibration", inputs)
    enc = load_core_encoder(a.encoder)
    meas = fitting_rows(_read_for_calibration(a.data, enc))
    cal = calibrate(meas, enc)
    _note_fitting_rows(cal, meas)
    command = f"fringe calibrate {a.data} --encoder {a.encoder} --out {a.out}"
    extra = core_files(cal, command)
    if a.plots:
        from ..calib.report import calibration_plots
        extra.update(calibration_plots(cal, meas))
    save_calibration(cal, a.out, extra, inputs, command)
    print(summary_text(cal, meas))
    print(f"wrote {a.out}/")
    return 0


def summary_text(cal, meas) -> str:
    from ..dsp.metrics import error_arcsec, error_figures
    from ..engine.pipeline import run_float

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
        # rows with a fault flag (a glitched coarse code, a clipped channel) carry no angle to score
        ok = (res.status & FAULTS) == 0
        flagged = int(len(ok) - np.count_nonzero(ok))
        if flagged == len(ok):
            ok[:] = True
        err = error_arcsec(res.angle_deg[ok], meas.ref_deg[ok])
        fig = error_figures(err, res.frac[ok], res.position[ok] / cal.encoder.lines_per_rev)
        lines.append(f"on the calibration data: RMS {fig.rms_arcsec:.3f}\", interpolation {fig.interp_pp_arcsec:.3f}\" "
                     f"p-p, long period {fig.lp_pp_arcsec:.3f}\" p-p"
                     + (f" ({flagged} rows with fault flags left out)" if 0 < flagged < len(ok) else ""))
    return "\n".join(lines)


def cmd_correct(a) -> int:
    from ..io.calstore import load_calibration
    from ..io.dataio import FractionalReadings, csv_writer, iter_measurement, read_measurement
    from ..io.outputs import check_output_file
    from .engines import run_engine, streamable

    inputs = (a.data, a.cal)
    check_inputs((("data file", a.data),), a.cal)
    check_output_file(a.out, "correct", inputs)
    cal = load_calibration(a.cal)
    comments = (f"fringe correct --engine {a.engine}: {a.data} with {a.cal}",)
    formats = {"angle_deg": "%.9f", "status": "%d"}
    summary = CorrectSummary()
    with csv_writer(a.out, ("angle_deg", "status"), comments, formats, inputs) as w:
        step = streamable(a.engine, cal, a.cal)       # pieces of bounded size, or the whole recording
        try:
            pieces = iter_measurement(a.data, cal.encoder) if step else [read_measurement(a.data, cal.encoder)]
            for meas in pieces:
                if cal.encoder.coarse_bits and meas.coarse is None:
                    raise FringeInputError(f"the calibration's encoder has a {cal.encoder.coarse_bits}-bit coarse "
                                           "code, but the recording has no 'coarse' column", a.data)
                if step:
                    angle, status = step(meas)
                else:
                    res = run_engine(a.engine, cal, meas, a.cal)
                    angle, status = res.angle_deg, res.status
                w.write({"angle_deg": angle, "status": status})
                summary.add(angle, status, meas.ref_deg)
        except FractionalReadings as e:
            raise e.for_calibration() from None
    print(f"wrote {a.out}: {summary.rows} rows, engine {a.engine}{summary.text()}")
    return 0


class CorrectSummary:
    """Rows, flagged samples and the error against ref_deg, gathered piece by piece (the constant zero
    offset removed as metrics.error_arcsec does, about the first piece's mean)."""

    def __init__(self):
        self.rows = self.flagged = 0
        self.centre = None
        self.all, self.clean = ErrorSums(), ErrorSums()     # every row; the rows without a fault flag
        self.has_ref = True

    def add(self, angle, status, ref):
        from ..dsp.position import circular_mean, wrap

        self.rows += len(angle)
        bad = (status & FAULTS) != 0
        self.flagged += int(np.count_nonzero(bad))
        if ref is None:
            self.has_ref = False
            return
        d = wrap(angle / 360.0 - ref / 360.0)
        if self.centre is None:
            self.centre = circular_mean(d[~bad] if not bad.all() else d)
        e = wrap(d - self.centre) * 1296000.0
        self.all.add(e)
        self.clean.add(e[~bad])

    def text(self) -> str:
        msg = f"; {self.flagged} samples carry fault flags" if self.flagged else ""
        if self.has_ref and self.rows:
            msg += f"; error against ref_deg: {self.all.text()}"
            if self.flagged and self.clean.n:
                msg += f"; on the {self.clean.n} rows without a flag: {self.clean.text()}"
        return msg


class ErrorSums:
    """Count, sums and extremes of an error in arcsec, gathered piece by piece."""

    def __init__(self):
        self.n, self.sum, self.sumsq, self.lo, self.hi = 0, 0.0, 0.0, np.inf, -np.inf

    def add(self, e):
        if len(e):
            self.n, self.sum, self.sumsq = self.n + len(e), self.sum + e.sum(), self.sumsq + float(np.dot(e, e))
            self.lo, self.hi = min(self.lo, e.min()), max(self.hi, e.max())

    def text(self) -> str:
        mean = self.sum / self.n
        rms = np.sqrt(max(self.sumsq / self.n - mean ** 2, 0.0))
        return f"RMS {rms:.3f}\", p-p {self.hi - self.lo:.3f}\""


def cmd_loop(a) -> int:
    from ..io.outputs import check_output_dir
    from ..loop.run import run_loop

    check_inputs((("encoder description", a.encoder), ("data file", a.data), ("validation recording", a.validate)))
    check_output_dir(a.out, "loop", (a.data, a.encoder, a.validate))
    enc = load_core_encoder(a.encoder)
    val = _read_for_calibration(a.validate, enc) if a.validate else None
    shown = []    # the plots need no more rows than the decision; no reference to the recordings is kept here
    base, state, report = run_loop(_loop_recording(a.data, enc, val is None), enc, val, shown)
    del val
    write_loop_outputs(base, state, report, shown[0], None, a.out)
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


def _loop_recording(path, enc, halves: bool):
    """The loop's recording, read as for calibration; with `halves`, each interleaved half long enough. No
    reference to it stays here: run_loop lets it go once it is split."""
    meas = _read_for_calibration(path, enc)
    if halves:
        _check_halves(meas)
    return meas


def _check_halves(meas):
    """Without --validate the loop fits on one interleaved half of the recording and judges on the other: each
    must be long enough to calibrate (else the message would count the rows of a half, not of the file)."""
    from ..calib.calibrate import MIN_SAMPLES
    from ..loop.run import VALIDATION_BLOCKS

    n = len(meas)
    half = int(np.count_nonzero((np.arange(n) * VALIDATION_BLOCKS // n) % 2))
    if min(half, n - half) < MIN_SAMPLES:
        raise FringeInputError(f"too few samples for the closed loop: {n} (without --validate it fits on one "
                               f"interleaved half and judges on the other, each needs at least {MIN_SAMPLES}: "
                               "give a longer recording or a --validate one)", meas.path)


def write_loop_outputs(base, state, report: dict, train, validate, out_dir: str):
    """`fringe loop`'s folder: DIR/report.json, DIR/report.md with plots, DIR/cal/; all or nothing. base and state
    are the loop's LoopStates (declared model, chosen one), train and validate its Measurements."""
    from ..hardware.corefiles import core_files
    from ..io.calstore import save_calibration
    from ..io.outputs import atomic_dir

    # matplotlib only now: its memory does not add to the loop's peak
    from ..loop.report import write_markdown, write_plots

    with atomic_dir(out_dir, "loop", command="fringe loop") as tmp:
        save_calibration(state.cal, os.path.join(tmp, "cal"), core_files(state.cal, "fringe loop"),
                         command="fringe loop")
        plots = write_plots(base, state, train if validate is None else validate, tmp)
        with open(os.path.join(tmp, "report.json"), "w", encoding="utf-8") as f:
            json.dump(report, f, indent=2, default=float)
            f.write("\n")
        write_markdown(report, plots, os.path.join(tmp, "report.md"))


ROM_OPTIONS = ("wave_addr_w", "wave_w", "fine_w", "cordic_stages", "lp_addr_w")


def cmd_rom(a) -> int:
    from ..hardware.corefiles import core_config, write_core_roms
    from ..hardware.rom import FORMATS
    from ..io.calstore import load_calibration
    from ..io.outputs import check_output_dir

    formats = list(dict.fromkeys(f.strip().lower() for f in a.format.split(",") if f.strip()))   # 'MEM', 'mem,mem'
    unknown = [f for f in formats if f not in FORMATS]
    if not formats or unknown:
        raise FringeInputError(f"{'unknown format ' + repr(unknown[0]) if unknown else 'no format given'} "
                               f"(choose from {','.join(FORMATS)})", "--format")
    check_inputs(cal_dir=a.cal)
    check_output_dir(a.out, "rom", (a.cal,))
    cal = load_calibration(a.cal)
    overrides = {k: getattr(a, k) for k in ROM_OPTIONS if getattr(a, k) is not None}
    options = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in overrides.items())
    cfg = core_config(cal, a.cal, **overrides)
    command = f"fringe rom {a.cal} --out {a.out} --format {','.join(formats)}" + (" " + options if options else "")
    files = write_core_roms(cal, cfg, a.out, formats, command, (a.cal,), where=options or a.cal)
    print(f"wrote {a.out}/: {', '.join(files)}")
    return 0


COMMANDS = {"simulate": cmd_simulate, "calibrate": cmd_calibrate, "correct": cmd_correct, "rom": cmd_rom,
            "loop": cmd_loop}


class Interrupted(BaseException):
    """A signal asked fringe to stop: raised where it runs, so every temporary output is removed on the way out
    (not KeyboardInterrupt, which makes Python re-kill itself with SIGINT when it arrives during an import)."""


def _interrupted(signum, frame):
    if outputs.COMMITTED:      # an output is in place: the work is done, the command finishes its last lines
        return
    raise Interrupted(signum)


def main(argv=None) -> int:
    """Every failure is one line on stderr and exit status 2 (130 and up for signals); nothing half-written."""
    import threading

    outputs.COMMITTED.clear()
    if threading.current_thread() is not threading.main_thread():   # only the main thread may set handlers
        return _main(argv)
    previous = {sig: signal.signal(sig, _interrupted) for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        return _main(argv)
    finally:                                        # main() called from Python: give the caller its handlers back
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _main(argv) -> int:
    debug = bool(os.environ.get("FRINGE_DEBUG"))
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            if not debug:
                warnings.simplefilter("ignore")
            args = build_parser().parse_args(argv)
            return COMMANDS[args.command](args)
    except FringeInputError as e:
        print(f"fringe: {e}", file=sys.stderr)
        return 2
    except (Interrupted, KeyboardInterrupt) as e:
        signum = e.args[0] if e.args and isinstance(e.args[0], int) else signal.SIGINT
        print(f"fringe: interrupted by {signal.Signals(signum).name}; nothing was written", file=sys.stderr)
        return 128 + signum
    except MemoryError:
        print("fringe: out of memory: the recording is too large for this machine (split it)", file=sys.stderr)
        return 2
    except OSError as e:
        where = e.filename or "output"
        print(f"fringe: {where}: {e.strerror or e}", file=sys.stderr)
        return 2
    except Exception as e:   # a fault of fringe itself: still one line, and no partial output (see FRINGE_DEBUG)
        if debug:
            raise
        first = str(e).splitlines()[0] if str(e) else ""
        print(f"fringe: internal error ({type(e).__name__}: {first}); set FRINGE_DEBUG=1 for the details",
              file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
