"""Every block can be found from its name alone (no simulator: files and text only).

For each ``rtl/verilog/fringe_<x>.v``: the VHDL twin ``rtl/vhdl/fringe_<x>.vhd``, the document
``docs/blocks/fringe_<x>.md``, the cocotb test ``tb/test_fringe_<x>.py`` and the bit-exact model
``model/fringe/fixed/<x>.py`` exist, but for the exceptions below (each says why); the document's
"Sources:" paragraph names both RTL files, its model (``bit-exact model ... `model/fringe/fixed/<m>.py```)
and its test (``tests? `tb/<t>.py```); the block table of ``docs/architecture.md`` has a row for the
block that names the same model (``fixed/<m>.py``).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Blocks whose bit-exact model is not model/fringe/fixed/<block without fringe_>.py (too many users to rename).
MODEL_EXCEPTIONS = {
    "fringe_regs": "regmap.py",   # the register map and address spaces that fringe_regs decodes
    "fringe_top": "core.py",      # fringe_top is fringe_core behind AXI4-Stream: it adds no arithmetic
}

#: Blocks without a cocotb test of their own name.
TEST_EXCEPTIONS = {
    "fringe_core": "tb/test_fringe_top.py",   # the core is driven through fringe_top (no separate bench)
}


def blocks(root: Path = ROOT) -> list[str]:
    """The block names: one per rtl/verilog/fringe_*.v (the .vh include files are not blocks)."""
    return sorted(p.stem for p in (root / "rtl" / "verilog").glob("fringe_*.v"))


def model_path(block: str) -> str:
    return "model/fringe/fixed/" + MODEL_EXCEPTIONS.get(block, block.removeprefix("fringe_") + ".py")


def cocotb_test(block: str) -> str:
    return TEST_EXCEPTIONS.get(block, f"tb/test_{block}.py")


def sources_paragraph(doc: str) -> str:
    """The document's paragraph that starts with "Sources:", whitespace collapsed ("" if none)."""
    for para in re.split(r"\n\s*\n", doc):
        if para.startswith("Sources:"):
            return " ".join(para.split())
    return ""


def architecture_model(root: Path, block: str) -> str | None:
    """The last cell of the block's row in docs/architecture.md's block table (None without a row)."""
    for line in (root / "docs" / "architecture.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] == block:
            return cells[-1]
    return None


def missing(root: Path, block: str) -> list[str]:
    """What someone looking for ``block`` by its name would not find."""
    out = []
    model, test = model_path(block), cocotb_test(block)
    files = {"VHDL twin": f"rtl/vhdl/{block}.vhd", "document": f"docs/blocks/{block}.md",
             "cocotb test": test, "bit-exact model": model}
    out += [f"{block}: no {what} {path}" for what, path in files.items() if not (root / path).is_file()]
    doc_path = root / files["document"]
    if doc_path.is_file():
        para = sources_paragraph(doc_path.read_text(encoding="utf-8"))
        needs = {f"`rtl/verilog/{block}.v`": f"`rtl/verilog/{block}.v`",
                 f"`rtl/vhdl/{block}.vhd`": f"`rtl/vhdl/{block}.vhd`",
                 f"bit-exact model `{model}`": rf"bit-exact model[^;`]*`{re.escape(model)}`",
                 f"tests `{test}`": rf"\btests? `{re.escape(test)}`"}
        if not para:
            out.append(f"{block}: {files['document']} has no paragraph starting with \"Sources:\"")
        else:
            out += [f"{block}: the \"Sources:\" paragraph of {files['document']} does not name {what}"
                    for what, pattern in needs.items() if not re.search(pattern, para)]
    row = architecture_model(root, block)
    want = f"`{model.removeprefix('model/fringe/')}`"
    if row != want:
        out.append(f"{block}: docs/architecture.md's block table "
                   + ("has no row for it" if row is None else f"names the model {row}, not {want}"))
    return out


@pytest.mark.parametrize("block", blocks())
def test_block_is_found_by_its_name(block):
    found = missing(ROOT, block)
    assert not found, "\n".join(found)


def test_exceptions_name_blocks():
    """An exception for a block that no longer exists (or no longer needs one) is removed, not kept."""
    names = set(blocks())
    stale = [b for b in {**MODEL_EXCEPTIONS, **TEST_EXCEPTIONS} if b not in names]
    fixed = ROOT / "model/fringe/fixed"
    stale += [b for b in MODEL_EXCEPTIONS if (fixed / (b.removeprefix("fringe_") + ".py")).is_file()]
    stale += [b for b in TEST_EXCEPTIONS if (ROOT / f"tb/test_{b}.py").is_file()]
    assert not stale, f"exceptions no longer needed: {sorted(set(stale))}"


def test_a_block_without_its_files_is_reported(tmp_path):
    """A new Verilog block with nothing else is reported for each thing it lacks; a complete one is not."""
    for d in ("rtl/verilog", "rtl/vhdl", "docs/blocks", "tb", "model/fringe/fixed"):
        (tmp_path / d).mkdir(parents=True)
    (tmp_path / "docs/architecture.md").write_text(
        "| block | does | model |\n|---|---|---|\n| fringe_good | x | `fixed/good.py` |\n")
    for path in ("rtl/verilog/fringe_good.v", "rtl/vhdl/fringe_good.vhd", "tb/test_fringe_good.py",
                 "model/fringe/fixed/good.py", "rtl/verilog/fringe_new.v", "rtl/verilog/fringe_pkg.vh"):
        (tmp_path / path).write_text("")
    (tmp_path / "docs/blocks/fringe_good.md").write_text(
        "# fringe_good\n\nSources: `rtl/verilog/fringe_good.v`, `rtl/vhdl/fringe_good.vhd`; bit-exact\n"
        "model `model/fringe/fixed/good.py`; tests `tb/test_fringe_good.py`.\n")
    assert blocks(tmp_path) == ["fringe_good", "fringe_new"]
    assert missing(tmp_path, "fringe_good") == []
    assert missing(tmp_path, "fringe_new") == [
        "fringe_new: no VHDL twin rtl/vhdl/fringe_new.vhd",
        "fringe_new: no document docs/blocks/fringe_new.md",
        "fringe_new: no cocotb test tb/test_fringe_new.py",
        "fringe_new: no bit-exact model model/fringe/fixed/new.py",
        "fringe_new: docs/architecture.md's block table has no row for it"]
    (tmp_path / "docs/blocks/fringe_new.md").write_text("# fringe_new\n\nSources: `rtl/verilog/fringe_new.v`.\n")
    assert "fringe_new: the \"Sources:\" paragraph of docs/blocks/fringe_new.md does not name " \
        "bit-exact model `model/fringe/fixed/new.py`" in missing(tmp_path, "fringe_new")
