"""What a block test's pytest side hands its cocotb side through run_block's extra_env: the HDL
parameters as JSON and the seed (``FRINGE_SEED`` from the environment replays a run); ``block_config``
reads them back on the cocotb side; ``signed`` reads a signed output word."""

from __future__ import annotations

import json
import os


def block_env(var: str, params: dict, default_seed: int) -> dict[str, str]:
    """``{var: params as JSON, "FRINGE_SEED": $FRINGE_SEED or default_seed}``."""
    return {var: json.dumps(params), "FRINGE_SEED": os.environ.get("FRINGE_SEED", str(default_seed))}


def run_seeded(toplevel: str, params: dict, sim: str, var: str, default_seed: int, timeout_s: int) -> None:
    """Simulate ``toplevel`` with its test module ``tb/test_<toplevel>.py``, handing it ``block_env``."""
    from cocotb_runner import run_block

    run_block(toplevel, f"test_{toplevel}", params, sim=sim, timeout_s=timeout_s,
              extra_env=block_env(var, params, default_seed))


def block_config(var: str, default_seed: int) -> tuple[dict, int, int]:
    """The cocotb side of ``block_env``: (the HDL parameters, their USER_W, the seed)."""
    raw = json.loads(os.environ[var])
    return raw, int(raw["USER_W"]), int(os.environ.get("FRINGE_SEED", default_seed))


def signed(v: int, w: int) -> int:
    """The low ``w`` bits of ``v`` as a two's complement s(w)."""
    v &= (1 << w) - 1
    return v - (1 << w) if v >> (w - 1) else v


def params_from_hdl(cls, raw: dict):
    """The model's parameter dataclass ``cls`` from HDL parameters (its fields' names upper case)."""
    return cls(**{f: raw[f.upper()] for f in cls.__dataclass_fields__})
