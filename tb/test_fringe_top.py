"""fringe_top (Verilog and VHDL) against the bit-exact core model, every output word exactly.

Data: a simulated recording per configuration (``fringe.dsp.simulate``), calibrated with
``fringe.calib.calibrate.calibrate`` (calibration A: the init files of both banks) and a second,
different recording and calibration (B: written through the configuration port in mid-stream).
Expected words: ``run_core`` / ``run_core_banks`` on the samples the DUT accepted.

Traffic (cocotbext-axi AxiStreamSource / AxiStreamSink, a monitor of both handshakes, the reset
and the configuration port at every clock):
- ``top_latency``: one sample, the first output exactly LATENCY = core_latency(cfg) clocks later;
- ``top_stream``: the recording at full speed, then random idle cycles and random backpressure;
- ``top_corners``: full-scale codes (CLIP_*), zero inputs (AMP_LOW), random codes, phase jumps
  (OVERSPEED), wrong coarse codes (COARSE_ERR), under random traffic;
- ``top_reset``: reset asserted twice in mid-stream: samples in flight are dropped, the model
  restarts on the samples after the reset;
- ``top_bank_swap``: calibration B (every register different from A) written into the inactive
  bank (every register and table word) while samples stream, then CTRL swaps back and forth at
  random: every sample is served by the bank active when it was accepted (status bit 7),
  bit-exact, including the samples in flight at each swap; active_bank follows;
- ``top_saturation``: extreme quadrature registers into the inactive bank, swap, random codes
  (SATURATED, AMP_HIGH).
Configurations: the seed preset (12-bit ADC, 256 lines, 9-bit coarse code), the same with fringe_trim
(TRIM = 1, random trim tables in both banks and through the configuration port), with the drift tracker
(DRIFT = 1: fringe_drift_normaliser and fringe_drift_observer), with
fringe_canceller (CANCEL = 1: the stream carries an additive tone at bank A's CANCEL_FREQ, bank B's word
differs, so a swap changes the NCO word), and a 16-bit ADC, 1 line, no coarse code; each pipelined
(COMPACT = 0) and also time-multiplexed on the simulators COMPACT_CONFIGS names (COMPACT = 1: the monitor
checks s_axis_tready against clocks_per_sample at every edge, the words are the same model's); with
the drift tracker (DRIFT_HOLD = 1) the monitor also expects s_axis_tready = 0 at each tracker block boundary until
the block's update is resolved.
Replay: ``FRINGE_SEED=<seed> pytest tb/test_fringe_top.py``.
"""

from __future__ import annotations

import dataclasses
import json
import os
import pickle
from pathlib import Path

import numpy as np
import pytest
from lib.cocotb_optional import cocotb

from fringe.encoder import Encoder
from fringe.fixed import drift as drift_mod
from fringe.fixed.config import CoreConfig, drift_pipe_latency
from fringe.fixed.core import CoreTables, core_latency, run_core, run_core_banks
from fringe.fixed.quadrature import QuadratureCoefs
from fringe.fixed.regmap import CTRL_SWAP, CTRL_WORD, REGISTERS, SPACE_LSB, SPACES
from fringe.fixed.regmap import LATENCY as REGS_LATENCY
from fringe.hardware.rtlsim import pack_inputs, top_parameters, top_widths, unpack_outputs, write_init_files
from fringe.hardware.tables import build_tables
from fringe.result import AMP_HIGH, AMP_LOW, BANK, CLIP_COS, CLIP_SIN, COARSE_ERR, OVERSPEED, SATURATED

REPO = Path(__file__).resolve().parent.parent
TOPLEVEL = "fringe_top"
DEFAULT_SEED = 20251124
DATA_ENV = "FRINGE_TOP_DATA"
CTRL_ADDR = SPACES["regs"] << SPACE_LSB | CTRL_WORD      # cfg_wr_addr of CTRL (regmap: the single source)
REG_INDEX = {r.name: r.index for r in REGISTERS}

# ============================================================================ cocotb side

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock
    from lib.pipeline_check import drive_ports, edges_until

    try:
        from cocotbext.axi import AxiStreamBus, AxiStreamFrame, AxiStreamSink, AxiStreamSource
    except ImportError:   # the pytest side without cocotbext-axi: test_fringe_top skips (AXI_MISSING)
        AxiStreamBus = AxiStreamFrame = AxiStreamSink = AxiStreamSource = None

AXI_MISSING = "cocotbext-axi is not installed (pip install -e '.[test]'): it drives fringe_top's streams"


class Case:
    """What the pytest side prepared: configuration, tables A and B, sample streams."""

    def __init__(self) -> None:
        d = Path(os.environ[DATA_ENV])
        with open(d / "case.pkl", "rb") as f:
            c = pickle.load(f)
        self.cfg: CoreConfig = c["cfg"]
        self.tab_a: CoreTables = c["tab_a"]
        self.tab_b: CoreTables = c["tab_b"]
        self.words_b: list[tuple[int, int]] = c["words_b"]     # (cfg_wr_addr, cfg_wr_data)
        self.stream = c["stream"]                              # dict of int64 arrays sin/cos/coarse
        self.seed = int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))
        self.lat = core_latency(self.cfg)
        self.w = top_widths(self.cfg)

    def tag(self) -> str:
        return f"[{self.cfg.test_id}, seed {self.seed}; replay with FRINGE_SEED={self.seed}]"


def _pauses(rng: np.random.Generator, p: float):
    while True:
        yield bool(rng.random() < p)


