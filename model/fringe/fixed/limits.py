"""The parameter checks the block models share, in the HDL's message formats (`<block>: NAME = v out of range
lo..hi`, without the HDL's instance path)."""

import numpy as np


def check_int(block: str, name: str, value) -> None:
    """ValueError unless value is an integer (a bool is not)."""
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise ValueError(f"{block}: {name} must be an integer, got {value!r}")


def check_integers(block: str, params, fields) -> None:
    """check_int on each of the dataclass fields, named upper case as in the HDL."""
    for name in fields:
        check_int(block, name.upper(), getattr(params, name))


def check_range(block: str, name: str, value: int, lo: int, hi: int, shown: str | None = None) -> None:
    """ValueError unless lo <= value <= hi; shown: the range as the HDL's message writes it (default lo..hi)."""
    if not lo <= value <= hi:
        raise ValueError(f"{block}: {name} = {value} out of range {shown or f'{lo}..{hi}'}")
