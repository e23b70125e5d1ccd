"""fringe_long_period RTL (Verilog and VHDL) against the bit-exact model, every output word.

Two halves in one file (the cocotb ``examples/adder`` layout):

- cocotb coroutines (``long_period_*``), run inside the simulator: they read the configuration
  from ``FRINGE_LP_PARAMS`` (JSON of the HDL parameters) and the seed from ``FRINGE_SEED``;
- the pytest launcher ``test_fringe_long_period`` builds and runs them with
  ``sim/cocotb_runner.py`` over several parameter sets and both simulators (``--sims``).

The run is planned before the simulation (``tb/lib/planned_stream.py``), table writes included, so
each sample's expected word comes from the vectorised model with the table contents it reads:

1. both banks from INIT_FILE (two different smooth corrections), the bank chosen per sample:
   full speed, then random in_valid gaps, ce stalls and resets;
2. bank 1 rewritten through the write port (one word per clock, whatever ce is, junk on the bus
   when wr_en = 0) with arbitrary words, extremes included, while samples read bank 0 and earlier
   samples are still in flight; then both banks again (the any-word wrap guarantee);
3. bank 0 rewritten with a new smooth table while samples read bank 1; then both banks.

Positions: uniform, 0, 1, REV-2, REV-1, both sides of entry boundaries, with zero at 0, REV-1 or
anywhere, both directions; corrections large enough to wrap pos - step both ways.

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_long_period.py -k ...``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import block_config, block_env

from fringe.fixed.long_period import (
    LATENCY,
    LongPeriodParams,
    index_mapping,
    long_period_words,
    make_table,
    pack_words,
)

TOPLEVEL = "fringe_long_period"
DEFAULT_SEED = 777


# ============================================================================ stimulus (pure Python)


def smooth_table(p: LongPeriodParams, seed: int, scale: float) -> np.ndarray:
    """Values of a sum of four random harmonics, peak about ``scale`` of the s(LP_W) range."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1.0, 1.0, (4, 2))
    amp = scale * (2.0 ** (p.lp_w - 1 - p.lp_frac)) / 4

    def err(pos):
        x = 2 * np.pi * np.asarray(pos, dtype=float) / p.rev
        return amp * sum(a[m, 0] * np.cos((m + 1) * x) + a[m, 1] * np.sin((m + 1) * x) for m in range(4))

    return make_table(err, p)


def init_words(p: LongPeriodParams) -> np.ndarray:
    """(2, N) RAM words of INIT_FILE: bank 0 and bank 1, two different smooth corrections of
    opposite signs at position 0 (so that pos - step wraps both ways near 0 and REV-1)."""
    t0, t1 = smooth_table(p, 1, 0.9), smooth_table(p, 2, 0.5)
    if (t0[0] > 0) == (t1[0] > 0):
        t1 = -t1
    return np.stack([pack_words(t0, p), pack_words(t1, p)])


def raw_words(p: LongPeriodParams, rng: np.random.Generator) -> list[int]:
    """Arbitrary words (slopes unrelated to the values), the extreme fields in the first entries."""
    w = p.lp_w
    lo, hi = 1 << (w - 1), (1 << (w - 1)) - 1          # the codes of -2^(w-1) and 2^(w-1)-1
    fields = [(lo, lo), (hi, hi), (lo, hi), (hi, lo)]   # (slope, value)
    fields += [(int(a), int(b)) for a, b in rng.integers(0, 1 << w, (p.entries - len(fields), 2))]
    return [(s << w) | v for s, v in fields]


