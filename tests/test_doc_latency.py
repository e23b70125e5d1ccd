"""The latencies the documents state are the models' (no simulator: text and constants only).

The blocks' ``LATENCY`` constants are the single source: ``sim/hdlgen.py`` writes them into fringe_pkg, the core
sums them (``core_latency``, ``drift_pipe_latency``), and the tests check the RTL against them. The documents
restate some of them as numbers (the block table of ``docs/architecture.md``, each block's "LATENCY = N", the
core's sums and the drift tracker's hold in ``docs/drift.md``); this test fails when a number has gone stale.
"""

from __future__ import annotations

import dataclasses
import importlib
import re

from hdl_text import REPO

from fringe.dsp.simulate import seed_encoder
from fringe.fixed import canceller, drift_normaliser, drift_observer, regmap, trim
from fringe.fixed.config import CoreConfig, drift_pipe_latency
from fringe.fixed.core import core_latency

DOCS = REPO / "docs"


def flat(rel: str) -> str:
    """A document with its line breaks and runs of spaces made single spaces (figures wrap across lines)."""
    return re.sub(r"\s+", " ", (DOCS / rel).read_text(encoding="utf-8"))


def block_table() -> dict[str, tuple[str, str]]:
    """docs/architecture.md's block table: block -> (LATENCY cell, model cell)."""
    rows = {}
    for line in (DOCS / "architecture.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and re.fullmatch(r"fringe_\w+", cells[0]):
            rows[cells[0]] = (cells[2], cells[4])
    return rows


def model_latency(model_cell: str) -> int | None:
    """LATENCY of the model module a table cell names (`fixed/<m>.py`), None when it has no constant."""
    m = re.fullmatch(r"`fixed/(\w+)\.py`", model_cell)
    assert m, model_cell
    value = getattr(importlib.import_module(f"fringe.fixed.{m.group(1)}"), "LATENCY", None)
    return value if isinstance(value, int) else None


def seed_core(**overrides) -> CoreConfig:
    """The seed core: the defaults CoreConfig.for_encoder gives the seed encoder (sim/synth.py's seed configs)."""
    return CoreConfig.for_encoder(seed_encoder(), **overrides)


def hold_stall(cfg: CoreConfig) -> int:
    """Clock enables in_ready is 0 at a tracker block boundary at full speed (DRIFT_HOLD = 1)."""
    return drift_normaliser.LATENCY + drift_pipe_latency(cfg) + drift_observer.LATENCY - 1


def test_block_table_latencies():
    rows = block_table()
    checked = 0
    for block, (lat, model) in rows.items():
        want = model_latency(model)
        if want is None or block in ("fringe_core", "fringe_top"):
            continue
        m = re.match(r"(\d+)\b", lat)
        assert m and int(m.group(1)) == want, f"docs/architecture.md: {block}'s LATENCY is {lat!r}, its model's {want}"
        checked += 1
    assert checked >= 8
    cp = CoreConfig().cordic()
    assert rows["fringe_cordic"][0] == f"STAGES + {cp.latency - cp.stages}"


def test_readme_block_table():
    """README.md's block table (a third copy, for the reader who starts there) agrees too."""
    rows = block_table()
    checked = 0
    for line in (REPO / "README.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and re.fullmatch(r"`fringe_\w+`", cells[0]) and cells[0].strip("`") in rows:
            want = model_latency(rows[cells[0].strip("`")][1])
            m = re.match(r"(\d+)\b", cells[2])
            if want is not None and m:
                assert int(m.group(1)) == want, f"README.md: {cells[0]}'s latency is {cells[2]!r}, its model's {want}"
                checked += 1
    assert checked >= 8


def test_block_document_and_header_latency():
    """The first "LATENCY = N clock enables" of a block's document and of both HDL headers is its model's LATENCY."""
    checked = 0
    for block, (_, model) in block_table().items():
        want = model_latency(model)
        if want is None or block in ("fringe_core", "fringe_top"):
            continue
        for path in (DOCS / "blocks" / f"{block}.md", REPO / "rtl/verilog" / f"{block}.v",
                     REPO / "rtl/vhdl" / f"{block}.vhd"):
            m = re.search(r"LATENCY = (\d+) clock enables", re.sub(r"\s+", " ", path.read_text(encoding="utf-8")))
            if m is not None:
                assert int(m.group(1)) == want, f"{path.relative_to(REPO)}: LATENCY = {m.group(1)}, its model's {want}"
                checked += 1
    assert checked >= 24


def test_register_write_latency():
    """A configuration write and a CTRL swap land regmap.LATENCY edges after the edge that takes them, as
    fringe_regs' document and the core's documents say (the block table's figure is checked above)."""
    n = regmap.LATENCY
    found = re.findall(r"(?:lands at|flips active_bank at) edge n\+(\d+)", flat("blocks/fringe_regs.md"))
    assert len(found) == 2 and all(int(k) == n for k in found), found
    for rel in ("architecture.md", "blocks/fringe_core.md"):
        found = re.findall(r"(\w+) clocks after (?:the|that) edge", flat(rel))
        assert len(found) == 2 and all(w == {1: "one", 2: "two", 3: "three", 4: "four"}[n] for w in found), (rel, found)


def test_core_latency_sums():
    base = CoreConfig()
    plus = {"TRIM": trim.LATENCY, "DRIFT": drift_normaliser.LATENCY, "CANCEL": canceller.LATENCY}
    assert core_latency(dataclasses.replace(base, trim=1)) - core_latency(base) == plus["TRIM"]
    assert core_latency(dataclasses.replace(base, drift=1)) - core_latency(base) == plus["DRIFT"]
    const = core_latency(base) - base.cordic_stages
    cell = block_table()["fringe_core"][0]
    extras = ", ".join(f"+ {n} {name}" for name, n in plus.items())
    assert cell == f"CORDIC_STAGES + {const} ({extras})"
    for rel in ("architecture.md", "blocks/fringe_core.md", "blocks/fringe_top.md"):
        text = flat(rel)
        assert f"CORDIC_STAGES + {const}" in text, rel
    arch, core = flat("architecture.md"), flat("blocks/fringe_core.md")
    assert f"({core_latency(seed_core())} for the seed configuration" in arch
    for text in (arch, core):
        for name, n in plus.items():
            assert re.search(rf"(plus )?{n} with {name} = 1", text), (name, n)


def test_drift_pipe_latency():
    """PIPE_LATENCY = CORDIC_STAGES + 13 (+ the canceller's) as docs/architecture.md and docs/drift.md say."""
    base = CoreConfig(drift=1)
    const = drift_pipe_latency(base) - base.cordic_stages
    for rel in ("architecture.md", "drift.md"):
        assert f"PIPE_LATENCY = CORDIC_STAGES + {const}" in flat(rel), rel
    assert f"CORDIC_STAGES + {const}, {canceller.LATENCY} more with the canceller" in flat("drift.md")


def test_hold_stall_in_the_seed_core():
    """The hold's stall per block (DRIFT_HOLD = 1, full speed) and the throughput docs/drift.md derives from it."""
    seed, default = seed_core(drift=1), CoreConfig(drift=1)
    stall = hold_stall(seed)
    for rel in ("architecture.md", "blocks/fringe_core.md", "drift.md"):
        found = re.findall(r"OBS_LATENCY - 1\b[^.;]*?(\d+) in the seed core", flat(rel))
        assert found and all(int(n) == stall for n in found), (rel, found, stall)
    drift = flat("drift.md")
    pairs = re.findall(r"(\d+) / (\d+) for B = (\d+)", drift)
    assert len(pairs) >= 3
    b_default = 1 << default.drift_block_log2
    assert f"for B = {b_default} (DRIFT_BLOCK_LOG2's default {default.drift_block_log2})" in drift
    for n, clocks, b in pairs:
        assert int(n) == int(b) and int(clocks) == int(b) + stall, (n, clocks, b)
    rates = re.search(r"runs at ([\d., or]+) samples per clock", drift).group(1)
    want = [f"{int(b) / (int(b) + stall):.2f}" for _, _, b in pairs]
    assert re.findall(r"\d\.\d\d", rates) == want
    m = re.search(r"the sum is CORDIC_STAGES \+ (\d+) \(\+ (\d+)\): (\d+) in the seed core \(CORDIC_STAGES (\d+)\), "
                  r"(\d+) with the HDL defaults \(CORDIC_STAGES (\d+)\)", drift)
    assert m
    assert [int(v) for v in m.groups()] == [
        stall + 1 - seed.cordic_stages, canceller.LATENCY, stall + 1, seed.cordic_stages,
        hold_stall(default) + 1, default.cordic_stages]
    # the core's timing message quoted with the HDL defaults
    total = hold_stall(default) + 1
    assert (f"CORDIC_STAGES {default.cordic_stages}) `fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = "
            f"{drift_normaliser.LATENCY} + {drift_pipe_latency(default)} + {drift_observer.LATENCY} = {total} "
            in drift)
