"""Integer constants read from the HDL sources, without a simulator.

``package_constants(lang)`` reads the generated constants of ``rtl/vhdl/fringe_pkg.vhd`` or
``rtl/verilog/fringe_pkg.vh``; ``block_constant(path, name)`` finds ``localparam integer NAME = ...;``
(Verilog) or ``constant NAME : integer := ...;`` (VHDL) in a block and evaluates its expression
(integers, ``+ - *``, parentheses and the package's names; ``generics`` supplies the others).
The latency tests compare these with the bit-exact model's constants.
"""

from __future__ import annotations

import ast
import operator
import re
from collections.abc import Mapping
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent.parent
PACKAGES = {"verilog": REPO / "rtl/verilog/fringe_pkg.vh", "vhdl": REPO / "rtl/vhdl/fringe_pkg.vhd"}

_VERILOG = r"localparam\s+(?:integer|\[\d+:0\])\s+{name}\s*=\s*([^;]+);"
_VHDL = r"constant\s+{name}\s*:\s*integer\s*:=\s*([^;]+);"
_SIZED = re.compile(r"\b\d+'d(\d+)\b")      # Verilog 5'd3 -> 3
_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul}


def _lang(path: Path) -> str:
    return "vhdl" if path.suffix == ".vhd" else "verilog"


def _strip_comments(text: str, lang: str) -> str:
    return re.sub(r"--[^\n]*" if lang == "vhdl" else r"//[^\n]*", "", text)


def _evaluate(expr: str, names: Mapping[str, int], where: str) -> int:
    def ev(node: ast.AST) -> int:
        if isinstance(node, ast.Constant) and isinstance(node.value, int):
            return node.value
        if isinstance(node, ast.Name):
            if node.id not in names:
                raise KeyError(f"{where}: {node.id} is neither a package constant nor a given generic")
            return names[node.id]
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.left), ev(node.right))
        raise ValueError(f"{where}: cannot evaluate {ast.unparse(node)!r}")

    return ev(ast.parse(_SIZED.sub(r"\1", expr.strip()), mode="eval").body)


def package_constants(lang: str) -> dict[str, int]:
    """{name: value} of every integer constant of the package of ``lang`` ("verilog" or "vhdl")."""
    text = _strip_comments(PACKAGES[lang].read_text(), lang)
    pat = _VERILOG if lang == "verilog" else _VHDL
    out: dict[str, int] = {}
    for m in re.finditer(pat.format(name=r"(\w+)"), text):
        out[m.group(1)] = _evaluate(m.group(2), out, f"{PACKAGES[lang].name}: {m.group(1)}")
    return out


def block_constant(path: Path, name: str, generics: Mapping[str, int] | None = None) -> int:
    """The value of the integer constant ``name`` declared in the HDL file ``path``."""
    lang = _lang(path)
    text = _strip_comments(path.read_text(), lang)
    pat = _VERILOG if lang == "verilog" else _VHDL
    m = re.search(pat.format(name=re.escape(name)), text, re.I if lang == "vhdl" else 0)
    if m is None:
        raise AssertionError(f"no integer constant {name} in {path}")
    return _evaluate(m.group(1), {**package_constants(lang), **(generics or {})}, f"{path.name}: {name}")


def package_function(lang: str, name: str, **args: int) -> int:
    """The value of the package's integer function ``name`` (a single expression of its arguments
    and the package constants) for the given arguments: ``return EXPR;`` in VHDL, ``name = EXPR;``
    in Verilog (the function carries the ``fringe_`` prefix there)."""
    text = _strip_comments(PACKAGES[lang].read_text(), lang)
    if lang == "vhdl":
        m = re.search(rf"function\s+{name}\s*\([^)]*\)\s*return\s+\w+\s+is\s+begin\s+return\s+([^;]+);", text, re.I)
    else:
        m = re.search(rf"\bfringe_{name}\s*=\s*([^;]+);", text)
    if m is None:
        raise AssertionError(f"no function {name} in {PACKAGES[lang].name}")
    names = {**package_constants(lang), **args}
    return _evaluate(" ".join(m.group(1).split()), names, f"{PACKAGES[lang].name}: {name}")


def both_languages(block: str) -> list[Path]:
    """The Verilog and the VHDL file of a block."""
    return [REPO / f"rtl/verilog/{block}.v", REPO / f"rtl/vhdl/{block}.vhd"]


def constants_test(block: str, **expected: int):
    """A test that the block's constants (``LATENCY=...``, in both languages) equal the model's: assign it to
    ``test_latency_constant_matches_model`` in the block's test module."""

    def test_latency_constant_matches_model():
        for f in both_languages(block):
            for name, value in expected.items():
                assert block_constant(f, name) == value, (f, name)

    return test_latency_constant_matches_model
