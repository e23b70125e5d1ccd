"""Unit tests of the bit-exact drift tracker model (model/fringe/fixed/drift.py: the core's
fringe_drift_normaliser and fringe_drift_observer together)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from hdl_text import REPO, block_texts, missing_checks
from param_cases import out_of_range

from fringe.dsp.drift_float import drift_float
from fringe.fixed.drift import (
    NORM_LATENCY,
    OBS_LATENCY,
    PARTIAL_MU_MIN,
    SWEEP_MIN_LOG2,
    DriftParams,
    drift_run,
    error_bound,
    kg_for,
    largest_kg_shift,
    make_fwd_table,
    pack_words,
    unpack_words,
)
from fringe.fixed.drift_normaliser import NormaliserParams, normaliser_run
from fringe.fixed.drift_observer import ObserverParams, observer_run

P1 = DriftParams(adc_w=14, fine_w=16, block_log2=8, mu_log2=3, ofs_frac=4, ginv_w=18, fwd_w=6, table_w=18,
                 table_frac=2, kg_w=18, kg_shift=38)                  # HOLD = 1 (the default)
P2 = DriftParams(adc_w=10, fine_w=12, block_log2=6, mu_log2=1, ofs_frac=0, ginv_w=12, fwd_w=4, table_w=12,
                 table_frac=0, kg_w=12, kg_shift=21, pipe_latency=12, hold=0)   # at the limit: 5 + 12 + 16 = D + 1
P1H0 = dataclasses.replace(P1, hold=0, kg_shift=37)                   # W = B/2: KG one shift less
P2H1 = dataclasses.replace(P2, hold=1, block_log2=4, pipe_latency=40, kg_shift=20)   # HOLD = 1: no latency limit


class Encoder:
    """A synthetic drifting encoder: W0 + A sin / cos with offsets and gains ramping over time."""

    def __init__(self, p: DriftParams, n: int, seed: int = 1, amp_frac: float = 0.3, speed: float = 0.013,
                 drift: float = 1.0, w0=(30.0, -20.0), phi: np.ndarray | None = None):
        rng = np.random.default_rng(seed)
        self.p = p
        amp = amp_frac * 2 ** (p.adc_w - 1)
        self.amp = amp
        self.w0f = w0
        t = np.arange(n)
        self.phi = 2 * np.pi * (t * speed + 0.3 * np.sin(t * 1e-4) + rng.uniform()) if phi is None else phi
        sc = 2 ** (p.adc_w - 14)
        self.os = (200 + drift * 100 * t / n) * sc
        self.oc = (-150 + drift * 80 * np.sin(t / n * 3)) * sc
        self.gs = 1.1 - drift * 0.05 * t / n
        self.gc = 0.92 + drift * 0.04 * t / n
        lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
        self.rs = np.clip(np.round(self.os + self.gs * (w0[0] + amp * np.sin(self.phi))), lo, hi).astype(np.int64)
        self.rc = np.clip(np.round(self.oc + self.gc * (w0[1] + amp * np.cos(self.phi))), lo, hi).astype(np.int64)
        vs, w0s = make_fwd_table(lambda ph: w0[0] + amp * np.sin(2 * np.pi * ph), p)
        vc, w0c = make_fwd_table(lambda ph: w0[1] + amp * np.cos(2 * np.pi * ph), p)
        self.values = (vs, vc)
        self.tables = np.stack([pack_words(vs, p), pack_words(vc, p)])
        self.w0 = (w0s, w0c)
        self.kg = (kg_for(vs, p), kg_for(vc, p))
        tf = 2.0 ** p.table_frac
        ws, wc, fw = w0s / tf, w0c / tf, p.fine_w

        def phase_of(ys, yc):
            x = np.mod(np.arctan2(np.asarray(ys) - ws, np.asarray(yc) - wc) / (2 * np.pi), 1.0)
            return np.floor(x * 2.0 ** fw).astype(np.int64) & ((1 << fw) - 1)

        self.phase_of = phase_of

    def run(self, **kw):
        return drift_run(self.rs, self.rc, self.phase_of, self.p, self.tables, self.w0, self.kg, **kw)


def reference(rs, rc, phase_of, p: DriftParams, tables, w0, kg, *, old: bool = False):
    """The contract of docs/drift.md as a plain per-sample loop on Python integers.

    old = True: the tracker before HOLD, window, gear shift and partial sweeps (D = B/2, every sample of the
    block accumulated, a fixed step 2^-MU_LOG2, only blocks of a whole period), for comparisons of the start-up."""
    B = p.b
    D = B // 2 if old else (0 if p.hold else B // 2)
    W = B if old or p.hold else B // 2
    wl = W.bit_length() - 1
    u = 0                                 # updates so far
    off, ginv = [0, 0], [p.unity, p.unity]
    pending = []                          # (apply index, state)
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    se, sea, sweep = [0, 0], [0, 0], 0
    prev = None
    ys, yc, sat, states = [], [], [], [(0, 0, p.unity, p.unity)]
    for n in range(len(rs)):
        while pending and pending[0][0] == n:
            _, st = pending.pop(0)
            off, ginv = list(st[:2]), list(st[2:])
        y, s = [], False
        for k, r in enumerate((int(rs[n]), int(rc[n]))):
            sh = p.ofs_frac + p.ginv_w - 2
            v = (((r << p.ofs_frac) - off[k]) * ginv[k] + (1 << (sh - 1))) >> sh
            s = s or not lo <= v <= hi
            y.append(min(max(v, lo), hi))
        ys.append(y[0])
        yc.append(y[1])
        sat.append(int(s))
        ph = int(phase_of(np.array([y[0]]), np.array([y[1]]))[0])
        fb = p.fb
        inwin = n % B >= B - W
        for k in (0, 1):
            word = int(tables[k][ph >> fb])
            sl, va = (int(x[0]) for x in unpack_words(np.array([word]), p))
            a = va + ((sl * (ph & ((1 << fb) - 1)) + (1 << (fb - 1))) >> fb)
            e = (y[k] << p.table_frac) - int(w0[k]) - a
            if inwin:
                se[k] += e
                sea[k] += e * a
        if prev is not None and inwin:
            d = (ph - prev) % (1 << p.fine_w)
            sweep += min(d, (1 << p.fine_w) - d)
        prev = ph
        if n % B == B - 1:
            cur = pending[-1][1] if pending else (off[0], off[1], ginv[0], ginv[1])
            full = sweep >= 1 << p.fine_w
            partial = sweep >= 1 << (p.fine_w - SWEEP_MIN_LOG2) and p.mu_log2 >= PARTIAL_MU_MIN
            if full or (not old and partial):
                # less than a period: the final step, not counted by the gear
                gear = min(p.mu_log2, u.bit_length()) if full and not old else p.mu_log2
                u += full
                no, ng = [], []
                for k in (0, 1):
                    # the offset step: twice the mean error (the old tracker: once)
                    o = cur[k] + ((se[k] << p.ofs_frac) >> (wl + p.table_frac + gear - (0 if old else 1)))
                    no.append(min(max(o, -(1 << (p.ofs_w - 1))), (1 << (p.ofs_w - 1)) - 1))
                    # the shift KG_SHIFT - (MU_LOG2 - G) of the contract, rounded with half of it
                    sh = p.kg_shift - (p.mu_log2 - gear)
                    step = (sea[k] * int(kg[k]) + (1 << (sh - 1))) >> sh if sh >= 1 else sea[k] * int(kg[k]) << -sh
                    g = cur[2 + k] - step
                    ng.append(min(max(g, 0), (1 << p.ginv_w) - 1))
                cur = (no[0], no[1], ng[0], ng[1])
            states.append(cur)
            pending.append((n + 1 + D, cur))
            se, sea, sweep = [0, 0], [0, 0], 0
    return np.array(ys), np.array(yc), np.array(sat), np.array(states)


# ---------------------------------------------------------------------------- parameters


def test_derived_constants():
    p = P1
    assert (p.b, p.d, p.w, p.fb, p.bins, p.ofs_w, p.unity, p.norm_shift, p.off_shift(3)) == (
        256, 0, 256, 10, 64, 18, 1 << 16, 20, 12)
    assert (p.e_w, p.se_w, p.sea_w, p.sweep_w, p.word_w) == (20, 28, 47, 24, 36)
    q = P1H0
    assert (q.d, q.w, q.w_log2, q.off_shift(0), q.se_w, q.sea_w, q.sweep_w) == (128, 128, 7, 8, 27, 46, 23)
    assert (NORM_LATENCY, OBS_LATENCY, p.norm_latency, p.obs_latency) == (5, 16, 5, 16)
    assert p.hdl_parameters() == p.observer().hdl_parameters()    # no HDL block takes PIPE_LATENCY: the core's own
    assert p.hdl_parameters()["KG_SHIFT"] == 38
    assert p.hdl_parameters()["HOLD"] == 1 and q.hdl_parameters()["HOLD"] == 0


def test_gear_schedule():
    """G_u = min(MU_LOG2, bit_length(u)): steps 1, 1/2, 1/4, 1/4, 1/8 x 4, ... down to 2^-MU_LOG2."""
    p = dataclasses.replace(P1, mu_log2=4)
    steps = [2.0 ** -p.gear(u) for u in range(20)]
    assert steps == [1, 0.5, 0.25, 0.25] + [0.125] * 4 + [0.0625] * 12
    assert [P1.gear(u) for u in (0, 1, 2, 4, 100)] == [0, 1, 2, 3, 3]
    assert [dataclasses.replace(P1, mu_log2=0).gear(u) for u in (0, 1, 5)] == [0, 0, 0]


BASE = P1H0.hdl_parameters()
KEYS = {k.lower(): k for k in BASE}


@pytest.mark.parametrize(
    "over, msg",
    [
        *out_of_range("fringe_drift_observer", "adc_w", 4, 24),
        ({"fine_w": 7, "fwd_w": 4}, "fringe_drift_observer: FINE_W = 7 out of range 8..30"),
        *out_of_range("fringe_drift_observer", "fine_w", 8, 30, values=(31,)),
        *out_of_range("fringe_drift_observer", "block_log2", 4, 12),
        *out_of_range("fringe_drift_observer", "mu_log2", 0, 8, values=(9,)),
        *out_of_range("fringe_drift_observer", "ofs_frac", 0, 8, values=(9,)),
        ({"adc_w": 24, "ofs_frac": 9}, "fringe_drift_observer: OFS_FRAC = 9 out of range 0..8"),
        ({"adc_w": 24, "ofs_frac": 8}, "NOERROR"),
        *out_of_range("fringe_drift_observer", "ginv_w", 8, 24),
        *out_of_range("fringe_drift_observer", "fwd_w", 2, 10, "min(10, FINE_W-1) = 10"),
        ({"fine_w": 9, "fwd_w": 9}, "fringe_drift_observer: FWD_W = 9 out of range 2..min(10, FINE_W-1) = 8"),
        *out_of_range("fringe_drift_observer", "table_w", 8, 24),
        *out_of_range("fringe_drift_observer", "table_frac", 0, 12, values=(13,)),
        *out_of_range("fringe_drift_observer", "kg_w", 8, 24),
        *out_of_range("fringe_drift_observer", "kg_shift", 1, 60),
        ({"pipe_latency": -1}, "fringe_core: PIPE_LATENCY = -1 must be >= 0"),
        ({"pipe_latency": 109}, "fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = 5 + 109 + 16 = 130 "
                                "exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = 129: the update would come too late"),
        ({"block_log2": 4}, "fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = 5 + 0 + 16 = 21 exceeds "
                            "D + 1 = 2^(BLOCK_LOG2-1) + 1 = 9: the update would come too late"),
        ({"block_log2": 4, "hold": 1}, "NOERROR"),             # HOLD = 1: no latency limit
        ({"pipe_latency": 1000, "hold": 1}, "NOERROR"),
        *out_of_range("fringe_drift_observer", "hold", 0, 1),
        ({"table_w": 18.0}, "fringe_drift_observer: TABLE_W must be an integer"),
    ],
)
def test_parameter_validation(over, msg):
    kw = {k: BASE[v] for k, v in KEYS.items()}
    kw.update(over)
    if msg == "NOERROR":
        DriftParams(**kw)
        return
    with pytest.raises(ValueError, match=re.escape(msg)):
        DriftParams(**kw)


def test_pipe_latency_limit_is_exact():
    DriftParams(**{**{k: BASE[v] for k, v in KEYS.items()}, "pipe_latency": 108})   # 5 + 108 + 16 = 129 = D + 1


def test_hdl_messages_match_model():
    """The HDL refuses with DriftParams' messages: the ranges in fringe_drift_observer (fringe_pkg's checks, which
    fringe_drift_normaliser shares for the state's parameters), the halves' timing in fringe_core (DRIFT = 1)."""
    v, h = block_texts("fringe_drift_observer")
    v += (REPO / "rtl/verilog/fringe_pkg.vh").read_text()     # the checks it shares with the normaliser are there
    ranges = (("ADC_W", "4..24"), ("FINE_W", "8..30"), ("BLOCK_LOG2", "4..12"), ("MU_LOG2", "0..8"),
              ("OFS_FRAC", "0..8"), ("GINV_W", "8..24"), ("TABLE_W", "8..24"), ("TABLE_FRAC", "0..12"),
              ("KG_W", "8..24"), ("KG_SHIFT", "1..60"), ("HOLD", "0..1"))
    assert not missing_checks("fringe_drift_observer", ranges)
    for frag in ("out of range 2..min(10, FINE_W-1) = ", "ADC_W + OFS_FRAC = ", " exceeds 32"):
        assert frag in v and frag in h, frag
    cv, ch = block_texts("fringe_core")
    for frag in ("fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = ", "exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = ",
                 ": the update would come too late"):
        assert frag in cv and frag in ch, frag


def test_latency_constants_in_hdl():
    """The package constants the core times the halves with (generated by sim/hdlgen.py) are the halves' LATENCY."""
    pattern = r"(?:localparam\s+integer\s+|constant\s+){}\s*(?::\s*integer\s*:)?=\s*(\w+)\s*;"
    for core, pkg in ((REPO / "rtl/verilog/fringe_core.v", REPO / "rtl/verilog/fringe_pkg.vh"),
                      (REPO / "rtl/vhdl/fringe_core.vhd", REPO / "rtl/vhdl/fringe_pkg.vhd")):
        for name, val in (("DRIFT_NORM_LATENCY", NORM_LATENCY), ("DRIFT_OBS_LATENCY", OBS_LATENCY)):
            m = re.search(pattern.format(name), pkg.read_text())
            assert m and int(m.group(1)) == val, (pkg, name)
            assert name in core.read_text(), (core, name)


