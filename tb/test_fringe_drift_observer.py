"""fringe_drift_observer RTL (Verilog and VHDL) against its bit-exact model, every block's update.

Two halves in one file (the cocotb ``examples/adder`` layout): the cocotb coroutines (``obs_*``), which read
the configuration from ``FRINGE_DRIFT_OBSERVER_PARAMS`` and the seed from ``FRINGE_SEED``, and the pytest
launcher ``test_fringe_drift_observer``.

The harness stands in for fringe_drift_normaliser: it drives the state inputs (a random state at the start
of each reset segment, anywhere in range or near unity, or the reset state) and takes each resolved update
``upd_take`` a random 0..3 clock enables after ``upd_resolved`` rises, the state then becoming the update (as
the normaliser does at its application sample, always before the next block's update reads the state). The
samples: phases of an encoder sweeping fast (a few periods per block), slow (less than a period: the final
step), slower (skipped blocks) and jumping at random (huge sweeps), normalised codes on a waveform with
offset and gain errors and noise, or anywhere in range; the bank, W0 and KG of each sample drawn among three
"model banks" (HDL bank 0, HDL bank 1, HDL bank 0 with KG at its maximum: GINV saturates); the tables in both
banks from the init files; random ce, obs_valid and resets, junk on the idle write bus. Checked per block:
``upd_resolved`` exactly LATENCY clock enables after the block's last sample (its own counted), and at the
take ``upd_valid`` and the update (OFF, GINV, saturation) equal to ``observer_run`` (per reset segment).

Replay a failure: ``FRINGE_SEED=<seed in the message> pytest tb/test_fringe_drift_observer.py -k ...``.
"""

from __future__ import annotations

import tempfile
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test
from lib.launch import block_config, block_env, params_from_hdl, signed

from fringe.fixed.drift import kg_for, make_fwd_table, pack_words
from fringe.fixed.drift_observer import LATENCY, PARTIAL_MU_MIN, ObserverParams, observer_run

TOPLEVEL = "fringe_drift_observer"
VAR = "FRINGE_DRIFT_OBSERVER_PARAMS"
DEFAULT_SEED = 515


params_of = partial(params_from_hdl, ObserverParams)     # HDL parameters -> the model's


def amplitude(p: ObserverParams) -> float:
    return 0.3 * 2 ** (p.adc_w - 1)


def waveform_tables(p: ObserverParams, version: int):
    """(words (2, bins), w0 (2,), kg (2,)) of a calibrated waveform: W0 + A sin / cos plus a small harmonic
    that differs per version."""
    amp = amplitude(p)
    h = 0.01 * version
    fs = lambda ph: 10 + 5 * version + amp * (np.sin(2 * np.pi * ph) + h * np.sin(6 * np.pi * ph))   # noqa: E731
    fc = lambda ph: -7 + amp * (np.cos(2 * np.pi * ph) + h * np.cos(6 * np.pi * ph))                 # noqa: E731
    (vs, w0s), (vc, w0c) = make_fwd_table(fs, p), make_fwd_table(fc, p)
    return np.stack([pack_words(vs, p), pack_words(vc, p)]), np.array([w0s, w0c]), np.array([kg_for(vs, p),
                                                                                               kg_for(vc, p)])


def init_files(p: ObserverParams, stem: str) -> dict[str, Path]:
    """FWD_SIN_INIT and FWD_COS_INIT: both tables' words of `waveform_tables` versions 0 (bank 0) and 1 (bank 1),
    written to ``<tmp>/fringe_tb/<stem>_<name>.mem``."""
    from fringe.fixed.table_ram import write_hex

    t0, t1 = waveform_tables(p, 0)[0], waveform_tables(p, 1)[0]
    base = Path(tempfile.gettempdir()) / "fringe_tb"
    return {name: write_hex(base / f"{stem}_{name}.mem", np.concatenate([t0[k], t1[k]]), p.word_w,
                            [f"tb/test_fringe_drift_observer.py initial {name} table: {p}", "bank 0 then bank 1"])
            for k, name in enumerate(("FWD_SIN_INIT", "FWD_COS_INIT"))}


def model_banks(p: ObserverParams):
    """(tables (3, 2, bins), w0 (3, 2), kg (3, 2), HDL bank per model bank)."""
    v0, v1 = waveform_tables(p, 0), waveform_tables(p, 1)
    kg_big = np.array([(1 << p.kg_w) - 1] * 2)
    return (np.stack([v0[0], v1[0], v0[0]]), np.stack([v0[1], v1[1], v0[1]]), np.stack([v0[2], v1[2], kg_big]),
            [0, 1, 0])