class Bench:
    """Source, sink and a monitor that sees, for every clock edge, both handshakes, rst, the
    CTRL writes and active_bank (read in the ReadOnly phase after the previous edge: exactly what
    the edge samples)."""

    def __init__(self, dut, case: Case, rng: np.random.Generator):
        self.dut, self.case, self.rng = dut, case, rng
        self.source = AxiStreamSource(AxiStreamBus.from_prefix(dut, "s_axis"), dut.clk,
                                      byte_size=case.w["S_DATA_W"])
        self.sink = AxiStreamSink(AxiStreamBus.from_prefix(dut, "m_axis"), dut.clk,
                                  byte_size=case.w["M_DATA_W"])
        for x in (self.source, self.sink):
            x.log.setLevel("WARNING")
        self.ins: list[tuple[int, int, int | None]] = []   # (word, bank, epoch or None: dropped)
        self.outs: list[tuple[int, int]] = []              # (word, epoch)
        self.epoch = 0
        self.bank = int(dut.active_bank.value)             # expected active bank
        self.swap_edges: list[int] = []
        self.pending_swaps: list[int] = []                 # edges at which a CTRL write takes effect
        self.edge = 0                                      # index of the coming edge
        self.ctrl_seen = 0
        self.n_ce = 0                                      # enabled edges so far
        # fringe_top's ce is a register: the previous edge's !m_axis_tvalid || m_axis_tready, 1 after a
        # reset (the Bench starts after _start's reset, whose last edge saw m_axis_tready = 1)
        self.ce = 1
        self.last_in: int | None = None                    # enabled edge of the last handshake since reset
        self.cps = case.cfg.clocks_per_sample
        # DRIFT = 1, DRIFT_HOLD = 1: the sample at a tracker block boundary (a nonzero multiple of B since
        # reset) waits until its update is resolved, NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY clock enables
        # after the block's last sample (fringe_drift_normaliser's hold on fringe_drift_observer's resolution):
        # the monitor expects s_axis_tready = 0 until exactly then
        cfg = case.cfg
        self.hold_b = (1 << cfg.drift_block_log2) if cfg.drift and cfg.drift_hold else 0
        self.hold_gap = drift_mod.NORM_LATENCY + drift_pipe_latency(cfg) + drift_mod.OBS_LATENCY
        self.n_since_rst = 0                               # samples accepted since reset
        cocotb.start_soon(self._monitor())

    async def _monitor(self) -> None:
        d = self.dut
        while True:
            await ReadOnly()
            # values the coming rising edge samples
            rst = int(d.rst.value)
            # s_axis_tready = ce and one sample per clocks_per_sample clock enables (COMPACT = 1)
            ce = self.ce
            self.ce = 1 if rst else int(not int(d.m_axis_tvalid.value) or int(d.m_axis_tready.value))
            gap = self.cps
            if self.hold_b and self.n_since_rst and self.n_since_rst % self.hold_b == 0:
                gap = max(gap, self.hold_gap)
            want = int(ce and (self.last_in is None or self.n_ce + 1 - self.last_in >= gap))
            if int(d.s_axis_tready.value) != want:
                raise AssertionError(f"edge {self.edge}: s_axis_tready = {int(d.s_axis_tready.value)}, expected "
                                     f"{want} (ce {ce}, last sample at enabled edge {self.last_in}, now "
                                     f"{self.n_ce + 1}, one per {self.cps}) {self.case.tag()}")
            if int(d.active_bank.value) != self.bank:
                raise AssertionError(f"edge {self.edge}: active_bank = {int(d.active_bank.value)}, "
                                     f"expected {self.bank} {self.case.tag()}")
            if int(d.m_axis_tvalid.value) and int(d.m_axis_tready.value):
                self.outs.append((int(d.m_axis_tdata.value), self.epoch))
            if int(d.s_axis_tvalid.value) and int(d.s_axis_tready.value):
                self.ins.append((int(d.s_axis_tdata.value), self.bank, None if rst else self.epoch))
                self.last_in = self.n_ce + 1
                self.n_since_rst += 1
            if rst:
                self.epoch += 1
                self.last_in = None
                self.n_since_rst = 0
            self.n_ce += ce
            if (int(d.cfg_wr_en.value) and int(d.cfg_wr_addr.value) == CTRL_ADDR
                    and int(d.cfg_wr_data.value) >> CTRL_SWAP & 1):
                self.pending_swaps.append(self.edge + REGS_LATENCY)    # fringe_regs: the swap lands with the writes
            if self.pending_swaps and self.pending_swaps[0] == self.edge:
                self.pending_swaps.pop(0)
                self.bank ^= 1           # samples after this edge take the other bank
                self.swap_edges.append(self.edge)
            self.edge += 1
            await RisingEdge(d.clk)

    async def run(self, sin, cos, coarse, *, full_speed: int = 0, p_idle: float = 0.0,
                  p_stall: float = 0.0) -> list[int]:
        """Send the samples (the first ``full_speed`` without pauses), wait for every output."""
        words = pack_inputs(self.case.cfg, sin, cos, coarse)
        n0 = len(self.ins)
        self.source.clear_pause_generator()
        self.sink.clear_pause_generator()
        await self.source.send(AxiStreamFrame(words))
        while len(self.ins) - n0 < min(full_speed, len(words)):
            await RisingEdge(self.dut.clk)
        if p_idle:
            self.source.set_pause_generator(_pauses(self.rng, p_idle))
        if p_stall:
            self.sink.set_pause_generator(_pauses(self.rng, p_stall))
        while len(self.ins) - n0 < len(words):
            await RisingEdge(self.dut.clk)
        got = [(w, b) for (w, b, _) in self.ins[n0:]]
        if [w for w, _ in got] != words:
            raise AssertionError(f"the monitor saw other input words than the source sent {self.case.tag()}")
        return words

    async def drain(self) -> None:
        """Until every accepted sample of the current epoch came out (and the sink is empty)."""
        self.source.clear_pause_generator()
        guard = 0
        while True:
            live = sum(1 for *_, e in self.ins if e == self.epoch)
            done = sum(1 for _, e in self.outs if e == self.epoch)
            if done >= live:
                break
            await RisingEdge(self.dut.clk)
            guard += 1
            if guard > 20 * self.case.lat + 1000:
                raise AssertionError(f"{live - done} samples never came out {self.case.tag()}")
        for _ in range(3):
            await RisingEdge(self.dut.clk)

    def check(self, stream: dict[str, np.ndarray], banks: tuple[CoreTables, CoreTables]) -> dict:
        """Every output word against the model, epoch by epoch (an epoch ends at a reset).

        ``stream`` holds the samples in the order sent: the i-th input handshake is sample i.
        Returns the number of words checked, the samples dropped by resets, the status words seen.
        """
        cfg, tag = self.case.cfg, self.case.tag()
        sink_words = []
        while not self.sink.empty():
            sink_words += [int(x) for x in self.sink.recv_nowait().tdata]
        if sink_words != [w for w, _ in self.outs]:
            raise AssertionError(f"the sink received {len(sink_words)} words, the monitor saw "
                                 f"{len(self.outs)} output handshakes, or the words differ {tag}")
        n = len(self.ins)
        assert n == len(stream["sin"]), (n, len(stream["sin"]))
        epochs = np.array([-1 if e is None else e for *_, e in self.ins])
        bank = np.array([b for _, b, _ in self.ins])
        stats = {"checked": 0, "dropped": 0, "status": np.zeros(0, dtype=np.int64), "epochs": 0}
        out_ep = np.array([e for _, e in self.outs], dtype=np.int64)
        out_words = [w for w, _ in self.outs]
        last = self.epoch
        for e in sorted(set(epochs.tolist()) | set(out_ep.tolist())):
            if e < 0:
                continue
            sel = epochs == e
            words_e = [w for w, k in zip(out_words, out_ep, strict=True) if k == e]
            n_in, n_out = int(sel.sum()), len(words_e)
            if n_out > n_in:
                raise AssertionError(f"epoch {e}: {n_out} outputs for {n_in} samples {tag}")
            if e == last and n_out != n_in:
                raise AssertionError(f"epoch {e}: {n_in - n_out} samples lost without a reset {tag}")
            if n_in - n_out > self.case.lat:
                raise AssertionError(f"epoch {e}: the reset dropped {n_in - n_out} samples, more than "
                                     f"the LATENCY {self.case.lat} in flight {tag}")
            if not n_out:
                continue
            co = stream["coarse"][sel] if cfg.coarse_w else None
            if np.all(bank[sel] == 0):
                m = run_core(banks[0], cfg, stream["sin"][sel], stream["cos"][sel], co)
            else:
                m = run_core_banks(banks, cfg, stream["sin"][sel], stream["cos"][sel], co, bank[sel])
            pos, status = unpack_outputs(cfg, words_e)
            exp_pos, exp_status = m.pos[:n_out], m.status[:n_out]
            bad = np.flatnonzero((pos != exp_pos) | (status != exp_status))
            if bad.size:
                i = int(bad[0])
                idx = np.flatnonzero(sel)[i]
                raise AssertionError(
                    f"epoch {e}, output {i} (sample {idx}: sin={stream['sin'][idx]} cos={stream['cos'][idx]}"
                    f"{' coarse=' + str(stream['coarse'][idx]) if cfg.coarse_w else ''}, bank {bank[sel][i]}): "
                    f"RTL pos={pos[i]} status={status[i]:#04x}, model pos={exp_pos[i]} status={exp_status[i]:#04x} "
                    f"({bad.size} of {n_out} words differ) {tag}")
            stats["checked"] += n_out
            stats["dropped"] += n_in - n_out
            stats["status"] = np.concatenate([stats["status"], status])
            stats["epochs"] += 1
        stats["dropped"] += int(np.sum(epochs < 0))
        return stats