class _LateParams(DriftParams):
    """HOLD = 1's window and gear, but each update applied one block late (from (j+2)B): what the core
    would compute if the boundary sample did not wait for its update."""

    @property
    def d(self) -> int:
        return self.b


@pytest.mark.parametrize("p", [P1, P2H1], ids=["P1", "P2-hold1"])
def test_hold_is_needed(p):
    """Without the hold the words differ: the model with every update applied one block late gives other
    normalised codes on a fast stream (so the core's RTL tests with DRIFT_HOLD = 1, which compare every word,
    catch a boundary sample taken before its update; tb/test_fringe_top.py also checks the hold's timing)."""
    enc = Encoder(p, 6 * p.b, seed=777, speed=2.3 / p.b)
    late = _LateParams(**{f: getattr(p, f) for f in p.__dataclass_fields__})
    r = enc.run()
    q = drift_run(enc.rs, enc.rc, enc.phase_of, late, enc.tables, enc.w0, enc.kg)
    k = min(q.apply_at.size, r.apply_at.size)
    assert r.updated.sum() >= 3 and late.d == p.b and (q.apply_at[:k] == r.apply_at[:k] + p.b).all()
    assert (q.y_sin[p.b:2 * p.b] == r.y_sin[p.b:2 * p.b]).mean() < 0.5    # block 1: reset state vs update 0


