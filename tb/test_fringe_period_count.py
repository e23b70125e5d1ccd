"""fringe_period_count RTL (Verilog and VHDL) against the bit-exact model, every output word.

Two halves in one file (the cocotb ``examples/adder`` layout):

- cocotb coroutines (``period_count_*``), run inside the simulator: they read the configuration
  from ``FRINGE_PC_PARAMS`` (JSON of the HDL parameters) and the seed from ``FRINGE_SEED``;
- the pytest launcher ``test_fringe_period_count`` builds and runs them with
  ``sim/cocotb_runner.py`` over several parameter sets and both simulators (``--sims``).

The block has state (the previous phase, the period counter), so the whole run is planned before
the simulation (``tb/lib/planned_stream.py``): which cycles reset, stall (ce = 0) or carry a valid
sample. The accepted samples between resets are then exactly the streams the vectorised model
``period_count`` takes, and its words are expected from the RTL, cycle by cycle.

Traffic: trajectories with reversals and exact quarter- and half-period jumps across period and
revolution wraps (pos 0 and REV-1), coarse codes following the position (every code edge, the
wrap from 2^COARSE_W-1 to 0) with wrong codes mixed in, codes whose edges jitter (flipped codes:
tracked samples, and at span >= 1/2 absolute positions a period off that the track must not take),
residuals exactly at the COARSE_TOL boundary, offsets at the supported limits (+-2^FINE_W: n from
-2 to LINES+1); full speed, then random in_valid gaps and ce stalls, resets in mid-stream (with ce
low too, and with a sample offered on the reset cycle), and restarts whose first sample jumps half
a period.

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_period_count.py -k ...``.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import run_seeded

from fringe.fixed.period_count import LATENCY, PeriodCountParams, coarse_absolute, period_count

TOPLEVEL = "fringe_period_count"
DEFAULT_SEED = 4242


# ============================================================================ stimulus (pure Python)


def _signed_steps(p: PeriodCountParams, rng: np.random.Generator, n: int, bias: float) -> np.ndarray:
    """Fine-count steps of a wandering position: smooth speed below a quarter period per sample,
    reversals, and exact jumps at the overspeed boundary (+-(Q-1), +-Q, +-(Q+1), 2Q-1, -2Q)."""
    q = 1 << (p.fine_w - 2)
    speed = np.clip(np.cumsum(rng.normal(0.0, 0.02, n)) + bias, -0.2, 0.2)
    flips = rng.random(n) < 0.01                                   # sudden reversals
    speed = np.where(np.cumsum(flips) % 2 == 1, -speed, speed)
    steps = np.round(speed * (1 << p.fine_w) + rng.normal(0, 3, n)).astype(np.int64)
    jumps = np.flatnonzero(rng.random(n) < 0.04)
    steps[jumps] = rng.choice([q - 1, q, q + 1, -(q - 1), -q, -(q + 1), 2 * q - 1, -2 * q], jumps.size)
    return steps


def _codes(p: PeriodCountParams, true: np.ndarray, ofs) -> np.ndarray:
    """The coarse code a correct reader gives at each true position, for the offset ``ofs``
    (the code's edge sits at k * span - m with m = span/2 - ofs)."""
    span = p.coarse_span
    m = span // 2 - ofs
    return (np.mod(true + m, p.rev) // span) % (1 << p.coarse_w)


def _corrupt(p: PeriodCountParams, rng: np.random.Generator, codes: np.ndarray, rate: float) -> np.ndarray:
    codes = codes.copy()
    bad = np.flatnonzero(rng.random(codes.size) < rate)
    shift = rng.choice([1, -1, 2, -2, 3, -3, 1 << (p.coarse_w - 1)], bad.size)
    codes[bad] = (codes[bad] + shift) % (1 << p.coarse_w)
    return codes


def sections(p: PeriodCountParams, rng: np.random.Generator) -> list[dict]:
    """The offered samples, in sections with their traffic: list of dict(phase, coarse, ofs, note,
    p_ce, p_valid, resets)."""
    fmask = (1 << p.fine_w) - 1
    out: list[dict] = []

    def add(true, ofs, note, p_ce=1.0, p_valid=1.0, resets=(), wrong=0.0, coarse=None):
        true = np.asarray(true, dtype=np.int64)
        ofs_a = np.broadcast_to(np.asarray(ofs, dtype=np.int64), true.shape).copy()
        if p.coarse_w and coarse is None:
            coarse = _corrupt(p, rng, _codes(p, true, ofs_a), wrong)
        elif coarse is None:
            coarse = np.zeros(true.size, dtype=np.int64)
        out.append({"phase": np.mod(true, p.rev) & fmask, "coarse": np.asarray(coarse, dtype=np.int64),
                    "ofs": ofs_a if p.coarse_w else np.zeros(true.size, dtype=np.int64), "note": note,
                    "p_ce": p_ce, "p_valid": p_valid, "resets": set(resets)})

    half_code = p.coarse_span // 2
    period = 1 << p.fine_w
    # a calibrated-like offset: half a code minus a misalignment below half a period
    ofs0 = int(half_code - rng.integers(-(period // 2) + 1, period // 2)) if p.coarse_w else 0

    # 1. full speed: across the revolution wrap forward (from a few periods before REV), then back
    n1 = 900
    start = p.rev - 3 * period - int(rng.integers(0, period))
    x = start + np.cumsum(_signed_steps(p, rng, n1, 0.15))
    add(x, ofs0, "sweep forward over REV-1 -> 0", wrong=0.03)
    x = 2 * period + np.cumsum(_signed_steps(p, rng, 500, -0.15))
    add(x, ofs0, "sweep backward over 0 -> REV-1", wrong=0.03)

    # 2. corner positions (each sample stands alone: overspeed is whatever the model says)
    q = 1 << (p.fine_w - 2)
    k = [1, p.lines - 1, int(rng.integers(0, p.lines))]
    corners = [0, 1, p.rev - 1, p.rev - 2, period - 1, period, q, q - 1, 3 * q, 3 * q + 1]
    corners += [kk * period + d for kk in k for d in (-1, 0, 1)]
    if p.coarse_w:
        m = half_code - ofs0                  # code edges at c * span - m
        for c in (0, 1, (1 << p.coarse_w) - 1, int(rng.integers(0, 1 << p.coarse_w))):
            corners += [c * p.coarse_span - m + d for d in (-1, 0, 1)]
    add(np.mod(np.array(corners, dtype=np.int64), p.rev), ofs0, "corner positions")

    # 3. gaps, stalls and resets on a long wandering stream (every coarse code edge for small LINES)
    n3 = 2200 if p.lines <= 256 else 1500
    x = int(rng.integers(0, p.rev)) + np.cumsum(_signed_steps(p, rng, n3, 0.12))
    add(x, ofs0, "wandering, gaps and stalls", p_ce=0.75, p_valid=0.7, resets={400, 401, 1300}, wrong=0.03)

    if p.coarse_w:
        # 3b. edge jitter: the code read at a position up to 0.2 period off (flipped near its edges),
        # a slow wander over many edges, a few really wrong codes (on trusted samples: coarse_err)
        x = int(rng.integers(0, p.rev)) + np.cumsum(np.round(
            (np.clip(np.cumsum(rng.normal(0, 0.01, 1200)), -0.15, 0.15) + rng.normal(0, 0.02, 1200)) * period
        ).astype(np.int64))
        jit = np.round(np.clip(rng.normal(0, 0.07, x.size), -0.2, 0.2) * period).astype(np.int64)
        add(x, ofs0, "edge jitter", coarse=_corrupt(p, rng, _codes(p, x + jit, ofs0), 0.01),
            p_ce=0.9, p_valid=0.9)
        # 4. residuals at the COARSE_TOL boundary and at the rounding of n, random codes
        tol, half = p.coarse_tol, 1 << (p.fine_w - 1)
        rs = [tol, tol + 1, -tol, -tol - 1, half - 1, -half, 0, 1, -1]
        codes = rng.integers(0, 1 << p.coarse_w, 8 * len(rs))
        codes[:2] = [0, (1 << p.coarse_w) - 1]
        r = np.tile(rs, 8)
        ph = np.mod(codes * p.coarse_span + ofs0 - r, period)
        add(ph, ofs0, "residual at +-COARSE_TOL, +-1", coarse=codes, p_ce=0.8, p_valid=0.8)
        # 4b. start-up at a jittered code edge, each after a reset (the first offered sample is lost to
        # it): a slow motion from beyond and from inside the jitter towards the edge and across it into
        # the next code's trusted band (start-up anchors, tracked start-up samples), one with overspeeds
        jitter = period >> 6
        for gap, jumps in ((3 * jitter, 0), (jitter // 2, 0), (0, 0), (2 * jitter, 2)):
            sign = 1 if rng.random() < 0.5 else -1
            edge = int(rng.integers(1, 1 << p.coarse_w)) * p.coarse_span - (half_code - ofs0)
            n4 = 40 + (gap + period // 4) * 2000 // period             # into the trusted band
            x = edge - sign * gap + sign * np.round(np.arange(n4) * period / 2000).astype(np.int64)
            x += rng.integers(-2, 3, n4)
            for j in rng.choice(np.arange(5, n4 // 3), jumps, replace=False):
                x[j:] += p.coarse_span // 4 + period // 4 + 1            # an overspeed before trust
            x = np.r_[x[0], x]
            jit = rng.integers(-jitter, jitter + 1, x.size)
            add(x, ofs0, f"start-up {gap} counts from an edge", coarse=_codes(p, x + jit, ofs0), p_ce=0.85,
                resets={0})
        # 5. the supported offset limits and beyond-half-period offsets: n from -2 to LINES+1
        for ofs in (period, -period, period - 1, -period + 1, half_code + half, half_code - half):
            x = int(rng.integers(0, p.rev)) + np.cumsum(_signed_steps(p, rng, 150, 0.1))
            add(x, ofs, f"coarse_ofs = {ofs}", wrong=0.05, p_ce=0.9, p_valid=0.9)
            cmax = (1 << p.coarse_w) - 1
            add([0, period - 1, 0, period - 1], ofs, f"extreme n, coarse_ofs = {ofs}",
                coarse=[0, 0, cmax, cmax])
    else:
        # 4. counting over many revolutions both ways, at the overspeed boundary
        x = int(rng.integers(0, p.rev)) + np.cumsum(_signed_steps(p, rng, 600, 0.19))
        add(x, 0, "counting forward, many revolutions", p_ce=0.9, p_valid=0.9)
        x = int(rng.integers(0, p.rev)) + np.cumsum(_signed_steps(p, rng, 600, -0.19))
        add(x, 0, "counting backward, many revolutions", p_ce=0.9, p_valid=0.9)
        # 5. random phases: every delta, mostly overspeed
        add(rng.integers(0, p.rev, 200), 0, "random phases", p_ce=0.9, p_valid=0.9)
    return out


def restart_cycles(p: PeriodCountParams, rng, phase_before: int) -> list[tuple[int, int, int, int, str]]:
    """(rst, ce, valid, phase, note) cycles that check the restart: samples, a reset (with a sample
    offered on the reset cycle: lost), a first sample half a period away (no overspeed; counting:
    pos = phase), then a reset with ce = 0 (rst wins) and again."""
    half = 1 << (p.fine_w - 1)
    fmask = (1 << p.fine_w) - 1
    a = phase_before
    seq = [(0, 1, 1, a, "before reset"), (0, 1, 1, (a + 10) & fmask, "before reset"),
           (1, 1, 1, (a + 20) & fmask, "offered on the reset cycle (lost)"),
           (0, 1, 1, (a + 10 + half) & fmask, "first after reset, half a period away"),
           (0, 1, 1, (a + 10 + half + 5) & fmask, "second after reset"),
           (0, 1, 0, 0, ""), (1, 0, 0, 0, "reset with ce = 0"),
           (0, 1, 1, (a + 3 * half // 2) & fmask, "first after a ce = 0 reset"),
           (0, 1, 1, (a + 3 * half // 2 + (half // 2)) & fmask, "exactly a quarter period later"),
           (0, 0, 1, int(rng.integers(0, fmask + 1)), "stalled (not taken)"),
           (1, 1, 1, a, "reset right after a sample"), (0, 1, 1, (a + half) & fmask, "first again"),
           (1, 1, 0, 0, "reset"), (0, 1, 1, 0, "first: phase 0"), (0, 1, 1, fmask, "one count back"),
           (0, 1, 1, 0, "one count forward")]
    return seq


def build_plan(p: PeriodCountParams, user_w: int, seed: int):
    """The cycles of the whole run with their expected outputs (pure Python: no simulator)."""
    from lib.planned_stream import Cycle, accepted_segments

    rng = np.random.default_rng(seed)
    pos_w = p.pos_w
    ofs_mask = (1 << (pos_w + 1)) - 1
    cw = max(p.coarse_w, 1)
    cycles: list[Cycle] = []
    data: dict[int, tuple[int, int, int, int]] = {}   # cycle -> (phase, coarse, ofs, user)

    def junk() -> dict[str, int]:
        return {"phase": int(rng.integers(0, 1 << p.fine_w)), "coarse": int(rng.integers(0, 1 << cw)),
                "coarse_ofs": int(rng.integers(0, ofs_mask + 1)), "in_user": int(rng.integers(0, 1 << user_w))}

    def sample_cycle(rst, ce, ph, co, ofs, note):
        user = int(rng.integers(0, 1 << user_w))
        c = Cycle(rst, ce, 1, {"phase": int(ph), "coarse": int(co) if p.coarse_w else int(rng.integers(0, 2)),
                               "coarse_ofs": int(ofs) & ofs_mask if p.coarse_w else int(rng.integers(0, ofs_mask + 1)),
                               "in_user": user}, note=note)
        data[len(cycles)] = (int(ph), int(co), int(ofs), user)
        cycles.append(c)
        return c.accepted or rst

    cycles.append(Cycle(1, 1, 0, junk(), note="power-up reset"))
    for sec in sections(p, rng):
        i = cyc = 0
        n = sec["phase"].size
        while i < n:
            rst = int(cyc in sec["resets"])
            ce = int(rng.random() < sec["p_ce"])
            if rng.random() < sec["p_valid"]:
                if sample_cycle(rst, ce, sec["phase"][i], sec["coarse"][i], sec["ofs"][i], sec["note"]):
                    i += 1     # taken, or lost to the reset
            else:
                cycles.append(Cycle(rst, ce, 0, junk(), note="idle"))
            cyc += 1
    last = [data[i][0] for i in sorted(data)][-1]
    ofs_r = int(p.coarse_span // 2) if p.coarse_w else 0
    for rst, ce, valid, ph, note in restart_cycles(p, rng, last):
        if valid:
            sample_cycle(rst, ce, ph, int(rng.integers(0, 1 << p.coarse_w)) if p.coarse_w else 0, ofs_r, note)
        else:
            cycles.append(Cycle(rst, ce, 0, junk(), note=note))
    for _ in range(LATENCY + 3):
        cycles.append(Cycle(0, 1, 0, junk(), note="drain"))

    # expected words: the model on each stream between resets
    segs = accepted_segments(cycles)
    for seg in segs:
        ph, co, ofs, user = (np.array([data[i][k] for i in seg], dtype=np.int64) for k in range(4))
        pos, over, err = period_count(ph, co if p.coarse_w else None, ofs, p)
        for j, i in enumerate(seg):
            cycles[i].expect = (int(pos[j]), int(over[j]), int(err[j]), int(user[j]))
    return cycles, segs


# ============================================================================ cocotb side


def _config() -> tuple[PeriodCountParams, int, int]:
    raw = json.loads(os.environ["FRINGE_PC_PARAMS"])
    p = PeriodCountParams(raw["FINE_W"], raw["LINES"], raw["COARSE_W"])
    return p, int(raw["USER_W"]), int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))


if cocotb is not None:
    from lib.clock import start_clock
    from lib.latency import check_latency
    from lib.planned_stream import plan_tag, play_plan

    def _read(dut) -> tuple[int, int, int, int]:
        return (int(dut.pos.value), int(dut.overspeed.value), int(dut.coarse_err.value), int(dut.out_user.value))

    @cocotb.test()
    async def period_count_latency(dut):
        """One sample: out_valid exactly LATENCY (the model's constant) clocks later, for one clock, with its word."""
        p, user_w, seed = _config()
        assert len(dut.phase) == p.fine_w and len(dut.pos) == p.pos_w and len(dut.coarse_ofs) == p.pos_w + 1
        assert len(dut.coarse) == max(p.coarse_w, 1) and len(dut.in_user) == user_w
        await start_clock(dut)
        ph = (3 << (p.fine_w - 2)) + 5
        co = (1 << p.coarse_w) - 1 if p.coarse_w else 0
        ofs = -(1 << (p.fine_w - 1)) if p.coarse_w else 0
        user = (1 << user_w) - 1

        def apply():
            dut.phase.value = ph
            dut.coarse.value = co
            dut.coarse_ofs.value = ofs & ((1 << (p.pos_w + 1)) - 1)
            dut.in_user.value = user

        pos, over, err = period_count(np.array([ph]), np.array([co]), ofs, p)
        await check_latency(dut, apply, p.latency, lambda: _read(dut), (int(pos[0]), int(over[0]), int(err[0]), user))

    @cocotb.test()
    async def period_count_stream(dut):
        """The planned run: every output word against the model, exact timing, stalls, resets."""
        p, user_w, seed = _config()
        tag = plan_tag(p, user_w, seed)
        cycles, segs = build_plan(p, user_w, seed)
        st = await play_plan(dut, cycles, p.latency, lambda: _read(dut), tag)
        if st.checked != sum(len(s) for s in segs) - st.dropped:
            raise AssertionError(f"[{tag}] checked {st.checked} words, expected {sum(len(s) for s in segs)} - "
                                 f"{st.dropped} dropped ({len(segs)} streams between resets)")


# ============================================================================ pytest side

PARAM_SETS = [
    # (PeriodCountParams, USER_W)
    (PeriodCountParams(fine_w=16, lines=256, coarse_w=9), 3),
    (PeriodCountParams(fine_w=12, lines=100, coarse_w=8), 1),       # LINES not a power of two
    (PeriodCountParams(fine_w=16, lines=1, coarse_w=0), 2),         # one period per revolution, counting
    (PeriodCountParams(fine_w=14, lines=3, coarse_w=0), 1),         # counting, REV not a power of two
    (PeriodCountParams(fine_w=30, lines=200_000, coarse_w=18), 1),  # widest: POS_W = 48
    (PeriodCountParams(fine_w=8, lines=1, coarse_w=1), 1),          # narrowest; a coarse code on one line
    (PeriodCountParams(fine_w=12, lines=64, coarse_w=6), 1),        # span = 1 period: edge flips slip
    (PeriodCountParams(fine_w=10, lines=96, coarse_w=7), 2),        # span = 3/4 period
    (PeriodCountParams(fine_w=12, lines=64, coarse_w=7), 1),        # span = 1/2 period
]


def _id(ps) -> str:
    p, user_w = ps
    return f"F{p.fine_w}-L{p.lines}-C{p.coarse_w}-U{user_w}"


def test_plan_is_effective():
    """The plans exercise what the module docstring promises (checked without a simulator)."""
    for p, user_w in PARAM_SETS:
        cycles, segs = build_plan(p, user_w, DEFAULT_SEED)
        exp = [c.expect for c in cycles if c.accepted]
        over = [e[1] for e in exp]
        assert 0 < sum(over) < len(exp) / 4, _id((p, user_w))
        assert len(segs) >= 5                                          # resets split the run
        pos = np.array([e[0] for e in exp])
        assert pos.min() == 0 and pos.max() == p.rev - 1, _id((p, user_w))
        assert np.any(np.diff(pos) < -p.rev // 2) and np.any(np.diff(pos) > p.rev // 2)   # both wraps
        if p.coarse_w:
            err = [e[2] for e in exp]
            assert 0 < sum(err) < len(exp) / 4
            if p.lines > 1:
                # tracked samples whose code's position is a period off (not taken), and trusted
                # samples that disagree with the track (flagged though |r| is small)
                got = differs = mismatch = startup_trk = startup_anchor = 0
                for seg in segs:
                    acc = [cycles[i] for i in seg]
                    ph = np.array([c.drive["phase"] for c in acc])
                    co = np.array([c.drive["coarse"] for c in acc])
                    ofs = np.array([c.drive["coarse_ofs"] for c in acc])
                    ofs = np.where(ofs >> p.pos_w, ofs - (1 << (p.pos_w + 1)), ofs)
                    pos_abs, r = coarse_absolute(ph, co, ofs, p)
                    e = np.array([c.expect for c in acc])
                    got += len(acc)
                    differs += int(np.sum(e[:, 0] != pos_abs))
                    mismatch += int(np.sum(e[:, 2].astype(bool) & (np.abs(r) <= p.coarse_tol)))
                    # before the first trusted sample: tracked samples whose code is a period off, and
                    # later start-up anchors that move the position (the code's, not the track's)
                    tr = (r >= -p.trust) & (r < p.trust)
                    first = max(1, int(np.argmax(tr)) if tr.any() else len(acc))
                    half = 1 << (p.fine_w - 1)
                    step = (ph[1:first] - ph[:first - 1] + half) % (2 * half) - half
                    pre, trk = e[1:first, 0], (e[:first - 1, 0] + step) % p.rev
                    startup_trk += int(np.sum(pre != pos_abs[1:first]))
                    startup_anchor += int(np.sum(pre != trk))
                assert 0 < differs < got / 4 and 0 < mismatch < got / 10, (_id((p, user_w)), differs, mismatch)
                if p.coarse_span == 1 << p.fine_w:
                    assert startup_trk > 20 and startup_anchor >= 2, (_id((p, user_w)), startup_trk, startup_anchor)
            codes = {c.drive["coarse"] for c in cycles if c.accepted}
            assert {0, (1 << p.coarse_w) - 1} <= codes
        assert any(c.rst and not c.ce for c in cycles) and any(c.rst and c.valid for c in cycles)


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY)


ILLEGAL = [
    {"FINE_W": 7, "LINES": 256, "COARSE_W": 0},
    {"FINE_W": 31, "LINES": 256, "COARSE_W": 0},
    {"FINE_W": 16, "LINES": 0, "COARSE_W": 0},
    {"FINE_W": 16, "LINES": (1 << 20) + 1, "COARSE_W": 0},
    {"FINE_W": 30, "LINES": (1 << 18) + 1, "COARSE_W": 0},
    {"FINE_W": 16, "LINES": 256, "COARSE_W": 15},
    {"FINE_W": 16, "LINES": 256, "COARSE_W": -1},
    {"FINE_W": 30, "LINES": 256, "COARSE_W": 25},
    {"FINE_W": 16, "LINES": 257, "COARSE_W": 8},
]

test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, lambda d: PeriodCountParams(d["FINE_W"], d["LINES"], d["COARSE_W"]))


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_period_count(sim, ps):
    p, user_w = ps
    run_seeded(TOPLEVEL, {**p.hdl_parameters(), "USER_W": user_w}, sim, "FRINGE_PC_PARAMS", DEFAULT_SEED, 240)
