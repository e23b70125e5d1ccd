"""fringe_regs (Verilog and VHDL): the register file, CTRL and the write decode against a model.

The model (below, from the register map fringe.fixed.regmap): a write presented at clock edge n is
decoded at edge n+1 (the table strobes wr_* with word, bank and data, for one clock) and lands at
edge n+LATENCY (regmap's); its bank is the one inactive before edge n; register words are 0..N_REGS-1 of space 0, a
write of bit CTRL_SWAP to CTRL_WORD flips active_bank at edge n+LATENCY; a table word outside its bank
(the bank sizes from the generics) and unknown spaces are ignored. Random traffic (fixed seed):
writes to every space, in and out of range, CTRL swaps, idle clocks; after every edge both banks of
the register file, active_bank and the strobes are compared. Replay: ``FRINGE_SEED=<seed>``.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from lib.cocotb_optional import cocotb

from fringe.fixed.regmap import CTRL_SWAP, CTRL_WORD, LATENCY, N_REGS, REG_W, SPACES

TOPLEVEL = "fringe_regs"
SEED = int(os.environ.get("FRINGE_SEED", 20261203))

# (generics, with REGS_INIT)
CONFIGS = [
    ({"WAVE_ADDR_W": 8, "LP_ADDR_W": 8, "MAP_PSI_W": 4, "MAP_PHI_W": 6, "FWD_W": 6}, False),
    ({"WAVE_ADDR_W": 3, "LP_ADDR_W": 5, "MAP_PSI_W": 0, "MAP_PHI_W": 2, "FWD_W": 4}, True),
]
STROBES = ("wr_sin", "wr_cos", "wr_lp", "wr_trim", "wr_fwd")


def bank_words(g: dict) -> dict[int, int]:
    """Words per bank of each table space."""
    trim = 1 << (1 + g["MAP_PSI_W"] + g["MAP_PHI_W"])
    return {SPACES["wave_sin"]: 2 << g["WAVE_ADDR_W"], SPACES["wave_cos"]: 2 << g["WAVE_ADDR_W"],
            SPACES["long_period"]: 1 << g["LP_ADDR_W"], SPACES["trim_map"]: trim, SPACES["trim_speed"]: trim,
            SPACES["trim_amp"]: trim, SPACES["drift_fwd_sin"]: 1 << g["FWD_W"],
            SPACES["drift_fwd_cos"]: 1 << g["FWD_W"]}


def decode(g: dict, space: int, word: int, data: int) -> dict:
    """The strobes of one presented write, and whether it writes a register or swaps the banks."""
    out = {s: 0 for s in STROBES} | {"wr_trim_sel": None, "wr_fwd_sel": None, "reg": None, "swap": False}
    size = bank_words(g).get(space)
    if space == SPACES["regs"]:
        out["reg"] = word if word < N_REGS else None
        out["swap"] = word == CTRL_WORD and bool(data >> CTRL_SWAP & 1)
    elif size is not None and word < size:
        name = {1: "wr_sin", 2: "wr_cos", 3: "wr_lp", 4: "wr_trim", 5: "wr_trim", 6: "wr_trim",
                7: "wr_fwd", 8: "wr_fwd"}[space]
        out[name] = 1
        if name == "wr_trim":
            out["wr_trim_sel"] = space - SPACES["trim_map"]
        if name == "wr_fwd":
            out["wr_fwd_sel"] = space - SPACES["drift_fwd_sin"]
    return out


def image(seed: int) -> list[int]:
    rng = np.random.default_rng(seed)
    return [int(rng.integers(0, 1 << REG_W)) for _ in range(2 * N_REGS)]


# --------------------------------------------------------------------------- cocotb side

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock

    @cocotb.test()
    async def regs_traffic(dut):
        cfg = json.loads(os.environ["FRINGE_CFG"])
        g, seed = cfg["generics"], cfg["seed"]
        tag = f"seed {seed}, {g}, init {cfg['init']}"
        rng = np.random.default_rng(seed)
        regs = image(seed) if cfg["init"] else [0] * (2 * N_REGS)
        bank = 0
        sizes = bank_words(g)
        dut.cfg_wr_en.value, dut.cfg_wr_addr.value, dut.cfg_wr_data.value = 0, 0, 0
        await start_clock(dut)
        pipe: list[dict | None] = [None] * LATENCY   # the writes presented at the last LATENCY edges
        n_reg = n_tab = n_swap = 0
        for cyc in range(3000):
            en = int(rng.random() < 0.6)
            space = int(rng.choice([0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 15]))
            limit = 0x90 if space == 0 else 2 * sizes.get(space, 64)
            word = CTRL_WORD if space == 0 and rng.random() < 0.1 else int(rng.integers(0, limit))
            data = int(rng.integers(0, 1 << 62)) << 2 | int(rng.integers(0, 4))
            dut.cfg_wr_en.value = en
            dut.cfg_wr_addr.value = space << 16 | word
            dut.cfg_wr_data.value = data
            now = {"dec": decode(g, space, word, data), "word": word, "data": data, "bank": 1 - bank} if en else None
            await RisingEdge(dut.clk)
            await ReadOnly()
            landing = pipe[0]
            if landing is not None:          # presented LATENCY edges ago: lands now
                d = landing["dec"]
                if d["reg"] is not None:
                    regs[landing["bank"] * N_REGS + d["reg"]] = landing["data"] & ((1 << REG_W) - 1)
                    n_reg += 1
                if d["swap"]:
                    bank ^= 1
                    n_swap += 1
            pipe = pipe[1:] + [now]
            got = int(dut.regs_q.value)
            for i in range(2 * N_REGS):
                w = got >> (REG_W * i) & ((1 << REG_W) - 1)
                if w != regs[i]:
                    raise AssertionError(f"[{tag}] cycle {cyc}: bank {i // N_REGS} register {i % N_REGS} = "
                                         f"{w:#x}, model {regs[i]:#x}")
            if int(dut.active_bank.value) != bank:
                raise AssertionError(f"[{tag}] cycle {cyc}: active_bank {int(dut.active_bank.value)}, model {bank}")
            decoded = pipe[-2]               # presented one edge ago: its strobes are out now
            exp = decoded["dec"] if decoded else decode(g, 15, 0, 0)
            for s in STROBES:
                if int(getattr(dut, s).value) != exp[s]:
                    raise AssertionError(f"[{tag}] cycle {cyc}: {s} = {int(getattr(dut, s).value)}, model {exp[s]}")
            if decoded and any(exp[s] for s in STROBES):
                n_tab += 1
                got_w = (int(dut.wr_word.value), int(dut.wr_bank.value), int(dut.wr_data.value))
                if got_w != (decoded["word"], decoded["bank"], decoded["data"]):
                    raise AssertionError(f"[{tag}] cycle {cyc}: (wr_word, wr_bank, wr_data) = {got_w}, model "
                                         f"{(decoded['word'], decoded['bank'], decoded['data'])}")
                for sel in ("wr_trim_sel", "wr_fwd_sel"):
                    if exp[sel] is not None and int(getattr(dut, sel).value) != exp[sel]:
                        raise AssertionError(f"[{tag}] cycle {cyc}: {sel} = {int(getattr(dut, sel).value)}, "
                                             f"model {exp[sel]}")
            await FallingEdge(dut.clk)
        if min(n_reg, n_tab, n_swap) < 20:
            raise AssertionError(f"[{tag}] too few writes: {n_reg} registers, {n_tab} table words, {n_swap} swaps")
        dut._log.info("[%s] %d register writes, %d table writes, %d swaps checked", tag, n_reg, n_tab, n_swap)


# --------------------------------------------------------------------------- pytest launcher


@pytest.mark.parametrize("case", range(len(CONFIGS)), ids=lambda i: f"cfg{i}")
def test_fringe_regs(sim, case):
    from cocotb_runner import run_block
    from fringe.fixed.table_ram import write_hex

    generics, init = CONFIGS[case]
    seed = SEED + case
    params: dict[str, object] = dict(generics)
    if init:
        path = Path(tempfile.gettempdir()) / "fringe_tb" / f"regs_s{seed}.hex"
        params["REGS_INIT"] = write_hex(path, image(seed), REG_W, [f"tb/test_fringe_regs.py image, seed {seed}"])
    print(f"fringe_regs {sim} {params} (replay: FRINGE_SEED={SEED})")
    run_block(TOPLEVEL, "test_fringe_regs", params, sim=sim, timeout_s=300,
              extra_env={"FRINGE_CFG": json.dumps({"generics": generics, "init": init, "seed": seed})})