def sections(p: ObserverParams):
    """(samples, speed in periods per sample or None for random jumps, model bank choice, note)."""
    B = p.b
    return [(8 * B, 2.3 / B, "0", "fast, bank 0"), (6 * B, 1.7 / B, "01", "fast, banks 0 and 1 at random"),
            (6 * B, 0.3 / B, "1", "slow: less than a period per block"), (4 * B, 0.01 / B, "0", "slower: skipped"),
            (4 * B, None, "01", "random phases"), (6 * B, 2.1 / B, "2", "KG at its maximum: GINV saturates")]


def draw_state(p: ObserverParams, rng, kind: int) -> tuple[int, int, int, int]:
    """A segment's first state: 0 the reset state, 1 near it, 2 anywhere in range."""
    if kind == 0:
        return p.reset_state()
    if kind == 1:
        o, g = 1 << (p.ofs_w - 6), p.unity // 10
        return (int(rng.integers(-o, o)), int(rng.integers(-o, o)), int(rng.integers(p.unity - g, p.unity + g)),
                int(rng.integers(p.unity - g, p.unity + g)))
    h = 1 << (p.ofs_w - 1)
    return (int(rng.integers(-h, h)), int(rng.integers(-h, h)), int(rng.integers(0, 1 << p.ginv_w)),
            int(rng.integers(0, 1 << p.ginv_w)))


def samples(p: ObserverParams, rng, w0):
    """Every observer sample of the run: (phase, y_sin, y_cos, model bank), per section."""
    tf = 2.0 ** p.table_frac
    amp = amplitude(p)
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    out = []
    x = rng.uniform()
    for n, speed, banks, _ in sections(p):
        if speed is None:
            xs = rng.uniform(size=n)
        else:
            xs = x + speed * np.arange(1, n + 1) * rng.uniform(0.8, 1.2)
            x = float(xs[-1])
        ph = np.floor(np.mod(xs, 1.0) * 2.0 ** p.fine_w).astype(np.int64) & ((1 << p.fine_w) - 1)
        mb = rng.choice([int(c) for c in banks], n)
        gs, gc = rng.uniform(0.9, 1.1, 2)
        ys = w0[mb, 0] / tf + rng.uniform(-20, 20) + gs * amp * np.sin(2 * np.pi * xs) + rng.normal(0, 2, n)
        yc = w0[mb, 1] / tf + rng.uniform(-20, 20) + gc * amp * np.cos(2 * np.pi * xs) + rng.normal(0, 2, n)
        wild = rng.random(n) < 0.02                 # anywhere in range
        ys[wild] = rng.integers(lo, hi + 1, int(wild.sum()))
        yc[wild] = rng.integers(lo, hi + 1, int(wild.sum()))
        out.append((ph, np.clip(np.round(ys), lo, hi).astype(np.int64), np.clip(np.round(yc), lo, hi).astype(np.int64),
                    mb))
    return [np.concatenate(a) for a in zip(*out, strict=True)]


