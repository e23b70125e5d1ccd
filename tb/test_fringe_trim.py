"""fringe_trim RTL (Verilog and VHDL) against the bit-exact model, every output word.

Two halves in one file (the cocotb ``examples/adder`` layout):

- cocotb coroutines (``trim_*``), run inside the simulator: they read the configuration from
  ``FRINGE_TRIM_PARAMS`` (JSON of the HDL parameters) and the seed from ``FRINGE_SEED``;
- the pytest launcher ``test_fringe_trim`` builds and runs them with ``sim/cocotb_runner.py`` over
  several parameter sets and both simulators (``--sims``).

The run is planned before the simulation (``tb/lib/planned_stream.py``), table writes included. The
speed of each accepted sample comes from the positions accepted since the last reset
(`speeds` per reset segment), its output word from the vectorised model with the table contents
it reads:

1. both banks from the INIT files (smooth tables in bank 0, arbitrary words with extremes in
   bank 1), the bank chosen per sample: full speed, then random in_valid gaps, ce stalls and
   resets in mid-stream (the history refills: START_SPEED for the first sample, then the start-up
   windows of 1, 2, 4, ... samples scaled to N), and resets while moving fast both ways (the
   scaled start-up speed saturates at -REV/2 and REV/2 - 1);
2. bank 1 of all three tables rewritten through the write port (one word per clock, whatever ce
   is, junk on the bus when wr_en = 0, and writes that must be ignored: wr_sel = 3, small-table
   words beyond their size) while samples read bank 0 and earlier samples are in flight; a bank
   flip to bank 1, then both banks;
3. bank 0 rewritten with new smooth tables while samples read bank 1; then both banks.

Positions move like an encoder: speed regimes from standing still to beyond REV/2 per window
(the wrap of the speed), both directions and reversals, through 0/REV, plus big jumps to
corners (0, REV-1, bin edges, sector edges). Corrections saturate both ways.

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_trim.py -k ...``.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import block_config, block_env

from fringe.fixed.trim import (
    LATENCY,
    TrimParams,
    magnitudes,
    make_gain_table,
    make_map_table,
    pack_words,
    sector_mapping,
    speeds,
    trim_words,
)

TOPLEVEL = "fringe_trim"
DEFAULT_SEED = 4242
TABLES = ("map", "speed", "amp")
SEL = {"map": 0, "speed": 1, "amp": 2}


# ============================================================================ stimulus (pure Python)


def table_size(p: TrimParams, name: str) -> int:
    return p.map_words if name == "map" else p.gain_words


def smooth_tables(p: TrimParams, seed: int, scale: float) -> dict[str, np.ndarray]:
    """Packed words of one bank: smooth random harmonics, peak about ``scale`` of the s(TRIM_W) range."""
    rng = np.random.default_rng(seed)
    top = scale * 2.0 ** (p.trim_w - 1)
    a = rng.uniform(-1, 1, (2, p.sectors, 4))
    g = rng.uniform(-1, 1, (2, 3))

    def fmap(d, s, ph):
        x = 2 * np.pi * ph
        return (top / 3 * (a[d, s, 0] + a[d, s, 1] * np.sin(x) + a[d, s, 2] * np.cos(x) + a[d, s, 3] * np.sin(2 * x))
                / 2 ** p.trim_frac)

    def gain(k):
        return lambda ph: top / 3 * (g[k, 0] + g[k, 1] * np.sin(2 * np.pi * ph) + g[k, 2] * np.cos(2 * np.pi * ph))

    return {"map": pack_words(make_map_table(fmap, p), p),
            "speed": pack_words(make_gain_table(gain(0), p, raw=True), p),
            "amp": pack_words(make_gain_table(gain(1), p, raw=True), p)}


def raw_tables(p: TrimParams, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Arbitrary words (slopes unrelated to the values), the extreme fields in the first words."""
    w = p.trim_w
    lo, hi = 1 << (w - 1), (1 << (w - 1)) - 1          # the codes of -2^(w-1) and 2^(w-1)-1
    fields = [(lo, lo), (hi, hi), (lo, hi), (hi, lo)]   # (slope, value)
    out = {}
    for name in TABLES:
        n = table_size(p, name)
        f = np.array(fields + [tuple(x) for x in rng.integers(0, 1 << w, (n - 4, 2))], dtype=np.int64)
        out[name] = (f[:, 0] << w) | f[:, 1]
    return out


