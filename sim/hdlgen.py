"""Write what the HDL repeats from the Python single source into marked regions.

- constants: the register map (``model/fringe/fixed/regmap.py``), the status bits (``fringe.result``)
  and the block latencies (the ``LATENCY`` constants of the bit-exact block models), into
  ``rtl/vhdl/fringe_pkg.vhd`` and ``rtl/verilog/fringe_pkg.vh``;
- parameters/generics and the maps that pass them on, from ``CoreConfig`` (``fixed/config.py``:
  HDL_PARAMETER_DOCS, the defaults of CoreConfig()): in Verilog the include files
  ``rtl/verilog/fringe_core_params.vh`` (the list fringe_core, fringe_top and ``sim/synth_wrap.v`` include
  inside their ``#( ... )``) and ``rtl/verilog/fringe_core_map.vh`` (every parameter passed on under its own
  name); in VHDL the generics of fringe_core and fringe_top and fringe_top's map;
- documentation tables: the status bits (``docs/architecture.md`` and ``README.md``, the meanings of
  STATUS_MEANINGS), the registers (``docs/architecture.md``) and the core parameters
  (``docs/blocks/fringe_core.md``).

A region lies between the lines ``-- BEGIN generated <region> ...`` and ``-- END generated <region>``
(``//`` in Verilog); the body is indented as the BEGIN line.

Each region's first line records the command that wrote it. ``tb/test_hdlgen.py`` fails when the
committed text differs from what this writes.

Usage: ``.venv/bin/python sim/hdlgen.py`` (rewrite the regions) or ``... --check`` (exit 1 and
name the stale regions, write nothing).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fringe import result
from fringe.fixed import (
    canceller,
    cordic,
    drift_normaliser,
    drift_observer,
    long_period,
    period_count,
    quadrature,
    regmap,
    trim,
    wave_lut,
)
from fringe.fixed.config import HDL_PARAMETER_DOCS, HDL_WIDE_PARAMETERS, INPUT_LATENCY, CoreConfig

REPO = Path(__file__).resolve().parent.parent
COMMAND = "python sim/hdlgen.py"
STATUS_NAMES = tuple(result.STATUS_NAMES)


@dataclass(frozen=True)
class Const:
    name: str
    value: int
    comment: str
    verilog_w: int = 0   # > 0: a sized Verilog constant (an index concatenated with a bank bit), else integer


def constants() -> list[Const]:
    """Every shared constant, in the order the packages list them."""
    out = [Const("REG_W", regmap.REG_W, "bits per register word"),
           Const("N_REGS", regmap.N_REGS, "register words per bank")]
    reg_addr_w = (regmap.N_REGS - 1).bit_length()
    out.append(Const("REG_INDEX_W", reg_addr_w, "bits of a register's index in its bank"))
    out += [Const(f"REG_{r.name}", r.index, f"{'s' if r.signed else 'u'}({r.width})", reg_addr_w)
            for r in regmap.REGISTERS]
    out += [Const("CTRL_WORD", regmap.CTRL_WORD, "register-space word of CTRL", regmap.SPACE_LSB),
            Const("CTRL_SWAP", regmap.CTRL_SWAP, "CTRL bit: 1 swaps the banks"),
            Const("SPACE_LSB", regmap.SPACE_LSB, "cfg_wr_addr bit where the address space starts")]
    space_w = regmap.CFG_ADDR_W - regmap.SPACE_LSB
    field = f"cfg_wr_addr[{regmap.CFG_ADDR_W - 1}:{regmap.SPACE_LSB}]"
    out += [Const(f"SPACE_{name.upper()}", v, f"{field} of the {name} image", space_w)
            for name, v in regmap.SPACES.items()]
    out.append(Const("STATUS_W", len(STATUS_NAMES), "bits of the status word"))
    for name in STATUS_NAMES:
        mask = getattr(result, name)
        out.append(Const(f"STATUS_{name}", mask.bit_length() - 1, "status bit"))
    cp = CoreConfig().cordic()
    out += [Const("CORE_INPUT_LATENCY", INPUT_LATENCY, "fringe_core input registers"),
            Const("WAVE_LUT_LATENCY", wave_lut.LATENCY, "fringe_wave_lut"),
            Const("QUADRATURE_LATENCY", quadrature.LATENCY, "fringe_quadrature"),
            Const("CORDIC_LATENCY_BASE", cp.latency - cp.stages, "fringe_cordic: STAGES + this"),
            Const("CORDIC_ITER_CLOCKS_BASE", cordic.ITER_CLOCKS_BASE,
                  "fringe_cordic ITERATIVE = 1: a sample every STAGES + this clock enables"),
            Const("PERIOD_COUNT_LATENCY", period_count.LATENCY, "fringe_period_count"),
            Const("TRIM_LATENCY", trim.LATENCY, "fringe_trim"),
            Const("LONG_PERIOD_LATENCY", long_period.LATENCY, "fringe_long_period"),
            Const("DRIFT_NORM_LATENCY", drift_normaliser.LATENCY, "fringe_drift_normaliser"),
            Const("DRIFT_OBS_LATENCY", drift_observer.LATENCY, "fringe_drift_observer"),
            Const("DRIFT_SWEEP_MIN_LOG2", drift_observer.SWEEP_MIN_LOG2,
                  "fringe_drift_observer: a block that swept 2^-this of a period updates"),
            Const("DRIFT_PARTIAL_MU_MIN", drift_observer.PARTIAL_MU_MIN,
                  "fringe_drift_observer: ... if MU_LOG2 is at least this"),
            Const("CANCEL_LATENCY", canceller.LATENCY, "fringe_canceller"),
            Const("CANCEL_ADAPT_LATENCY", canceller.ADAPT_LATENCY,
                  "fringe_canceller: a block's last sample to its update in place")]
    return out


def vhdl_constants() -> list[str]:
    w = max(len(c.name) for c in constants())
    return [f"constant {c.name:<{w}} : integer := {c.value};  -- {c.comment}" for c in constants()]


def verilog_constants() -> list[str]:
    w = max(len(c.name) for c in constants())

    def decl(c: Const) -> str:
        kind = f"[{c.verilog_w - 1}:0]" if c.verilog_w else "integer"
        value = f"{c.verilog_w}'d{c.value}" if c.verilog_w else str(c.value)
        return f"localparam {kind:<7} {c.name:<{w}} = {value};"
    return [f"{decl(c)}  // {c.comment}" for c in constants()]


# --------------------------------------------------------------------------- core parameter lists

#: a comment line before the parameter that opens a group
GROUPS = {"TRIM": "fringe_trim (closed-loop corrections): built only with TRIM = 1",
          "DRIFT": "the drift tracker (fringe_drift_normaliser, fringe_drift_observer): built only with DRIFT = 1",
          "CANCEL": "fringe_canceller (the adaptive interference canceller): built only with CANCEL = 1",
          "REGS_INIT": 'initial contents: $readmemh images, "" = zeros'}


def parameters() -> list[tuple[str, int | str, str]]:
    """(name, default, meaning) of every fringe_core / fringe_top parameter, in declaration order."""
    d = CoreConfig().hdl_parameter_defaults()
    return [(name, d[name], doc) for name, doc in HDL_PARAMETER_DOCS.items()]


def _declarations(decl, leader: str, sep: str, last: str) -> list[str]:
    ps = parameters()
    texts = [decl(name, v) for name, v, _ in ps]
    w = max(len(t) for t in texts) + 1
    out = []
    for i, ((name, _, doc), t) in enumerate(zip(ps, texts, strict=True)):
        if name in GROUPS:
            out.append(f"{leader} {GROUPS[name]}")
        out.append(f"{t + (sep if i < len(ps) - 1 else last):<{w}} {leader} {doc}")
    return out


#: the name column of the declarations: the longest name
NAME_W = max(len(name) for name in HDL_PARAMETER_DOCS)


def verilog_parameters() -> list[str]:
    def decl(name: str, v: int | str) -> str:
        if isinstance(v, str):
            return f'parameter         {name:<{NAME_W}} = "{v}"'
        if name in HDL_WIDE_PARAMETERS:
            return f"parameter [63:0]  {name:<{NAME_W}} = 64'd{v}"
        return f"parameter integer {name:<{NAME_W}} = {v}"
    return _declarations(decl, "//", ",", "")


def vhdl_generics() -> list[str]:
    def decl(name: str, v: int | str) -> str:
        if isinstance(v, str):
            return f'{name:<{NAME_W}} : string  := "{v}"'
        return f"{name:<{NAME_W}} : {'natural' if name in HDL_WIDE_PARAMETERS else 'integer'} := {v}"
    return _declarations(decl, "--", ";", "")


def _map(item, width: int = 104) -> list[str]:
    """Every parameter passed on under its own name, wrapped into lines of at most ``width``."""
    names = [name for name, _, _ in parameters()]
    lines, cur = [], ""
    for i, name in enumerate(names):
        piece = item(name) + ("," if i < len(names) - 1 else "")
        if cur and len(cur) + 1 + len(piece) > width:
            lines.append(cur)
            cur = piece
        else:
            cur = f"{cur} {piece}" if cur else piece
    return lines + [cur]


def verilog_map() -> list[str]:
    return _map(lambda n: f".{n}({n})")


def vhdl_map() -> list[str]:
    return _map(lambda n: f"{n} => {n}")


# --------------------------------------------------------------------------- documentation tables

STATUS_MEANINGS = {
    "CLIP_SIN": "sine ADC code at either end of its range",
    "CLIP_COS": "cosine ADC code at either end of its range",
    "AMP_LOW": "vector magnitude below the low threshold (loss of signal)",
    "AMP_HIGH": "vector magnitude above the high threshold",
    "OVERSPEED": "fine phase moved a quarter period or more since the last sample",
    "COARSE_ERR": "coarse code disagrees with the fine phase or the tracked position",
    "SATURATED": "an internal value saturated (quadrature stage, drift normaliser, canceller output or "
                 "coefficients) or the trim was clipped",
    "BANK": "which table bank served this sample (information, not a fault)",
}


def status_table() -> list[str]:
    rows = ["| bit | name | meaning |", "|---|---|---|"]
    rows += [f"| {getattr(result, n).bit_length() - 1} | {n} | {STATUS_MEANINGS[n]} |" for n in STATUS_NAMES]
    return rows


def register_table() -> list[str]:
    rows = ["| index | name | format | meaning |", "|---|---|---|---|"]
    rows += [f"| {r.index} | {r.name} | {'s' if r.signed else 'u'}({r.width}) | {r.meaning} |"
             for r in regmap.REGISTERS]
    rows.append(f"| {len(regmap.REGISTERS)}..{regmap.N_REGS - 1} | - | - | reserved (0) |")
    rows.append(f"| {regmap.CTRL_WORD:#x} | CTRL | - | write bit {regmap.CTRL_SWAP} = 1: swap the banks "
                "(a command, not a register) |")
    return rows


def parameter_table() -> list[str]:
    """fringe_core's (and fringe_top's) parameters for ``docs/blocks/fringe_core.md``, with the group notes."""
    rows = ["| name | default | meaning |", "|---|---|---|"]
    for name, v, doc in parameters():
        if name in GROUPS:
            rows.append(f"| | | *{GROUPS[name]}* |")
        default = f'`"{v}"`' if isinstance(v, str) else f"{v}"
        rows.append(f"| {name} | {default} | {doc.replace('|', '/')} |")
    return rows


#: file -> (comment leader, {region: body lines})
REGIONS: dict[str, tuple[str, dict[str, Callable[[], list[str]]]]] = {
    "rtl/vhdl/fringe_pkg.vhd": ("--", {"constants": vhdl_constants}),
    "rtl/verilog/fringe_pkg.vh": ("//", {"constants": verilog_constants}),
    # one Verilog text, included by fringe_core, fringe_top and sim/synth_wrap.v inside #( ... )
    "rtl/verilog/fringe_core_params.vh": ("//", {"parameters": verilog_parameters}),
    "rtl/verilog/fringe_core_map.vh": ("//", {"core map": verilog_map}),
    # VHDL has no include: the generics are written into both entities
    "rtl/vhdl/fringe_core.vhd": ("--", {"generics": vhdl_generics}),
    "rtl/vhdl/fringe_top.vhd": ("--", {"generics": vhdl_generics, "core map": vhdl_map}),
    "docs/architecture.md": ("<!--", {"status": status_table, "registers": register_table}),
    "docs/blocks/fringe_core.md": ("<!--", {"parameters": parameter_table}),
    "README.md": ("<!--", {"status": status_table}),
}


def render(text: str, leader: str, region: str, body: list[str], where: str) -> str:
    """``text`` with the lines between the region's BEGIN and END markers replaced by ``body``."""
    pat = re.compile(rf"^([ \t]*){re.escape(leader)} BEGIN generated {region}\b[^\n]*\n.*?"
                     rf"^[ \t]*{re.escape(leader)} END generated {region}[^\n]*$", re.S | re.M)
    m = pat.search(text)
    if m is None:
        raise ValueError(f"{where}: no '{leader} BEGIN generated {region}' ... '{leader} END generated {region}'")
    ind = m.group(1)
    close = " -->" if leader == "<!--" else ""   # Markdown comments
    block = "\n".join([f"{ind}{leader} BEGIN generated {region} (written by {COMMAND}; do not edit){close}",
                       *[f"{ind}{line}" for line in body], f"{ind}{leader} END generated {region}{close}"])
    return text[:m.start()] + block + text[m.end():]


def generated(rel: str, text: str | None = None) -> str:
    """The text ``rel`` should have: its committed text with every region regenerated."""
    leader, regions = REGIONS[rel]
    out = (REPO / rel).read_text() if text is None else text
    for region, body in regions.items():
        out = render(out, leader, region, body(), rel)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if a region is stale; write nothing")
    args = ap.parse_args(argv)
    stale = []
    for rel in REGIONS:
        old = (REPO / rel).read_text()
        new = generated(rel, old)
        if new != old:
            stale.append(rel)
            if not args.check:
                (REPO / rel).write_text(new)
    verb = "stale" if args.check else "rewrote"
    print(f"hdlgen: {verb} {', '.join(stale)}" if stale else "hdlgen: every region up to date")
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
