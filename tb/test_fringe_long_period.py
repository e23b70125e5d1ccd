"""fringe_long_period (Verilog and VHDL) against the bit-exact model, every output word exactly.

Tables: bank 0 and bank 1 loaded with different corrections from the init file; in mid-stream
bank 1 is rewritten through the write port while samples read bank 0, then samples switch to
bank 1 and must see the new table. Traffic: random positions with the revolution wrap and both
ends, random zero and direction, full speed, then random gaps, stalls and a reset.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

from fringe.fixed.long_period import LongPeriodParams, index_mapping, long_period, make_table, pack_words

TOPLEVEL = "fringe_long_period"
LATENCY = 6
DEFAULT_SEED = 777

# (LINES, FINE_W, LP_ADDR_W, LP_W, LP_FRAC, LP_IF)
PARAM_SETS = [(256, 16, 8, 18, 4, 8), (100, 12, 6, 16, 3, 6), (1, 16, 10, 18, 4, 8)]


def tables(p: LongPeriodParams, seed: int) -> list[np.ndarray]:
    """Three smooth corrections (a few fine counts to hundreds), as table values."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(3):
        a = rng.uniform(-1, 1, (4, 2)) * min(300.0, 2 ** (p.lp_w - 2 - p.lp_frac))
        out.append(make_table(lambda pos, a=a: sum(a[m, 0] * np.cos((m + 1) * 2 * np.pi * pos / p.rev)
                                                   + a[m, 1] * np.sin((m + 1) * 2 * np.pi * pos / p.rev)
                                                   for m in range(4)) / 4, p))
    return out


def params_of(ps) -> tuple[LongPeriodParams, dict]:
    lines, fw, aw, w, frac, interp = ps
    p = LongPeriodParams(lines, fw, aw, w, frac, interp)
    recip, shift = index_mapping(lines, fw, aw, interp)
    hdl = {"LINES": lines, "FINE_W": fw, "LP_ADDR_W": aw, "LP_W": w, "LP_FRAC": frac, "LP_IF": interp,
           "LP_RECIP": recip, "LP_SHIFT": shift, "USER_W": 2}
    return p, hdl


try:
    import cocotb
except ImportError:  # pragma: no cover
    cocotb = None

if cocotb is not None:
    from pipeline_check import StreamChecker, lv, start_clock

    @cocotb.test()
    async def long_period_stream(dut):
        raw = json.loads(os.environ["FRINGE_LP_PARAMS"])
        p = LongPeriodParams(raw["LINES"], raw["FINE_W"], raw["LP_ADDR_W"], raw["LP_W"], raw["LP_FRAC"], raw["LP_IF"])
        seed = int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))
        rng = np.random.default_rng(seed)
        t0, t1, t1_new = tables(p, 5)
        bank_tables = np.array([t0, t1])
        new_words = pack_words(t1_new, p)
        n_entries = 1 << p.lp_addr_w
        await start_clock(dut)
        from cocotb.triggers import FallingEdge, RisingEdge
        dut.rst.value, dut.ce.value, dut.in_valid.value = 1, 1, 0      # power-up reset
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)
        dut.wr_en.value = 0
        dut.wr_addr.value = 0
        dut.wr_data.value = 0
        checker = StreamChecker(dut, LATENCY, lambda: (lv(dut.pos_out), lv(dut.out_user)), f"seed {seed}")
        edge = [0, 1, p.rev - 1, p.rev - 2, p.rev // 2] + [int(k * p.rev / n_entries) for k in range(4)]
        state = {"bank": 0}

        def make_sample(cyc):
            pos = int(rng.choice(edge)) if rng.random() < 0.1 else int(rng.integers(0, p.rev))
            zero = int(rng.integers(0, p.rev)) if rng.random() < 0.5 else 0
            direction = int(rng.integers(0, 2))
            user = int(rng.integers(0, 4))
            b = state["bank"]
            dut.pos.value, dut.zero.value, dut.dir.value = pos, zero, direction
            dut.bank.value, dut.in_user.value = b, user
            exp = long_period(np.array([pos]), bank_tables[b], zero, direction, p)
            return int(exp[0]), user

        def make_idle(cyc):
            dut.pos.value = int(rng.integers(0, p.rev))

        # full speed on the two init banks, then gaps, stalls and a reset
        for phase_cycles, p_valid, p_ce, resets in ((300, 1.0, 1.0, ()), (600, 0.7, 0.8, (350,))):
            for _ in range(2):
                state["bank"] ^= 1
                await checker.run(phase_cycles // 2, make_sample, make_idle, rng, p_valid, p_ce, resets)
        await checker.flush(make_idle, rng)
        # rewrite bank 1 while samples read bank 0
        state["bank"] = 0
        writes = list(enumerate(new_words))

        def on_cycle(cyc):
            if writes:
                k, w = writes.pop(0)
                dut.wr_en.value = 1
                dut.wr_addr.value = (1 << p.lp_addr_w) | k
                dut.wr_data.value = int(w)
            else:
                dut.wr_en.value = 0

        await checker.run(n_entries + 20, make_sample, make_idle, rng, 0.9, 0.9, (), on_cycle=on_cycle)
        dut.wr_en.value = 0
        await checker.flush(make_idle, rng)
        bank_tables[1] = t1_new
        state["bank"] = 1
        await checker.run(400, make_sample, make_idle, rng, 0.8, 0.8)
        await checker.flush(make_idle, rng)
        assert checker.n_out > 800, checker.n_out     # every one of them compared


def _init_file(ps) -> str:
    """Both banks' words as the RAM's hex image (a fixed path per parameter set: builds are cached)."""
    from fringe.fixed.table_ram import write_hex

    p, _ = params_of(ps)
    t0, t1, _ = tables(p, 5)
    path = Path(tempfile.gettempdir()) / "fringe_tb" / f"lp_{'_'.join(map(str, ps))}.mem"
    write_hex(path, np.concatenate([pack_words(t0, p), pack_words(t1, p)]), 2 * p.lp_w, ["test tables"])
    return str(path)


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[f"L{a}-f{b}-a{c}" for a, b, c, *_ in PARAM_SETS])
def test_fringe_long_period(sim, ps):
    from cocotb_runner import run_block

    p, hdl = params_of(ps)
    if sim == "ghdl" and hdl["LP_RECIP"] >= 1 << 31:
        pytest.skip("LP_RECIP >= 2^31 does not fit a VHDL integer generic (documented limit)")
    path = _init_file(ps)
    env = {"FRINGE_LP_PARAMS": json.dumps(hdl)}
    hdl["INIT_FILE"] = f'"{path}"' if sim == "verilator" else path     # a Verilog string needs its quotes
    if sim == "verilator":
        hdl["LP_RECIP"] = f"64'd{hdl['LP_RECIP']}"                     # a 64-bit parameter
    run_block(TOPLEVEL, "test_fringe_long_period", hdl, sim=sim, extra_env=env)
