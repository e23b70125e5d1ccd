"""The latency check every pipeline block's test runs (cocotb side)."""

from __future__ import annotations

from collections.abc import Callable

from cocotb.triggers import FallingEdge

from lib.planned_stream import hdl_constant, measure_latency


async def check_latency(dut, apply_sample: Callable[[], None], latency: int, read_output: Callable[[], tuple],
                        expected: tuple) -> None:
    """One sample into the idle block after a reset: ``out_valid`` exactly ``latency`` clocks later,
    for one clock, with ``read_output() == expected``; the HDL's LATENCY constant, where the simulator
    exposes it (Verilator does, GHDL's VPI does not), equal to ``latency``. Call at a falling edge
    with the clock running."""
    n = await measure_latency(dut, apply_sample)
    if n != latency:
        raise AssertionError(f"latency {n} clocks, documented LATENCY = {latency}")
    got = read_output()
    if got != expected:
        raise AssertionError(f"latency sample: RTL {got}, model {expected}")
    await FallingEdge(dut.clk)
    if int(dut.out_valid.value):
        raise AssertionError("out_valid high for more than one clock")
    hdl_lat = hdl_constant(dut, "LATENCY")
    if hdl_lat is not None and hdl_lat != latency:
        raise AssertionError(f"HDL LATENCY = {hdl_lat}, model {latency}")
    dut._log.info("latency %d clocks (HDL constant: %s)", latency, hdl_lat)
