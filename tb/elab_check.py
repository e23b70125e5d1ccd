"""Elaborate one block with given parameters and return the tools' messages (for the tests
that check that illegal parameters stop elaboration with a clear message), and the two refusal
tests every block's testbench shares (``refusal_tests``).

- verilator: ``verilator --lint-only -Wall -G...`` on the block's sources (``rtl/verilog`` on the
  include path);
- ghdl: analyse into a scratch library, then ``ghdl --elab-run`` with ``-g...`` for a zero-length run.
"""

from __future__ import annotations

import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence

import pytest

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


def _case_id(params: Mapping[str, object]) -> str:
    return "_".join(f"{k}{v}" for k, v in params.items())


def refusal_tests(toplevel: str, illegal: Sequence[Mapping[str, object]], make_params: Callable[[dict], object],
                  base: Mapping[str, object] | None = None, some_legal: bool = False):
    """The tests ``test_illegal_parameters_stop_elaboration`` and ``test_illegal_user_w_stops_elaboration``
    of ``toplevel`` (assign them to those names in the test module).

    Each of ``illegal`` (HDL parameters over ``base``) must be refused by the bit-exact model
    (``make_params(parameters)`` raises ValueError) and by each HDL with the model's own message. With
    ``some_legal``, a set the model accepts (a limit case in the list) must elaborate instead. USER_W = 0
    must stop elaboration with "<toplevel>: USER_W = 0 must be >= 1".
    """
    base = dict(base or {})

    @pytest.mark.parametrize("over", illegal, ids=_case_id)
    def test_illegal_parameters_stop_elaboration(sim, over):
        """The HDL stops with the model's message (the model raises the same text)."""
        params = {**base, **over}
        try:
            make_params(params)
        except ValueError as e:
            assert_refused(toplevel, sim, params, str(e))
            return
        assert some_legal, f"the model accepts {params}"
        rc, out = elaborate(toplevel, sim, params)
        assert rc == 0, out[-3000:]

    def test_illegal_user_w_stops_elaboration(sim):
        assert_refused(toplevel, sim, {**base, "USER_W": 0}, f"{toplevel}: USER_W = 0 must be >= 1")

    return test_illegal_parameters_stop_elaboration, test_illegal_user_w_stops_elaboration
