"""What the tests read in the HDL sources: the VHDL range checks (fringe_pkg's check_range, which builds the
message "<unit>: <NAME> = <value> out of range <lo>..<hi>" the model raises, and check_position, which checks
FINE_W, LINES and POS_W of the blocks that count in REV)."""

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]   # the checkout: rtl/, sim/ and docs/ below it


def vhdl_checks_range(text: str, unit: str, name: str, rng: str) -> bool:
    """Whether the VHDL checks NAME against the range "lo..hi" with the model's message: a call of
    check_range(unit, NAME, NAME, lo, hi[, hi_text]) or the message written out."""
    if f'"{unit}: {name} = " & integer\'image({name}) & " out of range {rng}"' in text:
        return True
    lo, hi = rng.split("..")
    hi_value = hi.replace("^", "**")
    call = (rf'check_range\("{re.escape(unit)}", "{re.escape(name)}", {re.escape(name)}, {re.escape(lo)}, '
            rf'{re.escape(hi_value)}(, "{re.escape(hi)}")?\)')
    if re.search(call, text):
        return True
    # FINE_W and LINES, checked by fringe_pkg's check_position(unit, FINE_W, LINES, pos_w_max)
    in_pkg = (rf'check_range\(unit, "{re.escape(name)}", {re.escape(name.lower())}, {re.escape(lo)}, '
              rf'{re.escape(hi_value)}(, "{re.escape(hi)}")?\)')
    position = rf'check_position\("{re.escape(unit)}", FINE_W, LINES, \d+\)'
    if (name in ("FINE_W", "LINES") and re.search(position, text) is not None
            and re.search(in_pkg, _position_body(text)) is not None):
        return True
    # the drift tracker's parameters, checked by fringe_pkg's check_drift_state / check_drift_observer(unit, ...)
    return any(re.search(rf'{proc}\("{re.escape(unit)}", ', text) is not None
               and re.search(in_pkg, _procedure_body(text, proc)) is not None for proc in DRIFT_CHECKS)


#: fringe_pkg's checks of the drift tracker's parameters (VHDL procedures; Verilog macros FRINGE_CHECK_DRIFT_*)
DRIFT_CHECKS = ("check_drift_state", "check_drift_observer")


def _procedure_body(text: str, proc: str) -> str:
    m = re.search(rf"procedure {proc}\([^)]*\) is(.*?)end procedure {proc};", text, re.S)
    return m.group(1) if m else ""


def _position_body(text: str) -> str:
    return _procedure_body(text, "check_position")


def vhdl_checks_position(text: str, unit: str, pos_w_max: int) -> bool:
    """Whether the VHDL checks POS_W = FINE_W + clog2(LINES) <= pos_w_max with the model's message
    "<unit>: POS_W = FINE_W + clog2(LINES) = <v> exceeds <pos_w_max>" (through fringe_pkg's check_position)."""
    body = _position_body(text)
    return (f'check_position("{unit}", FINE_W, LINES, {pos_w_max})' in text
            and 'unit & ": POS_W = FINE_W + clog2(LINES) = " & integer\'image(fine_w + clog2(lines))' in body
            and '& " exceeds " & integer\'image(pos_w_max)' in body and "fine_w + clog2(lines) <= pos_w_max" in body)