if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock
    from lib.planned_stream import hdl_constant

    def _update(dut, p):
        return (int(dut.upd_valid.value), signed(int(dut.upd_off_sin.value), p.ofs_w),
                signed(int(dut.upd_off_cos.value), p.ofs_w), int(dut.upd_ginv_sin.value),
                int(dut.upd_ginv_cos.value), int(dut.upd_sat.value))

    def _drive_state(dut, p, st):
        dut.off_sin.value = st[0] & ((1 << p.ofs_w) - 1)
        dut.off_cos.value = st[1] & ((1 << p.ofs_w) - 1)
        dut.ginv_sin.value = st[2]
        dut.ginv_cos.value = st[3]

    @cocotb.test()
    async def obs_stream(dut):
        """Random traffic with the emulated normaliser: every block's resolution time and update against the model."""
        raw, _, seed = block_config(VAR, DEFAULT_SEED)
        p = params_of(raw)
        assert len(dut.obs_phase) == p.fine_w and len(dut.wr_data) == p.word_w and len(dut.upd_off_sin) == p.ofs_w
        h = hdl_constant(dut, "LATENCY")
        if h is not None and h != LATENCY:
            raise AssertionError(f"HDL LATENCY = {h}, model {LATENCY}")
        tag = f"{p}, seed={seed}; replay with FRINGE_SEED={seed}"
        rng = np.random.default_rng(seed)
        mtables, mw0, mkg, hdl_bank = model_banks(p)
        ph, ys, yc, mb = samples(p, rng, mw0)
        total = ph.size
        resets = {int(total * 0.35), total - 6 * p.b + 3}       # just before these samples (the second: KG big)
        await start_clock(dut)
        dut.rst.value = 1                                       # power-up reset
        dut.ce.value = 1
        dut.obs_valid.value = 0
        dut.upd_take.value = 0
        dut.wr_en.value = 0
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)
        segs = [{"first": 0, "state": draw_state(p, rng, 1), "blocks": []}]
        state = segs[0]["state"]
        k = 0                      # the next sample
        ages: list = []            # clock enables since each resolved-pending block's last sample
        take_in = None             # clock enables until the take
        block = 0                  # resolutions in this segment
        mask = (1 << p.adc_w) - 1
        i = 0

        def fail(msg):
            raise AssertionError(f"[{tag}] cycle {i}: {msg}")

        while k < total or ages or take_in is not None:
            rst = int(k in resets)
            ce = int(rng.random() < 0.85)
            valid = int(k < total and rng.random() < 0.8)
            take = int(ce and not rst and take_in == 0)
            dut.rst.value = rst
            dut.ce.value = ce
            dut.obs_valid.value = valid
            m = int(mb[k]) if valid else int(rng.integers(0, 3))
            dut.obs_phase.value = int(ph[k]) if valid else int(rng.integers(0, 1 << p.fine_w))
            dut.obs_y_sin.value = (int(ys[k]) if valid else int(rng.integers(0, 1 << p.adc_w))) & mask
            dut.obs_y_cos.value = (int(yc[k]) if valid else int(rng.integers(0, 1 << p.adc_w))) & mask
            dut.obs_bank.value = hdl_bank[m]
            dut.w0_sin.value = int(mw0[m, 0]) & ((1 << (p.adc_w + p.table_frac)) - 1)
            dut.w0_cos.value = int(mw0[m, 1]) & ((1 << (p.adc_w + p.table_frac)) - 1)
            dut.kg_sin.value = int(mkg[m, 0])
            dut.kg_cos.value = int(mkg[m, 1])
            dut.wr_en.value = 0
            dut.wr_sel.value = int(rng.integers(0, 2))
            dut.wr_addr.value = int(rng.integers(0, 2 << p.fwd_w))
            dut.wr_data.value = int(rng.integers(0, 1 << 62)) & ((1 << p.word_w) - 1)
            dut.upd_take.value = take
            _drive_state(dut, p, state)
            if take:
                got = _update(dut, p)
                segs[-1]["blocks"].append(got)
                if got[0]:
                    state = got[1:5]
            await RisingEdge(dut.clk)
            await ReadOnly()
            resolved = int(dut.upd_resolved.value)
            if rst:
                if resolved or int(dut.upd_valid.value):
                    fail("upd_resolved or upd_valid = 1 right after a reset")
                resets.discard(k)
                segs.append({"first": k, "state": draw_state(p, rng, len(segs) % 3), "blocks": []})
                state = segs[-1]["state"]
                ages, take_in, block = [], None, 0
            elif ce:
                ages = [a + 1 for a in ages]
                if valid:
                    k += 1
                    if (k - segs[-1]["first"]) % p.b == 0:
                        ages.append(1)
                if take:
                    take_in = None
                    if resolved:
                        fail("upd_resolved still 1 after the take")
                elif take_in is not None:
                    take_in -= 1
                due = bool(ages) and ages[0] >= LATENCY
                if due:
                    ages.pop(0)
                    block += 1
                    take_in = int(rng.integers(0, 4))
                if resolved != int(due or take_in is not None):
                    fail(f"upd_resolved = {resolved}, expected {int(due or take_in is not None)} (block {block})")
            await FallingEdge(dut.clk)
            i += 1
        # the model per reset segment
        firsts = [s["first"] for s in segs] + [total]
        upd = sat = skip = 0
        for sg, s in enumerate(segs):
            a, b = firsts[sg], firsts[sg + 1]
            r = observer_run(ph[a:b], ys[a:b], yc[a:b], mtables, mw0, mkg, p, bank=mb[a:b], state=s["state"])
            # (a reset drops the block whose update is on its way)
            if not r.updated.size - (sg + 1 < len(segs)) <= len(s["blocks"]) <= r.updated.size:
                raise AssertionError(f"[{tag}] segment {sg}: {len(s['blocks'])} blocks taken, model {r.updated.size}")
            for j, got in enumerate(s["blocks"]):
                if got[0] != int(r.updated[j]) or (got[0] and (got[1:5] != tuple(int(x) for x in r.states[j + 1])
                                                              or got[5] != int(r.track_sat[j]))):
                    raise AssertionError(f"[{tag}] segment {sg} block {j}: RTL {got}, model updated "
                                         f"{bool(r.updated[j])}, state {r.states[j + 1]}, sat {r.track_sat[j]}")
            upd += int(r.updated.sum())
            skip += int((~r.updated).sum())
            sat += int(r.track_sat.sum())
        if not (upd >= 15 and skip >= 3 and sat and len(segs) == 3):
            raise AssertionError(f"[{tag}] not effective: {upd} updates, {skip} skips, {sat} saturated, "
                                 f"{len(segs)} segments")
        dut._log.info("%d cycles, %d samples, %d updates and %d skips checked (%d saturated)", i, total, upd, skip,
                      sat)


