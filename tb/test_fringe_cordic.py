"""fringe_cordic RTL (Verilog and VHDL) against the bit-exact model, every output word.

Two halves in one file (the cocotb ``examples/adder`` layout):

- cocotb coroutines (``cordic_*``), run inside the simulator: they read the configuration from
  ``FRINGE_CORDIC_PARAMS`` (JSON of the HDL parameters) and the seed from ``FRINGE_SEED``;
- the pytest launcher ``test_fringe_cordic`` builds and runs them with ``sim/cocotb_runner.py``
  over several parameter sets and both simulators (``--sims`` / ``FRINGE_SIMS``).

Replay a failure: ``FRINGE_SEED=<seed printed in the failure> pytest tb/test_fringe_cordic.py -k ...``.
"""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pytest
from lib.cocotb_optional import cocotb
from lib.launch import run_seeded

from fringe.fixed.cordic import CordicParams, cordic

TOPLEVEL = "fringe_cordic"
DEFAULT_SEED = 20240611

# ============================================================================ cocotb side

if cocotb is not None:
    from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge
    from lib.clock import start_clock
    from lib.pipeline_check import drive_ports, edges_until


def _config() -> tuple[CordicParams, int, int]:
    raw = json.loads(os.environ["FRINGE_CORDIC_PARAMS"])
    p = CordicParams(raw["IN_W"], raw["FINE_W"], raw["STAGES"], raw["GUARD"], int(raw.get("ITERATIVE", 0)))
    return p, int(raw.get("USER_W", 1)), int(os.environ.get("FRINGE_SEED", DEFAULT_SEED))


