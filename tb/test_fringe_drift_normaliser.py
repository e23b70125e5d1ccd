"""fringe_drift_normaliser RTL (Verilog and VHDL) against its bit-exact model, every output word and state.

Two halves in one file (the cocotb ``examples/adder`` layout): the cocotb coroutines (``norm_*``), which read
the configuration from ``FRINGE_DRIFT_NORMALISER_PARAMS`` and the seed from ``FRINGE_SEED``, and the pytest
launcher ``test_fringe_drift_normaliser``.

The harness stands in for fringe_drift_observer: for every block of accepted samples it draws the block's
update (a random state, both channels' OFF and GINV over their whole ranges or near the reset state, and its
saturation flag) or a skip, and resolves it a random number of clock enables after the block's last sample
(HOLD = 0: at most D, as the core's latency check guarantees; HOLD = 1: up to 40, the sample at the boundary
waits). It holds the pending update until ``upd_take``, as the observer does. The stimulus: random raw codes
(full scale included), random ce, in_valid and resets, and a full-speed section. Checked:

- ``norm_valid`` exactly LATENCY clock enables after each accepted sample, never after a reset, and the word
  (y_sin, y_cos, norm_sat, norm_user) equal to ``normaliser_run`` with the drawn states (per reset segment);
- the state outputs after every accepted sample equal the model's state of that sample;
- ``upd_take`` exactly at the accepted application samples ``(j+1)B + D``; ``in_ready`` 0 exactly while the
  next sample is an application sample whose update is not resolved (HOLD = 1), always 1 with HOLD = 0.

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_drift_normaliser.py -k ...``.
"""

from __future__ import annotations

from collections import deque
from functools import partial

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import block_config, params_from_hdl, run_seeded, signed

from fringe.fixed.drift_normaliser import LATENCY, NormaliserParams, normaliser_run

TOPLEVEL = "fringe_drift_normaliser"
VAR = "FRINGE_DRIFT_NORMALISER_PARAMS"
DEFAULT_SEED = 4242


params_of = partial(params_from_hdl, NormaliserParams)     # HDL parameters -> the model's


def draw_update(p: NormaliserParams, rng) -> tuple[tuple[int, int, int, int], int] | None:
    """A block's update as the observer would resolve it (None: the block is skipped)."""
    r = rng.random()
    if r < 0.2:
        return None
    olo, ohi = -(1 << (p.ofs_w - 1)), (1 << (p.ofs_w - 1))
    if r < 0.45:       # anywhere: y saturates often
        st = (int(rng.integers(olo, ohi)), int(rng.integers(olo, ohi)), int(rng.integers(0, 1 << p.ginv_w)),
              int(rng.integers(0, 1 << p.ginv_w)))
    else:              # near the reset state: offsets of a few percent of full scale, gains within 20 %
        o = 1 << (p.ofs_w - 5)
        g = p.unity // 5
        st = (int(rng.integers(-o, o)), int(rng.integers(-o, o)), int(rng.integers(p.unity - g, p.unity + g)),
              int(rng.integers(p.unity - g, p.unity + g)))
    return st, int(rng.random() < 0.3)