# ---------------------------------------------------------------------------- tables


def test_tables_pack_unpack_and_limits():
    p = P1
    v, w0 = make_fwd_table(lambda ph: 10 + 4000 * np.sin(2 * np.pi * ph), p)
    assert w0 == 40 and abs(v.mean()) < 1
    sl, va = unpack_words(pack_words(v, p), p)
    np.testing.assert_array_equal(va, v)
    np.testing.assert_array_equal(sl, np.roll(v, -1) - v)
    with pytest.raises(ValueError, match="does not fit s\\(18\\)"):
        make_fwd_table(lambda ph: 1e5 * np.sin(2 * np.pi * ph), p)
    with pytest.raises(ValueError, match="KG = .* does not fit u\\(18\\)"):
        kg_for(np.ones(p.bins, dtype=np.int64), p)
    kg = kg_for(v, p)
    # the 4/3 makes up for the 3/4 of a gain error the observer sees inside the core
    assert abs(kg * 3 / 4 * p.b * np.mean(v.astype(float) ** 2) / 2.0 ** (p.kg_shift + p.ginv_w - 2 - p.mu_log2)
               - 1) < 1e-4


# ---------------------------------------------------------------------------- bit-exact behaviour


@pytest.mark.parametrize("p", [P1, P2, P1H0, P2H1], ids=["P1", "P2-hold0", "P1-hold0", "P2-hold1"])
def test_matches_plain_reference(p):
    enc = Encoder(p, max(9 * p.b, 600) + 37, seed=3, speed=max(0.05, 1.5 / p.w), drift=5.0)
    r = enc.run()
    ys, yc, sat, states = reference(enc.rs, enc.rc, enc.phase_of, p, enc.tables, enc.w0, enc.kg)
    np.testing.assert_array_equal(r.y_sin, ys)
    np.testing.assert_array_equal(r.y_cos, yc)
    np.testing.assert_array_equal(r.sat, sat)
    np.testing.assert_array_equal(r.states, states)
    assert r.updated.any() and (np.diff(r.states, axis=0) != 0).any()


