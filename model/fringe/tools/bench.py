"""`make bench`: accuracy, speed and size figures, written to OUT/bench.json and OUT/bench.md.

Benchmarks measure; tests judge correctness. Each figure here is measured on this machine
in this run; the targets from the issues are printed next to them with pass/fail.
"""

import argparse
import glob
import json
import os
import platform
import sys
import time

import numpy as np

from .. import __version__
from ..calib.calibrate import calibrate, ellipse_only, seed_method, uncorrected
from ..calib.evaluate import figures, float_engine, measurement_of, noise_floor_arcsec
from ..dsp.metrics import error_arcsec
from ..dsp.simulate import seed_encoder, simulate
from ..fixed.config import CoreConfig
from ..fixed.core import error_budget
from ..hardware.rtlsim import RtlSimulationError, run_rtl, run_rtl_result
from ..hardware.tables import build_tables, run_model
from ..io.datasets import RM44_ENCODER, halves, read_rm44
from .bench_drift_step import startup as drift_startup
from .bench_io import io_and_memory
from .bench_real import real_vs_plain_bench, simulated_bench
from .bench_reference_free import reference_free_bench, reference_free_markdown
from .population import loop_speed, population_bench

SHARED_DATA = os.path.join(os.path.dirname(__file__), "..", "..", "..", "..", "shared", "data")


def seed_preset_accuracy(samples: int = 200_000) -> dict:
    cfg = seed_encoder()
    cfg.samples = samples
    train, val = measurement_of(simulate(cfg, 1)), measurement_of(simulate(cfg, 2))
    cal = calibrate(train, cfg.encoder())
    methods = {"uncorrected": uncorrected(cal, val), "ellipse_only": ellipse_only(cal, train),
               "seed_method": seed_method(cal, train), "fringe_float": cal}
    out = {name: figures(c, val)[0].to_dict() for name, c in methods.items()}
    core_cfg = CoreConfig.for_encoder(cal.encoder)
    tables = build_tables(cal, core_cfg)
    model = lambda c, m: run_model(c, core_cfg, m.sin, m.cos, m.coarse, tables=tables)  # noqa: E731
    out["fringe_model"] = figures(cal, val, model)[0].to_dict()
    out["core_config"] = core_cfg.to_dict()
    q = cal.quad
    out["model_error_budget_arcsec"] = error_budget(tables, core_cfg, (q.k_ss, q.k_sc, q.k_cc))
    floor = noise_floor_arcsec(cal, cfg, 2)
    floor_model = noise_floor_arcsec(cal, cfg, 2, model)
    f = out["fringe_float"]
    out["noise_floor_rms_arcsec"] = round(floor, 4)
    out["targets"] = {
        "interp_pp_le_1arcsec": f["interp_pp_arcsec"] <= 1.0,
        "lp_pp_le_1arcsec": f["lp_pp_arcsec"] <= 1.0,
        "rms_within_10pct_of_floor": f["rms_arcsec"] <= 1.10 * floor,
        "model_interp_pp_le_1arcsec": out["fringe_model"]["interp_pp_arcsec"] <= 1.0,
        "model_lp_pp_le_1arcsec": out["fringe_model"]["lp_pp_arcsec"] <= 1.0,
        "model_rms_within_10pct_of_floor": out["fringe_model"]["rms_arcsec"] <= 1.10 * floor_model,
    }
    out["noise_floor_model_rms_arcsec"] = round(floor_model, 4)
    out["setup"] = f"seed-encoder preset, {samples} samples; calibrated on seed 1, validated on seed 2"
    return out