def init_tables(p: TrimParams) -> dict[str, np.ndarray]:
    """The INIT images, (2, words) per table: bank 0 smooth, bank 1 arbitrary words."""
    t0, t1 = smooth_tables(p, 1, 0.8), raw_tables(p, np.random.default_rng(2))
    return {k: np.stack([t0[k], t1[k]]) for k in TABLES}


def corners(p: TrimParams, rng: np.random.Generator) -> np.ndarray:
    """0, REV-1, bin edges and sector edges (both sides)."""
    per = 1 << p.fine_w
    periods = rng.integers(0, p.lines, 6)
    bins = rng.integers(0, p.bins, 6)
    edges = [0, p.rev - 1, *(int(k) * per + (int(b) << p.fb) for k, b in zip(periods, bins, strict=True))]
    edges += [int(k) * per + per - 1 for k in periods]
    edges += [-(-(s * p.rev) >> p.map_psi_w) for s in range(p.sectors)]
    e = np.array(edges, dtype=np.int64)
    return np.mod(np.concatenate([e, e + 1, e - 1]), p.rev)


def motion(p: TrimParams, rng: np.random.Generator, n: int, v0: float = 0.0) -> np.ndarray:
    """Encoder-like positions: speed regimes (still, slow, fast, beyond REV/2 per window), smooth
    reversals, wrapping through 0/REV, and 4 % jumps to corners; starting at v0 windows per sample."""
    fast = p.rev / p.window
    v = np.empty(n)
    i, cur = 0, v0 * fast
    while i < n:
        k = int(rng.integers(20, 120))
        target = rng.choice([0.0, 1e-5, 1e-3, 0.05, 0.3, 0.7]) * fast * rng.choice([-1, 1])
        ramp = np.linspace(cur, target, min(k, n - i) + 1)[1:]
        v[i:i + ramp.size] = ramp
        i += ramp.size
        cur = target
    x = np.cumsum(v) + rng.integers(0, p.rev)
    pos = np.mod(np.floor(x), p.rev).astype(np.int64)
    jump = rng.random(n) < 0.04
    pos[jump] = rng.choice(corners(p, rng), int(jump.sum()))
    return pos


