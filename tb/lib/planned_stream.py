"""Cycle-by-cycle stimulus planned before the simulation, and a driver that checks every output word.

For blocks whose expected output depends on which samples were actually accepted (state such as a
period counter, or a table rewritten in mid-stream), the whole run is decided up front: each
`Cycle` says what ``rst``, ``ce`` and ``in_valid`` are and what the data ports carry. The caller
then knows exactly which samples the block takes (``ce = 1``, ``in_valid = 1``, ``rst = 0``) and
which resets split the stream (`accepted_segments`), computes the expected words with the
vectorised bit-exact model, and stores them in ``Cycle.expect``. `drive` plays the plan:

- after every edge with ``rst = 1`` (whatever ``ce`` is: rst wins) the samples in flight are
  dropped and ``out_valid`` must be 0;
- after every edge with ``ce = 1`` the oldest sample in flight must come out exactly when it has
  seen ``latency`` clock enables (its own included), no earlier, no later, with the expected word;
- after an edge with ``ce = 0``, ``out_valid`` and the output word must not change.

Failure messages carry ``tag`` (configuration and seed, for replay), the cycle and the sample's
note.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge

from lib.clock import start_clock


@dataclass
class Cycle:
    """One clock of the plan: control, the data ports to drive, the expected output if accepted."""

    rst: int
    ce: int
    valid: int
    drive: dict[str, int] = field(default_factory=dict)   # port name -> unsigned value
    expect: tuple | None = None                           # filled in by the caller (accepted samples)
    note: str = ""

    @property
    def accepted(self) -> bool:
        return bool(self.ce and self.valid and not self.rst)


def accepted_segments(cycles: Sequence[Cycle]) -> list[list[int]]:
    """Indices of the accepted cycles, split at every reset (each list starts right after a reset)."""
    segs: list[list[int]] = [[]]
    for i, c in enumerate(cycles):
        if c.rst:
            if segs[-1]:
                segs.append([])
        elif c.accepted:
            segs[-1].append(i)
    return [s for s in segs if s]


def draw_controls(rng, cyc: int, resets, p_ce: float, user_w: int, bus: Callable[..., dict[str, int]],
                  writes: list) -> tuple[int, int, dict[str, int], int]:
    """The controls of a plan's cycle ``cyc``, in the order the block plans draw them from ``rng``:
    (rst: ``cyc`` in ``resets``, ce with probability ``p_ce``, the write bus ``bus(w)`` for the next of
    ``writes`` (taken from the list) or ``bus()``'s idle junk, the sideband u(user_w))."""
    rst = int(cyc in resets)
    ce = int(rng.random() < p_ce)
    b = bus(writes.pop(0)) if writes else bus()
    user = int(rng.integers(0, 1 << user_w))
    return rst, ce, b, user


def accepted_positions(cycles: Sequence[Cycle], rev: int, tag: str) -> list[Cycle]:
    """The accepted cycles of a position block's plan (port ``pos``), checked to carry their expected
    outputs and to reach both ends of the revolution, 0 and REV - 1."""
    acc = [c for c in cycles if c.accepted]
    assert all(c.expect is not None for c in acc), f"{tag}: an accepted cycle without its expected output"
    assert {0, rev - 1} <= {c.drive["pos"] for c in acc}, tag
    return acc


def idle_cycles(cycles: list[Cycle], k: int, bus: Callable[[], dict[str, int]], note: str) -> None:
    """Append ``k`` idle clocks with ce = 1 (the write bus ``bus()``'s idle junk): every sample taken so
    far moves on (has read its tables, or has come out)."""
    cycles += [Cycle(0, 1, 0, {"in_user": 0, **bus()}, note=note) for _ in range(k)]


@dataclass
class DriveStats:
    cycles: int = 0
    accepted: int = 0
    checked: int = 0
    dropped: int = 0      # in flight when a reset came


def apply_cycle(dut, c: Cycle, handles: dict[str, object]) -> None:
    """Drive one planned cycle's rst, ce, in_valid and data inputs (``handles`` caches the signal handles)."""
    dut.rst.value = c.rst
    dut.ce.value = c.ce
    dut.in_valid.value = c.valid
    for name, v in c.drive.items():
        h = handles.get(name)
        if h is None:
            h = handles[name] = getattr(dut, name)
        h.value = v


async def drive(dut, cycles: Sequence[Cycle], latency: int, read_output: Callable[[], tuple], tag: str,
                stats: DriveStats | None = None) -> DriveStats:
    """Play ``cycles`` (call at a falling edge; returns at a falling edge) and check every output."""
    st = stats or DriveStats()
    handles: dict[str, object] = {}
    inflight: deque = deque()      # [clock enables seen, expected, cycle index, note]
    last_valid: int | None = None
    last_out: tuple | None = None

    def fail(i: int, msg: str) -> None:
        raise AssertionError(f"[{tag}] cycle {i}: {msg}")

    for i, c in enumerate(cycles):
        apply_cycle(dut, c, handles)
        if c.accepted and c.expect is None:
            fail(i, "accepted sample without an expected output (plan error)")
        await RisingEdge(dut.clk)
        await ReadOnly()
        st.cycles += 1
        out_valid = int(dut.out_valid.value)
        if c.rst:
            st.dropped += len(inflight)
            inflight.clear()
            if out_valid:
                fail(i, f"out_valid = 1 right after a reset (ce = {c.ce})")
        elif c.ce:
            for s in inflight:
                s[0] += 1
            if c.valid:
                inflight.append([1, c.expect, i, c.note])
                st.accepted += 1
            due = bool(inflight) and inflight[0][0] >= latency
            if out_valid != int(due):
                age = inflight[0][0] if inflight else None
                fail(i, f"out_valid = {out_valid}, expected {int(due)} (LATENCY {latency}; the oldest "
                        f"sample in flight has seen {age} clock enables)")
            if due:
                _, exp, j, note = inflight.popleft()
                got = read_output()
                if got != exp:
                    fail(i, f"sample taken at cycle {j} ({note}): RTL {got}, model {exp}")
                st.checked += 1
                last_out = got
        else:
            if last_valid is not None and out_valid != last_valid:
                fail(i, "out_valid changed while ce = 0")
            if out_valid and last_out is not None and read_output() != last_out:
                fail(i, f"output changed while ce = 0: {last_out} -> {read_output()}")
        last_valid = out_valid
        if not out_valid:
            last_out = None
        await FallingEdge(dut.clk)
    if inflight:
        fail(len(cycles), f"{len(inflight)} sample(s) still in flight at the end of the plan (add idle cycles)")
    return st


async def measure_latency(dut, apply_sample: Callable[[], None], max_clocks: int = 40, valid: str = "out_valid") -> int:
    """Enabled clocks from one sample's edge to ``valid`` (ce = 1 throughout, pipeline idle and reset)."""
    dut.rst.value = 1
    dut.ce.value = 1
    dut.in_valid.value = 0
    await RisingEdge(dut.clk)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    await RisingEdge(dut.clk)
    await FallingEdge(dut.clk)
    apply_sample()
    dut.in_valid.value = 1
    await RisingEdge(dut.clk)
    await FallingEdge(dut.clk)
    dut.in_valid.value = 0
    n = 1
    out_valid = getattr(dut, valid)
    while not int(out_valid.value):
        await RisingEdge(dut.clk)
        await FallingEdge(dut.clk)
        n += 1
        if n > max_clocks:
            raise AssertionError(f"no {valid} within {max_clocks} clocks")
    return n


def hdl_constant(dut, name: str) -> int | None:
    """A localparam/constant through the simulator's VPI, where it is exposed (Verilator: yes)."""
    try:
        return int(getattr(dut, name).value)
    except (AttributeError, TypeError, ValueError):
        return None


async def play_plan(dut, cycles: Sequence[Cycle], latency: int, read_output: Callable[[], tuple],
                    tag: str) -> DriveStats:
    """Start the clock, `drive` the plan, and require that a reset dropped a sample in flight (the
    plans put resets in mid-stream: a run without one did not test them); logs what was checked."""
    await start_clock(dut)
    st = await drive(dut, cycles, latency, read_output, tag)
    if st.dropped == 0:
        raise AssertionError(f"[{tag}] no reset dropped a sample in flight: test not effective")
    dut._log.info("%d cycles, %d samples taken, %d words checked bit-exact, %d dropped by resets",
                  st.cycles, st.accepted, st.checked, st.dropped)
    return st


def plan_tag(p, user_w: int, seed: int) -> str:
    """What a planned run's failures name: the parameters, USER_W and how to replay the seed."""
    return f"{p}, USER_W={user_w}, seed={seed}; replay with FRINGE_SEED={seed}"


async def play_planned(dut, config: Callable[[], tuple], build_plan: Callable[..., Sequence[Cycle]],
                       read_output: Callable[[object], tuple]) -> DriveStats:
    """A block's whole planned run: ``(p, USER_W, seed) = config()``, the plan ``build_plan(p, USER_W,
    seed)``, played (`play_plan`) against ``read_output(dut)`` with the latency ``p.latency``."""
    p, user_w, seed = config()
    cycles = build_plan(p, user_w, seed)
    return await play_plan(dut, cycles, p.latency, lambda: read_output(dut), plan_tag(p, user_w, seed))
