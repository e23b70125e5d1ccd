"""Shared fixtures: simulated seed-encoder recordings (small, fixed seeds) and the shared data folder."""

import os
from pathlib import Path

import numpy as np
import pytest

from fringe.dsp.simulate import seed_encoder, simulate
from fringe.io.dataio import Measurement

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def measurement_of(rec, path="sim") -> Measurement:
    c = rec.columns
    return Measurement(path, c["sin"].astype(float), c["cos"].astype(float), c.get("coarse"),
                       c.get("ref_deg"), c.get("t_s"))


@pytest.fixture(scope="session")
def seed_recordings():
    """Two seed-encoder recordings: calibrate on the first, validate on the second."""
    cfg = seed_encoder()
    cfg.samples = 60_000
    return [simulate(cfg, seed=s) for s in (11, 12)]


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data folder absent: {SHARED_DATA}")
    return SHARED_DATA


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(int(os.environ.get("FRINGE_SEED", seed)))