def corner_vectors(in_w: int) -> list[tuple[int, int]]:
    """Axes, quadrant boundaries, diagonals, extreme codes, zero, and their neighbours."""
    lo, hi = -(1 << (in_w - 1)), (1 << (in_w - 1)) - 1
    vs = []
    for v in (1, 2, 3, 100, hi // 2, hi):
        vs += [(v, 0), (0, v), (-v, 0), (0, -v)]                 # the four axes
        vs += [(v, v), (-v, v), (-v, -v), (v, -v)]               # the diagonals
        vs += [(v, 1), (v, -1), (-v, 1), (-v, -1)]               # either side of the x axis
        vs += [(1, v), (-1, v), (1, -v), (-1, -v)]               # either side of the y axis
    vs += [(0, 0), (lo, 0), (0, lo), (lo, lo), (lo, hi), (hi, lo), (hi, hi), (lo, -1), (lo, 1),
           (-1, lo), (1, lo), (-1, 0), (-1, -1), (lo + 1, lo + 1), (hi, 0), (0, hi)]
    return vs


def random_vectors(rng: np.random.Generator, in_w: int, n: int) -> list[tuple[int, int]]:
    """Half uniform codes, half log-uniform magnitudes (1 .. full scale) at uniform angles."""
    lo, hi = -(1 << (in_w - 1)), (1 << (in_w - 1)) - 1
    nu = n // 2
    x = list(rng.integers(lo, hi + 1, nu))
    y = list(rng.integers(lo, hi + 1, nu))
    r = 2.0 ** rng.uniform(0, in_w - 1, n - nu)
    a = rng.uniform(-np.pi, np.pi, n - nu)
    x += list(np.clip(np.round(r * np.cos(a)), lo, hi).astype(np.int64))
    y += list(np.clip(np.round(r * np.sin(a)), lo, hi).astype(np.int64))
    return [(int(a), int(b)) for a, b in zip(x, y, strict=True)]


def _to_signed(v: int, w: int) -> int:
    return v - (1 << w) if v >> (w - 1) else v


class Bench:
    """Drives the DUT, mirrors its valid pipeline, and checks every consumed output word."""

    def __init__(self, dut, p: CordicParams, user_w: int, seed: int):
        self.dut, self.p, self.user_w, self.seed = dut, p, user_w, seed
        self.lat = p.latency
        self.mask = (1 << p.in_w) - 1
        self.pending: list[tuple[int, int, int, int, int, int]] = []  # accepted, not yet out
        self.n_ce = 0        # enabled edges so far
        self.checked = 0
        self.dropped = 0
        self.last_in: int | None = None   # enabled edge that took the last sample (None: none since reset)
        self.refused = 0     # in_valid offered while ready = 0

    def fail(self, msg: str) -> None:
        raise AssertionError(
            f"{msg} [{self.p}, USER_W={self.user_w}, seed={self.seed}; replay with FRINGE_SEED={self.seed}]")

    async def start(self) -> None:
        d = self.dut
        drive_ports(d, rst=1, ce=1, in_valid=0, x=0, y=0, in_user=0)
        await start_clock(d)
        for _ in range(3):
            await RisingEdge(d.clk)
        await FallingEdge(d.clk)

    async def cycle(self, ce: int, valid: int, vec: tuple[int, int], user: int, rst: int = 0,
                    expect: tuple[int, int] | None = None) -> bool:
        """Apply inputs for the next rising edge (we are at a falling edge), then advance to
        the next falling edge. Returns whether the input was accepted."""
        d = self.dut
        # Consume the output presented now if the coming edge is enabled and not a reset.
        if int(d.out_valid.value):
            if ce and not rst:
                self.consume()
        elif self.pending and self.n_ce + 1 - self.pending[0][5] >= self.lat:
            # The oldest sample in flight should be on the output since its enabled edge
            # n_in + LATENCY - 1.
            self.fail(f"out_valid low although a sample entered {self.n_ce + 1 - self.pending[0][5]} "
                      f"enabled clocks ago, documented LATENCY = {self.lat}")
        # ready: 1 exactly when clocks_per_sample enabled edges separate the coming one from the
        # edge that took the last sample (always 1 for the pipeline)
        ready = int(d.ready.value)
        want = int(self.last_in is None or self.n_ce + 1 - self.last_in >= self.p.clocks_per_sample)
        if ready != want:
            self.fail(f"ready = {ready} at enabled edge {self.n_ce + 1}, last sample taken at edge "
                      f"{self.last_in}, documented one sample per {self.p.clocks_per_sample} clock enables")
        d.ce.value = ce
        d.rst.value = rst
        d.in_valid.value = valid
        d.x.value = vec[0] & self.mask
        d.y.value = vec[1] & self.mask
        d.in_user.value = user
        accepted = bool(ce and valid and ready and not rst)
        self.refused += int(bool(ce and valid and not ready and not rst))
        if rst:
            self.dropped += len(self.pending)
            self.pending.clear()
            self.last_in = None
        if ce:
            self.n_ce += 1
        if accepted:
            self.last_in = self.n_ce
            ph, mg = expect
            self.pending.append((vec[0], vec[1], user, ph, mg, self.n_ce))
        await FallingEdge(d.clk)
        return accepted

    def consume(self) -> None:
        d = self.dut
        if not self.pending:
            self.fail("out_valid high with no sample in flight")
        x, y, user, ph, mg, n_in = self.pending.pop(0)
        got_ph = int(d.phase.value)
        got_mg = int(d.mag.value)
        got_user = int(d.out_user.value)
        # The sample was taken at enabled edge n_in; the coming enabled edge n_ce + 1 consumes
        # it, LATENCY enabled edges later (visible since edge n_in + LATENCY - 1).
        lat = self.n_ce + 1 - n_in
        if lat != self.lat:
            self.fail(f"latency {lat} enabled clocks for (x={x}, y={y}), documented {self.lat}")
        if (got_ph, got_mg, got_user) != (ph, mg, user):
            self.fail(f"(x={x}, y={y}, user={user}): RTL phase={got_ph} mag={got_mg} user={got_user}, "
                      f"model phase={ph} mag={mg}")
        self.checked += 1


async def _run_stream(dut, vectors, *, p_ce: float, p_valid: float, reset_at: set[int], rng, bench):
    xs = np.array([v[0] for v in vectors], dtype=np.int64)
    ys = np.array([v[1] for v in vectors], dtype=np.int64)
    ph, mg = cordic(xs, ys, bench.p)
    i = 0
    cyc = 0
    while i < len(vectors):
        ce = int(rng.random() < p_ce)
        valid = int(rng.random() < p_valid)
        rst = int(cyc in reset_at)
        user = int(rng.integers(0, 1 << bench.user_w))
        if valid:
            acc = await bench.cycle(ce, 1, vectors[i], user, rst, (int(ph[i]), int(mg[i])))
            if acc or rst:   # a sample offered during reset is lost: move on
                i += 1
        else:
            # Idle cycle: drive junk data with in_valid low (must be ignored).
            lo, hi = -(1 << (bench.p.in_w - 1)), 1 << (bench.p.in_w - 1)
            junk = (int(rng.integers(lo, hi)), int(rng.integers(lo, hi)))
            await bench.cycle(ce, 0, junk, user, rst)
        cyc += 1


async def _flush(bench) -> None:
    for _ in range(bench.lat + 2):
        await bench.cycle(1, 0, (0, 0), 0)
    if bench.pending:
        bench.fail(f"{len(bench.pending)} samples never came out")
    if int(bench.dut.out_valid.value):
        bench.fail("out_valid high after the pipeline drained")


if cocotb is not None:

    @cocotb.test()
    async def cordic_latency(dut):
        """One sample at full speed: out_valid exactly LATENCY = STAGES + 2 clocks later (both variants)."""
        p, user_w, seed = _config()
        assert len(dut.x) == p.in_w and len(dut.phase) == p.fine_w and len(dut.mag) == p.in_w + 1
        assert len(dut.in_user) == user_w
        bench = Bench(dut, p, user_w, seed)
        await bench.start()
        dut.rst.value = 0
        await FallingEdge(dut.clk)
        if int(dut.out_valid.value):
            bench.fail("out_valid high after reset")
        x, y = 3 << (p.in_w - 4), -(5 << (p.in_w - 5))
        dut.x.value = x & bench.mask
        dut.y.value = y & bench.mask
        dut.in_valid.value = 1
        dut.in_user.value = (1 << user_w) - 1
        await RisingEdge(dut.clk)
        dut.in_valid.value = 0
        n = await edges_until(dut.clk, dut.out_valid, p.latency + 5)
        if n is None:
            bench.fail("no output")
        # n counts the rising edges after the one that took the input.
        if n + 1 != p.latency:
            bench.fail(f"latency {n + 1} clocks, documented LATENCY = {p.latency}")
        ph, mg = cordic(np.array([x]), np.array([y]), p)
        if (int(dut.phase.value), int(dut.mag.value), int(dut.out_user.value)) != (
                int(ph[0]), int(mg[0]), (1 << user_w) - 1):
            bench.fail("latency sample: wrong output")
        await RisingEdge(dut.clk)
        await ReadOnly()
        if int(dut.out_valid.value):
            bench.fail("out_valid high for more than one clock")
        # The HDL constant, where the simulator exposes it (Verilator does, GHDL's VPI does not).
        try:
            hdl_lat = int(dut.LATENCY.value)
        except (AttributeError, TypeError, ValueError):
            hdl_lat = None
        if hdl_lat is not None and hdl_lat != p.latency:
            bench.fail(f"HDL LATENCY = {hdl_lat}, model {p.latency}")
        dut._log.info("latency %d clocks (HDL constant: %s)", p.latency, hdl_lat)

    @cocotb.test()
    async def cordic_stream(dut):
        """Corner cases, then random vectors: full speed, random in_valid gaps and ce stalls,
        and a reset in mid-stream; every output word against the model."""
        p, user_w, seed = _config()
        rng = np.random.default_rng(seed)
        bench = Bench(dut, p, user_w, seed)
        await bench.start()
        dut._log.info("seed %d (replay with FRINGE_SEED=%d)", seed, seed)
        corners = corner_vectors(p.in_w)
        # 1. corner cases at full speed
        await _run_stream(dut, corners, p_ce=1.0, p_valid=1.0, reset_at=set(), rng=rng, bench=bench)
        # 2. random vectors at full speed
        await _run_stream(dut, random_vectors(rng, p.in_w, 1500), p_ce=1.0, p_valid=1.0,
                          reset_at=set(), rng=rng, bench=bench)
        # 3. random gaps and stalls, corner cases again, a reset in mid-stream
        await _run_stream(dut, corners + random_vectors(rng, p.in_w, 2000), p_ce=0.75, p_valid=0.7,
                          reset_at={1500, 1501}, rng=rng, bench=bench)
        await _flush(bench)
        if bench.dropped == 0:
            bench.fail("the mid-stream reset dropped no sample in flight: test not effective")
        # 4. after the reset, stalls with data in flight at every stage, then drain
        await _run_stream(dut, random_vectors(rng, p.in_w, 800), p_ce=0.5, p_valid=0.9,
                          reset_at=set(), rng=rng, bench=bench)
        await _flush(bench)
        if p.iterative and bench.refused == 0:
            bench.fail("no sample was offered while ready = 0: the refusal is not tested")
        dut._log.info("checked %d output words bit-exact, %d dropped by reset, %d offers refused (ready = 0)",
                      bench.checked, bench.dropped, bench.refused)


# ============================================================================ pytest side

BASE_SETS = [
    # (CordicParams, USER_W)
    (CordicParams(in_w=18, fine_w=16, stages=18, guard=3), 3),
    (CordicParams(in_w=12, fine_w=12, stages=13, guard=2), 1),
    (CordicParams(in_w=10, fine_w=9, stages=8, guard=0), 2),      # no rounding, short pipeline
    (CordicParams(in_w=30, fine_w=30, stages=32, guard=8), 1),    # widest: 40-bit x/y, 38-bit z
]
# every set pipelined (ITERATIVE = 0) and iterated (ITERATIVE = 1)
PARAM_SETS = [(dataclasses.replace(p, iterative=it), u) for it in (0, 1) for p, u in BASE_SETS]


def _id(ps) -> str:
    p, user_w = ps
    return f"IN{p.in_w}-F{p.fine_w}-S{p.stages}-G{p.guard}-U{user_w}" + ("-iter" if p.iterative else "")


@pytest.mark.parametrize("ps", PARAM_SETS, ids=[_id(ps) for ps in PARAM_SETS])
def test_fringe_cordic(sim, ps):
    p, user_w = ps
    run_seeded(TOPLEVEL, {**p.hdl_parameters(), "USER_W": user_w}, sim, "FRINGE_CORDIC_PARAMS", DEFAULT_SEED, 240)
