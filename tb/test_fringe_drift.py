"""fringe_drift RTL (Verilog and VHDL) against the bit-exact model, every normaliser output word.

Two halves in one file (the cocotb ``examples/adder`` layout): cocotb coroutines (``drift_*``) that read
the configuration from ``FRINGE_DRIFT_PARAMS`` (JSON of the HDL parameters) and the seed from
``FRINGE_SEED``, and the pytest launcher ``test_fringe_drift``.

The harness stands in for the rest of the core: the observer is fed from the normaliser output through
an emulated pipeline of PIPE_LATENCY registers (advancing on ce, cleared by rst), with the phase and
normalised codes the model produced for that sample (the phase: an ideal atan2 of the model's
normalised codes, the "rest of the core"). The run is planned before the simulation
(``tb/planned_stream.py``): the input samples of a synthetic drifting encoder (offsets and gains
ramping), the resets, ce and in_valid patterns and the table writes; the model (`drift_run` per reset
segment, table versions numbered as model banks) gives every normaliser output word and the tracker
state after every accepted input sample, both checked exactly:

1. full speed (ce = 1, in_valid = 1: with HOLD = 0 the update arrives with zero margin when PIPE_LATENCY
   is at its limit; with HOLD = 1 every block boundary must wait exactly NORM_LATENCY + PIPE_LATENCY +
   OBS_LATENCY - 1 clocks with in_ready = 0, the first clock the update is resolved), bank 0;
2. random idle cycles and ce stalls while bank 1 of both tables is rewritten through the write port
   (junk on the bus when wr_en = 0), then a bank flip to the new bank 1, a reset in mid-stream;
3. a slow section (less than a period per block: updates at the final step, the gear holds), a slower one
   (less than a sixteenth: the blocks are skipped, the state holds), then fast;
4. full-scale spikes in the raw codes (y saturates: norm_sat); after a reset, KG at its maximum (about
   90 times the nominal): GINV overshoots and saturates (track_sat).

The plan is a sequence of offers: a cycle offering a sample (ce = 1, in_valid = 1) while the block's
in_ready is 0 is repeated until the sample is taken (AXI-Stream style), so the samples of each reset
segment, and the model's words, do not depend on how long the block holds.

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_drift.py -k ...``.
"""

from __future__ import annotations

import tempfile
from collections import deque
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import block_config, block_env, params_from_hdl, signed

from fringe.fixed.drift import (
    NORM_LATENCY,
    OBS_LATENCY,
    PARTIAL_MU_MIN,
    DriftParams,
    drift_run,
    kg_for,
    make_fwd_table,
    pack_words,
)

TOPLEVEL = "fringe_drift"
DEFAULT_SEED = 777


# ============================================================================ stimulus (pure Python)


def amplitude(p: DriftParams) -> float:
    return 0.3 * 2 ** (p.adc_w - 1)


def waveform_tables(p: DriftParams, version: int):
    """(words (2, bins), w0 (2,), kg (2,)) of a calibrated waveform: W0 + A sin / cos plus a small harmonic
    that differs per version."""
    amp = amplitude(p)
    h = 0.01 * version
    fs = lambda ph: 10 + 5 * version + amp * (np.sin(2 * np.pi * ph) + h * np.sin(6 * np.pi * ph))   # noqa: E731
    fc = lambda ph: -7 + amp * (np.cos(2 * np.pi * ph) + h * np.cos(6 * np.pi * ph))                 # noqa: E731
    (vs, w0s), (vc, w0c) = make_fwd_table(fs, p), make_fwd_table(fc, p)
    return np.stack([pack_words(vs, p), pack_words(vc, p)]), np.array([w0s, w0c]), np.array([kg_for(vs, p),
                                                                                               kg_for(vc, p)])


def phase_of_factory(p: DriftParams, w0):
    tf = 2.0 ** p.table_frac
    ws, wc = w0[0] / tf, w0[1] / tf

    def phase_of(ys, yc):
        x = np.mod(np.arctan2(np.asarray(ys, dtype=np.float64) - ws, np.asarray(yc, dtype=np.float64) - wc)
                   / (2 * np.pi), 1.0)
        return np.floor(x * 2.0 ** p.fine_w).astype(np.int64) & ((1 << p.fine_w) - 1)

    return phase_of