def speed(samples: int = 1_000_000) -> dict:
    cfg = seed_encoder()
    cfg.samples = samples
    meas = measurement_of(simulate(cfg, 7))
    t0 = time.perf_counter()
    cal = calibrate(meas, cfg.encoder())
    t_cal = time.perf_counter() - t0
    t0 = time.perf_counter()
    float_engine(cal, meas)
    t_cor = time.perf_counter() - t0
    core_cfg = CoreConfig.for_encoder(cal.encoder)
    tables = build_tables(cal, core_cfg)
    t0 = time.perf_counter()
    run_model(cal, core_cfg, meas.sin, meas.cos, meas.coarse, tables=tables)
    t_model = time.perf_counter() - t0
    return {"samples": samples, "calibrate_s": round(t_cal, 3), "calibrate_target_s": 10.0,
            "correct_float_samples_per_s": round(samples / t_cor),
            "correct_model_samples_per_s": round(samples / t_model),
            "targets": {"calibrate_1M_le_10s": t_cal <= 10.0, "correct_float_ge_1M_per_s": samples / t_cor >= 1e6,
                        "correct_model_ge_1M_per_s": samples / t_model >= 1e6}}


def engine_speed(samples: int = 1_000_000, cocotb_samples: int = 20_000, ghdl_samples: int = 0,
                 seed: int = 7) -> dict:
    """Speed of ``--engine verilog`` against ``--engine model`` in one run (for ``make bench``).

    A seed-encoder recording of ``samples`` samples (simulated with ``seed``), calibrated, goes
    through ``run_model`` and through ``run_rtl_result`` (the C++ harness); the engine's binary is
    built (or found in the cache) by a short warm-up run first, timed as ``build_s``. The cocotb
    harness (and GHDL when ``ghdl_samples`` > 0) run a leading slice, for comparison. The words of
    both full runs are compared. Target (issue 11): the Verilator engine within twice the model's time.
    """
    sim_cfg = seed_encoder()
    sim_cfg.samples = samples
    meas = measurement_of(simulate(sim_cfg, seed))
    cal = calibrate(meas, sim_cfg.encoder())
    cfg = CoreConfig.for_encoder(cal.encoder)
    tables = build_tables(cal, cfg)
    t0 = time.perf_counter()
    model = run_model(cal, cfg, meas.sin, meas.cos, meas.coarse, tables=tables)
    t_model = time.perf_counter() - t0
    t0 = time.perf_counter()
    run_rtl(cal, cfg, meas.sin[:100], meas.cos[:100], None if meas.coarse is None else meas.coarse[:100])
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    rtl = run_rtl_result(cal, cfg, meas.sin, meas.cos, meas.coarse, "verilog")
    t_rtl = time.perf_counter() - t0
    same = bool(np.array_equal(rtl.angle_deg, model.angle_deg) and np.array_equal(rtl.status, model.status))
    out = {"samples": samples, "config": cfg.test_id, "model_s": round(t_model, 3),
           "model_samples_per_s": round(samples / t_model), "verilog_build_s": round(t_build, 1),
           "verilog_s": round(t_rtl, 3), "verilog_samples_per_s": round(samples / t_rtl),
           "verilog_over_model": round(t_rtl / t_model, 2), "verilog_words_equal_model": same}
    for name, sim, harness, n in (("cocotb_verilator", "verilator", "cocotb", cocotb_samples),
                                  ("cocotb_ghdl", "ghdl", "cocotb", ghdl_samples)):
        if n <= 0:
            continue
        coarse = None if meas.coarse is None else meas.coarse[:n]
        try:
            run_rtl(cal, cfg, meas.sin[:100], meas.cos[:100], None if coarse is None else coarse[:100],
                    sim, harness=harness)                                      # build
            t0 = time.perf_counter()
            run_rtl(cal, cfg, meas.sin[:n], meas.cos[:n], coarse, sim, harness=harness)
            out[f"{name}_samples_per_s"] = round(n / (time.perf_counter() - t0))
        except RtlSimulationError as e:
            out[f"{name}_samples_per_s"] = f"not run: {str(e).splitlines()[0]}"
    out["targets"] = {"verilog_le_2x_model": t_rtl <= 2.0 * t_model, "verilog_words_equal_model": same}
    return out


def _per_rm44_file(folder: str, figures_of) -> dict | str:
    """``{file name: figures_of(train, val)}`` over the RM44 recordings, each split into its even (train) and
    odd (val) samples, or why there are none."""
    files = sorted(glob.glob(os.path.join(folder, "rm44_hall_vs_tonic", "*.csv")))
    if not files:
        return "skipped: ../shared/data/rm44_hall_vs_tonic not found"
    return {os.path.basename(path): figures_of(*halves(read_rm44(path))) for path in files}


