"""Elaborate one block with given parameters and return the tools' messages (for the tests
that check that illegal parameters stop elaboration with a clear message).

- verilator: ``verilator --lint-only -Wall -G...`` on the block's sources (``rtl/verilog`` on the
  include path);
- ghdl: analyse into a scratch library, then ``ghdl --elab-run`` with ``-g...`` for a zero-length run.
"""

from __future__ import annotations

import subprocess
import tempfile
from collections.abc import Mapping

from cocotb_runner import RTL_VERILOG, block_sources, setup_path, simulator_parameters


def elaborate(toplevel: str, sim: str, parameters: Mapping[str, object]) -> tuple[int, str]:
    """(exit status, stdout + stderr) of elaborating ``toplevel`` with ``parameters``."""
    setup_path()
    parameters = simulator_parameters(parameters, sim)
    srcs = [str(s) for s in block_sources(toplevel, sim)]
    if sim == "verilator":
        cmd = ["verilator", "--lint-only", "-Wall", f"-I{RTL_VERILOG}", "--top-module", toplevel,
               *[f"-G{k}={v}" for k, v in parameters.items()], *srcs]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        return r.returncode, r.stdout + r.stderr
    with tempfile.TemporaryDirectory(prefix="fringe_elab_") as work:
        r = subprocess.run(["ghdl", "-a", "--std=08", f"--workdir={work}", *srcs],
                           capture_output=True, text=True, timeout=120)
        if r.returncode:
            return r.returncode, r.stdout + r.stderr
        r = subprocess.run(["ghdl", "--elab-run", "--std=08", f"--workdir={work}", toplevel,
                            *[f"-g{k}={v}" for k, v in parameters.items()], "--stop-time=0ns"],
                           capture_output=True, text=True, timeout=120, cwd=work)
        return r.returncode, r.stdout + r.stderr


def assert_refused(toplevel: str, sim: str, parameters: Mapping[str, object], message: str) -> None:
    """Elaborating ``toplevel`` with ``parameters`` fails, and the tools' output holds ``message``."""
    __tracebackhide__ = True
    rc, out = elaborate(toplevel, sim, parameters)
    assert rc != 0 and message in out, f"{message!r} not in:\n{out[-3000:]}"