def encoder(p: DriftParams, rng, n: int, t0: int, speed: float, scale: float = 1.0):
    """n raw samples (sin, cos) of a drifting encoder starting at global sample t0, `speed` periods per sample."""
    t = np.arange(t0, t0 + n, dtype=np.float64)
    amp = amplitude(p) * scale
    sc = 2.0 ** (p.adc_w - 12)
    phi = 2 * np.pi * (speed * (t - t0) + rng.uniform())
    os_ = sc * (40 + 30 * np.sin(t / 700))
    oc = sc * (-25 + 20 * np.cos(t / 900))
    gs = 1.08 + 0.05 * np.sin(t / 1100)
    gc = 0.94 - 0.04 * np.sin(t / 800)
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    rs = np.clip(np.round(os_ + gs * (10 + amp * np.sin(phi)) + rng.normal(0, 1, n)), lo, hi).astype(np.int64)
    rc = np.clip(np.round(oc + gc * (-7 + amp * np.cos(phi)) + rng.normal(0, 1, n)), lo, hi).astype(np.int64)
    return rs, rc


def build_plan(p: DriftParams, user_w: int, seed: int):
    """The cycles of the run with the expected normaliser words and states; plus the observer feed."""
    from planned_stream import Cycle, accepted_segments, draw_controls

    rng = np.random.default_rng(seed)
    B = p.b
    word_mask = (1 << p.word_w) - 1
    # model banks: 0 = HDL bank 0 (init), 1 = HDL bank 1 (init, never read), 2 = HDL bank 1 rewritten,
    # 3 = HDL bank 0 with KG at its maximum (about 90 times the nominal: GINV overshoots and saturates)
    v0, v1, v2 = waveform_tables(p, 0), waveform_tables(p, 1), waveform_tables(p, 2)
    kg_big = np.array([(1 << p.kg_w) - 1] * 2)
    mtables = np.stack([v0[0], v1[0], v2[0], v0[0]])
    mw0 = np.stack([v0[1], v1[1], v2[1], v0[1]])
    mkg = np.stack([v0[2], v1[2], v2[2], kg_big])
    hdl_bank = [0, 1, 1, 0]
    cycles: list = []
    samples: dict[int, tuple[int, int, int, int]] = {}   # cycle -> (raw_s, raw_c, user, model bank)
    t_glob = [0]

    def bus(w=None):
        if w is None:
            return {"wr_en": 0, "wr_sel": int(rng.integers(0, 2)), "wr_addr": int(rng.integers(0, 2 << p.fwd_w)),
                    "wr_data": int(rng.integers(0, 1 << 62)) & word_mask}
        sel, addr, data = w
        return {"wr_en": 1, "wr_sel": sel, "wr_addr": addr, "wr_data": int(data)}

    def section(n, p_ce, p_valid, mbank, speed, resets=(), writes=None, note="", spikes=0.0):
        rs, rc = encoder(p, rng, n, t_glob[0], speed)
        hit = rng.random(n) < spikes                         # full-scale codes: y saturates
        rs[hit] = rng.choice([-(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1], int(hit.sum()))
        hit = rng.random(n) < spikes
        rc[hit] = rng.choice([-(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1], int(hit.sum()))
        t_glob[0] += n
        writes = list(writes or [])
        i = cyc = 0
        while i < n or writes:
            rst, ce, b, user = draw_controls(rng, cyc, resets, p_ce, user_w, bus, writes)
            if i < n and rng.random() < p_valid:
                c = Cycle(rst, ce, 1, {"raw_sin": int(rs[i]) & ((1 << p.adc_w) - 1),
                                       "raw_cos": int(rc[i]) & ((1 << p.adc_w) - 1), "in_user": user, **b}, note=note)
                if c.accepted:
                    samples[len(cycles)] = (int(rs[i]), int(rc[i]), user, mbank)
                if c.accepted or rst:
                    i += 1
            else:
                c = Cycle(rst, ce, 0, {"raw_sin": int(rng.integers(0, 1 << p.adc_w)),
                                       "raw_cos": int(rng.integers(0, 1 << p.adc_w)), "in_user": user, **b},
                          note="idle")
            cycles.append(c)
            cyc += 1

    fast = 2.3 / B          # periods per sample: a few periods per block
    cycles.append(Cycle(1, 1, 0, {"raw_sin": 0, "raw_cos": 0, "in_user": 0, **bus()}, note="power-up reset"))
    section(6 * B, 1.0, 1.0, 0, fast, note="full speed, bank 0")
    # bank 1 rewritten (every word of both tables, in random order) while samples use bank 0
    ws = [(k, (1 << p.fwd_w) | a, int(mtables[2, k, a])) for k in (0, 1) for a in range(p.bins)]
    ws = [ws[k] for k in rng.permutation(len(ws))]
    section(max(8 * B, len(ws) + 2 * B), 0.8, 0.75, 0, fast, writes=ws, note="gaps, stalls, bank 1 written")
    section(8 * B, 0.85, 0.8, 2, fast, resets={int(3.3 * B)}, note="bank flip to the new bank 1, reset")
    section(5 * B, 0.9, 0.9, 2, 0.3 / B, note="slow: less than a period per block, the final step")
    section(4 * B, 0.9, 0.9, 2, 0.01 / B, note="slower: blocks skipped")
    section(4 * B, 0.9, 0.9, 0, fast, note="bank 0 again, fast, full-scale spikes", spikes=0.02)
    section(6 * B, 0.9, 0.85, 3, fast, resets={3}, note="reset, KG far too large: GINV saturates")
    for _ in range(NORM_LATENCY + p.pipe_latency + 3):
        cycles.append(Cycle(0, 1, 0, {"raw_sin": 0, "raw_cos": 0, "in_user": 0, **bus()}, note="drain"))

    # the model per reset segment
    segs = accepted_segments(cycles)
    feed = []          # per segment: (phase, y_sin, y_cos, hdl bank, w0 (n, 2), kg (n, 2))
    results = []
    for sg, seg in enumerate(segs):
        raw = np.array([samples[i] for i in seg], dtype=np.int64)
        mb = raw[:, 3]
        r = drift_run(raw[:, 0], raw[:, 1], phase_of_factory(p, mw0[0]), p, mtables, mw0, mkg, bank=mb)
        results.append(r)
        feed.append((r.phase, r.y_sin, r.y_cos, np.array(hdl_bank)[mb], mw0[mb], mkg[mb]))
        for n, i in enumerate(seg):
            k = int(r.state_index[n])
            st = tuple(int(x) for x in r.states[k])
            tsat = int(r.track_sat[k - 1]) if k > 0 else 0
            cycles[i].expect = (int(r.y_sin[n]), int(r.y_cos[n]), int(r.sat[n]), int(raw[n, 2]), st + (tsat,), sg, n)
    return cycles, feed, results


# ============================================================================ cocotb side

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge


params_of = partial(params_from_hdl, DriftParams)     # HDL parameters -> the model's


def _config():
    raw, user_w, seed = block_config("FRINGE_DRIFT_PARAMS", DEFAULT_SEED)
    return params_of(raw), user_w, seed


if cocotb is not None:
    from planned_stream import apply_cycle, hdl_constant, measure_latency, start_clock

    async def _measure(dut, apply_sample, max_clocks: int = 40) -> int:
        """Enabled clocks from one sample's edge to norm_valid (ce = 1, pipeline idle and reset), which
        must be high for one clock."""
        n = await measure_latency(dut, apply_sample, max_clocks, valid="norm_valid")
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)
        if int(dut.norm_valid.value):
            raise AssertionError("norm_valid high for more than one clock")
        return n

    def _norm(dut, p):
        return (signed(int(dut.y_sin.value), p.adc_w), signed(int(dut.y_cos.value), p.adc_w), int(dut.norm_sat.value),
                int(dut.norm_user.value))

    def _state(dut, p):
        return (signed(int(dut.off_sin.value), p.ofs_w), signed(int(dut.off_cos.value), p.ofs_w),
                int(dut.ginv_sin.value), int(dut.ginv_cos.value), int(dut.track_sat.value))

    def _idle_obs(dut, p, rng):
        dut.obs_valid.value = 0
        dut.obs_phase.value = int(rng.integers(0, 1 << p.fine_w))
        dut.obs_y_sin.value = int(rng.integers(0, 1 << p.adc_w))
        dut.obs_y_cos.value = int(rng.integers(0, 1 << p.adc_w))
        dut.obs_bank.value = int(rng.integers(0, 2))
        dut.w0_sin.value = int(rng.integers(0, 1 << (p.adc_w + p.table_frac)))
        dut.w0_cos.value = int(rng.integers(0, 1 << (p.adc_w + p.table_frac)))
        dut.kg_sin.value = int(rng.integers(0, 1 << p.kg_w))
        dut.kg_cos.value = int(rng.integers(0, 1 << p.kg_w))

    @cocotb.test()
    async def drift_latency(dut):
        """One sample: norm_valid exactly NORM_LATENCY clocks later with the model's word (reset state)."""
        p, user_w, _ = _config()
        assert len(dut.raw_sin) == p.adc_w and len(dut.obs_phase) == p.fine_w and len(dut.wr_data) == p.word_w
        assert len(dut.off_sin) == p.ofs_w and len(dut.ginv_sin) == p.ginv_w and len(dut.kg_sin) == p.kg_w
        assert len(dut.w0_sin) == p.adc_w + p.table_frac and len(dut.wr_addr) == p.fwd_w + 1
        await start_clock(dut)
        dut.wr_en.value = 0
        _idle_obs(dut, p, np.random.default_rng(0))
        lo = -(1 << (p.adc_w - 1))

        def apply():
            dut.raw_sin.value = lo & ((1 << p.adc_w) - 1)
            dut.raw_cos.value = (-lo - 1)
            dut.in_user.value = (1 << user_w) - 1

        n = await _measure(dut, apply)
        if n != NORM_LATENCY:
            raise AssertionError(f"latency {n} clocks, documented NORM_LATENCY = {NORM_LATENCY}")
        got = _norm(dut, p)       # the word stays (only norm_valid fell): the reset state gives y = raw
        if got != (lo, -lo - 1, 0, (1 << user_w) - 1):
            raise AssertionError(f"latency sample: RTL {got}")
        for name, val in (("NORM_LATENCY", NORM_LATENCY), ("OBS_LATENCY", OBS_LATENCY)):
            h = hdl_constant(dut, name)
            if h is not None and h != val:
                raise AssertionError(f"HDL {name} = {h}, model {val}")

    @cocotb.test()
    async def drift_stream(dut):
        """The planned run: every normaliser word and the state after every accepted sample against the
        model; the observer fed through PIPE_LATENCY emulated pipeline registers."""
        p, user_w, seed = _config()
        tag = f"{p}, USER_W={user_w}, seed={seed}; replay with FRINGE_SEED={seed}"
        cycles, feed, results = build_plan(p, user_w, seed)
        rng = np.random.default_rng(seed + 1)
        await start_clock(dut)
        inflight: deque = deque()
        pipe = [None] * p.pipe_latency            # observer feed registers: (segment, index) or None
        cur = None                                # what the normaliser output carries now: (segment, index)
        last_out = None
        checked = states_checked = dropped = 0
        sat_seen = tsat_seen = False

        def fail(i, msg):
            raise AssertionError(f"[{tag}] cycle {i} ({cycles[i].note if i < len(cycles) else 'end'}): {msg}")

        handles: dict[str, object] = {}
        stall = NORM_LATENCY + p.pipe_latency + OBS_LATENCY - 1     # HOLD = 1 at full speed, per boundary
        holds = []                # per boundary waited at: (held clocks, all at full speed)
        held = 0
        held_full = True
        i = 0
        while i < len(cycles):
            c = cycles[i]
            apply_cycle(dut, c, handles)
            ready = int(dut.in_ready.value)          # from registers only: settled since the last edge
            src = pipe[-1] if p.pipe_latency else cur
            if src is None:
                _idle_obs(dut, p, rng)
            else:
                sg, n = src
                ph, ys, yc, bk, w0, kg = feed[sg]
                dut.obs_valid.value = 1
                dut.obs_phase.value = int(ph[n])
                dut.obs_y_sin.value = int(ys[n]) & ((1 << p.adc_w) - 1)
                dut.obs_y_cos.value = int(yc[n]) & ((1 << p.adc_w) - 1)
                dut.obs_bank.value = int(bk[n])
                dut.w0_sin.value = int(w0[n, 0]) & ((1 << (p.adc_w + p.table_frac)) - 1)
                dut.w0_cos.value = int(w0[n, 1]) & ((1 << (p.adc_w + p.table_frac)) - 1)
                dut.kg_sin.value = int(kg[n, 0])
                dut.kg_cos.value = int(kg[n, 1])
            await RisingEdge(dut.clk)
            await ReadOnly()
            nv = int(dut.norm_valid.value)
            hold = bool(c.ce and c.valid and not c.rst and not ready)   # offered, not taken: offer it again
            if hold:
                if not p.hold:
                    fail(i, "in_ready = 0 with HOLD = 0")
                held += 1
                held_full &= c.note.startswith("full speed")
            elif c.accepted and held:
                holds.append((held, held_full))
                held, held_full = 0, True
            if c.rst:
                held, held_full = 0, True
                dropped += len(inflight)
                inflight.clear()
                pipe = [None] * p.pipe_latency
                cur = None
                if nv:
                    fail(i, "norm_valid = 1 right after a reset")
                if _state(dut, p) != (0, 0, p.unity, p.unity, 0):
                    fail(i, f"state after reset {_state(dut, p)}")
            elif c.ce:
                if p.pipe_latency:
                    pipe = [cur] + pipe[:-1]
                for s in inflight:
                    s[0] += 1
                if c.valid and not hold:
                    inflight.append([1, c.expect, i])
                    st = _state(dut, p)
                    if st != c.expect[4]:
                        fail(i, f"state after sample {c.expect[6]} of segment {c.expect[5]}: RTL {st}, "
                                f"model {c.expect[4]}")
                    states_checked += 1
                    tsat_seen |= bool(st[4])
                due = bool(inflight) and inflight[0][0] >= NORM_LATENCY
                if nv != int(due):
                    fail(i, f"norm_valid = {nv}, expected {int(due)}")
                cur = None
                if due:
                    _, exp, j = inflight.popleft()
                    got = _norm(dut, p)
                    if got != exp[:4]:
                        fail(i, f"sample {exp[6]} of segment {exp[5]} taken at cycle {j}: RTL {got}, "
                                f"model {exp[:4]}")
                    checked += 1
                    sat_seen |= bool(got[2])
                    cur = (exp[5], exp[6])
                    last_out = got
            else:
                if last_out is not None and nv and _norm(dut, p) != last_out:
                    fail(i, "output changed while ce = 0")
            if not nv:
                last_out = None
            await FallingEdge(dut.clk)
            if not hold:
                i += 1
        if inflight:
            fail(len(cycles), "samples still in flight at the end")
        upd = sum(int(r.updated.sum()) for r in results)
        skipped = sum(int((~r.updated).sum()) for r in results)
        if not (dropped and sat_seen and tsat_seen and upd > 10 and skipped >= 3):
            raise AssertionError(f"[{tag}] plan not effective: dropped {dropped}, norm_sat {sat_seen}, "
                                 f"track_sat {tsat_seen}, updates {upd}, skipped {skipped}")
        # HOLD = 1: every boundary of the full-speed section waited exactly until its update was resolved
        # (the first clock after it, not one later: the words above show it was not earlier)
        full = [h for h, f in holds if f]
        if p.hold and (len(full) < 4 or any(h != stall for h in full)):
            raise AssertionError(f"[{tag}] full-speed holds {full}, expected at least 4 of {stall} clocks")
        dut._log.info("%d cycles, %d words and %d states checked, %d dropped by resets, %d updates, %d skipped, "
                      "holds %s", len(cycles), checked, states_checked, dropped, upd, skipped, holds)


# ============================================================================ pytest side

PARAM_SETS = [
    # (DriftParams, USER_W): HOLD = 0 with PIPE_LATENCY at its limit (4 + 13 + 16 = D + 1)
    (DriftParams(adc_w=12, fine_w=14, block_log2=6, mu_log2=2, ofs_frac=3, ginv_w=16, fwd_w=5, table_w=16,
                 table_frac=2, kg_w=16, kg_shift=23, pipe_latency=13, hold=0), 2),
    # HOLD = 1: a pipeline longer than the block (the hold covers it), the smallest block
    (DriftParams(adc_w=16, fine_w=18, block_log2=4, mu_log2=3, ofs_frac=0, ginv_w=20, fwd_w=7, table_w=20,
                 table_frac=0, kg_w=20, kg_shift=28, pipe_latency=21, hold=1), 1),
    # the widest words: ADC_W 24 + OFS_FRAC 8, GINV_W/TABLE_W/KG_W 24, FINE_W 30, FWD_W 10; HOLD = 1
    (DriftParams(adc_w=24, fine_w=30, block_log2=7, mu_log2=0, ofs_frac=8, ginv_w=24, fwd_w=10, table_w=24,
                 table_frac=1, kg_w=24, kg_shift=46, pipe_latency=0, hold=1), 3),
    # HOLD = 0, a longer block, MU_LOG2 at its maximum (the gear's left shift of SEA * KG by 8)
    (DriftParams(adc_w=14, fine_w=16, block_log2=7, mu_log2=8, ofs_frac=4, ginv_w=18, fwd_w=6, table_w=18,
                 table_frac=2, kg_w=18, kg_shift=36, pipe_latency=20, hold=0), 2),
]


def _id(ps) -> str:
    p, u = ps
    return (f"A{p.adc_w}-F{p.fine_w}-B{p.block_log2}-M{p.mu_log2}-O{p.ofs_frac}-G{p.ginv_w}-W{p.fwd_w}-T{p.table_w}"
            f"-TF{p.table_frac}-K{p.kg_w}-KS{p.kg_shift}-P{p.pipe_latency}-H{p.hold}-U{u}")


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_plan_is_effective(ps):
    """The plan exercises updates (of whole and of partial periods), skipped blocks, both saturations and resets
    (without a simulator)."""
    p, user_w = ps
    cycles, feed, results = build_plan(p, user_w, DEFAULT_SEED)
    assert len(results) == 3
    assert all(r.updated.sum() >= 5 for r in results[:2]) and (~results[1].updated).sum() >= 3   # slower: skipped
    partial = results[1].updated & (results[1].sweep < 1 << p.fine_w)      # slow: the final step
    assert (partial.sum() >= 3) == (p.mu_log2 >= PARTIAL_MU_MIN) and (results[1].updated & ~partial).sum() >= 3
    assert results[-1].updated.any()     # KG far too large: GINV saturates in the first updates
    assert results[-1].track_sat.any() and results[1].sat.any()
    assert not results[0].track_sat.any()
    assert all(c.expect is not None for c in cycles if c.accepted)
    assert any(c.drive.get("wr_en") and not c.ce for c in cycles)


test_latency_constant_matches_model = constants_test(TOPLEVEL, NORM_LATENCY=NORM_LATENCY, OBS_LATENCY=OBS_LATENCY)


BASE = PARAM_SETS[0][0].hdl_parameters()       # HOLD = 0 at the limit: PIPE_LATENCY 14 is one over
ILLEGAL = [
    {"ADC_W": 3}, {"ADC_W": 25}, {"FINE_W": 7, "FWD_W": 4}, {"FINE_W": 31}, {"BLOCK_LOG2": 13},
    {"MU_LOG2": 9}, {"OFS_FRAC": 9}, {"ADC_W": 24, "OFS_FRAC": 8, "PIPE_LATENCY": 0}, {"GINV_W": 7},
    {"GINV_W": 25}, {"FWD_W": 1}, {"FWD_W": 14}, {"TABLE_W": 7}, {"TABLE_W": 25}, {"TABLE_FRAC": 13},
    {"KG_W": 7}, {"KG_W": 25}, {"KG_SHIFT": 0}, {"KG_SHIFT": 61}, {"PIPE_LATENCY": -1}, {"PIPE_LATENCY": 14},
    {"BLOCK_LOG2": 4, "PIPE_LATENCY": 0}, {"HOLD": -1}, {"HOLD": 2},
]


test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, params_of, BASE, some_legal=True)   # ADC_W 24 + OFS_FRAC 8 = 32 is legal


