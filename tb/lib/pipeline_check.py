"""Cycle-accurate stream checker for fringe pipeline blocks (clk, rst, ce, in_valid, out_valid).

Drives one block through random traffic and compares every output word exactly:

- each clock, ``ce`` is 1 with probability ``p_ce`` and ``in_valid`` with ``p_valid``; a valid
  input calls ``make_sample(cycle)`` which drives the data inputs and returns the expected output
  (the caller's bit-exact model); an invalid input calls ``make_idle(cycle)`` which drives
  garbage the block must ignore;
- ``rst`` is raised on the cycles in ``reset_cycles`` (whatever ``ce`` is: rst wins; use
  ``force_ce`` to pin ``ce`` on chosen cycles): samples in flight are dropped and ``out_valid``
  must be 0 after it;
- after every clock edge with ``ce`` = 1 the oldest sample in flight must come out exactly when
  it has seen ``latency`` clock enables (``in_valid`` edge included), no earlier, no later, with
  the expected value (``read_output()`` returns it); after an edge with ``ce`` = 0, ``out_valid``
  and the output word must not change.

The random generator is the caller's (fixed seed, printed in every failure message).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable

from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge


def lv(handle) -> int:
    """Unsigned value of a handle."""
    return int(handle.value)


def lv_signed(handle) -> int:
    """Signed value of a handle."""
    return handle.value.to_signed()


def to_bits(v: int, w: int) -> int:
    """Two's complement of v in w bits (for driving signed ports)."""
    return int(v) & ((1 << w) - 1)


def drive_ports(dut, **values: int) -> None:
    """Set several input ports at once (e.g. the idle inputs held during a reset)."""
    for name, v in values.items():
        getattr(dut, name).value = v


async def edges_until(clk, valid, limit: int) -> int | None:
    """Rising edges of ``clk`` after the present one until ``valid`` reads 1 (looked at in the ReadOnly
    phase, the present edge counts 0); None when it has not within ``limit`` edges. Returns in ReadOnly."""
    n = 0
    while True:
        await ReadOnly()
        if int(valid.value):
            return n
        n += 1
        if n > limit:
            return None
        await RisingEdge(clk)


class StreamChecker:
    """See the module docstring. ``tag`` (e.g. the seed) prefixes every failure message."""

    def __init__(self, dut, latency: int, read_output: Callable[[], tuple], tag: str):
        self.dut = dut
        self.latency = latency
        self.read_output = read_output
        self.tag = tag
        self.inflight: deque = deque()   # [age, expected, index]
        self.n_in = 0
        self.n_out = 0
        self.last_out: tuple | None = None
        self.last_valid: int | None = None
        self.since_in: int | None = None   # enabled edges since the last sample was taken (None: none since reset)

    def _fail(self, msg: str) -> None:
        raise AssertionError(f"[{self.tag}] {msg}")

    async def run(
        self,
        cycles: int,
        make_sample: Callable[[int], tuple],
        make_idle: Callable[[int], None],
        rng,
        p_valid: float = 1.0,
        p_ce: float = 1.0,
        reset_cycles: Iterable[int] = (),
        force_ce: dict[int, int] | None = None,
        on_cycle: Callable[[int], None] | None = None,
        max_samples: int | None = None,
        min_gap: int = 1,
    ) -> None:
        """Run ``cycles`` clocks of traffic (call at a falling edge; returns at a falling edge).
        ``min_gap``: in_valid = 1 at an enabled edge only ``min_gap`` or more enabled edges after the
        last sample taken (a block that takes one sample per ``min_gap`` clock enables)."""
        dut = self.dut
        resets = set(reset_cycles)
        for cyc in range(cycles):
            rst = 1 if cyc in resets else 0
            ce = 1 if rng.random() < p_ce else 0
            if force_ce and cyc in force_ce:
                ce = force_ce[cyc]
            more = max_samples is None or self.n_in < max_samples
            valid = 1 if (more and rng.random() < p_valid) else 0
            if ce and self.since_in is not None and self.since_in + 1 < min_gap:
                valid = 0
            dut.rst.value = rst
            dut.ce.value = ce
            dut.in_valid.value = valid
            if on_cycle is not None:
                on_cycle(cyc)
            expected = make_sample(cyc) if valid else None
            if not valid:
                make_idle(cyc)
            await RisingEdge(dut.clk)
            await ReadOnly()
            self._after_edge(cyc, rst, ce, valid, expected)
            if rst:
                self.since_in = None
            elif ce:
                self.since_in = 0 if valid else (None if self.since_in is None else self.since_in + 1)
            await FallingEdge(dut.clk)

    async def flush(self, make_idle: Callable[[int], None], rng, p_ce: float = 1.0) -> None:
        """Clock with in_valid = 0 until every sample in flight came out."""
        dut = self.dut
        guard = 0
        while self.inflight:
            guard += 1
            if guard > 50 * (self.latency + 2) / max(p_ce, 0.05):
                self._fail(f"{len(self.inflight)} sample(s) never came out")
            ce = 1 if rng.random() < p_ce else 0
            dut.rst.value = 0
            dut.ce.value = ce
            dut.in_valid.value = 0
            make_idle(-1)
            await RisingEdge(dut.clk)
            await ReadOnly()
            self._after_edge(-1, 0, ce, 0, None)
            await FallingEdge(dut.clk)

    def _after_edge(self, cyc: int, rst: int, ce: int, valid: int, expected) -> None:
        out_valid = lv(self.dut.out_valid)
        if rst:
            if self.inflight:
                self.dut._log.info(f"[{self.tag}] cycle {cyc}: reset (ce = {ce}) drops "
                                   f"{len(self.inflight)} sample(s)")
            self.inflight.clear()
            if out_valid != 0:
                self._fail(f"cycle {cyc}: out_valid = 1 right after reset")
        elif ce:
            for s in self.inflight:
                s[0] += 1
            if valid:
                self.inflight.append([1, expected, self.n_in])
                self.n_in += 1
            due = bool(self.inflight) and self.inflight[0][0] >= self.latency
            if out_valid != int(due):
                age = self.inflight[0][0] if self.inflight else None
                self._fail(f"cycle {cyc}: out_valid = {out_valid}, expected {int(due)} "
                           f"(LATENCY {self.latency}; oldest sample in flight has seen {age} clock enables)")
            if due:
                _, exp, idx = self.inflight.popleft()
                got = self.read_output()
                if got != exp:
                    self._fail(f"cycle {cyc}: sample {idx}: got {got}, expected {exp}")
                self.n_out += 1
                self.last_out = got
        else:
            if self.last_valid is not None and out_valid != self.last_valid:
                self._fail(f"cycle {cyc}: out_valid changed while ce = 0")
            if out_valid and self.last_out is not None:
                got = self.read_output()
                if got != self.last_out:
                    self._fail(f"cycle {cyc}: output changed while ce = 0: {self.last_out} -> {got}")
        self.last_valid = out_valid
        if not out_valid:
            self.last_out = None
