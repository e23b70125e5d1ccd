"""What every correction engine returns per sample (float, bit-exact model, RTL): the `Result`, and the
bits of its status word (docs/architecture.md)."""

from dataclasses import dataclass

import numpy as np

CLIP_SIN, CLIP_COS, AMP_LOW, AMP_HIGH, OVERSPEED, COARSE_ERR, SATURATED, BANK = (1 << i for i in range(8))
#: the fault flags of the status word (every bit below BANK, which only says which table bank served the sample)
FAULTS = BANK - 1
STATUS_NAMES = ["CLIP_SIN", "CLIP_COS", "AMP_LOW", "AMP_HIGH", "OVERSPEED", "COARSE_ERR", "SATURATED", "BANK"]


@dataclass
class Result:
    angle_deg: np.ndarray       # corrected output angle, [0, 360)
    status: np.ndarray          # int status word per sample
    frac: np.ndarray            # fine phase, fraction of a period
    position: np.ndarray        # encoder position before the trim and long-period corrections (the period
                                #   count's, which the trim's speed and sectors see), periods [0, lines)
    magnitude: np.ndarray       # corrected vector magnitude (1 nominal)
