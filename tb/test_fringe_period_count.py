"""fringe_period_count (Verilog and VHDL) against the bit-exact model, every output word exactly.

The block has state (previous phase, the period counter), so the expected words come from a
per-sample reference that advances only on accepted samples (ce = 1, in_valid = 1, no reset);
`test_reference_matches_vectorised_model` ties it to the vectorised model the core uses.
Traffic: trajectories with reversals, wraps and exact quarter-period jumps, wrong coarse codes,
random in_valid gaps and ce stalls, resets in mid-stream.
"""

from __future__ import annotations

import json
import os
from collections import deque

import numpy as np
import pytest

from fringe.fixed.period_count import PeriodCountParams, period_count

TOPLEVEL = "fringe_period_count"
LATENCY = 2
DEFAULT_SEED = 4242

PARAM_SETS = [(16, 256, 9), (12, 100, 8), (16, 1, 0), (14, 3, 0)]


class Reference:
    """One sample at a time, exactly as the RTL (and the vectorised model over a stream)."""

    def __init__(self, p: PeriodCountParams):
        self.p = p
        self.reset()

    def reset(self):
        self.prev = None
        self.pos = None

    def step(self, phase: int, coarse: int, ofs: int) -> tuple[int, int, int]:
        p = self.p
        half = 1 << (p.fine_w - 1)
        delta = 0 if self.prev is None else ((phase - self.prev + half) % (1 << p.fine_w)) - half
        fast = int(self.prev is not None and abs(delta) >= (1 << (p.fine_w - 2)))
        if p.coarse_w:
            pos, _, err = period_count(np.array([phase]), np.array([coarse]), ofs, p)
            pos, err = int(pos[0]), int(err[0])
        else:
            pos = phase if self.pos is None else (self.pos + delta) % p.rev
            err = 0
        self.prev, self.pos = phase, pos
        return pos, fast, err


def stimulus(p: PeriodCountParams, rng: np.random.Generator, n: int):
    """Phases of a wandering position (with exact quarter-period jumps), coarse codes, a few wrong."""
    step = np.cumsum(rng.normal(0, 0.002, n)) + rng.normal(0, 0.02, n)
    jumps = rng.random(n) < 0.03
    step[jumps] = rng.choice([0.25, -0.25, 0.2499, 0.3], jumps.sum())
    true = np.mod(np.cumsum(step) * (1 << p.fine_w) + rng.uniform(0, p.rev), p.rev).astype(np.int64)
    phase = true & ((1 << p.fine_w) - 1)
    if p.coarse_w:
        span = p.rev >> p.coarse_w if (p.rev >> p.coarse_w) << p.coarse_w == p.rev else p.rev / (1 << p.coarse_w)
        misalign = int(0.1 * (1 << p.fine_w))
        coarse = (np.floor((true + misalign) / span).astype(np.int64)) % (1 << p.coarse_w)
        bad = rng.random(n) < 0.02
        coarse[bad] = (coarse[bad] + rng.integers(1, 4, bad.sum())) % (1 << p.coarse_w)
        ofs = int(round(span / 2)) - misalign
    else:
        coarse = np.zeros(n, dtype=np.int64)
        ofs = 0
    return phase, coarse, ofs


def test_reference_matches_vectorised_model():
    for fw, lines, cw in PARAM_SETS:
        p = PeriodCountParams(fw, lines, cw)
        phase, coarse, ofs = stimulus(p, np.random.default_rng(1), 3000)
        ref = Reference(p)
        one = np.array([ref.step(int(a), int(b), ofs) for a, b in zip(phase, coarse, strict=True)])
        pos, fast, err = period_count(phase, coarse, ofs, p)
        np.testing.assert_array_equal(one[:, 0], pos)
        np.testing.assert_array_equal(one[:, 1], fast)
        np.testing.assert_array_equal(one[:, 2], err)


try:
    import cocotb
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
except ImportError:  # pragma: no cover
    cocotb = None

if cocotb is not None:
    from pipeline_check import lv, start_clock, to_bits

    @cocotb.test()
    async def period_count_stream(dut):
        raw = json.loads(os.environ["FRINGE_PC_PARAMS"])
        p = PeriodCountParams(raw["FINE_W"], raw["LINES"], raw["COARSE_W"])
        seed = int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))
        rng = np.random.default_rng(seed)
        tag = f"seed {seed}, {raw}"
        n = 3000
        phase, coarse, ofs = stimulus(p, rng, n)
        ref = Reference(p)
        await start_clock(dut)
        dut.coarse_ofs.value = to_bits(ofs, p.pos_w + 1)
        dut.in_user.value = 0
        dut.rst.value = 1
        dut.ce.value = 1
        dut.in_valid.value = 0
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)
        inflight: deque = deque()     # [clock enables seen, expected, index]
        i = cyc = 0
        resets = {700, 701, 1900}
        full_speed = 400              # the first samples at full speed, then gaps and stalls
        while i < n or inflight:
            cyc += 1
            if cyc > 20 * n:
                raise AssertionError(f"[{tag}] stream did not drain")
            rst = 1 if cyc in resets else 0
            ce = 1 if (i < full_speed or rng.random() < 0.8) else 0
            valid = 1 if i < n and (i < full_speed or rng.random() < 0.7) else 0
            user = int(rng.integers(0, 2))
            dut.rst.value, dut.ce.value, dut.in_valid.value, dut.in_user.value = rst, ce, valid, user
            if valid:
                dut.phase.value = int(phase[i])
                dut.coarse.value = int(coarse[i]) if p.coarse_w else 0
            else:
                dut.phase.value = int(rng.integers(0, 1 << p.fine_w))
            await RisingEdge(dut.clk)
            await ReadOnly()
            out_valid = lv(dut.out_valid)
            if rst:
                inflight.clear()
                ref.reset()
                if valid:
                    i += 1                # dropped by the reset
                assert out_valid == 0, f"[{tag}] cycle {cyc}: out_valid after reset"
            elif ce:
                for s in inflight:
                    s[0] += 1
                if valid:
                    inflight.append([1, ref.step(int(phase[i]), int(coarse[i]), ofs) + (user,), i])
                    i += 1
                due = bool(inflight) and inflight[0][0] >= LATENCY
                assert out_valid == int(due), f"[{tag}] cycle {cyc}: out_valid {out_valid}, expected {int(due)}"
                if due:
                    _, exp, idx = inflight.popleft()
                    got = (lv(dut.pos), lv(dut.overspeed), lv(dut.coarse_err), lv(dut.out_user))
                    assert got == exp, f"[{tag}] cycle {cyc}: sample {idx}: got {got}, expected {exp}"
            await FallingEdge(dut.clk)


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[f"fine{a}-lines{b}-coarse{c}" for a, b, c in PARAM_SETS])
def test_fringe_period_count(sim, ps):
    from cocotb_runner import run_block

    fw, lines, cw = ps
    params = {"FINE_W": fw, "LINES": lines, "COARSE_W": cw, "USER_W": 1}
    run_block(TOPLEVEL, "test_fringe_period_count", params, sim=sim,
              extra_env={"FRINGE_PC_PARAMS": json.dumps(params)})
