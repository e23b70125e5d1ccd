"""Judging a calibration on simulated data, where the truth is known."""

import dataclasses

import numpy as np

from ..dsp.calibration import Calibration
from ..dsp.metrics import ErrorFigures, error_arcsec, error_figures
from ..dsp.position import wrap
from ..dsp.simulate import Recording, SimulationConfig, simulate
from ..encoder import ARCSEC_PER_REV
from ..engine.pipeline import run_float
from ..io.dataio import Measurement
from ..result import Result


def measurement_of(rec: Recording, path: str = "simulated") -> Measurement:
    c = rec.columns
    return Measurement(path, c["sin"].astype(float), c["cos"].astype(float), c.get("coarse"),
                       c.get("ref_deg"), c.get("t_s"))


def float_engine(cal: Calibration, meas: Measurement) -> Result:
    return run_float(cal, meas.sin, meas.cos, meas.coarse, meas.t_s)


def figures(cal: Calibration, meas: Measurement, engine=float_engine) -> tuple[ErrorFigures, Result]:
    res = engine(cal, meas)
    err = error_arcsec(res.angle_deg, meas.ref_deg)
    return error_figures(err, res.frac, res.position / cal.encoder.lines_per_rev), res


def noise_floor_rows(cal: Calibration, cfg: SimulationConfig, seed: int, engine=float_engine
                     ) -> tuple[np.ndarray, float]:
    """What noise alone does to each row: the same recording with and without the additive noise (same
    trajectory, same coarse jitter) through the same correction (arcsec per row), and the reference's own
    quantisation RMS (uniform, q/sqrt(12))."""
    noisy = engine(cal, measurement_of(simulate(cfg, seed)))
    clean = engine(cal, measurement_of(simulate(dataclasses.replace(cfg, noise_rms=0.0), seed)))
    d = wrap((noisy.angle_deg - clean.angle_deg) / 360.0) * ARCSEC_PER_REV
    return d, ARCSEC_PER_REV / (1 << cfg.ref_bits) / np.sqrt(12)


def floor_rms(d: np.ndarray, ref_q: float) -> float:
    """The floor over the rows `d` of noise_floor_rows (their mean taken out, as the error's is)."""
    return float(np.sqrt(np.mean((d - d.mean()) ** 2) + ref_q ** 2))


def noise_floor_arcsec(cal: Calibration, cfg: SimulationConfig, seed: int, engine=float_engine) -> float:
    """The RMS error a perfect correction would leave (noise_floor_rows over the whole recording)."""
    return floor_rms(*noise_floor_rows(cal, cfg, seed, engine))
