"""What the tests read in the HDL sources: the VHDL range checks (fringe_pkg's check_range, which builds the
message "<unit>: <NAME> = <value> out of range <lo>..<hi>" the model raises)."""

import re


def vhdl_checks_range(text: str, unit: str, name: str, rng: str) -> bool:
    """Whether the VHDL checks NAME against the range "lo..hi" with the model's message: a call of
    check_range(unit, NAME, NAME, lo, hi[, hi_text]) or the message written out."""
    if f'"{unit}: {name} = " & integer\'image({name}) & " out of range {rng}"' in text:
        return True
    lo, hi = rng.split("..")
    hi_value = hi.replace("^", "**")
    call = (rf'check_range\("{re.escape(unit)}", "{re.escape(name)}", {re.escape(name)}, {re.escape(lo)}, '
            rf'{re.escape(hi_value)}(, "{re.escape(hi)}")?\)')
    return re.search(call, text) is not None


def vhdl_block_text(repo, block: str) -> str:
    """A VHDL block's source with fringe_pkg's, where its checks build their messages."""
    return (repo / "rtl" / "vhdl" / f"{block}.vhd").read_text() + (repo / "rtl" / "vhdl" / "fringe_pkg.vhd").read_text()
