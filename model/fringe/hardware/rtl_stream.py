"""cocotb module behind ``fringe.hardware.rtlsim.run_rtl``: stream samples through fringe_top at full speed.

Exchange directory ``$FRINGE_RTL_STREAM_DIR``:
- in:  ``input.txt`` (one s_axis_tdata word per line, hex), ``meta.json`` (``n``, ``latency``);
- out: ``output.txt`` (every m_axis_tdata word, hex, in order), ``result.json`` (measured latency).

The sink never stalls (``m_axis_tready`` = 1), so the pipelined core takes one sample per clock and the
compact one (COMPACT = 1) one per ``clocks_per_sample``; the drift tracker (DRIFT_HOLD = 1) holds the sample at each
block boundary until its update is resolved: a sample is held until s_axis_tready takes it. The
samples are driven and the outputs read at the falling edge (both settled there).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge


@cocotb.test()
async def rtl_stream(dut):
    xdir = Path(os.environ["FRINGE_RTL_STREAM_DIR"])
    words = [int(x, 16) for x in (xdir / "input.txt").read_text().split()]
    meta = json.loads((xdir / "meta.json").read_text())
    n, lat, per = int(meta["n"]), int(meta["latency"]), int(meta.get("clocks_per_sample", 1))
    hold = int(meta.get("hold_clocks", 0))     # the drift tracker's waits at its block boundaries (DRIFT_HOLD = 1)
    assert len(words) == n, f"input.txt has {len(words)} words, meta.json says {n}"

    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start(start_high=False))
    dut.rst.value = 1
    dut.s_axis_tvalid.value = 0
    dut.s_axis_tdata.value = 0
    dut.m_axis_tready.value = 1
    dut.cfg_wr_en.value = 0
    dut.cfg_wr_addr.value = 0
    dut.cfg_wr_data.value = 0
    for _ in range(3):
        await FallingEdge(dut.clk)
    dut.rst.value = 0

    out: list[int] = []
    first_out = None
    tdata, tvalid, m_valid, m_data = dut.s_axis_tdata, dut.s_axis_tvalid, dut.m_axis_tvalid, dut.m_axis_tdata
    tready = dut.s_axis_tready
    cyc = k = 0
    limit = n * per + hold + lat + 50
    while len(out) < n:
        # at a falling edge: the next rising edge takes this input (if s_axis_tready) and the output shown now
        if k < n:
            tdata.value = words[k]
            tvalid.value = 1
            if int(tready.value):
                k += 1
        else:
            tvalid.value = 0
        if int(m_valid.value):
            out.append(int(m_data.value))
            if first_out is None:
                first_out = cyc
        await FallingEdge(dut.clk)
        cyc += 1
        if cyc > limit:
            raise AssertionError(f"fringe_top: {len(out)} of {n} outputs after {cyc} clocks")
    tvalid.value = 0
    # the first input was taken at edge 0; the first output, shown after edge first_out - 1, is
    # consumed at edge first_out: LATENCY = first_out (clocks from handshake to tvalid)
    measured = first_out
    (xdir / "output.txt").write_text("".join(f"{w:x}\n" for w in out))
    (xdir / "result.json").write_text(json.dumps({"latency": measured, "cycles": cyc}))
    assert measured == lat, f"fringe_top latency {measured} clocks, documented {lat}"
