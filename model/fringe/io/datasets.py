"""Readers for the public recordings in ../shared/data (not shipped with fringe).

RLS RM44 Hall encoder against a Renishaw TONiC reference (see shared/data/README.md):
12-bit ADC stored as (ADC - 2048)/4096, so full scale is 0.5; one revolution is one signal
period (lines_per_rev = 1) in 1000 samples at 1 kHz; the reference is a fraction of a
revolution. The sine channel runs against the reference's direction, which calibration finds.
"""

import numpy as np

from ..encoder import Encoder
from ..errors import FringeInputError
from .dataio import Measurement

RM44_ENCODER = Encoder(lines_per_rev=1, adc_bits=12, coarse_bits=0, full_scale=0.5)
RM44_SAMPLE_RATE_HZ = 1000.0


def read_rm44(path: str) -> Measurement:
    try:
        with open(path, encoding="utf-8") as f:
            header = f.readline().strip().split(",")
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError) as e:
        raise FringeInputError(f"cannot read RM44 recording: {e}", path) from None
    try:
        col = {name: data[:, header.index(name)] for name in ("bsin", "bcos", "ref_angle_rev")}
    except ValueError:
        raise FringeInputError(f"not an RM44 recording (columns: {', '.join(header)})", path) from None
    scale = RM44_ENCODER.adc_half_range / RM44_ENCODER.full_scale
    t = np.arange(len(data)) / RM44_SAMPLE_RATE_HZ
    return Measurement(path, col["bsin"] * scale, col["bcos"] * scale, None,
                       np.mod(col["ref_angle_rev"] * 360.0, 360.0), t)


def halves(meas: Measurement) -> tuple[Measurement, Measurement]:
    """Even samples to calibrate, odd samples to validate: both cover the whole revolution."""
    idx = np.arange(len(meas))
    return meas.subset(idx % 2 == 0), meas.subset(idx % 2 == 1)
