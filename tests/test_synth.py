"""sim/synth.py's inputs, without running a tool (`make synth` does that): the tool folder and the
copies the YoWASP tools read (they see a /tmp of their own, so nothing may be read from the checkout
when it lies under /tmp)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("synth_run", REPO / "sim" / "synth.py")
synth = importlib.util.module_from_spec(_spec)
sys.modules["synth_run"] = synth     # dataclasses look their module up there
_spec.loader.exec_module(synth)


def test_tool_folder_leaves_tmp():
    assert synth.tool_root(Path("/work/x/results")) == Path("/work/x/results/synth")
    for out in (Path("/tmp"), Path("/tmp/checkout/results")):
        root = synth.tool_root(out)
        assert not root.is_relative_to("/tmp") and root.is_relative_to(Path.home() / ".cache")
    assert synth.tool_root(Path("/tmp/a/results")) != synth.tool_root(Path("/tmp/b/results"))


@pytest.mark.parametrize("key", sorted(synth.DEVICES))
def test_every_file_a_tool_reads_is_a_copy_in_the_tool_folder(key, tmp_path, monkeypatch):
    # snapshot_inputs rebinds the module's paths: restore them after the test
    for name in ("RTL", "WRAP", "CONSTRAINTS"):
        monkeypatch.setattr(synth, name, getattr(synth, name))
    root = tmp_path / "synth"
    synth.snapshot_inputs(root)
    device = synth.DEVICES[key]
    option, pin_file = device.pins
    if pin_file:
        assert (root / "constraints" / pin_file).is_file(), f"{key}: constraints/{pin_file} missing"
        assert "{}" in option
    assert synth.WRAP == root / "synth_wrap.v" and synth.WRAP.is_file()
    rtl = REPO / "rtl" / "verilog"
    copied = sorted(str(p.relative_to(synth.RTL)) for p in synth.RTL.rglob("*") if p.is_file())
    assert copied == sorted(str(p.relative_to(rtl)) for p in rtl.rglob("*") if p.suffix in (".v", ".vh"))
    # the technology layer (ECP5: rtl/verilog/tech/ecp5) is read from the copies too
    tech = synth.tech_sources(device)
    assert bool(tech) == bool(device.tech) and all(p.is_relative_to(root) for p in tech)
    assert synth.RTL.is_relative_to(root) and synth.CONSTRAINTS.is_relative_to(root)
