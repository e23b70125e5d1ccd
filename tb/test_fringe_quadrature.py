"""fringe_quadrature (Verilog and VHDL) against the bit-exact model, every output word exactly.

Traffic: full speed with corner cases first (extreme codes, saturation of s and c, rounding
ties), then random in_valid gaps and ce stalls with resets mid-stream, coefficient sets that
switch between samples (the block samples them with the sample) and random sideband.
Run: ``pytest tb/test_fringe_quadrature.py`` (``--sims verilator`` or ``ghdl`` to pick one).
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from lib.cocotb_optional import cocotb

from fringe.fixed.quadrature import (
    LATENCY,
    SHARED_MIN_CLOCKS,
    QuadratureCoefs,
    QuadratureParams,
    quadrature,
    quantise_coefs,
)

TOPLEVEL = "fringe_quadrature"

# (WAVE_W, COEF_W, USER_W, seed): differences of 19 and 21 bits are split into partial products
# (the rounding constant below the high one, or added for COEF_W = 20); 16 bits are not (the seed)
BASE_SETS = [
    (18, 18, 3, 101),
    (20, 16, 1, 202),
    (15, 16, 2, 303),
    (19, 20, 1, 404),
]
# each set with parallel products (SHARED_MUL = 0) and through one multiplier (SHARED_MUL = 1)
PARAM_SETS = [(*ps, shared) for shared in (0, 1) for ps in BASE_SETS]


def _ids(ps):
    return f"wave{ps[0]}_coef{ps[1]}_user{ps[2]}" + ("_shared" if ps[4] else "")


# --------------------------------------------------------------------------- cocotb side

if cocotb is not None:
    from lib.clock import start_clock
    from lib.pipeline_check import StreamChecker, lv, lv_signed, to_bits

    def _stimulus(p: QuadratureParams, rng, n: int):
        """n samples: realistic vectors, corners and random codes; coefficient sets that switch."""
        lo_w, hi_w = -(1 << (p.wave_w - 1)), (1 << (p.wave_w - 1)) - 1
        lo_k, hi_k = -(1 << (p.coef_w - 1)), (1 << (p.coef_w - 1)) - 1
        a = math.radians(2.5)
        sets = [
            quantise_coefs(1 / math.cos(a), math.tan(a), 1.0, 0.0, 0.0, p),            # seed form
            quantise_coefs(1.03 / math.cos(-a), -math.tan(a), 0.98, 0.011, -0.007, p),
            QuadratureCoefs(hi_k, hi_k, hi_k, lo_w // 2, hi_w // 2),                   # saturating
            QuadratureCoefs(lo_k, lo_k, lo_k, 0, 0),                                  # -2.0 gains
        ]
        scale = float(1 << p.wave_frac)
        th = rng.uniform(0, 2 * np.pi, n)
        r = rng.uniform(0.3, 1.6, n)
        xs = np.floor(r * np.sin(th) * scale + 0.5).astype(np.int64)
        xc = np.floor(r * np.cos(th) * scale + 0.5).astype(np.int64)
        # a third of the samples: random or extreme codes
        kind = rng.integers(0, 6, n)
        rand = kind == 0
        xs[rand] = rng.integers(lo_w, hi_w + 1, rand.sum())
        xc[rand] = rng.integers(lo_w, hi_w + 1, rand.sum())
        ext = kind == 1
        corner = np.array([lo_w, hi_w, 0, -1, 1, lo_w + 1, hi_w - 1])
        xs[ext] = rng.choice(corner, ext.sum())
        xc[ext] = rng.choice(corner, ext.sum())
        # coefficient set per sample: runs of one set (bank switches), some random codes
        k = np.zeros((5, n), dtype=np.int64)
        cur = 0
        for i in range(n):
            if rng.random() < 0.05:
                cur = int(rng.integers(0, len(sets)))
            if rng.random() < 0.1:
                k[:, i] = [rng.integers(lo_k, hi_k + 1) for _ in range(3)] + \
                          [rng.integers(lo_w, hi_w + 1) for _ in range(2)]
            else:
                c = sets[cur]
                k[:, i] = [c.k_ss, c.k_sc, c.k_cc, c.ofs_s, c.ofs_c]
        # first samples: a deterministic corner sweep at full speed
        m = 0
        for c in sets:
            for x1 in corner[:3]:
                for x2 in corner[:3]:
                    xs[m], xc[m] = x1, x2
                    k[:, m] = [c.k_ss, c.k_sc, c.k_cc, c.ofs_s, c.ofs_c]
                    m += 1
        coefs = QuadratureCoefs(*k)
        s, c, sat = quadrature(xs, xc, coefs, p)
        return xs, xc, k, s, c, sat

    @cocotb.test()
    async def quadrature_stream(dut):
        cfg = json.loads(os.environ["FRINGE_CFG"])
        seed = cfg["seed"]
        rng = np.random.default_rng(seed)
        p = QuadratureParams(cfg["WAVE_W"], cfg["COEF_W"])
        user_w = cfg["USER_W"]
        # SHARED_MUL = 1: a sample every SHARED_MIN_CLOCKS clock enables at most, so every phase runs
        # that many times longer
        gap = SHARED_MIN_CLOCKS if cfg.get("SHARED_MUL") else 1
        assert len(dut.xs) == p.wave_w and len(dut.k_ss) == p.coef_w and len(dut.in_user) == user_w
        n = 6000
        xs, xc, k, s_exp, c_exp, sat_exp = _stimulus(p, rng, n)
        assert sat_exp.any() and not sat_exp.all()
        users = rng.integers(0, 1 << user_w, n)
        wave_w, coef_w = p.wave_w, p.coef_w
        ports_k = [dut.k_ss, dut.k_sc, dut.k_cc]
        ports_o = [dut.ofs_s, dut.ofs_c]
        state = {"i": 0}

        def drive(i_xs, i_xc, kv, user):
            dut.xs.value = to_bits(i_xs, wave_w)
            dut.xc.value = to_bits(i_xc, wave_w)
            for h, v in zip(ports_k, kv[:3], strict=True):
                h.value = to_bits(v, coef_w)
            for h, v in zip(ports_o, kv[3:], strict=True):
                h.value = to_bits(v, wave_w)
            dut.in_user.value = int(user)

        def make_sample(_cyc):
            i = state["i"] % n   # (an offer at a disabled edge uses an index too: wrap around)
            state["i"] += 1
            drive(xs[i], xc[i], k[:, i], users[i])
            return (int(s_exp[i]), int(c_exp[i]), int(sat_exp[i]), int(users[i]))

        def make_idle(_cyc):
            j = int(rng.integers(0, n))  # garbage the block must ignore
            drive(xs[j] ^ 5, xc[j], k[:, j], rng.integers(0, 1 << user_w))

        def read_output():
            return (lv_signed(dut.s), lv_signed(dut.c), lv(dut.sat), lv(dut.out_user))

        tag = f"seed {seed}, {p}"
        dut.rst.value = 1
        dut.ce.value = 1
        dut.in_valid.value = 0
        make_idle(0)
        await start_clock(dut)
        chk = StreamChecker(dut, cfg["latency"], read_output, tag)
        await chk.run(2, make_sample, make_idle, rng, p_valid=0, reset_cycles={0, 1})
        # full speed: the corner sweep and more
        await chk.run(600 * gap, make_sample, make_idle, rng, min_gap=gap, p_valid=1.0, p_ce=1.0)
        # reset with ce = 0 while the pipeline is full (rst wins over ce)
        await chk.run(3, make_sample, make_idle, rng, min_gap=gap, p_valid=1.0, reset_cycles={0}, force_ce={0: 0})
        # random gaps and stalls, resets mid-stream
        await chk.run(3000 * gap, make_sample, make_idle, rng, p_valid=0.7, p_ce=0.75, min_gap=gap,
                      reset_cycles={700, 701, 1900}, force_ce={700: 1, 701: 0, 1900: 0},
                      max_samples=n - 1500)
        # full speed again, then backpressure-like long stalls
        await chk.run(600 * gap, make_sample, make_idle, rng, p_valid=1.0, p_ce=1.0, max_samples=n - 700,
                      min_gap=gap)
        await chk.run(1500 * gap, make_sample, make_idle, rng, p_valid=0.9, p_ce=0.3, max_samples=n, min_gap=gap)
        await chk.flush(make_idle, rng, p_ce=0.5)
        assert chk.n_out > 3000, f"[{tag}] only {chk.n_out} samples checked"
        dut._log.info(f"[{tag}] {chk.n_in} samples in, {chk.n_out} checked exactly")


# --------------------------------------------------------------------------- pytest launcher


def test_latency_constant_matches_model():
    from lib.hdl_constants import block_constant, both_languages

    for f in both_languages("fringe_quadrature"):
        assert block_constant(f, "LATENCY") == LATENCY, f


@pytest.mark.parametrize("params", [
    {"WAVE_W": 7, "COEF_W": 18},
    {"WAVE_W": 33, "COEF_W": 18},
    {"WAVE_W": 18, "COEF_W": 7},
    {"WAVE_W": 18, "COEF_W": 28},
], ids=lambda d: "_".join(f"{k}{v}" for k, v in d.items()))
def test_illegal_parameters_stop_elaboration(sim, params):
    """The HDL stops with the model's message (the model raises the same text)."""
    from elab_check import assert_refused

    with pytest.raises(ValueError) as e:
        QuadratureParams(params["WAVE_W"], params["COEF_W"])
    assert_refused(TOPLEVEL, sim, params, str(e.value))


def test_illegal_user_w_stops_elaboration(sim):
    from elab_check import assert_refused

    assert_refused(TOPLEVEL, sim, {"USER_W": 0}, "fringe_quadrature: USER_W = 0 must be >= 1")


@pytest.mark.parametrize("ps", PARAM_SETS, ids=_ids)
def test_fringe_quadrature(sim, ps):
    from cocotb_runner import run_block

    wave_w, coef_w, user_w, seed, shared = ps
    params = {"WAVE_W": wave_w, "COEF_W": coef_w, "USER_W": user_w, "SHARED_MUL": shared}
    cfg = dict(params, seed=seed, latency=LATENCY)
    print(f"fringe_quadrature {sim} {params} seed {seed}")
    run_block(TOPLEVEL, "test_fringe_quadrature", params, sim=sim,
              extra_env={"FRINGE_CFG": json.dumps(cfg)}, timeout_s=120)