def init_files(p, stem: str, test: str = "tb/test_fringe_drift.py") -> dict[str, Path]:
    """FWD_SIN_INIT and FWD_COS_INIT: both tables' words of `waveform_tables` versions 0 (bank 0) and 1 (bank 1),
    written to ``<tmp>/fringe_tb/<stem>_<name>.mem`` (DriftParams or the observer's ObserverParams)."""
    from fringe.fixed.table_ram import write_hex

    t0, t1 = waveform_tables(p, 0)[0], waveform_tables(p, 1)[0]
    base = Path(tempfile.gettempdir()) / "fringe_tb"
    return {name: write_hex(base / f"{stem}_{name}.mem", np.concatenate([t0[k], t1[k]]), p.word_w,
                            [f"{test} initial {name} table: {p}", "bank 0 then bank 1"])
            for k, name in enumerate(("FWD_SIN_INIT", "FWD_COS_INIT"))}


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_drift(sim, ps):
    from cocotb_runner import run_block

    p, user_w = ps
    hdl = {**p.hdl_parameters(), "USER_W": user_w}
    env = block_env("FRINGE_DRIFT_PARAMS", hdl, DEFAULT_SEED)
    for k, path in init_files(p, f"drift_{_id((p, 0))}").items():
        hdl[k] = path
    run_block(TOPLEVEL, "test_fringe_drift", hdl, sim=sim, timeout_s=600, extra_env=env)


