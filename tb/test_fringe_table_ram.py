"""fringe_table_ram (Verilog and VHDL): initial image, registered reads, writes to the other bank.

- every word of both banks read back after configuration: the $readmemh / std.textio image
  (written by ``fringe.fixed.table_ram.write_hex``), or zeros without INIT_FILE;
- random traffic: reads of the active bank with random ``rd_en`` (``rd_data`` must hold when
  it is 0), writes with random gaps to the inactive bank in the same clocks, bank flips; every
  read compared exactly with a Python model of the memory.
Run: ``pytest tb/test_fringe_table_ram.py`` (``--sims verilator`` or ``ghdl`` to pick one).
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from lib.cocotb_optional import cocotb

TOPLEVEL = "fringe_table_ram"

# (ADDR_W, DATA_W, with INIT_FILE, seed)
PARAM_SETS = [
    (5, 13, True, 11),    # width not a multiple of 4: hex digits padded
    (3, 64, False, 22),   # widest word, no init file: zeros
    # (tb/test_fringe_wave_lut.py runs wave-table sizes: ADDR_W 9 and 11, DATA_W 36 and 40)
]


def _ids(ps):
    return f"addr{ps[0]}_data{ps[1]}_{'init' if ps[2] else 'zero'}"


def image_words(addr_w: int, data_w: int, seed: int) -> np.ndarray:
    """The deterministic initial image of a test configuration (python ints)."""
    rng = np.random.default_rng(seed)
    n = 2 << addr_w
    words = [int(rng.integers(0, 1 << 32)) << 32 | int(rng.integers(0, 1 << 32)) for _ in range(n)]
    words = [w & ((1 << data_w) - 1) for w in words]
    words[0] = (1 << data_w) - 1      # all ones
    words[-1] = 1 << (data_w - 1)     # MSB only
    return np.array(words, dtype=object)


# --------------------------------------------------------------------------- cocotb side

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock
    from lib.pipeline_check import lv

    @cocotb.test()
    async def table_ram_traffic(dut):
        cfg = json.loads(os.environ["FRINGE_CFG"])
        addr_w, data_w, seed = cfg["ADDR_W"], cfg["DATA_W"], cfg["seed"]
        tag = f"seed {seed}, ADDR_W={addr_w} DATA_W={data_w}"
        assert len(dut.rd_addr) == addr_w + 1 and len(dut.rd_data) == data_w
        rng = np.random.default_rng(seed + 1)
        depth = 2 << addr_w
        bank_words = 1 << addr_w
        mem = list(image_words(addr_w, data_w, seed)) if cfg["init"] else [0] * depth
        mem = [int(w) for w in mem]

        dut.wr_en.value = 0
        dut.wr_addr.value = 0
        dut.wr_data.value = 0
        dut.rd_en.value = 0
        dut.rd_addr.value = 0
        await start_clock(dut)

        state = {"last": None}

        async def clock(rd_en, rd_addr, wr_en, wr_addr, wr_data, where):
            dut.rd_en.value = rd_en
            dut.rd_addr.value = rd_addr
            dut.wr_en.value = wr_en
            dut.wr_addr.value = wr_addr
            dut.wr_data.value = wr_data
            exp = mem[rd_addr] if rd_en else state["last"]
            await RisingEdge(dut.clk)
            await ReadOnly()
            if exp is not None:
                got = lv(dut.rd_data)
                if got != exp:
                    raise AssertionError(f"[{tag}] {where}: rd_data {got:#x}, expected {exp:#x} "
                                         f"(rd_en {rd_en}, rd_addr {rd_addr:#x})")
            state["last"] = exp
            if wr_en:
                mem[wr_addr] = wr_data
            await FallingEdge(dut.clk)

        # 1) the initial image, both banks, full speed
        for a in range(depth):
            await clock(1, a, 0, 0, 0, f"initial word {a}")
        # 2) traffic: read the active bank, write the other, flip
        active = 0
        n_reads = n_writes = 0
        for flip in range(6):
            inactive = 1 - active
            pending = list(rng.permutation(bank_words))  # rewrite the whole inactive bank
            cycles = 0
            while pending or cycles < 2 * bank_words:
                cycles += 1
                rd_en = int(rng.random() < 0.8)
                rd_addr = (active << addr_w) | int(rng.integers(0, bank_words))
                wr_en = int(bool(pending) and rng.random() < 0.6)
                word = int(pending.pop()) if wr_en else int(rng.integers(0, bank_words))
                wr_addr = (inactive << addr_w) | word
                wr_data = int(rng.integers(0, 1 << 32)) << 32 | int(rng.integers(0, 1 << 32))
                wr_data &= (1 << data_w) - 1
                await clock(rd_en, rd_addr, wr_en, wr_addr, wr_data, f"flip {flip}, cycle {cycles}")
                n_reads += rd_en
                n_writes += wr_en
            active = inactive
        # 3) every word again
        for a in range(depth):
            await clock(1, a, 0, 0, 0, f"final word {a}")
        dut._log.info(f"[{tag}] {n_reads} reads during {n_writes} writes, all words checked twice")


# --------------------------------------------------------------------------- pytest launcher


def hex_path(addr_w: int, data_w: int, seed: int) -> Path:
    """A fixed path per configuration (the Verilator build keeps the name, not the contents)."""
    return Path(tempfile.gettempdir()) / "fringe_tb" / f"table_ram_a{addr_w}_d{data_w}_s{seed}.hex"


@pytest.mark.parametrize("params, msg", [
    ({"ADDR_W": 0}, "fringe_table_ram: ADDR_W = 0 out of range 1..24"),
    ({"ADDR_W": 25}, "fringe_table_ram: ADDR_W = 25 out of range 1..24"),
    ({"DATA_W": 65}, "fringe_table_ram: DATA_W = 65 out of range 1..64"),
], ids=lambda v: "_".join(f"{k}{x}" for k, x in v.items()) if isinstance(v, dict) else "")
def test_illegal_parameters_stop_elaboration(sim, params, msg):
    from elab_check import assert_refused

    assert_refused(TOPLEVEL, sim, params, msg)


@pytest.mark.parametrize("ps", PARAM_SETS, ids=_ids)
def test_fringe_table_ram(sim, ps):
    from cocotb_runner import run_block
    from fringe.fixed.table_ram import write_hex

    addr_w, data_w, init, seed = ps
    params: dict[str, object] = {"ADDR_W": addr_w, "DATA_W": data_w}
    if init:
        path = write_hex(hex_path(addr_w, data_w, seed), image_words(addr_w, data_w, seed), data_w,
                         [f"tb/test_fringe_table_ram.py image: ADDR_W={addr_w} DATA_W={data_w} seed={seed}",
                          "bank 0 then bank 1"])
        params["INIT_FILE"] = path
    cfg = {"ADDR_W": addr_w, "DATA_W": data_w, "init": init, "seed": seed}
    print(f"fringe_table_ram {sim} {params} seed {seed}")
    run_block(TOPLEVEL, "test_fringe_table_ram", params, sim=sim,
              extra_env={"FRINGE_CFG": json.dumps(cfg)}, timeout_s=120)
