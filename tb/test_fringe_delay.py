"""fringe_delay RTL (Verilog and VHDL): out_valid and out_data equal the model after every clock.

The reference is the bit-exact model ``fringe.fixed.delay``: the word that went in with in_valid comes
out with out_valid after DEPTH clock enables; rst clears the valid stages only; ce = 0 freezes
everything; DEPTH = 0 is a wire. The stimulus is drawn first (full speed, then random gaps and
stalls with a reset in mid-stream, then a flush), the model computes both outputs after every
clock, and the simulation compares them (out_data wherever the model's data stages are loaded).
Parameter sets are drawn at random (WIDTH 1..64, DEPTH 2..40) from a fixed seed, plus DEPTH 0 and 1
(the cases the hand-copied shift registers got wrong).
Replay: ``FRINGE_SEED=<seed> pytest tb/test_fringe_delay.py``.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from lib.cocotb_optional import cocotb
from lib.launch import run_seeded

from fringe.fixed.delay import DelayParams, delay

TOPLEVEL = "fringe_delay"
DEFAULT_SEED = 20261201

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge, Timer


def _config() -> tuple[DelayParams, int]:
    raw = json.loads(os.environ["FRINGE_DELAY_PARAMS"])
    return DelayParams(width=int(raw["WIDTH"]), depth=int(raw["DEPTH"])), \
        int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))


def stimulus(rng: np.random.Generator, width: int, depth: int) -> dict[str, list[int]]:
    """rst, ce, in_valid and in_data per clock: a reset, 400 clocks at full speed, 1200 with gaps
    (in_valid 0.6) and stalls (ce 0.7) and a reset over clocks 600 and 601 of them, then a flush
    (in_valid 0, ce 0.5) long enough for the words in flight to come out."""
    n_flush = 8 * depth + 20
    rst = [1] + [0] * 400 + [int(i in (600, 601)) for i in range(1200)] + [0] * n_flush
    ce = [1] * 401 + [int(rng.random() < 0.7) for _ in range(1200)] + \
        [int(rng.random() < 0.5) for _ in range(n_flush)]
    valid = [0] + [1] * 400 + [int(rng.random() < 0.6) for _ in range(1200)] + [0] * n_flush
    return {"rst": rst, "ce": ce, "in_valid": valid, "in_data": [word(rng, width) for _ in rst]}


def word(rng: np.random.Generator, width: int) -> int:
    """A random u(WIDTH) word."""
    return int(rng.integers(0, 1 << width, dtype=np.uint64)) if width < 64 else \
        int(rng.integers(0, 1 << 62)) << 2 | int(rng.integers(0, 4))


if cocotb is not None:
    from lib.clock import start_clock

    @cocotb.test()
    async def delay_stream(dut):
        """Random words at full speed, with gaps and stalls, and a reset in mid-stream."""
        prm, seed = _config()
        rng = np.random.default_rng(seed)
        tag = f"seed {seed}, WIDTH {prm.width}, DEPTH {prm.depth}"
        dut._log.info("%s (replay with FRINGE_SEED=%d)", tag, seed)

        if prm.depth == 0:   # a wire: the output follows the input at once, whatever clk, rst, ce do
            st = {k: [int(v) for v in rng.integers(0, 2, 300)] for k in ("in_valid", "rst", "ce")}
            st["in_data"] = [word(rng, prm.width) for _ in range(300)]
            want_v, want_d = delay(st["in_valid"], st["in_data"], st["ce"], st["rst"], prm)
            for i in range(300):
                for name in ("in_valid", "in_data", "rst", "ce"):
                    getattr(dut, name).value = st[name][i]
                await Timer(1, unit="ns")
                got = (int(dut.out_valid.value), int(dut.out_data.value))
                if got != (int(want_v[i]), want_d[i]):
                    raise AssertionError(f"[{tag}] step {i}: out = ({got[0]}, {got[1]:#x}), model = "
                                         f"({int(want_v[i])}, {want_d[i]:#x})")
            return

        st = stimulus(rng, prm.width, prm.depth)
        want_v, want_d = delay(st["in_valid"], st["in_data"], st["ce"], st["rst"], prm)
        await start_clock(dut)
        n_words = 0
        for cyc in range(len(st["ce"])):
            for name in ("rst", "ce", "in_valid", "in_data"):
                getattr(dut, name).value = st[name][cyc]
            await RisingEdge(dut.clk)
            await ReadOnly()
            got_v = int(dut.out_valid.value)
            if got_v != int(want_v[cyc]):
                raise AssertionError(f"[{tag}] clock {cyc} (rst {st['rst'][cyc]}, ce {st['ce'][cyc]}): "
                                     f"out_valid = {got_v}, model {int(want_v[cyc])}")
            if want_d[cyc] is not None:   # (before the stages are loaded the RTL's data is undefined)
                got_d = int(dut.out_data.value)
                if got_d != want_d[cyc]:
                    raise AssertionError(f"[{tag}] clock {cyc} (ce {st['ce'][cyc]}, out_valid {got_v}): "
                                         f"out_data = {got_d:#x}, model {want_d[cyc]:#x}")
            n_words += bool(want_v[cyc]) and bool(st["ce"][cyc])
            await FallingEdge(dut.clk)
        if n_words < 800:   # 400 at full speed + about 500 of 1200 with gaps and stalls
            raise AssertionError(f"[{tag}] only {n_words} words checked")
        dut._log.info("%s: %d words checked (and both outputs after every clock)", tag, n_words)


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


@pytest.mark.parametrize("params", [{"WIDTH": 0, "DEPTH": 1}, {"WIDTH": 8, "DEPTH": -1}],
                         ids=lambda p: f"W{p['WIDTH']}-D{p['DEPTH']}")
def test_illegal_parameters_stop_elaboration(sim, params):
    """The model refuses the parameters, and the HDL stops elaboration with the model's message."""
    from elab_check import assert_refused

    with pytest.raises(ValueError) as refused:
        DelayParams(width=params["WIDTH"], depth=params["DEPTH"])
    assert_refused(TOPLEVEL, sim, params, str(refused.value))
