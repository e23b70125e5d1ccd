"""The motion as the loop sees it: the encoder's settled speed and the reference's speed, each averaged over one
electrical period. The evaluation records the reference's motion, the tests gate the speed effects on it, and the
tone search takes the steady revolution rate from the settled speed."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..dsp.effects import Context
from ..engine.pipeline import sample_times
from ..fixed.trim import speed_window_log2
from ..io.dataio import Measurement


def settled_speed(ctx: Context) -> np.ndarray:
    """The speed estimate once its window is full (before, it comes from shorter windows, as in the hardware)."""
    n = 1 << speed_window_log2(ctx.lines)
    return ctx.speed[n:] if len(ctx.speed) > 2 * n else ctx.speed


def _period_mean(v: np.ndarray, ctx: Context) -> np.ndarray:
    """v averaged over one electrical period."""
    step = np.mean(np.abs(np.diff(np.unwrap(ctx.phi)))) if len(ctx.phi) > 1 else 0.0
    per_period = int(round(2 * np.pi / step)) if step > 0 else 1
    return ndimage.uniform_filter1d(v, max(1, min(per_period, len(v) // 4)))


def motion_speed(ctx: Context) -> np.ndarray:
    """The settled speed averaged over one electrical period: the motion's speed, not the estimator's ripple (a
    short window's speed carries the fine-phase error's change at the electrical rate, which a steady motion
    would pass off as a speed that changes)."""
    return _period_mean(settled_speed(ctx), ctx)


def reference_motion(meas: Measurement, ctx: Context) -> np.ndarray | None:
    """The reference's speed (rev/s) averaged over one electrical period: the motion as the reference saw it. The
    encoder's own speed also carries its angle error's changes, which on an encoder of few lines vary over the
    revolution even at a steady motion (a speed that seems to change, and a speed effect that seems present)."""
    if meas is None or meas.ref_deg is None or len(meas.ref_deg) < 3:
        return None
    rev = np.unwrap(np.deg2rad(meas.ref_deg)) / (2 * np.pi)
    t = sample_times(len(rev), meas.t_s)
    dt = np.gradient(t)
    return _period_mean(np.gradient(rev) / np.where(dt > 0, dt, 1.0), ctx)
