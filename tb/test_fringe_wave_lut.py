"""fringe_wave_lut (Verilog and VHDL) against the bit-exact model, every output word exactly.

Tables: bank 0 and bank 1 start from INIT_FILE (two smooth waveform inverses); mid-stream the
test rewrites the inactive bank through the write port (random tables with steep slopes of both
signs) while samples read the active one, then flips the bank the samples carry, and again.
Traffic: full speed with corner cases first (end codes -> clip, table points, rounding ties,
both branches, both banks), then random in_valid gaps and ce stalls, resets mid-stream (one
with ce = 0), random bank per sample, random sideband.
Run: ``pytest tb/test_fringe_wave_lut.py`` (``--sims verilator`` or ``ghdl`` to pick one).
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from elab_check import refusal_tests
from lib.cocotb_optional import cocotb
from lib.hdl_constants import constants_test

from fringe.fixed.wave_lut import LATENCY, WaveLutParams, make_table, pack_words, wave_lut

TOPLEVEL = "fringe_wave_lut"

# (ADC_W, WAVE_ADDR_W, WAVE_W, USER_W, seed)
PARAM_SETS = [
    (12, 8, 18, 2, 1201),
    (16, 10, 20, 1, 1602),
]


def _ids(ps):
    return f"adc{ps[0]}_addr{ps[1]}_wave{ps[2]}_user{ps[3]}"


def initial_tables(p: WaveLutParams) -> np.ndarray:
    """Banks 0 and 1 of INIT_FILE: two smooth stand-ins for waveform inverses, shape (2, 2, N+1)."""
    half = float(1 << (p.adc_w - 1))

    def f0(a, b):
        r = np.asarray(a) / half
        return 1.5 * np.sin(1.2 * r) if b == 0 else 1.3 * np.arcsin(r / 1.1)

    def f1(a, b):
        r = np.asarray(a) / half
        return -1.9 * r + 0.05 * r ** 3 if b == 0 else 1.2 * np.tanh(2 * r) - 0.3

    return np.stack([make_table(f0, p), make_table(f1, p)])


def random_table(p: WaveLutParams, rng) -> np.ndarray:
    """Random walks over the whole s(WAVE_W) range with slopes up to +-2^(WAVE_W-2).

    Branch 0 starts at the most negative value, branch 1 at the most positive one.
    """
    lo, hi = p.value_min, p.value_max
    step = rng.integers(-(1 << (p.wave_w - 2)), (1 << (p.wave_w - 2)) + 1, size=(2, p.entries + 1))
    step[:, 0] = [lo, hi]
    step[0, 1], step[1, 1] = 1 << (p.wave_w - 2), -(1 << (p.wave_w - 2))
    # clipping is 1-Lipschitz: slopes stay within +-2^(WAVE_W-2)
    return np.clip(np.cumsum(step, axis=1), lo, hi)


# --------------------------------------------------------------------------- cocotb side

if cocotb is not None:
    from lib.clock import start_clock
    from lib.pipeline_check import StreamChecker, lv, lv_signed, to_bits

    class Tables:
        """Expected outputs of every table for every (branch, code), and the write schedule."""

        def __init__(self, p: WaveLutParams, rng):
            self.p = p
            self.half = 1 << (p.adc_w - 1)
            init = initial_tables(p)
            self.tables = [init[0], init[1]] + [random_table(p, rng) for _ in range(3)]
            codes = np.arange(-self.half, self.half)
            self.x = []
            for t in self.tables:
                self.x.append(np.stack([wave_lut(codes, b, t, p)[0] for b in (0, 1)]))
            self.words = [pack_words(t, p) for t in self.tables]
            self.bank = [0, 1]          # table id held by each bank

        def expected(self, adc: int, branch: int, bank: int) -> int:
            return int(self.x[self.bank[bank]][branch, adc + self.half])

    @cocotb.test()
    async def wave_lut_stream(dut):
        cfg = json.loads(os.environ["FRINGE_CFG"])
        seed = cfg["seed"]
        rng = np.random.default_rng(seed)
        p = WaveLutParams(cfg["ADC_W"], cfg["WAVE_ADDR_W"], cfg["WAVE_W"])
        user_w = cfg["USER_W"]
        assert len(dut.adc) == p.adc_w and len(dut.x) == p.wave_w and len(dut.wr_data) == p.word_w
        tag = f"seed {seed}, {p}"
        tabs = Tables(p, rng)
        half, fb = tabs.half, p.fb

        # corner codes: both ends (clip), each table point, rounding tie and last fraction
        points = p.entry_codes()[:-1]
        corner_codes = np.unique(np.concatenate([
            [-half, half - 1, -half + 1, half - 2, 0, -1],
            points[:: max(1, p.entries // 64)],
            points[:: max(1, p.entries // 64)] + (1 << (fb - 1)),
            points[:: max(1, p.entries // 64)] + (1 << fb) - 1,
        ]))
        corners = [(int(a), b, k) for a in corner_codes for b in (0, 1) for k in (0, 1)]
        st = {"active": 0, "random_bank": False, "corner": 0,
              "writing": None, "pending": [], "wr_p": 0.0}

        def drive(adc, branch, bank, user):
            dut.adc.value = to_bits(adc, p.adc_w)
            dut.branch.value = branch
            dut.bank.value = bank
            dut.in_user.value = int(user)

        def make_sample(_cyc):
            if st["corner"] < len(corners):
                adc, branch, bank = corners[st["corner"]]
                st["corner"] += 1
            else:
                r = rng.random()
                if r < 0.05:
                    adc = int(rng.choice([-half, half - 1]))
                elif r < 0.15:
                    adc = int(rng.choice(points)) + int(rng.choice([0, 1 << (fb - 1), (1 << fb) - 1]))
                else:
                    adc = int(rng.integers(-half, half))
                branch = int(rng.integers(0, 2))
                bank = int(rng.integers(0, 2)) if st["random_bank"] else st["active"]
            user = int(rng.integers(0, 1 << user_w))
            drive(adc, branch, bank, user)
            clip = int(adc in (-half, half - 1))
            return (tabs.expected(adc, branch, bank), clip, user)

        def make_idle(_cyc):
            drive(int(rng.integers(-half, half)), int(rng.integers(0, 2)), int(rng.integers(0, 2)),
                  int(rng.integers(0, 1 << user_w)))

        def on_cycle(_cyc):
            """Software side: write the next table into the inactive bank, word by word."""
            if st["pending"] and rng.random() < st["wr_p"]:
                tid, bank = st["writing"]
                a = st["pending"].pop()
                dut.wr_en.value = 1
                dut.wr_addr.value = (bank << (p.wave_addr_w + 1)) | a
                dut.wr_data.value = int(tabs.words[tid][a])
                if not st["pending"]:
                    tabs.bank[bank] = tid   # complete after this clock edge
            else:
                dut.wr_en.value = 0
                dut.wr_addr.value = int(rng.integers(0, 1 << (p.wave_addr_w + 2)))
                dut.wr_data.value = int(rng.integers(0, 1 << 30))

        def start_write(tid):
            bank = 1 - st["active"]
            tabs.bank[bank] = None          # mixed contents: no sample may read it
            st["writing"] = (tid, bank)
            st["pending"] = [int(a) for a in rng.permutation(p.bank_words)]

        def read_output():
            return (lv_signed(dut.x), lv(dut.clip), lv(dut.out_user))

        dut.rst.value = 1
        dut.ce.value = 1
        dut.in_valid.value = 0
        on_cycle(0)
        make_idle(0)
        await start_clock(dut)
        chk = StreamChecker(dut, cfg["latency"], read_output, tag)
        run = chk.run

        await run(2, make_sample, make_idle, rng, p_valid=0, reset_cycles={0, 1}, on_cycle=on_cycle)
        # 1) corner cases at full speed, banks from INIT_FILE
        await run(len(corners) + 20, make_sample, make_idle, rng, on_cycle=on_cycle)
        assert st["corner"] == len(corners)
        # reset with ce = 0 while the pipeline is full (rst wins over ce)
        await run(3, make_sample, make_idle, rng, reset_cycles={0}, force_ce={0: 0}, on_cycle=on_cycle)
        # 2) random bank per sample
        st["random_bank"] = True
        await run(400, make_sample, make_idle, rng, p_valid=0.8, p_ce=0.8, on_cycle=on_cycle)
        st["random_bank"] = False
        # 3) three table updates: write the inactive bank during traffic, then flip
        for k, tid in enumerate((2, 3, 4)):
            start_write(tid)
            st["wr_p"] = 0.7
            resets = {150 + 97 * k} if k != 1 else set()
            while st["pending"]:
                await run(64, make_sample, make_idle, rng, p_valid=0.75, p_ce=0.7,
                          reset_cycles=resets, on_cycle=on_cycle)
                resets = set()
            assert tabs.bank[1 - st["active"]] == tid
            st["active"] = 1 - st["active"]           # flip between two samples
            await run(40, make_sample, make_idle, rng, p_valid=1.0, p_ce=1.0, on_cycle=on_cycle)
        # 4) both banks again, random per sample, long stalls
        st["random_bank"] = True
        await run(600, make_sample, make_idle, rng, p_valid=0.9, p_ce=0.3, on_cycle=on_cycle)
        await chk.flush(make_idle, rng, p_ce=0.5)
        assert chk.n_out > 1000, f"[{tag}] only {chk.n_out} samples checked"
        dut._log.info(f"[{tag}] {chk.n_in} samples in, {chk.n_out} checked exactly; "
                      f"banks hold tables {tabs.bank}")


# --------------------------------------------------------------------------- pytest launcher


test_latency_constant_matches_model = constants_test(TOPLEVEL, LATENCY=LATENCY)


ILLEGAL = [
    {"ADC_W": 25, "WAVE_ADDR_W": 8, "WAVE_W": 18},
    {"ADC_W": 12, "WAVE_ADDR_W": 12, "WAVE_W": 18},
    {"ADC_W": 12, "WAVE_ADDR_W": 1, "WAVE_W": 18},
    {"ADC_W": 12, "WAVE_ADDR_W": 8, "WAVE_W": 33},
]

test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration = refusal_tests(
    TOPLEVEL, ILLEGAL, lambda d: WaveLutParams(d["ADC_W"], d["WAVE_ADDR_W"], d["WAVE_W"]))


def hex_path(p: WaveLutParams, seed: int) -> Path:
    """A fixed path per configuration (the Verilator build keeps the name, not the contents)."""
    return Path(tempfile.gettempdir()) / "fringe_tb" / (
        f"wave_lut_adc{p.adc_w}_addr{p.wave_addr_w}_wave{p.wave_w}_s{seed}.hex")


@pytest.mark.parametrize("ps", PARAM_SETS, ids=_ids)
def test_fringe_wave_lut(sim, ps):
    from cocotb_runner import run_block
    from fringe.fixed.table_ram import write_hex

    adc_w, wave_addr_w, wave_w, user_w, seed = ps
    p = WaveLutParams(adc_w, wave_addr_w, wave_w)
    init = initial_tables(p)
    words = np.concatenate([pack_words(init[0], p), pack_words(init[1], p)])
    path = write_hex(hex_path(p, seed), words, p.word_w,
                     [f"tb/test_fringe_wave_lut.py initial tables: ADC_W={adc_w} WAVE_ADDR_W={wave_addr_w} "
                      f"WAVE_W={wave_w}", "bank 0 then bank 1; word {slope, value}, address {branch, addr}"])
    params = {"ADC_W": adc_w, "WAVE_ADDR_W": wave_addr_w, "WAVE_W": wave_w, "USER_W": user_w,
              "INIT_FILE": path}
    cfg = {"ADC_W": adc_w, "WAVE_ADDR_W": wave_addr_w, "WAVE_W": wave_w, "USER_W": user_w,
           "seed": seed, "latency": LATENCY}
    print(f"fringe_wave_lut {sim} {params} seed {seed}")
    run_block(TOPLEVEL, "test_fringe_wave_lut", params, sim=sim,
              extra_env={"FRINGE_CFG": json.dumps(cfg)}, timeout_s=150)
