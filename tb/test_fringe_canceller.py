"""fringe_canceller RTL (Verilog and VHDL) against the bit-exact model, every output word.

Two halves in one file (the cocotb ``examples/adder`` layout): cocotb coroutines (``canceller_*``) that
read the configuration from ``FRINGE_CANCEL_PARAMS`` (JSON of the HDL parameters) and the seed from
``FRINGE_SEED``, and the pytest launcher ``test_fringe_canceller``.

The run is planned before the simulation (``tb/lib/planned_stream.py``): the input samples of a synthetic
encoder (a circle of radius about R turning at an electrical speed, plus a tone at an NCO word, plus
noise), the per-sample NCO word, the resets and the ce and in_valid patterns. The model (`cancel` per
reset segment) gives every output word (c_out, s_out, sat, track_sat, out_user), checked exactly:

1. full speed (ce = 1, in_valid = 1: each update lands with the least margin before its block + 2);
2. random idle cycles and ce stalls, pauses after block ends (an update lands before, on or after the
   first sample of the next block); the tone's NCO word changes between samples (a bank swap: one
   stretch on the other bank's word, then single samples of either bank), a reset in mid-stream;
3. full speed again after the reset;
4. inputs near full scale with the coefficients adapted: the subtraction saturates (sat), and e clips;
5. a reset, then a tone beyond the coefficients' range (2^(A_W-1-A_FRAC) data LSBs): the coefficients
   saturate and track_sat stays set.

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_canceller.py -k ...``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import block_config, block_env, signed

from fringe.fixed.canceller import ADAPT_LATENCY, LATENCY, CancelParams, cancel, freq_word, sine_table

TOPLEVEL = "fringe_canceller"
DEFAULT_SEED = 777
REPO = Path(__file__).resolve().parent.parent
SPEED = 0.0131            # electrical turns per sample
TONE = 0.0373             # tone turns per sample (bank 0's CANCEL_FREQ), not a multiple of SPEED
TONE_B = 0.0911           # bank 1's


# ============================================================================ stimulus (pure Python)


def encoder(p: CancelParams, rng, freq: np.ndarray, radius: float, tone: float, t0: float):
    """Samples (c, s) of a circle of `radius` x R plus a tone of amplitude `tone` x R on each channel
    (its phase follows the NCO words `freq` of the samples), plus noise; clipped to s(WAVE_W)."""
    n = len(freq)
    r = p.radius
    phi = 2 * np.pi * (SPEED * np.arange(n) + t0)
    acc = np.concatenate([[0], np.cumsum(freq[:-1].astype(np.float64))]) / 2.0 ** 32
    th = 2 * np.pi * acc + rng.uniform(0, 2 * np.pi)
    a = rng.uniform(-1, 1, 4) * tone * r
    nc = a[0] * np.cos(th) + a[1] * np.sin(th)
    ns = a[2] * np.cos(th) + a[3] * np.sin(th)
    noise = max(1.0, r * 1e-3)
    lo, hi = -(1 << (p.wave_w - 1)), (1 << (p.wave_w - 1)) - 1
    c = np.clip(np.floor(radius * r * np.cos(phi) + nc + rng.normal(0, noise, n) + 0.5), lo, hi).astype(np.int64)
    s = np.clip(np.floor(radius * r * np.sin(phi) + ns + rng.normal(0, noise, n) + 0.5), lo, hi).astype(np.int64)
    return c, s


def build_plan(p: CancelParams, user_w: int, seed: int):
    """The cycles of the run with the expected output words; and the model's result per reset segment."""
    from lib.planned_stream import Cycle, accepted_segments

    rng = np.random.default_rng(seed)
    B = p.b
    mask = (1 << p.wave_w) - 1
    f0, f1 = freq_word(TONE, 1.0), freq_word(TONE_B, 1.0)
    a_range = 2.0 ** (p.a_w - 1 - p.a_frac) / p.radius     # the coefficients' range, in R
    cycles: list = []
    samples: dict[int, tuple[int, int, int, int]] = {}     # cycle -> (c, s, freq, user)

    taken = [0]       # samples accepted since the last reset

    def idle(ce, user, note="idle"):
        return Cycle(0, ce, 0, {"c": int(rng.integers(0, 1 << p.wave_w)), "s": int(rng.integers(0, 1 << p.wave_w)),
                                "freq": int(rng.integers(0, 1 << 32)), "in_user": user}, note=note)

    def section(n, p_ce, p_valid, note, radius=1.0, tone=0.1, resets=(), freq=None, pauses=False):
        """n samples; pauses: after half the blocks' last samples, 8..30 idle cycles, so that some updates
        land before the next block begins, some after, some on the edge of its first sample."""
        fq = np.full(n, f0, dtype=np.int64) if freq is None else freq
        c, s = encoder(p, rng, fq, radius, tone, rng.uniform())
        i = cyc = 0
        while i < n:
            rst = int(cyc in resets)
            ce = int(rng.random() < p_ce)
            user = int(rng.integers(0, 1 << user_w))
            if rst:
                taken[0] = 0
            if rng.random() < p_valid:
                cy = Cycle(rst, ce, 1, {"c": int(c[i]) & mask, "s": int(s[i]) & mask, "freq": int(fq[i]),
                                        "in_user": user}, note=note)
                if cy.accepted:
                    samples[len(cycles)] = (int(c[i]), int(s[i]), int(fq[i]), user)
                    taken[0] += 1
                if cy.accepted or rst:
                    i += 1
            else:
                cy = Cycle(rst, ce, 0, {**idle(ce, user).drive}, note="idle")
            cycles.append(cy)
            cyc += 1
            if pauses and cy.accepted and taken[0] % B == 0 and rng.random() < 0.5:
                for _ in range(int(rng.integers(8, 31))):
                    cycles.append(idle(int(rng.random() < 0.9), int(rng.integers(0, 1 << user_w)), "pause"))

    cycles.append(Cycle(1, 1, 0, {"c": 0, "s": 0, "freq": 0, "in_user": 0}, note="power-up reset"))
    section(24 * B, 1.0, 1.0, "full speed, bank 0")
    # the other bank's word for a stretch, then single samples of either bank
    n2 = 20 * B
    fq = np.full(n2, f0, dtype=np.int64)
    fq[3 * B:9 * B] = f1
    pick = rng.random(n2) < 0.1
    fq[pick] = rng.choice([f0, f1], int(pick.sum()))
    section(n2, 0.8, 0.75, "gaps, stalls, pauses, bank swaps", resets={int(15.3 * B)}, freq=fq, pauses=True)
    section(16 * B, 1.0, 1.0, "full speed after the reset")
    section(6 * B, 0.9, 0.9, "near full scale: the subtraction saturates", radius=1.97, tone=0.05)
    # (a gear shift that starts lower takes about 2^MU_LOG2 blocks more to reach the range)
    blocks = 40 + (3 << p.mu_log2 if p.gear_offset else 0)
    section(blocks * B, 0.9, 0.9, "reset, a tone beyond the coefficients' range", tone=min(1.5 * a_range, 0.7),
            resets={2})
    for _ in range(LATENCY + 3):
        cycles.append(idle(1, 0, "drain"))

    results = []
    for seg in accepted_segments(cycles):
        x = np.array([samples[i] for i in seg], dtype=np.int64)
        r = cancel(x[:, 0], x[:, 1], x[:, 2], p)
        results.append(r)
        for n, i in enumerate(seg):
            cycles[i].expect = (int(r.c[n]), int(r.s[n]), int(r.sat[n]), int(r.track_sat[n]), int(x[n, 3]))
    return cycles, results


