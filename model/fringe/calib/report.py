"""Plots a person would look at: error against angle, and Lissajous figures, before and after."""

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..dsp.calibration import Calibration  # noqa: E402
from ..dsp.metrics import error_arcsec, split_error  # noqa: E402
from ..engine.pipeline import run_float  # noqa: E402


def error_plot(path: str, curves: dict, fine_bins: int = 64, rev_bins: int = 256):
    """curves: label -> (error_arcsec, fine phase fraction, revolution fraction)."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7))
    for label, (err, frac, rev) in curves.items():
        interp, lp = split_error(err, frac, rev, fine_bins, rev_bins)
        ax1.plot((np.arange(fine_bins) + 0.5) / fine_bins * 360, interp, ".-", label=label)
        ax2.plot((np.arange(rev_bins) + 0.5) / rev_bins * 360, lp, "-", label=label)
    ax1.set(xlabel="fine phase (electrical degrees)", ylabel="mean error (arcsec)",
            title="Interpolation error (bin means over one signal period)")
    ax2.set(xlabel="position in the revolution (degrees)", ylabel="mean error (arcsec)",
            title="Long-period error (bin means over the revolution)")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def lissajous_plot(path: str, cal: Calibration, sin: np.ndarray, cos: np.ndarray, max_points: int = 20000):
    step = max(1, len(sin) // max_points)
    s, c = sin[::step], cos[::step]
    xs = cal.inv_sin(s, c) if cal.inv_sin is not None else s
    xc = cal.inv_cos(c, s) if cal.inv_cos is not None else c
    cs, cc = cal.quad.apply(xs, xc)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 5))
    ax1.plot(c, s, ",", alpha=0.5)
    ax1.set(title="Raw readings", xlabel="cos (counts)", ylabel="sin (counts)", aspect="equal")
    t = np.linspace(0, 2 * np.pi, 400)
    ax2.plot(np.cos(t), np.sin(t), "k-", lw=0.5, label="unit circle")
    ax2.plot(cc, cs, ",", alpha=0.5, label="corrected")
    r = np.hypot(cs, cc)
    ax2.set(title=f"Corrected (radius {r.min():.4f} .. {r.max():.4f})", xlabel="cos'", ylabel="sin'",
            aspect="equal")
    ax2.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def calibration_plots(cal: Calibration, meas) -> dict:
    """Writers for the plots of a calibration on its own data (for CAL_DIR)."""
    writers = {"lissajous.png": lambda p: lissajous_plot(p, cal, meas.sin, meas.cos)}
    if meas.ref_deg is not None:
        from .calibrate import uncorrected

        def err_plot(p):
            curves = {}
            for label, c in (("uncorrected", uncorrected(cal, meas)), ("corrected", cal)):
                res = run_float(c, meas.sin, meas.cos, meas.coarse, meas.t_s)
                curves[label] = (error_arcsec(res.angle_deg, meas.ref_deg), res.frac,
                                 res.position / cal.encoder.lines_per_rev)
            error_plot(p, curves)
        writers["error.png"] = err_plot
    return writers


def ensure_dir(path: str):
    os.makedirs(path, exist_ok=True)