def rm44(folder: str) -> dict | str:
    def one(train, val) -> dict:
        cal = calibrate(train, RM44_ENCODER)
        raw = figures(uncorrected(cal, val), val)[0]
        ell = figures(ellipse_only(cal, train), val)[0]
        fixed, res = figures(cal, val)
        err = error_arcsec(res.angle_deg, val.ref_deg)
        return {
            "raw_rms_arcsec": round(raw.rms_arcsec, 1), "raw_pp_arcsec": round(raw.pp_arcsec, 1),
            "ellipse_rms_arcsec": round(ell.rms_arcsec, 1),
            "corrected_rms_arcsec": round(fixed.rms_arcsec, 1), "corrected_pp_arcsec": round(fixed.pp_arcsec, 1),
            "noise_estimate_arcsec": round(float(np.std(np.diff(err)) / np.sqrt(2)), 1),
        }

    rows = _per_rm44_file(folder, one)
    if isinstance(rows, str):
        return rows
    return {"setup": "calibrated on the even samples of each file, validated on the odd ones", "files": rows}


def de_vs_desa() -> dict | str:
    from ..dsp import longperiod
    if not hasattr(longperiod, "de_benchmark"):
        return "skipped: longperiod.de_benchmark not available"
    t0 = time.perf_counter()
    r = longperiod.de_benchmark()
    r["elapsed_s"] = round(time.perf_counter() - t0, 1)
    return r


def _model_rms(state, val) -> float | str:
    """Validation RMS of the loop's calibration through the bit-exact core (fringe_trim carrying the
    added corrections), or which correction keeps it in the float engine."""
    from ..cli.engines import run_engine
    from ..hardware.closed_loop import unsupported
    from ..loop.evaluation import evaluate

    if unsupported(state.cal):
        return "float only: " + ", ".join(unsupported(state.cal))
    return round(evaluate(state, val, run_engine("model", state.cal, val, None)).rms, 4)


def loop_scenarios(samples: int = 100_000) -> dict:
    from ..loop.run import run_loop
    from ..loop.scenarios import SCENARIOS, scenario

    rows = {}
    for name in SCENARIOS:
        cfg, expected = scenario(name, samples)
        val = measurement_of(simulate(cfg, 2))
        base, state, rep = run_loop(measurement_of(simulate(cfg, 1)), cfg.encoder(), val)
        found = [e["name"] for e in rep["effects_added"]]
        floor = noise_floor_arcsec(state.cal, cfg, 2)
        rows[name] = {"expected": sorted(expected), "found": found, "named_right": set(found) == expected,
                      "rms_before_arcsec": rep["before"]["rms_arcsec"], "rms_after_arcsec": rep["after"]["rms_arcsec"],
                      "rms_after_model_arcsec": _model_rms(state, val), "floor_arcsec": round(floor, 4),
                      "within_25pct_of_floor": rep["after"]["rms_arcsec"] <= 1.25 * floor}
    return {"setup": f"seed encoder + effect, {samples} samples, fitted on seed 1, validated on seed 2", "cases": rows}


def loop_rm44(folder: str) -> dict | str:
    from ..loop.run import run_loop

    def one(train, val) -> dict:
        _, state, rep = run_loop(train, RM44_ENCODER, val)
        return {
            "rms_before_arcsec": rep["before"]["rms_arcsec"], "rms_after_arcsec": rep["after"]["rms_arcsec"],
            "rms_after_model_arcsec": _model_rms(state, val),
            "noise_floor_arcsec": rep["noise_floor_arcsec"],
            "added": [e["name"] for e in rep["effects_added"]],
            "left": [f"{u['domain']}: {u['rms_arcsec']}" for u in rep["unexplained"]
                     if u["rms_arcsec"] is not None and u["domain"] != "noise"]}

    rows = _per_rm44_file(folder, one)
    if isinstance(rows, str):
        return rows
    return {"setup": "fringe loop, fitted on the even samples, validated on the odd ones", "files": rows}


