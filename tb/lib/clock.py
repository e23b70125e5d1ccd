"""The testbenches' one clock: every block test starts ``dut.clk`` here, so that all of them see the same period
and the same first edge."""

from __future__ import annotations

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge

CLK_PERIOD_NS = 10


async def start_clock(dut) -> None:
    """Start ``dut.clk`` (first rising edge half a period in)."""
    dut.clk.value = 0
    cocotb.start_soon(Clock(dut.clk, CLK_PERIOD_NS, unit="ns").start(start_high=False))
    await FallingEdge(dut.clk)