if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock
    from lib.planned_stream import hdl_constant, measure_latency

    def _state(dut, p):
        return (signed(int(dut.off_sin.value), p.ofs_w), signed(int(dut.off_cos.value), p.ofs_w),
                int(dut.ginv_sin.value), int(dut.ginv_cos.value), int(dut.track_sat.value))

    def _word(dut, p):
        return (signed(int(dut.y_sin.value), p.adc_w), signed(int(dut.y_cos.value), p.adc_w),
                int(dut.norm_sat.value), int(dut.norm_user.value))

    class Observer:
        """The observer's side of the hand-over: the pending update, resolved some clock enables after the
        block's last sample, held until upd_take."""

        def __init__(self, dut, p, rng):
            self.dut, self.p, self.rng = dut, p, rng
            self.reset()

        def reset(self):
            self.valid = self.resolved = 0
            self.value = ((0, 0, 0, 0), 0)
            self.countdown = None          # (clock enables left, the block's update)

        def drive(self):
            d, m = self.dut, self.p
            (os_, oc, gs, gc), sat = self.value
            d.upd_valid.value = self.valid
            d.upd_resolved.value = self.resolved
            d.upd_off_sin.value = os_ & ((1 << m.ofs_w) - 1)
            d.upd_off_cos.value = oc & ((1 << m.ofs_w) - 1)
            d.upd_ginv_sin.value = gs
            d.upd_ginv_cos.value = gc
            d.upd_sat.value = sat

        def block_end(self, upd, full_speed: bool):
            hi = self.p.d if not self.p.hold else (1 if full_speed else 40)
            self.countdown = [int(self.rng.integers(1, hi + 1)), upd]

        def edge(self, take: bool):
            """One enabled clock edge (rst = 0): the countdown, then the take (the resolution wins, as in the RTL)."""
            if self.countdown is not None:
                self.countdown[0] -= 1
                if self.countdown[0] == 0:
                    upd = self.countdown[1]
                    self.resolved = 1
                    if upd is not None:
                        self.valid, self.value = 1, upd
                    self.countdown = None
                    return
            if take:
                self.valid = self.resolved = 0

    @cocotb.test()
    async def norm_latency(dut):
        """One sample: norm_valid exactly LATENCY clocks later, the reset state gives y = raw."""
        raw, user_w, _ = block_config(VAR, DEFAULT_SEED)
        p = params_of(raw)
        await start_clock(dut)
        Observer(dut, p, np.random.default_rng(0)).drive()
        lo = -(1 << (p.adc_w - 1))

        def apply():
            dut.raw_sin.value = lo & ((1 << p.adc_w) - 1)
            dut.raw_cos.value = -lo - 1
            dut.in_user.value = (1 << user_w) - 1

        n = await measure_latency(dut, apply, valid="norm_valid")
        if n != LATENCY:
            raise AssertionError(f"latency {n} clocks, documented LATENCY = {LATENCY}")
        if _word(dut, p) != (lo, -lo - 1, 0, (1 << user_w) - 1):
            raise AssertionError(f"latency sample: RTL {_word(dut, p)}")
        h = hdl_constant(dut, "LATENCY")
        if h is not None and h != LATENCY:
            raise AssertionError(f"HDL LATENCY = {h}, model {LATENCY}")

    @cocotb.test()
    async def norm_stream(dut):
        """Random traffic with the emulated observer: every word, state, take and hold against the model."""
        raw, user_w, seed = block_config(VAR, DEFAULT_SEED)
        p = params_of(raw)
        tag = f"{p}, USER_W={user_w}, seed={seed}; replay with FRINGE_SEED={seed}"
        rng = np.random.default_rng(seed)
        B = p.b
        n_cycles = 40 * B + 400
        resets = {int(n_cycles * 0.45), int(n_cycles * 0.8)}
        full = range(60, 60 + 6 * B)            # ce = 1, in_valid = 1
        lo = -(1 << (p.adc_w - 1))
        obs = Observer(dut, p, rng)
        await start_clock(dut)
        segs = [{"raw": [], "user": [], "states": [p.reset_state()], "flags": [0]}]
        words, states, holds = [], [], []         # (segment, index, word / state)
        inflight: deque = deque()
        takes = 0
        last_word = None
        dut.rst.value = 1
        dut.ce.value = 1
        dut.in_valid.value = 0
        obs.drive()
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)

        def fail(i, msg):
            raise AssertionError(f"[{tag}] cycle {i}: {msg}")

        offer = None
        for i in range(n_cycles):
            seg = segs[-1]
            n = len(seg["raw"])                          # accepted since the reset
            rst = int(i in resets)
            ce = 1 if i in full else int(rng.random() < 0.85)
            valid = 1 if i in full else int(rng.random() < 0.8)
            if offer is None:
                if rng.random() < 0.1:
                    offer = (int(rng.choice([lo, -lo - 1])), int(rng.integers(lo, -lo)))
                else:
                    offer = (int(rng.integers(lo, -lo)), int(rng.integers(lo, -lo)))
                offer += (int(rng.integers(0, 1 << user_w)),)
            dut.rst.value = rst
            dut.ce.value = ce
            dut.in_valid.value = valid
            dut.raw_sin.value = offer[0] & ((1 << p.adc_w) - 1)
            dut.raw_cos.value = offer[1] & ((1 << p.adc_w) - 1)
            dut.in_user.value = offer[2]
            obs.drive()
            at_apply = n >= B and n % B == p.d
            await ReadOnly()
            ready = int(dut.in_ready.value)
            want_ready = int(not p.hold or not at_apply or obs.resolved)
            if ready != want_ready:
                fail(i, f"in_ready = {ready}, expected {want_ready} ({n} accepted, resolved {obs.resolved})")
            accepted = bool(ce and valid and ready and not rst)
            take = int(dut.upd_take.value)
            if take != int(accepted and at_apply):
                fail(i, f"upd_take = {take}, expected {int(accepted and at_apply)}")
            if ce and valid and not rst and not ready:
                holds.append(i)
            await RisingEdge(dut.clk)
            await ReadOnly()
            nv = int(dut.norm_valid.value)
            if rst:
                if nv:
                    fail(i, "norm_valid = 1 right after a reset")
                if _state(dut, p) != p.reset_state() + (0,):
                    fail(i, f"state after a reset: {_state(dut, p)}")
                inflight.clear()
                obs.reset()
                segs.append({"raw": [], "user": [], "states": [p.reset_state()], "flags": [0]})
                offer = None
            elif ce:
                for s in inflight:
                    s[0] += 1
                if accepted:
                    takes += take
                    seg["raw"].append(offer[:2])
                    seg["user"].append(offer[2])
                    inflight.append([1, len(segs) - 1, n])
                    states.append((len(segs) - 1, n, _state(dut, p)))
                    offer = None
                    if (n + 1) % B == 0:                 # the block's last sample: the observer starts on it
                        upd = draw_update(p, rng)
                        st, fl = (upd if upd is not None else (seg["states"][-1], seg["flags"][-1]))
                        seg["states"].append(st)
                        seg["flags"].append(fl)
                        obs.block_end(upd, i in full)
                obs.edge(accepted and at_apply)
                due = bool(inflight) and inflight[0][0] >= LATENCY
                if nv != int(due):
                    fail(i, f"norm_valid = {nv}, expected {int(due)}")
                if due:
                    _, sg, k = inflight.popleft()
                    last_word = _word(dut, p)
                    words.append((sg, k, last_word))
            elif nv and _word(dut, p) != last_word:
                fail(i, "the output changed while ce = 0")
            await FallingEdge(dut.clk)
        # the model per reset segment
        model = []
        for sg in segs:
            r = np.array(sg["raw"], dtype=np.int64).reshape(-1, 2)
            ys, yc, sat, sidx = normaliser_run(r[:, 0], r[:, 1], sg["states"], p)
            model.append((ys, yc, sat, sidx))
        for sg, k, got in words:
            ys, yc, sat, _ = model[sg]
            exp = (int(ys[k]), int(yc[k]), int(sat[k]), segs[sg]["user"][k])
            if got != exp:
                raise AssertionError(f"[{tag}] sample {k} of segment {sg}: RTL {got}, model {exp}")
        for sg, k, got in states:
            row = int(model[sg][3][k])
            exp = tuple(segs[sg]["states"][row]) + (segs[sg]["flags"][row],)
            if got != exp:
                raise AssertionError(f"[{tag}] state after sample {k} of segment {sg}: RTL {got}, model {exp}")
        sats = sum(int(m[2].sum()) for m in model)
        if not (takes >= 20 and sats and len(words) > 20 * B and (holds or not p.hold)):
            raise AssertionError(f"[{tag}] not effective: {takes} takes, {sats} saturated words, {len(words)} "
                                 f"words, {len(holds)} holds")
        dut._log.info("%d words and %d states checked, %d takes, %d holds, %d saturated", len(words), len(states),
                      takes, len(holds), sats)