# ============================================================================ cocotb side



def params_of(raw: dict) -> CancelParams:
    return CancelParams(raw["WAVE_W"], raw["LUT_W"], raw["C_W"], raw["BLOCK_LOG2"], raw["MU_LOG2"], raw["A_FRAC"],
                        raw["A_W"], raw.get("GEAR_OFFSET", 0))


def _config():
    raw, user_w, seed = block_config("FRINGE_CANCEL_PARAMS", DEFAULT_SEED)
    return params_of(raw), user_w, seed


if cocotb is not None:
    from lib.clock import start_clock
    from lib.latency import check_latency
    from lib.planned_stream import hdl_constant, play_plan

    def _read(dut, p: CancelParams):
        return (signed(int(dut.c_out.value), p.wave_w), signed(int(dut.s_out.value), p.wave_w), int(dut.sat.value),
                int(dut.track_sat.value), int(dut.out_user.value))

    @cocotb.test()
    async def canceller_latency(dut):
        """One sample after reset: out_valid exactly LATENCY clocks later with the model's word (zero
        coefficients: the sample itself); the HDL's ADAPT_LATENCY equal to the model's."""
        p, user_w, _ = _config()
        assert len(dut.c) == p.wave_w and len(dut.c_out) == p.wave_w and len(dut.freq) == 32
        assert len(dut.in_user) == user_w
        await start_clock(dut)
        lo = -(1 << (p.wave_w - 1))

        def apply():
            dut.c.value = lo & ((1 << p.wave_w) - 1)
            dut.s.value = -lo - 1
            dut.freq.value = 0xFFFFFFFF
            dut.in_user.value = (1 << user_w) - 1

        await check_latency(dut, apply, LATENCY, lambda: _read(dut, p), (lo, -lo - 1, 0, 0, (1 << user_w) - 1))
        h = hdl_constant(dut, "ADAPT_LATENCY")
        if h is not None and h != ADAPT_LATENCY:
            raise AssertionError(f"HDL ADAPT_LATENCY = {h}, model {ADAPT_LATENCY}")

    @cocotb.test()
    async def canceller_stream(dut):
        """The planned run: every output word against the model, exact timing."""
        p, user_w, seed = _config()
        tag = f"{p}, USER_W={user_w}, seed={seed}; replay with FRINGE_SEED={seed}"
        cycles, _ = build_plan(p, user_w, seed)
        await play_plan(dut, cycles, LATENCY, lambda: _read(dut, p), tag)