def entry_ends(p: LongPeriodParams, ks) -> list[int]:
    """First and last position of the entries ks (frac 0 and frac at its largest)."""
    return [q for k in ks for q in (-(-(k * p.rev) // p.entries), -(-((k + 1) * p.rev) // p.entries) - 1)]


def positions(p: LongPeriodParams, rng: np.random.Generator, n: int, hot=()) -> np.ndarray:
    """Uniform positions, 15 % of them at 0, 1, REV-2, REV-1, both sides of entry boundaries, and
    ``hot`` positions."""
    ks = [0, 1, 2, 3, p.entries - 1] + list(rng.integers(0, p.entries, 4))
    edges = [0, 1, p.rev - 2, p.rev - 1, *entry_ends(p, ks), *hot]
    edges = np.array(edges, dtype=np.int64)
    edges = np.mod(np.concatenate([edges, edges + 1, edges - 1]), p.rev)
    pos = rng.integers(0, p.rev, n)
    pick = rng.random(n) < 0.15
    pos[pick] = rng.choice(edges, pick.sum())
    return pos


def build_plan(p: LongPeriodParams, user_w: int, seed: int):
    """The cycles of the whole run with their expected outputs, and the table contents over time."""
    from lib.planned_stream import Cycle, draw_controls, idle_cycles

    rng = np.random.default_rng(seed)
    n = p.entries
    word_mask = (1 << (2 * p.lp_w)) - 1
    words = init_words(p).astype(object)        # current RAM contents (Python ints: up to 64 bits)
    cycles: list[Cycle] = []
    pending: list[tuple[int, int, int, int, int, int]] = []   # (cycle, pos, zero, dir, bank, user)

    def flush_expect():
        """Expected words of the offered samples so far, with the current table contents."""
        if not pending:
            return
        idx, pos, zero, d, bank, user = (np.array(col, dtype=np.int64) for col in zip(*pending, strict=True))
        out = long_period_words(pos, np.array(words.tolist(), dtype=np.uint64), zero, d, p, bank=bank)
        for j, i in enumerate(idx):
            cycles[i].expect = (int(out[j]), int(user[j]))
        pending.clear()

    def write_bus(k=None, bank=None, word=None) -> dict[str, int]:
        if k is None:   # idle bus: junk that must not be written
            return {"wr_en": 0, "wr_addr": int(rng.integers(0, 2 * n)),
                    "wr_data": int(rng.integers(0, 1 << 62)) & word_mask}
        return {"wr_en": 1, "wr_addr": (bank << p.lp_addr_w) | k, "wr_data": int(word)}

    def section(n_samples, p_ce, p_valid, banks=(0, 1), resets=(), writes=None, note="", hot=()):
        pos = positions(p, rng, n_samples, hot)
        zero = np.where(rng.random(n_samples) < 0.5, rng.integers(0, p.rev, n_samples),
                        rng.choice([0, p.rev - 1], n_samples))
        d = rng.integers(0, 2, n_samples)
        bank = rng.choice(banks, n_samples)
        writes = list(writes or [])
        i = cyc = 0
        while i < n_samples or writes:
            rst, ce, bus, user = draw_controls(rng, cyc, resets, p_ce, user_w, lambda w=(): write_bus(*w), writes)
            if i < n_samples and rng.random() < p_valid:
                c = Cycle(rst, ce, 1, {"pos": int(pos[i]), "zero": int(zero[i]), "dir": int(d[i]),
                                       "bank": int(bank[i]), "in_user": user, **bus}, note=note)
                pending.append((len(cycles), int(pos[i]), int(zero[i]), int(d[i]), int(bank[i]), user))
                if c.accepted or rst:
                    i += 1
            else:
                c = Cycle(rst, ce, 0, {"pos": int(rng.integers(0, 1 << p.pos_w)), "zero": int(rng.integers(0, p.rev)),
                                       "dir": int(rng.integers(0, 2)), "bank": int(rng.integers(0, 2)),
                                       "in_user": user, **bus}, note="idle")
            cycles.append(c)
            cyc += 1

    def settle(k=2):
        idle_cycles(cycles, k, write_bus, "settle")

    cycles.append(Cycle(1, 1, 0, {"pos": 0, "zero": 0, "dir": 0, "bank": 0, "in_user": 0, **write_bus()},
                        note="power-up reset"))
    # 1. both init banks, per-sample bank: full speed, then gaps, stalls and resets
    section(500, 1.0, 1.0, note="init tables, full speed")
    section(700, 0.75, 0.7, resets={150, 151, 420}, note="init tables, gaps and stalls")
    flush_expect()
    settle()
    # 2. bank 1 <- arbitrary words while samples read bank 0
    new1 = raw_words(p, rng)
    section(n // 2 + 20, 0.8, 0.8, banks=(0,), writes=[(k, 1, new1[k]) for k in range(n)],
            note="bank 0 while bank 1 is written")
    flush_expect()
    words[1] = new1
    # the extreme words sit in entries 0..3: their ends give the largest |corr|
    section(600, 0.85, 0.8, resets={300}, note="bank 0 and the arbitrary bank 1", hot=entry_ends(p, range(4)) * 4)
    flush_expect()
    settle()
    # 3. bank 0 <- a new smooth table while samples read bank 1
    new0 = pack_words(-smooth_table(p, 3, 0.7), p)
    section(n // 2 + 20, 0.8, 0.8, banks=(1,), writes=[(k, 0, int(new0[k])) for k in range(n)],
            note="bank 1 while bank 0 is written")
    flush_expect()
    words[0] = [int(v) for v in new0]
    section(400, 1.0, 0.9, note="new bank 0 and bank 1")
    flush_expect()
    idle_cycles(cycles, LATENCY + 2, write_bus, "drain")
    return cycles


# ============================================================================ cocotb side


def params_of(raw: dict) -> LongPeriodParams:
    return LongPeriodParams(raw["LINES"], raw["FINE_W"], raw["LP_ADDR_W"], raw["LP_W"], raw["LP_FRAC"], raw["LP_IF"],
                            raw["LP_RECIP"], raw["LP_SHIFT"])


def _config() -> tuple[LongPeriodParams, int, int]:
    raw, user_w, seed = block_config("FRINGE_LP_PARAMS", DEFAULT_SEED)
    return params_of(raw), user_w, seed


if cocotb is not None:
    from lib.clock import start_clock
    from lib.latency import check_latency
    from lib.planned_stream import play_planned

    def _read(dut) -> tuple[int, int]:
        return int(dut.pos_out.value), int(dut.out_user.value)

    @cocotb.test()
    async def long_period_latency(dut):
        """One sample: out_valid exactly LATENCY (the model's constant) clocks later, for one clock, with its word."""
        p, user_w, seed = _config()
        assert len(dut.pos) == p.pos_w and len(dut.zero) == p.pos_w and len(dut.pos_out) == p.pos_w
        assert len(dut.wr_data) == 2 * p.lp_w and len(dut.wr_addr) == p.lp_addr_w + 1
        assert len(dut.in_user) == user_w
        await start_clock(dut)
        dut.wr_en.value = 0
        pos, zero, user = p.rev - 1, p.rev // 3, (1 << user_w) - 1

        def apply():
            dut.pos.value = pos
            dut.zero.value = zero
            dut.dir.value = 1
            dut.bank.value = 1
            dut.in_user.value = user

        want = int(long_period_words(np.array([pos]), init_words(p), zero, 1, p, bank=np.array([1]))[0])
        await check_latency(dut, apply, p.latency, lambda: _read(dut), (want, user))

    @cocotb.test()
    async def long_period_stream(dut):
        """The planned run: every output word against the model, exact timing, table rewrites."""
        await play_planned(dut, _config, build_plan, _read)


# ============================================================================ pytest side

PARAM_SETS = [
    # (LongPeriodParams, USER_W)
    # widest words, 2^(LP_W - LP_FRAC) = REV: |step| reaches a whole revolution with arbitrary words
    (LongPeriodParams(lines=256, fine_w=16, lp_addr_w=8, lp_w=32, lp_frac=8, lp_if=16), 3),
    # REV not a power of two (LP_RECIP = 335545, LP_SHIFT = 31), no rounding term (LP_FRAC = 0)
    (LongPeriodParams(lines=100, fine_w=12, lp_addr_w=6, lp_w=14, lp_frac=0, lp_if=6), 1),
    # one line, 1024 entries of 64 counts
    (LongPeriodParams(lines=1, fine_w=16, lp_addr_w=10, lp_w=18, lp_frac=4, lp_if=8), 2),
]


def _id(ps) -> str:
    p, user_w = ps
    return f"L{p.lines}-F{p.fine_w}-A{p.lp_addr_w}-W{p.lp_w}-FR{p.lp_frac}-IF{p.lp_if}-U{user_w}"


def test_plan_is_effective():
    """The plans exercise what the module docstring promises (checked without a simulator)."""
    from lib.planned_stream import accepted_positions

    for p, user_w in PARAM_SETS:
        cycles = build_plan(p, user_w, DEFAULT_SEED)
        acc = accepted_positions(cycles, p.rev, _id((p, user_w)))
        assert {c.drive["bank"] for c in acc} == {0, 1} and {c.drive["dir"] for c in acc} == {0, 1}
        writes = [c for c in cycles if c.drive.get("wr_en")]
        assert len(writes) == 2 * p.entries and any(not c.ce for c in writes)
        # pos - step wraps both ways for some samples (the corrections are large)
        wd = init_words(p)
        steps = [(c.drive["pos"], c.drive["bank"]) for c in acc[:1000]]
        pc = [int(long_period_words(np.array([q]), wd, 0, 0, p, bank=np.array([b]))[0]) for q, b in steps]
        assert any(a - b > p.rev // 2 for (a, _), b in zip(steps, pc, strict=True))
        assert any(b - a > p.rev // 2 for (a, _), b in zip(steps, pc, strict=True))


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY)


def _hdl_params(lines, fine_w, addr, lp_w, frac, lp_if, recip=None, shift=None) -> dict:
    if recip is None:
        try:
            recip, shift = index_mapping(lines, fine_w, addr, lp_if)
        except (ValueError, ZeroDivisionError):
            recip, shift = 1, 16
    return {"LINES": lines, "FINE_W": fine_w, "LP_ADDR_W": addr, "LP_W": lp_w, "LP_FRAC": frac, "LP_IF": lp_if,
            "LP_RECIP": recip, "LP_SHIFT": shift}


ILLEGAL = [
    _hdl_params(256, 7, 8, 18, 4, 8),
    _hdl_params(256, 31, 8, 18, 4, 8),
    _hdl_params(0, 16, 8, 18, 4, 8, 1, 16),
    _hdl_params((1 << 20) + 1, 16, 8, 18, 4, 8, 1, 16),
    _hdl_params((1 << 18) + 1, 30, 8, 18, 4, 8, 1, 16),
    _hdl_params(256, 16, 1, 18, 4, 8),
    _hdl_params(256, 16, 17, 18, 4, 8),
    _hdl_params(1, 8, 9, 16, 4, 8),                  # 512 entries > REV = 256
    _hdl_params(256, 16, 8, 7, 0, 8),
    _hdl_params(256, 16, 8, 33, 12, 8),
    _hdl_params(256, 16, 8, 18, 17, 8),
    _hdl_params(256, 16, 8, 18, 4, 0, 1, 16),
    _hdl_params(256, 16, 8, 18, 4, 17, 1, 17),
    _hdl_params(1, 16, 10, 21, 4, 8),                 # 2^17 > REV = 2^16
    _hdl_params(256, 16, 8, 18, 4, 8, 1, 4),          # LP_SHIFT < LP_IF
    _hdl_params(256, 16, 8, 18, 4, 8, 1, 128),
    _hdl_params(256, 16, 8, 18, 4, 8, 2, 16),         # wrong reciprocals
    _hdl_params(256, 16, 8, 18, 4, 8, 1, 15),
    _hdl_params(100, 12, 6, 14, 0, 6, 335544, 31),    # one below index_mapping's
    _hdl_params(100, 12, 6, 14, 0, 6, 0, 31),
]


def _lp_params(d: dict) -> LongPeriodParams:
    return LongPeriodParams(d["LINES"], d["FINE_W"], d["LP_ADDR_W"], d["LP_W"], d["LP_FRAC"], d["LP_IF"],
                            d["LP_RECIP"], d["LP_SHIFT"])


test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, _lp_params)


def _init_file(p: LongPeriodParams) -> Path:
    """Both banks' initial words as the RAM's hex image (a fixed path per parameter set)."""
    from fringe.fixed.table_ram import write_hex

    path = Path(tempfile.gettempdir()) / "fringe_tb" / (
        f"long_period_L{p.lines}_F{p.fine_w}_A{p.lp_addr_w}_W{p.lp_w}_FR{p.lp_frac}.mem")
    return write_hex(path, init_words(p).ravel(), 2 * p.lp_w,
                     [f"tb/test_fringe_long_period.py initial tables: {p}",
                      "bank 0 then bank 1; word {slope, value}"])


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_long_period(sim, ps):
    from cocotb_runner import run_block

    p, user_w = ps
    hdl = {**p.hdl_parameters(), "USER_W": user_w}
    if sim == "ghdl" and hdl["LP_RECIP"] >= 1 << 31:
        pytest.skip("LP_RECIP >= 2^31 does not fit a VHDL integer generic (documented limit)")
    env = block_env("FRINGE_LP_PARAMS", hdl, DEFAULT_SEED)
    hdl["INIT_FILE"] = _init_file(p)
    run_block(TOPLEVEL, "test_fringe_long_period", hdl, sim=sim, timeout_s=240, extra_env=env)