# ============================================================================ pytest side

PARAM_SETS = [
    # (NormaliserParams, USER_W): the core's seed-like widths, HOLD = 0
    (NormaliserParams(adc_w=12, block_log2=6, ofs_frac=3, ginv_w=16, hold=0), 2),
    # HOLD = 1, the smallest block, no offset fraction
    (NormaliserParams(adc_w=16, block_log2=4, ofs_frac=0, ginv_w=20, hold=1), 1),
    # the widest words: ADC_W 24 + OFS_FRAC 8, GINV_W 24
    (NormaliserParams(adc_w=24, block_log2=5, ofs_frac=8, ginv_w=24, hold=1), 3),
    # the narrowest: ADC_W 4, GINV_W 8, HOLD = 0
    (NormaliserParams(adc_w=4, block_log2=5, ofs_frac=2, ginv_w=8, hold=0), 1),
]


def _id(ps) -> str:
    p, u = ps
    return f"A{p.adc_w}-B{p.block_log2}-O{p.ofs_frac}-G{p.ginv_w}-H{p.hold}-U{u}"


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_drift_normaliser(sim, ps):
    p, user_w = ps
    run_seeded(TOPLEVEL, {**p.hdl_parameters(), "USER_W": user_w}, sim, VAR, DEFAULT_SEED, 600)


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY)

BASE = PARAM_SETS[0][0].hdl_parameters()
ILLEGAL = [
    {"ADC_W": 3}, {"ADC_W": 25}, {"BLOCK_LOG2": 3}, {"BLOCK_LOG2": 13}, {"OFS_FRAC": -1}, {"OFS_FRAC": 9},
    {"ADC_W": 24, "OFS_FRAC": 8}, {"GINV_W": 7}, {"GINV_W": 25}, {"HOLD": -1}, {"HOLD": 2},
]

test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, params_of, BASE, some_legal=True)   # ADC_W 24 + OFS_FRAC 8 = 32 is legal


def test_drawn_updates_cover_skips_and_saturation():
    """The harness's updates include skips, states anywhere and near unity, and saturation flags (no simulator)."""
    p = PARAM_SETS[0][0]
    rng = np.random.default_rng(DEFAULT_SEED)
    ups = [draw_update(p, rng) for _ in range(200)]
    assert sum(u is None for u in ups) > 20 and sum(u is not None and u[1] for u in ups) > 20
    assert any(u is not None and u[0][2] < p.unity // 2 for u in ups)
