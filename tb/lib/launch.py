"""What a block test's pytest side hands its cocotb side through run_block's extra_env: the HDL
parameters as JSON and the seed (``FRINGE_SEED`` from the environment replays a run)."""

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