def _written_by(path: str, target: str) -> dict | str:
    """The JSON a make target wrote, or why it is not there."""
    if not os.path.exists(path):
        return f"not run: make {target} writes {path} (make bench runs it first)"
    with open(path) as f:
        return json.load(f)


def synthesis(out_dir: str) -> dict | str:
    """The figures of the last `make synth` (sim/synth.py writes OUT/synth.json)."""
    return _written_by(os.path.join(out_dir, "synth.json"), "synth")


def synthesis_families(out_dir: str) -> dict | str:
    """Gowin, Nexus and GateMate (`make synth-families`: OUT/families/synth.json)."""
    return _written_by(os.path.join(out_dir, "families", "synth.json"), "synth-families")


def formal(out_dir: str) -> dict | str:
    """The proofs of the last `make formal` (sim/formal/run.py writes OUT/formal.json)."""
    return _written_by(os.path.join(out_dir, "formal.json"), "formal")


def _table(header: list[str], rows) -> list[str]:
    """A Markdown table: the header line, the rule, a line per row of cells."""
    return (["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])


def _files_table(part: dict | str, header: list[str], row) -> list[str]:
    """A section's setup and its table of files (``row(name, figures)``: the cells), or why it was not run."""
    if isinstance(part, str):
        return [part]
    return [part["setup"], "", *_table(header, (row(name, f) for name, f in part["files"].items()))]


def markdown(results: dict) -> str:
    lines = [f"# fringe bench ({results['meta']['date']}, {results['meta']['machine']})", ""]
    acc = results["seed_preset"]
    lines += ["## Seed-encoder preset (arcsec)", "", acc["setup"], ""]
    lines += _table(["method", "RMS", "p-p", "interp p-p", "long-period p-p"],
                    ([k, f"{acc[k]['rms_arcsec']:.3f}", f"{acc[k]['pp_arcsec']:.2f}",
                      f"{acc[k]['interp_pp_arcsec']:.3f}", f"{acc[k]['lp_pp_arcsec']:.3f}"]
                     for k in ("uncorrected", "ellipse_only", "seed_method", "fringe_float", "fringe_model")))
    lines += ["", f"Noise floor (RMS): float {acc['noise_floor_rms_arcsec']}\", bit-exact core "
              f"{acc['noise_floor_model_rms_arcsec']}\"; core {acc['core_config']}; model error budget "
              f"{acc['model_error_budget_arcsec']}; targets: {acc['targets']}", ""]
    sp = results["speed"]
    lines += ["## Speed", "", f"calibrate {sp['samples']} samples: {sp['calibrate_s']} s; "
              f"correct --engine float: {sp['correct_float_samples_per_s']:,} samples/s; --engine model: "
              f"{sp['correct_model_samples_per_s']:,} samples/s; targets: {sp['targets']}", ""]
    lines += ["## RM44 real data (arcsec)", ""]
    lines += _files_table(results["rm44"], ["file", "raw RMS", "raw p-p", "ellipse RMS", "corrected RMS",
                                            "corrected p-p", "noise"],
                          lambda name, f: [name] + [f[k] for k in ("raw_rms_arcsec", "raw_pp_arcsec",
                                                                   "ellipse_rms_arcsec", "corrected_rms_arcsec",
                                                                   "corrected_pp_arcsec", "noise_estimate_arcsec")])
    lines += ["", "## Closed loop on simulated effects (arcsec)", ""]
    lc = results["loop_scenarios"]
    lines += [lc["setup"], ""]
    lines += _table(["case", "expected", "found", "RMS before", "after (float)", "after (bit-exact core)", "floor",
                     "named right", "<= 1.25 floor"],
                    ([name, ", ".join(r["expected"]) or "-", ", ".join(r["found"]) or "-", r["rms_before_arcsec"],
                      r["rms_after_arcsec"], r["rms_after_model_arcsec"], r["floor_arcsec"], r["named_right"],
                      r["within_25pct_of_floor"]] for name, r in lc["cases"].items()))
    lines += ["", "## Closed loop on the RM44 recordings (arcsec)", ""]
    lines += _files_table(results["loop_rm44"], ["file", "before", "after (float)", "after (bit-exact core)", "noise",
                                                 "added", "left"],
                          lambda name, r: [name, r["rms_before_arcsec"], r["rms_after_arcsec"],
                                           r["rms_after_model_arcsec"], r["noise_floor_arcsec"],
                                           ", ".join(r["added"]) or "-", "; ".join(r["left"]) or "-"])
    lines += ["", "## Seed 000 Fig. 4: DE vs DE+SA", "", "```", json.dumps(results["de_vs_desa"], indent=1), "```", ""]
    lines += ["## Synthesis (make synth: Yosys + nextpnr)", ""]
    sy = results["synthesis"]
    if isinstance(sy, str):
        lines.append(sy)
    else:
        lines += _table(["config", "device", "LUT", "FF", "DSP", "BRAM", "Fmax MHz", "target", "meets",
                         "latency (cycles)"],
                        ([r["config"], r["device"]] + [r.get(k) for k in ("luts", "flip_flops", "dsp", "bram",
                                                                           "fmax_mhz", "target_mhz", "meets_target",
                                                                           "latency_cycles")] for r in sy["runs"]))
    lines.append("")
    for name, render in OTHER_SECTIONS.items():     # sections with their own renderer, else JSON
        if name not in results:
            continue
        if render is not None and not isinstance(results[name], str):
            lines += [render(results[name]), ""]
        else:
            lines += [f"## {name}", "", "```json", json.dumps(results[name], indent=1, default=str), "```", ""]
    return "\n".join(lines)


OTHER_SECTIONS = {"reference_free": reference_free_markdown, "real_vs_plain_fit": None, "one_line_population": None,
                  "io_and_memory": None, "loop_population": None, "loop_speed": None,
                  "drift_startup": None, "rtl_engine_speed": None,
                  "synthesis_families": None, "formal": None}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="fringe.tools.bench", description=__doc__)
    p.add_argument("--out", default="results")
    p.add_argument("--quick", action="store_true", help="smaller runs (for a smoke test)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    results = {"meta": {"fringe": __version__, "date": time.strftime("%Y-%m-%d %H:%M"),
                        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"}}
    steps = [("seed_preset", lambda: seed_preset_accuracy(40_000 if a.quick else 200_000)),
             ("speed", lambda: speed(100_000 if a.quick else 1_000_000)),
             ("rm44", lambda: rm44(SHARED_DATA)),
             ("loop_scenarios", lambda: loop_scenarios(40_000 if a.quick else 100_000)),
             ("loop_rm44", lambda: loop_rm44(SHARED_DATA)),
             ("de_vs_desa", de_vs_desa),
             ("reference_free", lambda: reference_free_bench(SHARED_DATA)),
             ("real_vs_plain_fit", lambda: real_vs_plain_bench(SHARED_DATA)),
             ("one_line_population", lambda: simulated_bench(6 if a.quick else 24, 2000)),
             ("io_and_memory", lambda: io_and_memory(a.quick)),
             ("loop_population", lambda: population_bench(20 if a.quick else 200, 9000, workers=2)),
             ("loop_speed", lambda: loop_speed(200_000 if a.quick else 1_000_000)),
             ("drift_startup", lambda: drift_startup(10 if a.quick else 30)),
             ("rtl_engine_speed", lambda: engine_speed(samples=100_000 if a.quick else 1_000_000)),
             ("synthesis", lambda: synthesis(a.out)),
             ("synthesis_families", lambda: synthesis_families(a.out)),
             ("formal", lambda: formal(a.out))]
    for name, fn in steps:
        t0 = time.perf_counter()
        print(f"bench: {name} ...", flush=True)
        results[name] = fn()
        print(f"bench: {name} done in {time.perf_counter() - t0:.1f} s", flush=True)
    with open(os.path.join(a.out, "bench.json"), "w") as f:
        json.dump(results, f, indent=2, default=lambda o: o.item() if hasattr(o, "item") else str(o))
    md = markdown(results)
    with open(os.path.join(a.out, "bench.md"), "w") as f:
        f.write(md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
