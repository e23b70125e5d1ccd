"""Real recordings from ../shared/data (skipped when the folder is absent)."""

import numpy as np
import pytest

from fringe.calibrate import calibrate, uncorrected
from fringe.datasets import RM44_ENCODER, halves, read_rm44
from fringe.evaluate import figures


@pytest.mark.parametrize("name", ["2017_10_02_xs_000u.csv", "2017_10_02_xs_450u.csv"])
def test_rm44_calibrated_on_half_corrects_the_other_half(shared_data, name):
    """The RM44's error is dominated by harmonics 1-4 (README: 1.2 deg p-p, 5.9 deg at 450 um).
    Calibrated on the even samples, the odd ones must come down to the sensor's noise: the
    residual's systematic part (bin means over 64 bins of ~8 samples) must be far below the raw one,
    and the direction must come out reversed (the sin channel runs against the reference)."""
    meas = read_rm44(str(shared_data / "rm44_hall_vs_tonic" / name))
    train, val = halves(meas)
    cal = calibrate(train, RM44_ENCODER)
    assert cal.direction == -1
    raw, _ = figures(uncorrected(cal, val), val)
    fixed, res = figures(cal, val)
    assert fixed.rms_arcsec < 0.5 * raw.rms_arcsec
    # noise from successive differences of the residual (the systematic part is smooth)
    from fringe.metrics import error_arcsec
    err = error_arcsec(res.angle_deg, val.ref_deg)
    noise = np.std(np.diff(err)) / np.sqrt(2)
    assert fixed.rms_arcsec < 1.5 * noise