@pytest.mark.parametrize("p", [P1, P2, P1H0, P2H1], ids=["P1", "P2-hold0", "P1-hold0", "P2-hold1"])
def test_composes_the_halves_models(p):
    """drift_run is the normaliser's model on the observer's states, and the observer's model on the normaliser's
    codes and the core's phases: the tracker is the composition of fringe_drift_normaliser and
    fringe_drift_observer (their RTL tests check each half against these models)."""
    enc = Encoder(p, max(9 * p.b, 600) + 37, seed=3, speed=max(0.05, 1.5 / p.w), drift=5.0)
    r = enc.run()
    ys, yc, sat, sidx = normaliser_run(enc.rs, enc.rc, r.states, p.normaliser())
    for got, want in ((ys, r.y_sin), (yc, r.y_cos), (sat, r.sat), (sidx, r.state_index)):
        np.testing.assert_array_equal(got, want)
    o = observer_run(r.phase, r.y_sin, r.y_cos, enc.tables, enc.w0, enc.kg, p.observer())
    for f in ("states", "updated", "track_sat", "sweep", "se", "sea"):
        np.testing.assert_array_equal(getattr(o, f), getattr(r, f), err_msg=f)
    assert r.updated.any()


@pytest.mark.parametrize("make, name", [(lambda: NormaliserParams(ginv_w=7), "fringe_drift_normaliser: GINV_W = 7"),
                                        (lambda: NormaliserParams(adc_w=24, ofs_frac=9),
                                         "fringe_drift_normaliser: OFS_FRAC = 9 out of range 0..8"),
                                        (lambda: ObserverParams(kg_shift=61), "fringe_drift_observer: KG_SHIFT = 61"),
                                        (lambda: ObserverParams(fine_w=9, fwd_w=9),
                                         "fringe_drift_observer: FWD_W = 9 out of range 2..min(10, FINE_W-1) = 8"),
                                        (lambda: ObserverParams(hold=2), "fringe_drift_observer: HOLD = 2")])
def test_halves_refuse_with_their_names(make, name):
    with pytest.raises(ValueError, match=re.escape(name)):
        make()


