"""fringe_delay RTL (Verilog and VHDL): every word comes out after exactly DEPTH clock enables.

The model is the definition: the word that went in with in_valid comes out with out_valid after
DEPTH clock enables; rst clears the valid stages only; ce = 0 freezes everything; DEPTH = 0 is a
wire. Parameter sets are drawn at random (WIDTH 1..64, DEPTH 2..40) from a fixed seed, plus
DEPTH 0 and 1 (the cases the hand-copied shift registers got wrong).
Replay: ``FRINGE_SEED=<seed> pytest tb/test_fringe_delay.py``.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from lib.cocotb_optional import cocotb
from lib.launch import run_seeded

TOPLEVEL = "fringe_delay"
DEFAULT_SEED = 20261201

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, Timer


def _config() -> tuple[int, int, int]:
    raw = json.loads(os.environ["FRINGE_DELAY_PARAMS"])
    return int(raw["WIDTH"]), int(raw["DEPTH"]), int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))


if cocotb is not None:
    from pipeline_check import StreamChecker, start_clock

    @cocotb.test()
    async def delay_stream(dut):
        """Random words at full speed, with gaps and stalls, and a reset in mid-stream."""
        width, depth, seed = _config()
        rng = np.random.default_rng(seed)
        tag = f"seed {seed}, WIDTH {width}, DEPTH {depth}"
        dut._log.info("%s (replay with FRINGE_SEED=%d)", tag, seed)

        def word() -> int:
            return int(rng.integers(0, 1 << width, dtype=np.uint64)) if width < 64 else \
                int(rng.integers(0, 1 << 62)) << 2 | int(rng.integers(0, 4))

        if depth == 0:   # a wire: the output follows the input at once, whatever clk, rst, ce do
            for i in range(300):
                v, w = int(rng.integers(0, 2)), word()
                dut.in_valid.value, dut.in_data.value = v, w
                dut.rst.value, dut.ce.value = int(rng.integers(0, 2)), int(rng.integers(0, 2))
                await Timer(1, unit="ns")
                if (int(dut.out_valid.value), int(dut.out_data.value)) != (v, w):
                    raise AssertionError(f"[{tag}] step {i}: out = ({int(dut.out_valid.value)}, "
                                         f"{int(dut.out_data.value):#x}), in = ({v}, {w:#x})")
            return

        await start_clock(dut)
        chk = StreamChecker(dut, depth, lambda: (int(dut.out_data.value),), tag)

        def make_sample(_cyc: int) -> tuple:
            w = word()
            dut.in_data.value = w
            return (w,)

        def make_idle(_cyc: int) -> None:
            dut.in_data.value = word()

        dut.rst.value, dut.ce.value, dut.in_valid.value = 1, 1, 0
        await FallingEdge(dut.clk)
        await chk.run(400, make_sample, make_idle, rng)                       # full speed
        await chk.run(1200, make_sample, make_idle, rng, p_valid=0.6, p_ce=0.7,
                      reset_cycles={600, 601})                                 # gaps, stalls, reset
        await chk.flush(make_idle, rng, p_ce=0.5)
        await ReadOnly()
        if chk.n_out < 800:   # 400 at full speed + about 500 of 1200 with gaps and stalls
            raise AssertionError(f"[{tag}] only {chk.n_out} words checked")
        dut._log.info("%s: %d words checked", tag, chk.n_out)


# ============================================================================ pytest side

def param_sets(seed: int = DEFAULT_SEED, n_random: int = 3) -> list[dict[str, int]]:
    rng = np.random.default_rng(seed)
    sets = [{"WIDTH": 1, "DEPTH": 0}, {"WIDTH": 7, "DEPTH": 1}]
    sets += [{"WIDTH": int(rng.integers(1, 65)), "DEPTH": int(rng.integers(2, 41))} for _ in range(n_random)]
    return sets


PARAM_SETS = param_sets()


@pytest.mark.parametrize("params", PARAM_SETS, ids=[f"W{p['WIDTH']}-D{p['DEPTH']}" for p in PARAM_SETS])
def test_fringe_delay(sim, params):
    run_seeded(TOPLEVEL, params, sim, "FRINGE_DELAY_PARAMS", DEFAULT_SEED, 120)
