"""The correction engines behind `fringe correct --engine`."""

from .dataio import Measurement
from .errors import FringeInputError
from .pipeline import Calibration, Result, run_float


def run_engine(name: str, cal: Calibration, meas: Measurement, cal_dir: str) -> Result:
    if name == "float":
        return run_float(cal, meas.sin, meas.cos, meas.coarse)
    raise FringeInputError(f"engine '{name}' is not built yet in this version (use --engine float)", "--engine")