def build_plan(p: TrimParams, user_w: int, seed: int):
    """The cycles of the whole run with their expected outputs."""
    from lib.planned_stream import Cycle, accepted_segments, draw_controls, idle_cycles

    rng = np.random.default_rng(seed)
    word_mask = (1 << p.word_w) - 1
    cur = {k: v.copy() for k, v in init_tables(p).items()}   # current RAM contents
    versions = [{k: v.copy() for k, v in cur.items()}]
    cycles: list[Cycle] = []
    taken: dict[int, tuple[int, int, int, int, int]] = {}   # cycle -> (pos, mag, bank, user, version)

    def write_bus(w=None) -> dict[str, int]:
        if w is None:   # idle bus: junk that must not be written
            return {"wr_en": 0, "wr_sel": int(rng.integers(0, 4)), "wr_addr": int(rng.integers(0, 1 << p.wr_addr_w)),
                    "wr_data": int(rng.integers(0, 1 << 62)) & word_mask}
        sel, addr, data = w
        return {"wr_en": 1, "wr_sel": sel, "wr_addr": addr, "wr_data": int(data)}

    def section(n_samples, p_ce, p_valid, banks=(0, 1), resets=(), writes=None, note="", v0=0.0):
        pos = motion(p, rng, n_samples, v0)
        mag = np.where(rng.random(n_samples) < 0.1, rng.choice([0, (1 << p.amp_w) - 1], n_samples),
                       rng.integers(0, 1 << p.amp_w, n_samples))
        bank = rng.choice(banks, n_samples)
        writes = list(writes or [])
        i = cyc = 0
        while i < n_samples or writes:
            rst, ce, bus, user = draw_controls(rng, cyc, resets, p_ce, user_w, write_bus, writes)
            if i < n_samples and rng.random() < p_valid:
                c = Cycle(rst, ce, 1, {"pos": int(pos[i]), "mag": int(mag[i]), "bank": int(bank[i]),
                                       "in_user": user, **bus}, note=note)
                if c.accepted:
                    taken[len(cycles)] = (int(pos[i]), int(mag[i]), int(bank[i]), user, len(versions) - 1)
                if c.accepted or rst:
                    i += 1
            else:
                c = Cycle(rst, ce, 0, {"pos": int(rng.integers(0, 1 << p.pos_w)),
                                       "mag": int(rng.integers(0, 1 << p.amp_w)), "bank": int(rng.integers(0, 2)),
                                       "in_user": user, **bus}, note="idle")
            cycles.append(c)
            cyc += 1

    def settle(k=3):
        idle_cycles(cycles, k, write_bus, "settle")

    def rewrite(bank: int, new: dict[str, np.ndarray], n_map: int) -> list[tuple[int, int, int]]:
        """Writes of all gain words and n_map map words of ``bank``, with ignored writes mixed in."""
        top = bank << (p.wr_addr_w - 1)
        ws = [(SEL[k], top | int(a), int(new[k][a])) for k in ("speed", "amp") for a in range(p.gain_words)]
        for a in rng.choice(p.map_words, min(n_map, p.map_words), replace=False):
            ws.append((0, top | int(a), int(new["map"][a])))
        junk = [(3, top | int(a), int(rng.integers(0, word_mask))) for a in rng.integers(0, 1 << (p.wr_addr_w - 1), 8)]
        beyond = [(int(rng.integers(1, 3)), top | (int(rng.integers(1, p.map_words // p.gain_words)) * p.gain_words)
                   | int(rng.integers(0, p.gain_words)), int(rng.integers(0, word_mask))) for _ in range(8)]
        order = ws + junk + beyond
        return [order[k] for k in rng.permutation(len(order))]

    def apply(ws):
        for sel, addr, data in ws:
            b, a = addr >> (p.wr_addr_w - 1), addr & ((1 << (p.wr_addr_w - 1)) - 1)
            name = {0: "map", 1: "speed", 2: "amp"}.get(sel)
            if name is None or a >= table_size(p, name):
                continue
            cur[name][b, a] = data
        versions.append({k: v.copy() for k, v in cur.items()})

    cycles.append(Cycle(1, 1, 0, {"pos": 0, "mag": 0, "bank": 0, "in_user": 0, **write_bus()},
                        note="power-up reset"))
    # 1. both init banks, per-sample bank: full speed, then gaps, stalls and resets
    section(700, 1.0, 1.0, note="init tables, full speed")
    section(900, 0.75, 0.7, resets={150, 151, 470}, note="init tables, gaps, stalls, resets")
    # resets in fast motion: the start-up speed (2^k samples scaled to N) saturates both ways
    section(120, 0.9, 0.9, resets={0}, v0=0.7, note="reset moving forwards fast")
    section(120, 1.0, 1.0, resets={0}, v0=-0.7, note="reset moving backwards fast")
    settle()
    # 2. bank 1 <- arbitrary words while samples read bank 0; then bank 1 only, then both
    ws = rewrite(1, raw_tables(p, rng), 160)
    section(len(ws) // 2 + 40, 0.8, 0.8, banks=(0,), writes=ws, note="bank 0 while bank 1 is written")
    settle()
    apply(ws)
    section(300, 0.9, 0.9, banks=(1,), resets={100}, note="bank flip: new bank 1")
    section(500, 0.85, 0.8, note="bank 0 and the new bank 1")
    settle()
    # 3. bank 0 <- new smooth tables while samples read bank 1
    ws = rewrite(0, smooth_tables(p, 3, 0.95), 160)
    section(len(ws) // 2 + 40, 0.8, 0.8, banks=(1,), writes=ws, note="bank 1 while bank 0 is written")
    settle()
    apply(ws)
    section(600, 1.0, 0.9, resets={333}, note="new bank 0 and bank 1")
    idle_cycles(cycles, LATENCY + 2, write_bus, "drain")

    # expected words: speeds and magnitude averages per reset segment, outputs per table version
    idx, sp, avg = [], [], []
    for seg in accepted_segments(cycles):
        idx += seg
        sp.append(speeds(np.array([taken[i][0] for i in seg], dtype=np.int64), p))
        avg.append(magnitudes(np.array([taken[i][1] for i in seg], dtype=np.int64), p))
    sp_of = dict(zip(idx, np.concatenate(sp).tolist(), strict=True))
    avg_of = dict(zip(idx, np.concatenate(avg).tolist(), strict=True))
    for ver, tabs in enumerate(versions):
        sel = [i for i in idx if taken[i][4] == ver]
        if not sel:
            continue
        pos, mag, bank, user = (np.array([taken[i][k] for i in sel], dtype=np.int64) for k in range(4))
        out, d, sat = trim_words(pos, mag, tabs["map"], tabs["speed"], tabs["amp"], p, bank=bank,
                                 speed=np.array([sp_of[i] for i in sel], dtype=np.int64),
                                 avg=np.array([avg_of[i] for i in sel], dtype=np.int64))
        for j, i in enumerate(sel):
            cycles[i].expect = (int(out[j]), int(d[j]), int(sat[j]), int(user[j]))
    return cycles


# ============================================================================ cocotb side


def params_of(raw: dict) -> TrimParams:
    psi = raw["MAP_PSI_W"]
    return TrimParams(raw["LINES"], raw["FINE_W"], raw["AMP_W"], raw["SPEED_LOG2"], psi, raw["MAP_PHI_W"],
                      raw["TRIM_W"], raw["TRIM_FRAC"], raw["G_SHIFT"],
                      raw["SECT_RECIP"] if psi else None, raw["SECT_SHIFT"] if psi else None,
                      raw.get("START_SPEED", 0), raw.get("MAG_SMOOTH_LOG2", 0))


def _config() -> tuple[TrimParams, int, int]:
    raw, user_w, seed = block_config("FRINGE_TRIM_PARAMS", DEFAULT_SEED)
    return params_of(raw), user_w, seed


if cocotb is not None:
    from lib.clock import start_clock
    from lib.latency import check_latency
    from lib.planned_stream import play_planned

    def _read(dut) -> tuple[int, int, int, int]:
        return int(dut.pos_out.value), int(dut.dir.value), int(dut.sat.value), int(dut.out_user.value)

    @cocotb.test()
    async def trim_latency(dut):
        """One sample: out_valid exactly LATENCY (the model's constant) clocks later, for one clock, with its word."""
        p, user_w, seed = _config()
        assert len(dut.pos) == p.pos_w and len(dut.pos_out) == p.pos_w and len(dut.mag) == p.amp_w
        assert len(dut.wr_data) == p.word_w and len(dut.wr_addr) == p.wr_addr_w and len(dut.wr_sel) == 2
        assert len(dut.in_user) == user_w
        await start_clock(dut)
        dut.wr_en.value = 0
        pos, mag, user = p.rev - 1, (1 << p.amp_w) - 1, (1 << user_w) - 1

        def apply():
            dut.pos.value = pos
            dut.mag.value = mag
            dut.bank.value = 0
            dut.in_user.value = user

        t = init_tables(p)
        want = trim_words(np.array([pos]), mag, t["map"], t["speed"], t["amp"], p, bank=np.array([0]))
        await check_latency(dut, apply, p.latency, lambda: _read(dut), (*(int(x[0]) for x in want), user))

    @cocotb.test()
    async def trim_stream(dut):
        """The planned run: every output word against the model, exact timing, table rewrites."""
        await play_planned(dut, _config, build_plan, _read)


# ============================================================================ pytest side

PARAM_SETS = [
    # (TrimParams, USER_W)
    # the magnitude averaged over ~8 samples
    (TrimParams(lines=256, fine_w=16, amp_w=12, speed_log2=5, map_psi_w=4, map_phi_w=6, trim_w=18, trim_frac=4,
                g_shift=18, start_speed=123457, mag_smooth_log2=3), 3),
    # REV not a power of two (SECT_RECIP 536871, SECT_SHIFT 38), window of one sample, TRIM_FRAC 0; the first
    # sample's speed at -REV/2 (backwards)
    (TrimParams(lines=1000, fine_w=12, amp_w=10, speed_log2=0, map_psi_w=3, map_phi_w=5, trim_w=16, trim_frac=0,
                g_shift=16, start_speed=-1000 * 2048), 1),
    # no sectors; the magnitude's average the longest (its accumulator 28 bits)
    (TrimParams(lines=37, fine_w=10, amp_w=16, speed_log2=2, map_psi_w=0, map_phi_w=4, trim_w=12, trim_frac=2,
                g_shift=10, mag_smooth_log2=12), 2),
    # the widest words: POS_W 31, AMP_W 32, TRIM_W 24, G_SHIFT 48, TRIM_FRAC 16
    (TrimParams(lines=3, fine_w=29, amp_w=32, speed_log2=3, map_psi_w=2, map_phi_w=10, trim_w=24, trim_frac=16,
                g_shift=48, start_speed=3 * (1 << 28) - 1), 2),
]


def _id(ps) -> str:
    p, user_w = ps
    return (f"L{p.lines}-F{p.fine_w}-A{p.amp_w}-S{p.speed_log2}-PSI{p.map_psi_w}-PHI{p.map_phi_w}-W{p.trim_w}"
            f"-FR{p.trim_frac}-G{p.g_shift}-U{user_w}" + (f"-M{p.mag_smooth_log2}" if p.mag_smooth_log2 else ""))


def test_plan_is_effective():
    """The plans exercise what the module docstring promises (checked without a simulator)."""
    from lib.planned_stream import accepted_positions, accepted_segments

    for p, user_w in PARAM_SETS:
        cycles = build_plan(p, user_w, DEFAULT_SEED)
        acc = accepted_positions(cycles, p.rev, _id((p, user_w)))
        assert {c.drive["bank"] for c in acc} == {0, 1}
        exp = np.array([c.expect for c in acc])
        assert set(exp[:, 1].tolist()) == {0, 1}, _id((p, user_w))                         # dir
        segs = accepted_segments(cycles)
        assert len(segs) >= 5 and all(len(s) > p.window for s in segs[1:])
        # the speed restarts at START_SPEED after every reset, then comes from the start-up windows (saturating
        # both ways when they are scaled up; N = 1 has none)
        half = p.rev // 2
        sp = [speeds(np.array([cycles[i].drive["pos"] for i in s]), p) for s in segs]
        assert all(x[0] == p.start_speed for x in sp)
        start = np.concatenate([x[1:p.window] for x in sp])
        if p.window > 1:
            assert {-half, half - 1} <= set(start.tolist()), _id((p, user_w))
            assert ((start > -half) & (start < half - 1) & (start != 0)).sum() >= 3, _id((p, user_w))
        writes = [c for c in cycles if c.drive.get("wr_en")]
        assert any(not c.ce for c in writes) and {c.drive["wr_sel"] for c in writes} == {0, 1, 2, 3}
        if p.mag_smooth_log2:
            # the same stimulus trimmed with the sample's own magnitude gives other words: the average shows
            own = accepted_positions(build_plan(dataclasses.replace(p, mag_smooth_log2=0), user_w, DEFAULT_SEED),
                                     p.rev, _id((p, user_w)))
            assert [c.drive for c in own] == [c.drive for c in acc]
            differ = np.mean([a.expect != b.expect for a, b in zip(own, acc, strict=True)])
            assert differ > 0.2, (_id((p, user_w)), differ)
        # the saturation goes both ways (not reachable with G_SHIFT 48 and TRIM_FRAC 16)
        if p.g_shift < 48:
            half = p.corr_max
            corr = {(c.drive["pos"] - c.expect[0]) % p.rev for c in acc if c.expect[2]}
            assert corr == {half - 1, p.rev - half}, _id((p, user_w))


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY)


BASE = {"LINES": 256, "FINE_W": 16, "AMP_W": 12, "SPEED_LOG2": 5, "MAP_PSI_W": 4, "MAP_PHI_W": 6, "TRIM_W": 18,
        "TRIM_FRAC": 4, "G_SHIFT": 18, "SECT_RECIP": 1, "SECT_SHIFT": 20}
ILLEGAL = [
    {"FINE_W": 7, "MAP_PHI_W": 4},
    {"FINE_W": 31},
    {"LINES": 0, "MAP_PSI_W": 0},
    {"LINES": 1 << 16},
    {"AMP_W": 3},
    {"AMP_W": 33},
    {"SPEED_LOG2": 9},
    {"MAP_PSI_W": 9},
    {"MAP_PHI_W": 1},
    {"MAP_PHI_W": 11},
    {"TRIM_W": 7},
    {"TRIM_W": 25},
    {"TRIM_FRAC": 17},
    {"G_SHIFT": 0},
    {"G_SHIFT": 49},
    {"SECT_SHIFT": 128},
    {"SECT_RECIP": 1, "SECT_SHIFT": 19},
    {"LINES": 1000, "FINE_W": 12, "MAP_PSI_W": 3, "MAP_PHI_W": 5, "SECT_RECIP": 536870, "SECT_SHIFT": 38},
    {"START_SPEED": 1 << 23},          # REV / 2 (REV = 2^24)
    {"START_SPEED": -(1 << 23) - 1},
    {"MAG_SMOOTH_LOG2": -1},
    {"MAG_SMOOTH_LOG2": 13},
]


def _trim_params(d: dict) -> TrimParams:
    return TrimParams(d["LINES"], d["FINE_W"], d["AMP_W"], d["SPEED_LOG2"], d["MAP_PSI_W"], d["MAP_PHI_W"], d["TRIM_W"],
                      d["TRIM_FRAC"], d["G_SHIFT"], d["SECT_RECIP"], d["SECT_SHIFT"], d.get("START_SPEED", 0),
                      d.get("MAG_SMOOTH_LOG2", 0))


test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, _trim_params, BASE)


def _init_files(p: TrimParams) -> dict[str, Path]:
    """The three tables' initial words as hex images (a fixed path per parameter set)."""
    from fringe.fixed.table_ram import write_hex

    tag = _id((p, 0))
    t = init_tables(p)
    base = Path(tempfile.gettempdir()) / "fringe_tb"
    return {k: write_hex(base / f"trim_{tag}_{k}.mem", t[k].ravel(), p.word_w,
                         [f"tb/test_fringe_trim.py initial {k} table: {p}", "bank 0 then bank 1; word {slope, value}"])
            for k in TABLES}


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_trim(sim, ps):
    from cocotb_runner import run_block

    p, user_w = ps
    hdl = {**p.hdl_parameters(), "USER_W": user_w}
    if p.map_psi_w == 0:
        hdl["SECT_RECIP"], hdl["SECT_SHIFT"] = 0, 0
    assert (hdl["SECT_RECIP"], hdl["SECT_SHIFT"]) == sector_mapping(p.lines, p.fine_w, p.map_psi_w)
    if sim == "ghdl" and hdl["SECT_RECIP"] >= 1 << 31:
        pytest.skip("SECT_RECIP >= 2^31 does not fit a VHDL integer generic (documented limit)")
    env = block_env("FRINGE_TRIM_PARAMS", hdl, DEFAULT_SEED)
    for k, path in _init_files(p).items():
        hdl[f"{k.upper()}_INIT"] = path
    run_block(TOPLEVEL, "test_fringe_trim", hdl, sim=sim, timeout_s=400, extra_env=env)