# ============================================================================ pytest side

PARAM_SETS = [
    # HOLD = 0 (the window is the second half of the block), the seed-like widths
    ObserverParams(adc_w=12, fine_w=14, block_log2=6, mu_log2=2, ofs_frac=3, ginv_w=16, fwd_w=5, table_w=16,
                   table_frac=2, kg_w=16, kg_shift=23, hold=0),
    # HOLD = 1, the smallest block
    ObserverParams(adc_w=16, fine_w=18, block_log2=4, mu_log2=3, ofs_frac=0, ginv_w=20, fwd_w=7, table_w=20,
                   table_frac=0, kg_w=20, kg_shift=28, hold=1),
    # the widest words: ADC_W 24 + OFS_FRAC 8, GINV_W/TABLE_W/KG_W 24, FINE_W 30, FWD_W 10
    ObserverParams(adc_w=24, fine_w=30, block_log2=7, mu_log2=0, ofs_frac=8, ginv_w=24, fwd_w=10, table_w=24,
                   table_frac=1, kg_w=24, kg_shift=46, hold=1),
    # HOLD = 0, MU_LOG2 at its maximum (the gear's left shift of SEA * KG by 8)
    ObserverParams(adc_w=14, fine_w=16, block_log2=7, mu_log2=8, ofs_frac=4, ginv_w=18, fwd_w=6, table_w=18,
                   table_frac=2, kg_w=18, kg_shift=36, hold=0),
]


def _id(p: ObserverParams) -> str:
    return (f"A{p.adc_w}-F{p.fine_w}-B{p.block_log2}-M{p.mu_log2}-O{p.ofs_frac}-G{p.ginv_w}-W{p.fwd_w}-T{p.table_w}"
            f"-TF{p.table_frac}-K{p.kg_w}-KS{p.kg_shift}-H{p.hold}")


@pytest.mark.parametrize("p", PARAM_SETS, ids=[_id(p) for p in PARAM_SETS])
def test_plan_is_effective(p):
    """The samples sweep whole periods, partial ones (the final step, from MU_LOG2 = PARTIAL_MU_MIN) and less
    (skipped), and saturate GINV with KG at its maximum (no simulator; reset state, no resets)."""
    rng = np.random.default_rng(DEFAULT_SEED)
    mtables, mw0, mkg, _ = model_banks(p)
    ph, ys, yc, mb = samples(p, rng, mw0)
    r = observer_run(ph, ys, yc, mtables, mw0, mkg, p, bank=mb)
    partial = r.updated & (r.sweep < 1 << p.fine_w)
    assert r.updated.sum() >= 15 and (~r.updated).sum() >= 3 and r.track_sat.any()
    assert (partial.sum() >= 3) == (p.mu_log2 >= PARTIAL_MU_MIN)


@pytest.mark.parametrize("p", PARAM_SETS, ids=[_id(p) for p in PARAM_SETS])
def test_fringe_drift_observer(sim, p):
    from cocotb_runner import run_block

    hdl = p.hdl_parameters()
    env = block_env(VAR, {**hdl, "USER_W": 1}, DEFAULT_SEED)
    for name, path in init_files(p, f"drift_obs_{_id(p)}").items():
        hdl[name] = path
    run_block(TOPLEVEL, "test_fringe_drift_observer", hdl, sim=sim, timeout_s=900, extra_env=env)


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY)

BASE = PARAM_SETS[0].hdl_parameters()
ILLEGAL = [
    {"ADC_W": 3}, {"ADC_W": 25}, {"FINE_W": 7, "FWD_W": 4}, {"FINE_W": 31}, {"BLOCK_LOG2": 13},
    {"MU_LOG2": 9}, {"OFS_FRAC": 9}, {"ADC_W": 24, "OFS_FRAC": 8}, {"GINV_W": 7}, {"GINV_W": 25}, {"FWD_W": 1},
    {"FWD_W": 14}, {"TABLE_W": 7}, {"TABLE_W": 25}, {"TABLE_FRAC": 13}, {"KG_W": 7}, {"KG_W": 25},
    {"KG_SHIFT": 0}, {"KG_SHIFT": 61}, {"HOLD": -1}, {"HOLD": 2},
]

# (the observer has no sideband: no USER_W test)
test_illegal_parameters_stop_elaboration, _ = refusal_tests(TOPLEVEL, ILLEGAL, params_of, BASE, some_legal=True)