async def _start(dut) -> None:
    drive_ports(dut, rst=1, s_axis_tvalid=0, s_axis_tdata=0, m_axis_tready=1, cfg_wr_en=0, cfg_wr_addr=0,
                cfg_wr_data=0)
    await start_clock(dut)
    for _ in range(3):
        await RisingEdge(dut.clk)
    dut.rst.value = 0
    await RisingEdge(dut.clk)


def _slice(stream: dict, a: int, b: int) -> dict:
    return {k: v[a:b] for k, v in stream.items()}


def _cat(*streams: dict) -> dict:
    return {k: np.concatenate([s[k] for s in streams]) for k in streams[0]}


if cocotb is not None:

    @cocotb.test()
    async def top_latency(dut):
        """One sample after reset: m_axis_tvalid exactly LATENCY clocks after the handshake."""
        case = Case()
        cfg = case.cfg
        await _start(dut)
        assert len(dut.s_axis_tdata) == case.w["S_DATA_W"] and len(dut.m_axis_tdata) == case.w["M_DATA_W"]
        await FallingEdge(dut.clk)
        s = _slice(case.stream, 0, 1)
        dut.s_axis_tdata.value = pack_inputs(cfg, s["sin"], s["cos"], s["coarse"])[0]
        dut.s_axis_tvalid.value = 1
        await ReadOnly()
        assert int(dut.s_axis_tready.value) == 1
        await RisingEdge(dut.clk)            # edge 0 takes the sample
        dut.s_axis_tvalid.value = 0
        n = await edges_until(dut.clk, dut.m_axis_tvalid, case.lat + 10)
        if n is None:
            raise AssertionError(f"no output {case.tag()}")
        # valid after edge n: consumed at edge n + 1, LATENCY = n + 1 clocks
        if n + 1 != case.lat:
            raise AssertionError(f"latency {n + 1} clocks, documented LATENCY = {case.lat} {case.tag()}")
        m = run_core(case.tab_a, cfg, s["sin"], s["cos"], s["coarse"] if cfg.coarse_w else None)
        pos, status = unpack_outputs(cfg, [int(dut.m_axis_tdata.value)])
        assert (int(pos[0]), int(status[0])) == (int(m.pos[0]), int(m.status[0])), (pos, status, m.pos, m.status)
        for name in ("LATENCY",):
            try:
                hdl = int(getattr(dut, name).value)
            except (AttributeError, TypeError, ValueError):
                hdl = None
            if hdl is not None and hdl != case.lat:
                raise AssertionError(f"HDL {name} = {hdl}, model core_latency = {case.lat}")
        dut._log.info("latency %d clocks (HDL constant visible: %s)", case.lat, hdl is not None)

    @cocotb.test()
    async def top_stream(dut):
        """The recording at full speed, then random idle cycles and backpressure."""
        case = Case()
        rng = np.random.default_rng(case.seed)
        await _start(dut)
        b = Bench(dut, case, rng)
        s = case.stream
        n = len(s["sin"])
        await b.run(s["sin"], s["cos"], s["coarse"], full_speed=n // 2, p_idle=0.3, p_stall=0.3)
        await b.drain()
        st = b.check(_slice(s, 0, n), (case.tab_a, case.tab_a))
        assert st["dropped"] == 0
        dut._log.info("checked %d words bit-exact", st["checked"])

    @cocotb.test()
    async def top_corners(dut):
        """Full scale, zero, random codes, phase jumps, wrong coarse codes; random traffic."""
        case = Case()
        cfg = case.cfg
        rng = np.random.default_rng(case.seed + 1)
        await _start(dut)
        b = Bench(dut, case, rng)
        s = case.stream
        n = len(s["sin"])
        lo, hi = -(1 << (cfg.adc_w - 1)), (1 << (cfg.adc_w - 1)) - 1
        parts = []
        k = 0

        def take(m, start=None):
            nonlocal k
            a = k if start is None else start
            seg = {x: np.array(v[a:a + m]) for x, v in s.items()}
            k = a + m
            return seg

        parts.append(take(60))
        for sv, cv in ((hi, None), (lo, None), (None, hi), (None, lo), (hi, lo), (lo, hi), (0, 0)):
            seg = take(8)
            if sv is not None:
                seg["sin"][:] = sv
            if cv is not None:
                seg["cos"][:] = cv
            parts.append(seg)
            parts.append(take(20))
        rnd = take(80)
        rnd["sin"] = rng.integers(lo, hi + 1, 80)
        rnd["cos"] = rng.integers(lo, hi + 1, 80)
        parts.append(rnd)
        for _ in range(6):                                   # phase jumps: continue elsewhere
            parts.append(take(40, start=int(rng.integers(0, n - 40))))
        if cfg.coarse_w:
            seg = take(60)
            wrong = rng.integers(1, (1 << cfg.coarse_w), 60)
            seg["coarse"] = (seg["coarse"] + wrong) % (1 << cfg.coarse_w)
            parts.append(seg)
            parts.append(take(40))
        st_in = _cat(*parts)
        await b.run(st_in["sin"], st_in["cos"], st_in["coarse"], full_speed=len(st_in["sin"]) // 3,
                    p_idle=0.25, p_stall=0.4)
        await b.drain()
        st = b.check(st_in, (case.tab_a, case.tab_a))
        seen = np.bitwise_or.reduce(st["status"])
        want = CLIP_SIN | CLIP_COS | AMP_LOW | OVERSPEED | (COARSE_ERR if cfg.coarse_w else 0)
        if seen & want != want:
            raise AssertionError(f"corner stream did not raise every flag: seen {seen:#04x}, want {want:#04x}")
        dut._log.info("checked %d corner words bit-exact, flags seen %#04x", st["checked"], seen)

    @cocotb.test()
    async def top_reset(dut):
        """Two resets in mid-stream (random traffic); the model restarts after each."""
        case = Case()
        rng = np.random.default_rng(case.seed + 2)
        await _start(dut)
        b = Bench(dut, case, rng)
        s = case.stream
        n = min(len(s["sin"]) // 2, 1500)
        seg = _slice(s, len(s["sin"]) - n, len(s["sin"]))

        async def resets():
            for at, width in ((n // 3, 1), (2 * n // 3, 3)):
                while len(b.ins) < at:
                    await RisingEdge(dut.clk)
                dut.rst.value = 1
                for _ in range(width):
                    await RisingEdge(dut.clk)
                dut.rst.value = 0

        cocotb.start_soon(resets())
        await b.run(seg["sin"], seg["cos"], seg["coarse"], p_idle=0.2, p_stall=0.3)
        await b.drain()
        st = b.check(seg, (case.tab_a, case.tab_a))
        if st["epochs"] < 3 or st["dropped"] == 0:
            raise AssertionError(f"resets not effective: {st['epochs']} epochs, {st['dropped']} dropped")
        dut._log.info("checked %d words over %d epochs, %d samples dropped by the resets",
                      st["checked"], st["epochs"], st["dropped"])

    @cocotb.test()
    async def top_bank_swap(dut):
        """Calibration B into the inactive bank while streaming, swap, bit-exact on both sides."""
        case = Case()
        rng = np.random.default_rng(case.seed + 3)
        await _start(dut)
        if int(dut.active_bank.value) != 0:
            raise AssertionError("active_bank is not 0 at power-up")
        b = Bench(dut, case, rng)
        s = case.stream
        n_w = len(case.words_b)
        n = n_w + 1500
        seg = _cat(*([s] * (1 + n // len(s["sin"]))))
        seg = _slice(seg, 0, n)
        # slowly varying amplitude (0.45 .. 1.05 of the recording's), so that magnitudes cross the
        # AMP_LOW thresholds of both banks
        f = 0.45 + 0.6 * np.abs(np.sin(np.arange(n) * (np.pi / 700)))
        seg["sin"] = np.round(seg["sin"] * f).astype(np.int64)
        seg["cos"] = np.round(seg["cos"] * f).astype(np.int64)
        state = {}

        async def writer():
            while len(b.ins) < 100:
                await RisingEdge(dut.clk)
            for addr, data in case.words_b:
                dut.cfg_wr_en.value = 1
                dut.cfg_wr_addr.value = addr
                dut.cfg_wr_data.value = data
                await RisingEdge(dut.clk)
                if rng.random() < 0.05:     # a gap now and then
                    dut.cfg_wr_en.value = 0
                    await RisingEdge(dut.clk)
            # CTRL with its swap bit clear: no swap
            dut.cfg_wr_addr.value = CTRL_ADDR
            dut.cfg_wr_data.value = 1 << (CTRL_SWAP + 1)
            await RisingEdge(dut.clk)
            state["swapped_at"] = len(b.ins)
            # then swaps back and forth (both banks hold a complete calibration): each one with
            # samples of the other bank in flight
            while len(b.ins) < n - 50:
                dut.cfg_wr_en.value = 1
                dut.cfg_wr_addr.value = CTRL_ADDR
                dut.cfg_wr_data.value = 1 << CTRL_SWAP
                await RisingEdge(dut.clk)
                dut.cfg_wr_en.value = 0
                for _ in range(int(rng.integers(10, 250))):
                    await RisingEdge(dut.clk)

        cocotb.start_soon(writer())
        await b.run(seg["sin"], seg["cos"], seg["coarse"], full_speed=200, p_idle=0.15, p_stall=0.2)
        await b.drain()
        if "swapped_at" not in state or len(b.swap_edges) < 4:
            raise AssertionError(f"too few swaps during the stream ({state}, {b.swap_edges})")
        st = b.check(seg, (case.tab_a, case.tab_b))
        bank_bits = (st["status"] & BANK) != 0
        n0, n1 = int(np.sum(~bank_bits)), int(np.sum(bank_bits))
        if not (n0 > 100 and n1 > 100) or np.any(bank_bits[:state["swapped_at"]]):
            raise AssertionError(f"bank bits: {n0} samples on A, {n1} on B (expected both, A first)")
        # A and B must really differ on the samples served by B (else the test proves nothing).
        co = seg["coarse"][bank_bits] if case.cfg.coarse_w else None
        ma = run_core(case.tab_a, case.cfg, seg["sin"][bank_bits], seg["cos"][bank_bits], co)
        mb = run_core(case.tab_b, case.cfg, seg["sin"][bank_bits], seg["cos"][bank_bits], co)
        differ = int(np.sum(ma.pos != mb.pos))
        if differ < n1 // 2:
            raise AssertionError(f"calibrations A and B differ on only {differ} of {n1} positions")
        dut._log.info("checked %d words: %d on bank 0 (A), %d on bank 1 (B); %d cfg writes, %d swaps; "
                      "flags seen %#04x", st["checked"], n0, n1, n_w, len(b.swap_edges),
                      np.bitwise_or.reduce(st["status"]))


    @cocotb.test()
    async def top_saturation(dut):
        """Extreme quadrature registers (gains near 2, offset -1) written into the inactive bank
        through the register port, swap, random codes: SATURATED and AMP_HIGH, bit-exact."""
        case = Case()
        cfg = case.cfg
        rng = np.random.default_rng(case.seed + 4)
        await _start(dut)
        banks = [case.tab_a, case.tab_b]          # what the previous tests left in the banks
        inactive = 1 - int(dut.active_bank.value)
        kmax, one = (1 << (cfg.coef_w - 1)) - 1, 1 << (cfg.wave_w - 2)
        banks[inactive] = dataclasses.replace(
            banks[inactive], quad=QuadratureCoefs(kmax, kmax - 1234, kmax, -one, one // 3))
        q = banks[inactive].quad
        for name, v in (("K_SS", q.k_ss), ("K_SC", q.k_sc), ("K_CC", q.k_cc), ("OFS_S", q.ofs_s), ("OFS_C", q.ofs_c)):
            dut.cfg_wr_en.value = 1
            dut.cfg_wr_addr.value = SPACES["regs"] << SPACE_LSB | REG_INDEX[name]
            dut.cfg_wr_data.value = int(v) & 0xFFFFFFFF
            await RisingEdge(dut.clk)
        dut.cfg_wr_addr.value = CTRL_ADDR
        dut.cfg_wr_data.value = 1 << CTRL_SWAP
        await RisingEdge(dut.clk)
        dut.cfg_wr_en.value = 0
        for _ in range(REGS_LATENCY + 1):
            await RisingEdge(dut.clk)
        if int(dut.active_bank.value) != inactive:
            raise AssertionError("the swap did not happen")
        b = Bench(dut, case, rng)
        lo, hi = -(1 << (cfg.adc_w - 1)), (1 << (cfg.adc_w - 1)) - 1
        s = _slice(case.stream, 0, 300)
        rnd = {"sin": rng.integers(lo, hi + 1, 300), "cos": rng.integers(lo, hi + 1, 300),
               "coarse": rng.integers(0, 1 << max(cfg.coarse_w, 1), 300)}
        st_in = _cat(s, rnd)
        await b.run(st_in["sin"], st_in["cos"], st_in["coarse"], full_speed=100, p_idle=0.3, p_stall=0.3)
        await b.drain()
        st = b.check(st_in, (banks[0], banks[1]))
        seen = np.bitwise_or.reduce(st["status"])
        if seen & (SATURATED | AMP_HIGH) != SATURATED | AMP_HIGH:
            raise AssertionError(f"SATURATED / AMP_HIGH not raised: flags seen {seen:#04x}")
        dut._log.info("checked %d words on bank %d with extreme gains, flags seen %#04x", st["checked"],
                      inactive, seen)


# ============================================================================ pytest side


def one_line_sim(**kw):
    from fringe.dsp.simulate import ChannelConfig, SimulationConfig

    base = dict(lines_per_rev=1, adc_bits=16, coarse_bits=0, samples=20000, speed_mean_rev_s=1.0,
                speed_swing_rev_s=0.5,
                sin_channel=ChannelConfig(offset=0.01, gain=0.8, phase_rad=0.002, sin_h={1: 1.0, 3: 0.01}),
                cos_channel=ChannelConfig(offset=-0.005, gain=0.78, cos_h={1: 1.0, 2: 0.006}),
                graduation_error={1: (20.0, -10.0), 2: (5.0, 3.0)})
    base.update(kw)
    return SimulationConfig(**base)


def seed_sim(**kw):
    from fringe.dsp.simulate import seed_encoder

    return dataclasses.replace(seed_encoder(), **{"samples": 20000, **kw})


def other_channels(sc):
    """A different encoder of the same kind: other offsets, gains, phase, harmonics (calibration B)."""
    from fringe.dsp.simulate import ChannelConfig

    s, c = sc.sin_channel, sc.cos_channel
    return dataclasses.replace(
        sc, sin_channel=ChannelConfig(offset=s.offset + 0.02, gain=s.gain * 0.93, phase_rad=s.phase_rad + 0.01,
                                      sin_h={**s.sin_h, 3: s.sin_h.get(3, 0.0) + 0.02}, cos_h=dict(s.cos_h)),
        cos_channel=ChannelConfig(offset=c.offset - 0.015, gain=c.gain * 0.97, phase_rad=c.phase_rad,
                                  sin_h=dict(c.sin_h), cos_h={**c.cos_h, 2: c.cos_h.get(2, 0.0) + 0.01}),
        ref_zero_deg=sc.ref_zero_deg + 33.0)


# name -> (core configuration, simulation configuration, decimation of the recording for the DUT)
CONFIGS = {
    "adc12-L256-c9": (lambda: CoreConfig(), seed_sim, 1),
    "adc16-L1-c0": (lambda: CoreConfig.for_encoder(Encoder(1, 16, 0)), one_line_sim, 8),
    # (the magnitude terms on the magnitude's average over ~4 samples: TRIM_MAG_SMOOTH_LOG2 through core and top)
    "adc12-L256-c9-trim": (lambda: CoreConfig(trim=1, trim_map_psi_w=4, trim_map_phi_w=5, trim_g_shift=20,
                                              trim_mag_smooth_log2=2), seed_sim, 1),
    "adc12-L256-c9-drift": (lambda: CoreConfig(drift=1, drift_block_log2=7, drift_fwd_w=6), seed_sim, 1),
    # DRIFT_HOLD = 0: nothing waits, each update applies half a block after its block (the halves' timing check)
    "adc12-L256-c9-drift-h0": (lambda: CoreConfig(drift=1, drift_block_log2=7, drift_fwd_w=6, drift_hold=0),
                               seed_sim, 1),
    "adc12-L256-c9-cancel": (lambda: CoreConfig(cancel=1), seed_sim, 1),
}
#: CANCEL = 1: the tone on the stream (fraction of FS, Hz) and bank A's / B's CANCEL_FREQ tones (Hz)
CANCEL_TONE = (0.02, 437.0)
CANCEL_TONES_HZ = (437.0, 1210.0)
N_STREAM = 2500
#: the configurations also run with COMPACT = 1 (the same tests), on these simulators. A compact run takes
#: CORDIC_STAGES clocks per sample: about 70 s each on Verilator, 100-250 s on GHDL (measured 2026-12-02).
#: Within the CI budget: every configuration on Verilator, the seed preset on GHDL too (the VHDL of the
#: iterated CORDIC is also checked on its own, tb/test_fringe_cordic.py, on both simulators).
COMPACT_CONFIGS = {"adc12-L256-c9": ("verilator", "ghdl"), "adc16-L1-c0": ("verilator",),
                   "adc12-L256-c9-trim": ("verilator",), "adc12-L256-c9-drift": ("verilator",),
                   "adc12-L256-c9-cancel": ("verilator",)}
VARIANTS = [(name, 0) for name in CONFIGS] + [(name, 1) for name in COMPACT_CONFIGS]


def cfg_words(t: CoreTables, cfg: CoreConfig) -> list[tuple[int, int]]:
    """(cfg_wr_addr, cfg_wr_data) of one bank of every banked image: registers, sine, cosine, long period, ..."""
    from fringe.hardware.rom import images

    sel = {"regs": 0, "wave_sin": 1, "wave_cos": 2, "long_period": 3, "trim_map": 4, "trim_speed": 5, "trim_amp": 6,
           "drift_fwd_sin": 7, "drift_fwd_cos": 8}
    out = []
    for im in images(t, cfg):
        if im.name == "cancel_lut":     # a constant ROM (CANCEL_LUT_INIT), no address space
            continue
        half = len(im.words) // 2
        out += [((sel[im.name] << 16) | i, int(w)) for i, w in enumerate(im.words[:half])]
    return out


def random_trim(cfg: CoreConfig, rng: np.random.Generator):
    """Random fringe_trim tables (any contents are legal: RTL and model must agree on every word).
    Values within a quarter of s(TRIM_W), so the periodic slopes fit."""
    from fringe.hardware.closed_loop import TrimTables

    tp = cfg.trim_params()
    lim = 1 << (tp.trim_w - 3)
    return TrimTables(rng.integers(-lim, lim, (2, tp.sectors, tp.bins)), rng.integers(-lim, lim, tp.bins),
                      rng.integers(-lim, lim, tp.bins))


_PREPARED: dict[tuple[str, int], Path] = {}


def prepare(name: str, compact: int = 0) -> Path:
    """Calibrations, init files and sample streams of one configuration (COMPACT = compact), at a fixed place."""
    if (name, compact) in _PREPARED:
        return _PREPARED[name, compact]
    from fringe.calib.calibrate import calibrate
    from fringe.calib.evaluate import measurement_of
    from fringe.dsp.simulate import simulate

    make_cfg, make_sim, dec = CONFIGS[name]
    cfg = dataclasses.replace(make_cfg(), compact=compact)
    sc = make_sim()
    rec_a = simulate(sc, seed=11)
    cal_a = calibrate(measurement_of(rec_a), rec_a.encoder)
    if cfg.drift:      # the gain-loop constants' scale for this encoder
        from fringe.hardware.closed_loop import choose_kg_shift
        cfg = dataclasses.replace(cfg, drift_kg_shift=choose_kg_shift(cal_a, cfg))
    rec_b = simulate(other_channels(sc), seed=12)
    cal_b = calibrate(measurement_of(rec_b), rec_b.encoder)
    tab_a, tab_b = build_tables(cal_a, cfg), build_tables(cal_b, cfg)
    # B differs from A in every register (offsets, gains, thresholds, direction), so a stage that
    # reads the wrong bank shows
    q, wf = tab_b.quad, 1 << (cfg.wave_w - 2)
    tab_b = dataclasses.replace(
        tab_b, quad=QuadratureCoefs(q.k_ss, q.k_sc, q.k_cc - 37, q.ofs_s + wf // 150, q.ofs_c - wf // 230),
        amp_low=int(tab_b.amp_low * 1.5), amp_high=int(tab_b.amp_high * 0.6), direction=1 - tab_a.direction)
    if cfg.trim:
        rng = np.random.default_rng(DEFAULT_SEED)
        tab_a = dataclasses.replace(tab_a, trim=random_trim(cfg, rng))
        tab_b = dataclasses.replace(tab_b, trim=random_trim(cfg, rng))
    tone = {}
    if cfg.cancel:     # the tone on the stream; each bank's NCO word (a swap changes it)
        from fringe.fixed.canceller import freq_word

        fa, fb = (freq_word(f, sc.sample_rate_hz) for f in CANCEL_TONES_HZ)
        tab_a, tab_b = dataclasses.replace(tab_a, cancel_freq=fa), dataclasses.replace(tab_b, cancel_freq=fb)
        tone = {"interference_fs": CANCEL_TONE[0], "interference_hz": CANCEL_TONE[1]}
    rec = simulate(make_sim(samples=N_STREAM * dec, **tone), seed=13)   # samples the DUT sees
    cols = rec.columns
    stream = {"sin": cols["sin"][::dec].astype(np.int64), "cos": cols["cos"][::dec].astype(np.int64),
              "coarse": (cols["coarse"][::dec] if cfg.coarse_w else np.zeros(N_STREAM)).astype(np.int64)}
    d = REPO / "sim_build" / "tb_fringe_top" / (name + ("-compact" if compact else ""))
    write_init_files(tab_a, cfg, d, command=f"tb/test_fringe_top.py {name}: calibration A")
    blob = pickle.dumps({"cfg": cfg, "tab_a": tab_a, "tab_b": tab_b, "words_b": cfg_words(tab_b, cfg),
                         "stream": stream})
    tmp = d / "case.pkl.tmp"
    tmp.write_bytes(blob)
    os.replace(tmp, d / "case.pkl")
    _PREPARED[name, compact] = d
    return d


@pytest.mark.parametrize("name, compact", VARIANTS,
                         ids=[name + ("-compact" if c else "") for name, c in VARIANTS])
def test_fringe_top(sim, name, compact):
    from cocotb_runner import run_block

    pytest.importorskip("cocotbext.axi", reason=AXI_MISSING)
    if compact and sim not in COMPACT_CONFIGS[name]:
        pytest.skip(f"COMPACT = 1 of {name} runs on {', '.join(COMPACT_CONFIGS[name])} only (CI budget, "
                    "COMPACT_CONFIGS)")
    d = prepare(name, compact)
    with open(d / "case.pkl", "rb") as f:
        cfg = pickle.load(f)["cfg"]
    params = top_parameters(cfg, d)
    seed = os.environ.get("FRINGE_SEED", str(DEFAULT_SEED))
    print(f"fringe_top {sim} {name} COMPACT={compact} {json.dumps(params)} seed {seed}")
    run_block(TOPLEVEL, "test_fringe_top", params, sim=sim, timeout_s=200,
              extra_env={DATA_ENV: str(d), "FRINGE_SEED": seed})


def test_latency_documented():
    """The LATENCY of core and top (both HDLs) is the model's core_latency over a random population of
    configurations, and the core's bank taps and every block use the blocks' latencies."""
    import re

    from lib.hdl_constants import block_constant, both_languages, package_function

    from fringe.fixed import canceller, long_period, period_count, quadrature, trim, wave_lut

    rng = np.random.default_rng(20261201)
    configs = [CoreConfig(cordic_stages=int(rng.integers(4, 33)), trim=int(rng.integers(0, 2)),
                          drift=int(rng.integers(0, 2)), cancel=int(rng.integers(0, 2))) for _ in range(20)]
    for lang in ("verilog", "vhdl"):
        for cfg in configs:
            got = package_function(lang, "core_latency", cordic_stages=cfg.cordic_stages, trim=cfg.trim,
                                   drift=cfg.drift, cancel=cfg.cancel)
            assert got == core_latency(cfg), (lang, cfg)
    call = re.compile(r"LATENCY\s*(:\s*integer\s*:)?=\s*(fringe_)?core_latency\(CORDIC_STAGES, TRIM, DRIFT, CANCEL\)")
    for f in both_languages("fringe_core") + both_languages("fringe_top"):
        assert call.search(f.read_text()), f
    # the core's bank pipeline taps (registers read one clock enable ahead) use the blocks' latencies
    for f in both_languages("fringe_core"):
        for name, n in (("LAT_WL", wave_lut.LATENCY), ("LAT_Q", quadrature.LATENCY), ("LAT_P", period_count.LATENCY)):
            assert block_constant(f, name) == n, (f, name)
        for cfg in configs:
            assert block_constant(f, "LAT_C", {"CORDIC_STAGES": cfg.cordic_stages}) == cfg.cordic().latency
            assert block_constant(f, "LAT_T", {"TRIM": cfg.trim}) == cfg.trim * trim.LATENCY
            assert block_constant(f, "LAT_X", {"CANCEL": cfg.cancel}) == cfg.cancel * canceller.LATENCY
    for block, n in (("fringe_wave_lut", wave_lut.LATENCY), ("fringe_quadrature", quadrature.LATENCY),
                     ("fringe_period_count", period_count.LATENCY), ("fringe_long_period", long_period.LATENCY),
                     ("fringe_trim", trim.LATENCY), ("fringe_canceller", canceller.LATENCY)):
        for f in both_languages(block):
            assert block_constant(f, "LATENCY") == n, f
    for f in both_languages("fringe_cordic"):
        assert block_constant(f, "LATENCY", {"STAGES": 13}) == CoreConfig(cordic_stages=13).cordic().latency
    # one sample per clocks_per_sample clock enables, COMPACT = 0 and 1, core and top
    for f in both_languages("fringe_core") + both_languages("fringe_top"):
        for cfg in configs:
            for compact in (0, 1):
                got = block_constant(f, "CLOCKS_PER_SAMPLE", {"CORDIC_STAGES": cfg.cordic_stages, "COMPACT": compact})
                assert got == dataclasses.replace(cfg, compact=compact).clocks_per_sample, (f, cfg, compact)


@pytest.mark.parametrize("params, message", [
    ({"LINES": 1 << 16, "FINE_W": 16, "COARSE_W": 0}, "fringe_core: POS_W = clog2(LINES) + FINE_W = 32 > 31"),
    ({"ADC_W": 20, "WAVE_ADDR_W": 16}, "fringe_core: WAVE_ADDR_W = 16: a table bank must fit the 16-bit word address"),
    ({"LP_ADDR_W": 17}, "fringe_core: LP_ADDR_W = 17 > 16"),
    # DRIFT_HOLD = 0: the update of fringe_drift_observer would reach fringe_drift_normaliser too late (the
    # model's message: the latencies may change)
    ({"DRIFT": 1, "DRIFT_HOLD": 0, "DRIFT_BLOCK_LOG2": 5},
     str(pytest.raises(ValueError, CoreConfig, drift=1, drift_hold=0, drift_block_log2=5).value)),
], ids=["pos_w", "wave_addr_w", "lp_addr_w", "drift_late"])
def test_illegal_parameters_stop_elaboration(sim, params, message):
    from elab_check import assert_refused

    assert_refused("fringe_core", sim, params, message)
