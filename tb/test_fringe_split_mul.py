"""fringe_split_mul RTL (Verilog and VHDL): p is the exact product a * b, LATENCY clock enables later.

The model is Python's integer product. Operands are random over their whole range (with the
extremes, where a split into chunks would lose a carry or a sign, drawn often), a new pair on
every clock, ce random: after every edge the output must be the product of the pair that has seen
exactly LATENCY clock enables. Parameter sets: a fixed seed draws widths 1..80, signedness,
LATENCY 2..5 and chunk widths LO_W 4..17, plus the corners 1 x 1 bits, one 18 x 18 multiplier and
two of LATENCY 1 (the unregistered sum: fringe_quadrature's 20 x 19 bits, and 45 x 7 in 6-bit chunks).
Replay: ``FRINGE_SEED=<seed> pytest tb/test_fringe_split_mul.py``.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from lib.cocotb_optional import cocotb
from lib.launch import block_env

TOPLEVEL = "fringe_split_mul"
DEFAULT_SEED = 20261202

if cocotb is not None:
    from cocotb.triggers import FallingEdge


def operand(rng: np.random.Generator, width: int, is_signed: bool) -> int:
    """A random operand of ``width`` bits: one time in four an extreme (min, max, 0, -1, 1), else uniform."""
    lo, hi = (-(1 << (width - 1)), (1 << (width - 1)) - 1) if is_signed else (0, (1 << width) - 1)
    if rng.random() < 0.25:
        return int(rng.choice([v for v in (lo, hi, 0, -1, 1) if lo <= v <= hi]))
    raw = int.from_bytes(rng.bytes((width + 7) // 8), "little") & ((1 << width) - 1)
    return raw - (1 << width) if is_signed and raw >> (width - 1) else raw


if cocotb is not None:
    from pipeline_check import start_clock

    @cocotb.test()
    async def split_mul_products(dut):
        """A new random pair every clock, ce random; every output word is checked."""
        params = json.loads(os.environ["FRINGE_SPLIT_MUL_PARAMS"])
        seed = int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))
        a_w, b_w, latency = params["A_W"], params["B_W"], params["LATENCY"]
        a_signed, b_signed = bool(params["A_SIGNED"]), bool(params["B_SIGNED"])
        p_w = a_w + b_w
        rng = np.random.default_rng([seed, a_w, b_w, latency])
        tag = f"seed {seed}, {params}"
        dut._log.info("%s (replay with FRINGE_SEED=%d)", tag, seed)

        await start_clock(dut)
        taken: list[tuple[int, int]] = []    # the pairs presented on clocks with ce = 1
        checked = 0
        for cyc in range(1500):
            if len(taken) >= latency:
                a, b = taken[-latency]
                want = (a * b) & ((1 << p_w) - 1)
                got = int(dut.p.value)
                if got != want:
                    raise AssertionError(f"[{tag}] clock {cyc}: p = {got:#x}, want {a} * {b} = {a * b} "
                                         f"({want:#x})")
                checked += 1
            a, b = operand(rng, a_w, a_signed), operand(rng, b_w, b_signed)
            ce = int(cyc < 200 or rng.random() < 0.7)
            dut.a.value = a & ((1 << a_w) - 1)
            dut.b.value = b & ((1 << b_w) - 1)
            dut.ce.value = ce
            if ce:
                taken.append((a, b))
            await FallingEdge(dut.clk)
        if checked < 1000:
            raise AssertionError(f"[{tag}] only {checked} products checked")
        dut._log.info("%s: %d products checked", tag, checked)


# ============================================================================ pytest side

def param_sets(seed: int = DEFAULT_SEED, n_random: int = 4) -> list[dict[str, int]]:
    rng = np.random.default_rng(seed)
    sets = [{"A_W": 1, "A_SIGNED": 0, "B_W": 1, "B_SIGNED": 1, "LATENCY": 2, "LO_W": 17},
            {"A_W": 18, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 1, "LATENCY": 2, "LO_W": 17},
            {"A_W": 20, "A_SIGNED": 1, "B_W": 19, "B_SIGNED": 1, "LATENCY": 1, "LO_W": 17},
            {"A_W": 45, "A_SIGNED": 0, "B_W": 7, "B_SIGNED": 1, "LATENCY": 1, "LO_W": 6}]
    sets += [{"A_W": int(rng.integers(1, 81)), "A_SIGNED": int(rng.integers(0, 2)),
              "B_W": int(rng.integers(1, 81)), "B_SIGNED": int(rng.integers(0, 2)),
              "LATENCY": int(rng.integers(2, 6)), "LO_W": int(rng.integers(4, 18))} for _ in range(n_random)]
    return sets


PARAM_SETS = param_sets(int(os.environ.get("FRINGE_SEED", DEFAULT_SEED)))


def _id(p: dict[str, int]) -> str:
    return f"{'us'[p['A_SIGNED']]}{p['A_W']}x{'us'[p['B_SIGNED']]}{p['B_W']}-L{p['LATENCY']}-C{p['LO_W']}"


@pytest.mark.parametrize("params", PARAM_SETS, ids=[_id(p) for p in PARAM_SETS])
def test_fringe_split_mul(sim, params):
    from cocotb_runner import run_block

    env = block_env("FRINGE_SPLIT_MUL_PARAMS", params, DEFAULT_SEED)
    print(f"fringe_split_mul: seed {env['FRINGE_SEED']}, {params}")
    run_block(TOPLEVEL, "test_fringe_split_mul", params, sim=sim, timeout_s=300, extra_env=env)
