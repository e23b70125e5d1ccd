"""fringe_split_mul RTL (Verilog and VHDL): p is the exact product a * b, LATENCY clock enables later.

The reference is the bit-exact model ``fringe.fixed.split_mul`` (the exact product, LATENCY clock
enables later). Operands are random over their whole range (with the extremes, where a split into
chunks would lose a carry or a sign, drawn often), a new pair on every clock, ce random: after every
edge the output must equal the model's p (the product of the pair that has seen exactly LATENCY
clock enables). Parameter sets: a fixed seed draws widths 1..80, signedness,
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

from fringe.fixed.split_mul import SplitMulParams, split_mul

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
    from lib.clock import start_clock

    @cocotb.test()
    async def split_mul_products(dut):
        """A new random pair every clock, ce random; every output word is checked."""
        params = json.loads(os.environ["FRINGE_SPLIT_MUL_PARAMS"])
        seed = int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))
        prm = SplitMulParams(**{k.lower(): int(v) for k, v in params.items()})
        rng = np.random.default_rng([seed, prm.a_w, prm.b_w, prm.latency])
        tag = f"seed {seed}, {params}"
        dut._log.info("%s (replay with FRINGE_SEED=%d)", tag, seed)

        a_in, b_in, ce_in = [], [], []
        for cyc in range(1500):
            a_in.append(operand(rng, prm.a_w, bool(prm.a_signed)))
            b_in.append(operand(rng, prm.b_w, bool(prm.b_signed)))
            ce_in.append(int(cyc < 200 or rng.random() < 0.7))
        want = split_mul(a_in, b_in, ce_in, prm)     # p after every clock (None: not loaded yet)
        p_signed = bool(prm.a_signed or prm.b_signed)

        await start_clock(dut)
        checked = 0
        for cyc in range(1500):
            dut.a.value = a_in[cyc] & ((1 << prm.a_w) - 1)
            dut.b.value = b_in[cyc] & ((1 << prm.b_w) - 1)
            dut.ce.value = ce_in[cyc]
            await FallingEdge(dut.clk)        # (the rising edge in between took them)
            if want[cyc] is not None:
                got = dut.p.value.to_signed() if p_signed else int(dut.p.value)
                if got != want[cyc]:
                    raise AssertionError(f"[{tag}] clock {cyc}: p = {got}, model {want[cyc]} ({got:#x} vs "
                                         f"{want[cyc] & ((1 << prm.p_w) - 1):#x})")
                checked += 1
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


LEGAL = {"A_W": 18, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 1, "LATENCY": 2, "LO_W": 17}


@pytest.mark.parametrize("over", [{"A_W": 0}, {"LATENCY": 0}, {"LO_W": 0}],
                         ids=lambda o: "_".join(f"{k}{v}" for k, v in o.items()))
def test_illegal_parameters_stop_elaboration(sim, over):
    """The model refuses the parameters, and the HDL stops elaboration with the model's message."""
    from elab_check import assert_refused

    params = {**LEGAL, **over}
    with pytest.raises(ValueError) as refused:
        SplitMulParams(**{k.lower(): v for k, v in params.items()})
    assert_refused(TOPLEVEL, sim, params, str(refused.value))
