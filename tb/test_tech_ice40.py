"""The iCE40 choices (FRINGE_TECH_ICE40, which sim/synth.py defines for the UP5K; no primitives of its own): a
narrow product in the fabric, not in an SB_MAC16 each (fringe_interp_table's slope * fc for FB 2..4, radix-4
Booth; fringe_split_mul's partial products with a factor of 1 to 3 live bits). The same words, clock for clock,
as the generic code: the blocks' own cocotb tests against the bit-exact model (Verilator), and the compact
seed core (fringe_top, COMPACT = 1) through tb/test_fringe_top.py's test, whose every output word is the
model's.
"""

from __future__ import annotations

import json
import os
import pickle
import re
from pathlib import Path

import pytest
from lib.launch import block_env

REPO = Path(__file__).resolve().parent.parent
DEFINE = REPO / "tb" / "ice40" / "fringe_tech_ice40_define.v"

INTERP_CONFIGS = [   # FB 2..4: the Booth product; FB 5: the generic product beside it
    {"ADDR_W": 9, "W": 15, "FB": 4, "OUT_W": 15, "ROUND_SHIFT": 0, "PIECE_W": 0},    # the seed's wave table
    {"ADDR_W": 5, "W": 12, "FB": 2, "OUT_W": 14, "ROUND_SHIFT": 2, "PIECE_W": 0},
    {"ADDR_W": 6, "W": 18, "FB": 3, "OUT_W": 18, "ROUND_SHIFT": 0, "PIECE_W": 0},
    {"ADDR_W": 11, "W": 9, "FB": 4, "OUT_W": 12, "ROUND_SHIFT": 1, "PIECE_W": 11},   # RAM pieces
    {"ADDR_W": 4, "W": 7, "FB": 5, "OUT_W": 9, "ROUND_SHIFT": 0, "PIECE_W": 0},
]

SPLIT_MUL_PARAMS = [
    {"A_W": 18, "A_SIGNED": 1, "B_W": 8, "B_SIGNED": 1, "LATENCY": 2, "LO_W": 15},    # fringe_long_period's
    {"A_W": 20, "A_SIGNED": 1, "B_W": 19, "B_SIGNED": 1, "LATENCY": 3, "LO_W": 17},   # a 3 x 2 term
    {"A_W": 47, "A_SIGNED": 1, "B_W": 18, "B_SIGNED": 0, "LATENCY": 4, "LO_W": 17},   # 1-bit terms
]


def _sources(toplevel: str) -> list[Path]:
    from cocotb_runner import block_sources

    return [DEFINE] + block_sources(toplevel, "verilator")


def _skip_without_verilator():
    from cocotb_runner import available_simulators

    if available_simulators()["verilator"]:
        pytest.skip(available_simulators()["verilator"])


def _assert_built_with(results: Path, name: str) -> None:
    """The build holds the iCE40 choice's register (FRINGE_TECH_ICE40 reached the block)."""
    text = "".join(p.read_text(errors="replace") for p in results.parent.glob("Vtop*.h"))
    assert re.search(rf"(\W|__){name}\b", text), f"{results.parent}: no {name} (the generic code was built)"


@pytest.mark.parametrize("cfg", INTERP_CONFIGS, ids=lambda c: f"A{c['ADDR_W']}-W{c['W']}-FB{c['FB']}-P{c['PIECE_W']}")
def test_ice40_interp_table(cfg):
    from cocotb_runner import run_block

    _skip_without_verilator()
    full = {**cfg, "init": False, "seed": 20261205 + cfg["ADDR_W"] + cfg["FB"]}
    results = run_block("fringe_interp_table", "test_fringe_interp_table", cfg, sim="verilator",
                        extra_env={"FRINGE_CFG": json.dumps(full)}, timeout_s=300,
                        sources=_sources("fringe_interp_table"))
    if 2 <= cfg["FB"] <= 4:
        _assert_built_with(results, "pb3")


def _mul_id(p: dict) -> str:
    return f"{'us'[p['A_SIGNED']]}{p['A_W']}x{'us'[p['B_SIGNED']]}{p['B_W']}-L{p['LATENCY']}"


@pytest.mark.parametrize("params", SPLIT_MUL_PARAMS, ids=_mul_id)
def test_ice40_split_mul(params):
    from cocotb_runner import run_block

    _skip_without_verilator()
    env = block_env("FRINGE_SPLIT_MUL_PARAMS", params, 20261205)
    run_block("fringe_split_mul", "test_fringe_split_mul", params, sim="verilator", timeout_s=300,
              extra_env=env, sources=_sources("fringe_split_mul"))


def test_ice40_fringe_top_compact():
    """The compact seed core (seed_compact's configuration in tb/test_fringe_top.py) with the iCE40 choices."""
    import test_fringe_top as top

    from cocotb_runner import run_block

    _skip_without_verilator()
    pytest.importorskip("cocotbext.axi", reason=top.AXI_MISSING)
    d = top.prepare("adc12-L256-c9", 1)
    with open(d / "case.pkl", "rb") as f:
        cfg = pickle.load(f)["cfg"]
    params = top.top_parameters(cfg, d)
    seed = os.environ.get("FRINGE_SEED", str(top.DEFAULT_SEED))
    results = run_block(top.TOPLEVEL, "test_fringe_top", params, sim="verilator", timeout_s=300,
                        extra_env={top.DATA_ENV: str(d), "FRINGE_SEED": seed}, sources=_sources(top.TOPLEVEL))
    _assert_built_with(results, "pb3")