def verilog_checks_range(text: str, unit: str, name: str, rng: str) -> bool:
    """Whether the Verilog checks NAME against the range "lo..hi" with the model's message: the $error
    written out, or fringe_pkg.vh's FRINGE_CHECK_RANGE(label, unit, NAME, NAME, lo, hi), whose format
    builds that message."""
    if f'"{unit}: {name} = %0d out of range {rng} (instance %m)"' in text:
        return True
    lo, hi = rng.split("..")
    call = (rf'`FRINGE_CHECK_RANGE\(\w+, "{re.escape(unit)}", "{re.escape(name)}", {re.escape(name)}, '
            rf'{re.escape(lo)}, {re.escape(hi)}\)')
    pkg = _verilog_pkg()
    macro = ('if ((V) < (LO) || (V) > (HI)) begin : LABEL \\\n'
             '        $error("%s: %s = %0d out of range %0d..%0d (instance %m)", UNIT, NAME, V, LO, HI);')
    if re.search(call, text) is not None and macro in pkg:
        return True
    # FINE_W and LINES, checked by fringe_pkg.vh's FRINGE_CHECK_POSITION(unit, FINE_W, LINES, pos_w_max)
    position = {"FINE_W": '`FRINGE_CHECK_RANGE(g_bad_fine_w, UNIT, "FINE_W", FW, 8, 30)',
                "LINES": '$error("%s: LINES = %0d out of range 1..2^20 (instance %m)", UNIT, LN);'}
    if (name in position and f"{name}:{rng}" in ("FINE_W:8..30", "LINES:1..2^20") and macro in pkg
            and position[name] in pkg and re.search(_position_call(unit), text) is not None):
        return True
    # the drift tracker's parameters, checked by fringe_pkg.vh's FRINGE_CHECK_DRIFT_STATE / _OBSERVER(unit)
    in_macro = (rf'`FRINGE_CHECK_RANGE\(\w+, UNIT, "{re.escape(name)}", {re.escape(name)}, {re.escape(lo)}, '
                rf'{re.escape(hi)}\)')
    return macro in pkg and any(f'`FRINGE_CHECK_DRIFT_{what}("{unit}")' in text
                                and re.search(in_macro, _macro_body(pkg, f"FRINGE_CHECK_DRIFT_{what}"))
                                for what in ("STATE", "OBSERVER"))


def _macro_body(pkg: str, macro: str) -> str:
    """The body of the Verilog macro (its continued lines)."""
    m = re.search(rf"`define {macro}\(.*?\) \\\n((?:.*\\\n)*.*)", pkg)
    return m.group(1) if m else ""


def _verilog_pkg() -> str:
    return (REPO / "rtl" / "verilog" / "fringe_pkg.vh").read_text()


def _position_call(unit: str, pos_w_max: int | None = None) -> str:
    mx = r"\d+" if pos_w_max is None else str(pos_w_max)
    return rf'`FRINGE_CHECK_POSITION\("{re.escape(unit)}", FINE_W, LINES, {mx}\)'


def verilog_checks_position(text: str, unit: str, pos_w_max: int) -> bool:
    """Whether the Verilog checks POS_W = FINE_W + clog2(LINES) <= pos_w_max with the model's message
    "<unit>: POS_W = FINE_W + clog2(LINES) = <v> exceeds <pos_w_max>" (fringe_pkg.vh's FRINGE_CHECK_POSITION)."""
    fmt = '$error("%s: POS_W = FINE_W + clog2(LINES) = %0d exceeds %0d (instance %m)", UNIT, (FW) + $clog2(LN), PMAX);'
    return re.search(_position_call(unit, pos_w_max), text) is not None and fmt in _verilog_pkg()


def vhdl_block_text(repo, block: str) -> str:
    """A VHDL block's source with fringe_pkg's, where its checks build their messages."""
    return (repo / "rtl" / "vhdl" / f"{block}.vhd").read_text() + (repo / "rtl" / "vhdl" / "fringe_pkg.vhd").read_text()


def block_texts(block: str) -> tuple[str, str]:
    """A block's Verilog source, and its VHDL source with fringe_pkg's (``vhdl_block_text``)."""
    return (REPO / "rtl" / "verilog" / f"{block}.v").read_text(), vhdl_block_text(REPO, block)


def missing_checks(block: str, ranges, pos_w_max: int | None = None) -> list[str]:
    """The checks with the model's messages a block lacks, in either language: a range check per
    (NAME, "lo..hi") of ``ranges``, and the POS_W <= pos_w_max check where given. Empty when all are there."""
    v, h = block_texts(block)
    missing = []
    for name, rng in ranges:
        missing += [f"Verilog {name} {rng}"] * (not verilog_checks_range(v, block, name, rng))
        missing += [f"VHDL {name} {rng}"] * (not vhdl_checks_range(h, block, name, rng))
    if pos_w_max is not None:
        missing += [f"Verilog POS_W <= {pos_w_max}"] * (not verilog_checks_position(v, block, pos_w_max))
        missing += [f"VHDL POS_W <= {pos_w_max}"] * (not vhdl_checks_position(h, block, pos_w_max))
    return missing