def test_halves_parameters():
    """The halves' parameters of a DriftParams carry its values; its HDL map is the observer's, the normaliser's a
    subset."""
    assert P2.normaliser() == NormaliserParams(adc_w=10, block_log2=6, ofs_frac=0, ginv_w=12, hold=0)
    assert P2.observer().hdl_parameters() == P2.hdl_parameters()
    assert set(P2.normaliser().hdl_parameters()) <= set(P2.hdl_parameters())


def test_segment_boundaries_do_not_matter():
    p = P2
    enc = Encoder(p, 40 * p.b + 5, seed=4, speed=0.05)
    base = enc.run()
    for chunk in (1, 7, 33, 1000):
        r = enc.run(chunk=chunk)
        for f in ("y_sin", "y_cos", "sat", "phase", "states", "updated", "track_sat", "sweep", "state_index"):
            np.testing.assert_array_equal(getattr(r, f), getattr(base, f), err_msg=f"chunk {chunk}: {f}")
    # a prefix of the stream gives a prefix of the result
    short = drift_run(enc.rs[:1000], enc.rc[:1000], enc.phase_of, p, enc.tables, enc.w0, enc.kg)
    np.testing.assert_array_equal(short.y_sin, base.y_sin[:1000])
    np.testing.assert_array_equal(short.states, base.states[:short.states.shape[0]])


def test_slow_blocks_are_skipped():
    p = P2
    enc = Encoder(p, 30 * p.b, seed=5, speed=0.03 / p.w)      # 0.03 period per window: below a sixteenth
    r = enc.run()
    assert not r.updated.any() and (r.sweep < 1 << (p.fine_w - SWEEP_MIN_LOG2)).all()
    assert (r.states == r.states[0]).all()
    fast = Encoder(p, 30 * p.b, seed=5, speed=1.5 / p.w).run()     # 1.5 periods per window
    assert fast.updated.all()


def test_partial_sweeps_update_at_the_final_gear():
    """A block that sweeps at least a sixteenth of a period but less than a whole one updates at the final
    step 2^-MU_LOG2 and leaves the gear where it was (a slow start-up is not stuck with all of its drift until
    some block sweeps a period); a block that sweeps less is skipped. Four blocks each of 0.5, 0.03, 1.5, 0.2,
    1.5 periods per block: the offset moves by (SE * 2^OFS_FRAC) >>> (log2(W) + TABLE_FRAC - 1 + G) with G the
    gear of the whole-period updates counted so far, or MU_LOG2."""
    p = dataclasses.replace(P2H1, mu_log2=3)
    rates = np.repeat([0.5, 0.03, 1.5, 0.2, 1.5], 4 * p.b) / p.b          # periods per sample
    enc = Encoder(p, rates.size, seed=9, phi=2 * np.pi * (np.cumsum(rates) + 0.1))
    r = enc.run()
    full = r.sweep >= 1 << p.fine_w
    partial = ~full & (r.sweep >= 1 << (p.fine_w - SWEEP_MIN_LOG2))
    assert full.sum() == 8 and partial.sum() == 8 and (r.updated == (full | partial)).all()
    assert not r.track_sat.any()
    gears, u = [], 0
    for f in full:
        gears.append(p.gear(u) if f else p.mu_log2)
        u += int(f)
    assert gears[8:12] == [0, 1, 2, 2] and gears[16:20] == [3, 3, 3, 3]   # the first whole period: step 1
    moved = np.diff(r.states[:, :2], axis=0)
    for j in np.flatnonzero(r.updated):
        assert tuple(moved[j]) == tuple((se << p.ofs_frac) >> p.off_shift(gears[j]) for se in r.se[j]), j


def test_partial_sweeps_need_a_small_final_step():
    """On an arc offset and gain are one direction: a servo dithering a quarter period back and forth near the
    sine's peak (0.1-0.15 period per block) drove GINV to 0 with a final step of 1/2 (absorbing: y = 0). Partial
    blocks therefore update only from MU_LOG2 = PARTIAL_MU_MIN (2) on, where the state stays bounded."""
    for mu in (1, 2):
        p = dataclasses.replace(P2H1, mu_log2=mu, block_log2=6)
        t = np.arange(200 * p.b)
        enc = Encoder(p, t.size, seed=3, phi=2 * np.pi * (0.25 + 0.125 * np.sin(2 * np.pi * t / (4 * p.b))))
        r = enc.run()
        assert (r.sweep < 1 << p.fine_w).all() and (r.sweep >= 1 << (p.fine_w - SWEEP_MIN_LOG2)).mean() > 0.9
        if mu < PARTIAL_MU_MIN:
            assert not r.updated.any()
        else:
            assert r.updated.mean() > 0.9 and not r.track_sat.any()
            assert r.states[:, 2:].min() > p.unity // 2       # gains 0.92 and 1.1: GINV near 1 / gain


def test_state_and_output_saturation():
    p = dataclasses.replace(P2, kg_shift=16)
    enc = Encoder(p, 60 * p.b, seed=6, amp_frac=0.45, speed=0.05, drift=0.0)
    enc.kg = ((1 << p.kg_w) - 1,) * 2                           # a far too large gain step: GINV overshoots
    r = enc.run()
    assert r.track_sat.any() and r.sat.any()
    assert r.states[:, 2:].min() == 0 and r.states[:, 2:].max() == (1 << p.ginv_w) - 1