class _LateParams(DriftParams):
    """HOLD = 1's window and gear, but each update applied one block late (from (j+2)B): what the core
    would compute if the boundary sample did not wait for its update."""

    @property
    def d(self) -> int:
        return self.b


@pytest.mark.parametrize("ps", [ps for ps in PARAM_SETS if ps[0].hold],
                         ids=[_id(ps) for ps in PARAM_SETS if ps[0].hold])
def test_hold_is_needed(ps):
    """Without the hold the words differ: the model with every update applied one block late gives other
    normalised codes on a stream like the plan's full-speed section (so the exact comparison of the stream
    test catches a boundary sample taken before its update)."""
    p, _ = ps
    rs, rc = encoder(p, np.random.default_rng(DEFAULT_SEED), 6 * p.b, 0, 2.3 / p.b)
    tables, w0, kg = waveform_tables(p, 0)
    late = _LateParams(**{f: getattr(p, f) for f in p.__dataclass_fields__})
    r = drift_run(rs, rc, phase_of_factory(p, w0), p, tables, w0, kg)
    q = drift_run(rs, rc, phase_of_factory(p, w0), late, tables, w0, kg)
    k = min(q.apply_at.size, r.apply_at.size)
    assert r.updated.sum() >= 3 and late.d == p.b and (q.apply_at[:k] == r.apply_at[:k] + p.b).all()
    assert (q.y_sin[p.b:2 * p.b] == r.y_sin[p.b:2 * p.b]).mean() < 0.5    # block 1: reset state vs update 0
