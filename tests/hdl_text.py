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
    return (name in ("FINE_W", "LINES") and re.search(position, text) is not None
            and re.search(in_pkg, _position_body(text)) is not None)


def _position_body(text: str) -> str:
    m = re.search(r"procedure check_position\(.*?\) is(.*?)end procedure check_position;", text, re.S)
    return m.group(1) if m else ""


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
    pkg = (REPO / "rtl" / "verilog" / "fringe_pkg.vh").read_text()
    macro = ('if ((V) < (LO) || (V) > (HI)) begin : LABEL \\\n'
             '        $error("%s: %s = %0d out of range %0d..%0d (instance %m)", UNIT, NAME, V, LO, HI);')
    return re.search(call, text) is not None and macro in pkg


def vhdl_block_text(repo, block: str) -> str:
    """A VHDL block's source with fringe_pkg's, where its checks build their messages."""
    return (repo / "rtl" / "vhdl" / f"{block}.vhd").read_text() + (repo / "rtl" / "vhdl" / "fringe_pkg.vhd").read_text()
