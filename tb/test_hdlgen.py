"""The generated HDL text is what sim/hdlgen.py writes from the Python single source, and the two
packages agree with each other and with the model (no simulator needed)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "sim"))

import hdlgen  # noqa: E402
from lib.hdl_constants import package_constants  # noqa: E402


@pytest.mark.parametrize("rel", sorted(hdlgen.REGIONS))
def test_committed_text_equals_generated(rel):
    committed = (hdlgen.REPO / rel).read_text()
    assert hdlgen.generated(rel, committed) == committed, f"{rel} is stale: run {hdlgen.COMMAND}"


def test_a_changed_value_is_detected():
    rel = "rtl/vhdl/fringe_pkg.vhd"
    committed = (hdlgen.REPO / rel).read_text()
    # (whatever the column alignment of the generated block)
    tampered = re.sub(r"(constant REG_K_SC\s+: integer := )1;", r"\g<1>7;", committed)
    assert tampered != committed
    assert hdlgen.generated(rel, tampered) == committed


def test_missing_region_is_an_error():
    with pytest.raises(ValueError, match="BEGIN generated constants"):
        hdlgen.generated("rtl/vhdl/fringe_pkg.vhd", "package fringe_pkg is\nend package;\n")


def test_packages_hold_the_model_constants():
    model = {c.name: c.value for c in hdlgen.constants()}
    assert package_constants("vhdl") == model
    assert package_constants("verilog") == model


def test_every_core_parameter_is_declared():
    """Every CoreConfig field and every derived parameter the model passes has a declaration."""
    import dataclasses

    from fringe.fixed.config import HDL_PARAMETER_DOCS, CoreConfig

    cfg = CoreConfig(trim=1, drift=1)
    names = {f.name.upper() for f in dataclasses.fields(cfg)} | set(cfg.hdl_parameters())
    assert names <= set(HDL_PARAMETER_DOCS), names - set(HDL_PARAMETER_DOCS)
    assert set(cfg.hdl_parameter_defaults()) == set(HDL_PARAMETER_DOCS)