# ============================================================================ pytest side

PARAM_SETS = [
    # (CancelParams, USER_W)
    (CancelParams(), 1),                                                                  # the default
    (CancelParams(wave_w=10, lut_w=4, c_w=8, block_log2=4, mu_log2=1, a_frac=2, a_w=10), 2),   # small
    (CancelParams(wave_w=31, lut_w=12, c_w=18, block_log2=6, mu_log2=12, a_frac=4, a_w=32), 3),  # wide
    (CancelParams(block_log2=5, mu_log2=6, a_frac=2, a_w=14, gear_offset=4), 1),    # the gear shift from 2^-5
    (CancelParams(wave_w=12, lut_w=8, c_w=12, mu_log2=3, a_frac=2, a_w=10, gear_offset=2), 1),   # one step (last gear)
]


def _id(ps) -> str:
    p, u = ps
    return f"W{p.wave_w}-L{p.lut_w}-C{p.c_w}-B{p.block_log2}-M{p.mu_log2}-F{p.a_frac}-A{p.a_w}-G{p.gear_offset}-U{u}"


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_plan_is_effective(ps):
    """The plan exercises updates, both saturations, resets and NCO word changes (without a simulator)."""
    p, user_w = ps
    cycles, results = build_plan(p, user_w, DEFAULT_SEED)
    assert len(results) == 3
    assert all(c.expect is not None for c in cycles if c.accepted)
    # the coefficients adapt (nonzero, changing) before the saturating sections
    for r in results[:2]:
        assert (r.coefs != 0).any(axis=1).sum() > 10
        assert len({tuple(row) for row in r.coefs}) > 8
    assert results[1].sat.any() and not results[0].track_sat.any()
    assert results[-1].track_sat.any() and not results[-1].track_sat[:2 * p.b].any()
    assert len({c.drive["freq"] for c in cycles if c.accepted}) == 2
    assert any(not c.ce for c in cycles) and any(c.ce and not c.valid for c in cycles)


@pytest.mark.parametrize("ps", PARAM_SETS[:1], ids=[_id(ps) for ps in PARAM_SETS[:1]])
def test_plan_cancels_the_tone(ps):
    """The first section's estimate reaches the tone: the residual radial ripple falls (the plan drives a
    working canceller, not only words)."""
    p, _ = ps
    _, results = build_plan(p, 1, DEFAULT_SEED)
    r = results[0]
    rad = np.hypot(r.c.astype(float), r.s.astype(float)) / p.radius
    early, late = rad[:2 * p.b].std(), rad[18 * p.b:24 * p.b].std()
    assert late < 0.3 * early, (early, late)


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY, ADAPT_LATENCY=ADAPT_LATENCY)


BASE = PARAM_SETS[0][0].hdl_parameters()
ILLEGAL = [
    {"WAVE_W": 7}, {"WAVE_W": 32}, {"LUT_W": 3}, {"LUT_W": 13}, {"C_W": 7}, {"C_W": 19},
    {"BLOCK_LOG2": 3}, {"BLOCK_LOG2": 13}, {"MU_LOG2": 0}, {"MU_LOG2": 13}, {"A_FRAC": -1}, {"A_FRAC": 13},
    {"A_W": 7}, {"A_W": 23}, {"WAVE_W": 31, "A_W": 33}, {"WAVE_W": 31, "A_W": 32},
    {"BLOCK_LOG2": 4, "C_W": 8, "A_FRAC": 11, "A_W": 20},
    {"GEAR_OFFSET": -1}, {"GEAR_OFFSET": 6}, {"MU_LOG2": 3, "GEAR_OFFSET": 3},
]


test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, params_of, BASE, some_legal=True)   # WAVE_W 31, A_W 32 is legal


def _lut_file(p: CancelParams) -> Path:
    from fringe.fixed.table_ram import write_hex

    base = Path(tempfile.gettempdir()) / "fringe_tb"
    lut = sine_table(p) & ((1 << p.c_w) - 1)
    return write_hex(base / f"canceller_L{p.lut_w}_C{p.c_w}.mem", lut, p.c_w,
                     [f"tb/test_fringe_canceller.py sine table: LUT_W = {p.lut_w}, C_W = {p.c_w}"])


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_canceller(sim, ps):
    from cocotb_runner import run_block

    p, user_w = ps
    hdl = {**p.hdl_parameters(), "USER_W": user_w}
    env = block_env("FRINGE_CANCEL_PARAMS", hdl, DEFAULT_SEED)
    hdl["LUT_INIT"] = _lut_file(p)
    run_block(TOPLEVEL, "test_fringe_canceller", hdl, sim=sim, timeout_s=600, extra_env=env)