# ---------------------------------------------------------------------------- tracking quality


def test_tracker_converges_on_drifting_signal():
    p = P1
    n = 400_000
    enc = Encoder(p, n, seed=7)
    r = enc.run()
    j = np.arange(r.states.shape[0] - 1)
    at = np.minimum(r.apply_at, n - 1)
    late = j >= len(j) // 4
    off_err = np.abs(r.states[1:, :2] / 2.0 ** p.ofs_frac - np.stack([enc.os[at], enc.oc[at]], 1))[late]
    gain_err = np.abs(r.states[1:, 2:] / p.unity * np.stack([enc.gs[at], enc.gc[at]], 1) - 1)[late]
    drift_off = np.ptp(enc.os) + 200, np.ptp(enc.oc) + 150
    assert off_err.max() < 3.0, off_err.max()                   # drift 100 (and 200 initial) codes
    assert off_err.max() < 0.02 * min(drift_off)
    assert gain_err.max() < 3e-3, gain_err.max()                # gains 1.1 -> 1.05 and 0.92 -> 0.96
    # the signals after the tracker: the offset and gain seen by the rest of the core are near nominal
    tail = slice(n // 2, n)
    ys = r.y_sin[tail] - enc.w0[0] / 2.0 ** p.table_frac
    assert abs(ys.mean()) < 3.0 and abs(np.sqrt(2) * ys.std() / enc.amp - 1) < 3e-3


@pytest.mark.parametrize("p", [P1, P1H0], ids=["hold1", "hold0"])
def test_float_agrees_within_bound(p):
    enc = Encoder(p, 300_000, seed=8)
    r = enc.run()
    f = drift_float(enc.rs, enc.rc, enc.phase_of, p, enc.tables, enc.w0, enc.kg)
    np.testing.assert_array_equal(f["updated"], r.updated)
    d = np.abs(f["states"] - r.states)[r.states.shape[0] // 3:]
    b = error_bound(p)
    assert d[:, :2].max() <= b["off_lsb"], (d[:, :2].max(), b)
    assert d[:, 2:].max() <= b["ginv_lsb"], (d[:, 2:].max(), b)
    assert np.abs(f["y_sin"] - r.y_sin)[100_000:].max() < 2.0




# ---------------------------------------------------------------------------- start-up: deadbeat and gear shift


def _exact_stream(p: DriftParams, n: int, off, gain, step_bins: int = 3):
    """Raw codes that are exactly ``off + gain * value[bin]`` (integers: values are multiples of 16 and
    the gains 1 +- 1/16) at phases on the bin starts, stepping ``step_bins`` bins per sample (every bin once
    in any 2^FWD_W consecutive samples), with zero-mean tables (W0 = 0): the tracker's only errors are its
    own roundings. Returns (rs, rc, phase_of, tables, w0, kg, values)."""
    amp = 0.3 * 2 ** (p.adc_w - 1)
    k = np.arange(p.bins)
    vals = [16 * np.round(amp * f(2 * np.pi * k / p.bins) / 16).astype(np.int64) for f in (np.sin, np.cos)]
    assert all(v.sum() == 0 for v in vals)                     # odd / even symmetry: W0 = 0
    bins = (step_bins * np.arange(n) + 5) % p.bins
    raw = [(o + g * v[bins]) for o, g, v in zip(off, gain, vals, strict=True)]
    assert all(np.array_equal(r, np.round(r)) for r in raw)
    ph = bins << p.fb
    pos = [0]

    def phase_of(ys, yc):                                      # the true phases, in order
        out = ph[pos[0]:pos[0] + len(ys)]
        pos[0] += len(ys)
        return out

    tables = np.stack([pack_words(v, p) for v in vals])
    kg = [kg_for(v, p) for v in vals]
    return raw[0].astype(np.int64), raw[1].astype(np.int64), phase_of, tables, (0, 0), kg, vals


def _core_stream(p: DriftParams, n: int, off, gain, periods: int = 2):
    """A round Lissajous figure (0.3 of full scale, W0 = 0) with constant offsets and gains, rounded to
    codes, noise-free, ``periods`` uniform periods per window; the phase as inside the core: atan2 of the
    normalised codes (minus W0), FINE_W bits. Returns (rs, rc, phase_of, tables, w0, kg, theta, amp)."""
    amp = 0.3 * 2 ** (p.adc_w - 1)
    th = 2 * np.pi * (np.arange(n) * periods / p.w + 0.1)
    ideal = (amp * np.sin(th), amp * np.cos(th))
    raw = [np.round(off[k] + gain[k] * ideal[k]).astype(np.int64) for k in (0, 1)]
    tabs = [make_fwd_table(lambda ph, f=f: amp * f(2 * np.pi * ph), p) for f in (np.sin, np.cos)]
    w0 = [t[1] for t in tabs]
    tf = 2.0 ** p.table_frac

    def phase_of(ys, yc):
        x = np.mod(np.arctan2(np.asarray(ys) - w0[0] / tf, np.asarray(yc) - w0[1] / tf) / (2 * np.pi), 1.0)
        return np.floor(x * 2.0 ** p.fine_w).astype(np.int64) & ((1 << p.fine_w) - 1)

    tables = np.stack([pack_words(t[0], p) for t in tabs])
    return raw[0], raw[1], phase_of, tables, w0, [kg_for(t[0], p) for t in tabs], th, amp


@pytest.mark.parametrize("hold", [1, 0])
def test_first_update_is_deadbeat_inside_the_core(hold):
    """With the phase from the normalised codes (as in the core) the observer sees half of an offset error
    (the radial part) and [[3/4, 1/4], [1/4, 3/4]] of the channels' relative gain errors (docs "Loop gain").
    The doubled offset step removes an offset in the first update (step 1) up to the third-order term of
    the exact mean error; the step before left half of it. KG's 4/3 removes a gain error of one channel to
    first order (the second-order rest -5/4 eps^2) and moves the other channel by -eps/3; before, 1/4 of it
    stayed and the other moved by -eps/4."""
    p = DriftParams(adc_w=14, fine_w=16, block_log2=7 - hold, mu_log2=3, ofs_frac=4, ginv_w=18, fwd_w=8,
                    table_w=18, table_frac=2, kg_w=18, kg_shift=36, hold=hold)
    # offsets only: the analysis' mean error, exact for a circle (no linearisation), over the first window
    off = (200, -150)
    rs, rc, phase_of, tables, w0, kg, th, amp = _core_stream(p, 3 * p.b, off, (1, 1))
    r = drift_run(rs, rc, phase_of, p, tables, w0, kg)
    assert r.updated.all()
    win = slice(p.b - p.w, p.b)
    ys, yc = off[0] + amp * np.sin(th[win]), off[1] + amp * np.cos(th[win])
    tp = np.arctan2(ys, yc)
    mean_e = np.array([(ys - amp * np.sin(tp)).mean(), (yc - amp * np.cos(tp)).mean()])
    np.testing.assert_allclose(mean_e / off, 0.5, rtol=2e-3)                     # the radial half
    first = r.states[1, :2] / 2.0 ** p.ofs_frac
    # rounding: the codes' (1/2) and the interpolation's (2^-TABLE_FRAC / 2) in the mean error, doubled;
    # the floored step (one OFF LSB)
    tol = 2 * (0.5 + 0.5 * 2.0 ** -p.table_frac) + 2.0 ** -p.ofs_frac
    assert np.abs(first - 2 * mean_e).max() <= tol, (first, 2 * mean_e)
    assert (np.abs(first - off) <= 0.1 * np.abs(off)).all(), first           # the step before: 0.5
    # a gain error on one channel at a time
    eps = 1 / 64
    # the codes' rounding against a (mean |a| = 2 amp / pi) relative to mean a^2 = amp^2 / 2, times 4/3,
    # and one GINV LSB
    tol = 4 / 3 * (2 / np.pi) / amp * (1 + 2.0 ** -p.table_frac) + 1 / p.unity
    for k in (0, 1):
        gain = [1.0, 1.0]
        gain[k] += eps
        rs, rc, phase_of, tables, w0, kg, _, _ = _core_stream(p, 2 * p.b, (0, 0), gain)
        r = drift_run(rs, rc, phase_of, p, tables, w0, kg)
        rel = r.states[1, 2:] / p.unity * np.array(gain) - 1                    # relative gain left
        assert abs(rel[k] + 5 / 4 * eps ** 2) <= tol, rel / eps                   # the step before: eps / 4
        assert abs(rel[1 - k] + eps / 3) <= tol + eps ** 2, rel / eps             # before: -eps / 4


def test_gear_shift_in_the_updates():
    """Update u moves the offset by 2^(1 - G_u) times its mean error (twice the mean error, the gear's
    step 2^-G_u). With a known phase (the true phase, exact codes, the gain loop off: KG = 0) the observer
    sees the whole offset error, so the step of 1 overshoots to the opposite error (the loop gain 2 of
    the docs' worst case) and the step of 1/2 removes it; an offset that steps by 256 codes every block
    shows the fractions of every update exactly (the offset error rounded to codes, as y is)."""
    p = DriftParams(adc_w=14, fine_w=16, block_log2=6, mu_log2=3, ofs_frac=4, ginv_w=18, fwd_w=6, table_w=18,
                    table_frac=0, kg_w=18, kg_shift=30, hold=1)
    off, gain = (1024, -512), (1.0, 1.0)
    rs, rc, phase_of, tables, w0, _, _ = _exact_stream(p, 10 * p.b, off, gain)
    r = drift_run(rs, rc, phase_of, p, tables, w0, (0, 0))
    err = np.array(off) * 2 ** p.ofs_frac - r.states[:, :2]
    assert (err[1] == -err[0]).all() and (err[2:] == 0).all()           # 1: overshoot, then 1/2: deadbeat
    rs2 = rs.copy()
    for j in range(1, 10):
        rs2[j * p.b:] += 256
    phase_of2 = _exact_stream(p, 10 * p.b, off, gain)[2]
    r2 = drift_run(rs2, rc, phase_of2, p, tables, w0, (0, 0))
    assert r2.updated.all()
    true = (off[0] + 256 * np.arange(10)) * 2 ** p.ofs_frac            # during block j
    e = true - r2.states[:-1, 0]                                       # the error update j sees
    moved = np.diff(r2.states[:, 0])
    seen = np.floor(e / 2 ** p.ofs_frac + 0.5) * 2 ** p.ofs_frac       # y is rounded to codes
    np.testing.assert_array_equal(moved, seen * 2.0 ** (1 - np.array([p.gear(u) for u in range(10)])))
    assert [p.gear(u) for u in range(10)] == [0, 1, 2, 2, 3, 3, 3, 3, 3, 3]


def _settle_samples(y_s, y_c, ideal_s, ideal_c, floor: float, win: int = 32) -> int:
    """Samples until the RMS error of the normalised codes (windows of ``win``) stays below 3 floors."""
    err = (np.asarray(y_s, float) - ideal_s) ** 2 + (np.asarray(y_c, float) - ideal_c) ** 2
    n = err.size // win * win
    rms = np.sqrt(err[:n].reshape(-1, win).mean(axis=1) / 2)
    bad = np.flatnonzero(rms > 3 * floor)
    return 0 if bad.size == 0 else int(bad[-1] + 1) * win


def test_startup_is_shorter_than_before():
    """From reset with a full offset / gain error and noise, the phase computed from the normalised codes
    (as in the core): the samples until the normalised codes stay within 3 times the noise floor (RMS over
    32-sample windows). HOLD = 1, B = 32, MU_LOG2 = 2 with the gear shift, against the tracker before (D =
    B/2, the whole block accumulated, a fixed step) with B = 128 (its smallest block in the core) at its
    best step; the same nominal averaging length B 2^MU_LOG2 = 128 as the old MU_LOG2 = 0 (whose true
    loop gain was half its step: the observer saw half of an offset error), and the same steady error
    (checked). Measured on the same stream; the floor is that of a perfect normaliser (the true
    offset and gain removed)."""
    p_new = DriftParams(adc_w=14, fine_w=16, block_log2=5, mu_log2=2, ofs_frac=4, ginv_w=18, fwd_w=6,
                        table_w=18, table_frac=2, kg_w=18, kg_shift=34, hold=1)
    n = 12_000
    enc = Encoder(p_new, n, seed=11, speed=0.05, drift=0.0)          # 1.6 periods per 32 samples
    rng = np.random.default_rng(12)
    lo, hi = -(1 << (p_new.adc_w - 1)), (1 << (p_new.adc_w - 1)) - 1
    noise = [rng.normal(0, 2.0, n) for _ in range(2)]
    ideal_s = enc.w0f[0] + enc.amp * np.sin(enc.phi)
    ideal_c = enc.w0f[1] + enc.amp * np.cos(enc.phi)
    rs = np.clip(np.round(enc.os + enc.gs * ideal_s + noise[0]), lo, hi).astype(np.int64)
    rc = np.clip(np.round(enc.oc + enc.gc * ideal_c + noise[1]), lo, hi).astype(np.int64)
    floor = np.sqrt((((rs - enc.os) / enc.gs - ideal_s) ** 2 + ((rc - enc.oc) / enc.gc - ideal_c) ** 2).mean() / 2)

    def run(p, old=False):
        vs, w0s = make_fwd_table(lambda ph: enc.w0f[0] + enc.amp * np.sin(2 * np.pi * ph), p)
        vc, w0c = make_fwd_table(lambda ph: enc.w0f[1] + enc.amp * np.cos(2 * np.pi * ph), p)
        tables = np.stack([pack_words(vs, p), pack_words(vc, p)])
        kp = largest_kg_shift(dataclasses.replace(p, hold=1) if old else p, (vs, vc))   # old: KG for W = B
        p = dataclasses.replace(p, kg_shift=kp.kg_shift)
        kg = (kg_for(vs, kp), kg_for(vc, kp))
        if old:
            ys, yc = reference(rs, rc, enc.phase_of, p, tables, (w0s, w0c), kg, old=True)[:2]
        else:
            r = drift_run(rs, rc, enc.phase_of, p, tables, (w0s, w0c), kg)
            ys, yc = r.y_sin, r.y_cos
        tail = np.sqrt((((ys - ideal_s) ** 2 + (yc - ideal_c) ** 2)[n // 2:]).mean() / 2)
        return _settle_samples(ys, yc, ideal_s, ideal_c, floor), tail / floor

    new, new_tail = run(p_new)
    olds = {mu: run(dataclasses.replace(p_new, block_log2=7, mu_log2=mu, hold=0), old=True) for mu in (0, 1, 2)}
    best = min(olds, key=lambda mu: olds[mu][0])
    print(f"start-up to 3x the floor ({floor:.2f} codes): HOLD=1 B=32 MU_LOG2=2: {new} samples (steady "
          f"{new_tail:.2f} floors); before, B=128: "
          + ", ".join(f"MU_LOG2={m}: {s} ({t:.2f})" for m, (s, t) in olds.items()))
    assert new < olds[best][0], (new, olds)
    assert new_tail <= 1.05 * olds[best][1], (new_tail, olds)     # not bought with a noisier steady state
