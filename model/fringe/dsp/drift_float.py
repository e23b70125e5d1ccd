"""The drift tracker's float twin: ``fixed/drift.py`` (``drift_run``, the bit-exact model of ``fringe_core``'s
drift normaliser and observer) without rounding, for the float engine.

The same equations, window, gear shift, sweep test and application points on the same table words; its states come
back in OFF and GINV LSBs, so that a test holds them against ``drift_run``'s within ``fixed.drift.error_bound``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..fixed.drift import NAME, DriftParams, unpack_words
from ..fixed.drift_observer import per_bank

__all__ = ["drift_float"]


def drift_float(raw_sin, raw_cos, phase_of: Callable[[np.ndarray, np.ndarray], np.ndarray], params: DriftParams,
                tables, w0, kg, *, bank=None) -> dict[str, np.ndarray]:
    """The same tracker in float without rounding (the float engine's tracker, `engine.pipeline.tracked_phase`).

    Units: codes. ``off`` in ADC codes (OFF / 2^OFS_FRAC), ``ginv`` the gain ratio (GINV / 2^(GINV_W-2)),
    ``y = (raw - off) * ginv`` clipped to the s(ADC_W) range, ``a = (value + slope * frac / 2^FB) /
    2^TABLE_FRAC`` (exact interpolation of the same table words), ``e = y - w0 - a`` (w0 = W0 /
    2^TABLE_FRAC), per update (the block's last W samples, gear G_u) ``off += 2 mean(e) 2^-G_u`` and ``ginv -=
    sum(e a) KG 2^(2 TABLE_FRAC - KG_SHIFT - GINV_W + 2 + MU_LOG2 - G_u)``, same sweep test (the phases from
    ``phase_of`` may be floats in fine counts), same application points. Returns y_sin, y_cos, phase (per
    sample) and states (blocks + 1, 4) in the fixed-point LSB units of OFF and GINV (floats) for a direct
    comparison, and updated."""
    p = params
    rs = np.asarray(raw_sin, dtype=np.float64)
    rc = np.asarray(raw_cos, dtype=np.float64)
    n = rs.size
    t = np.asarray(tables).astype(np.int64)
    if t.ndim == 2:
        t = t[None]
    nb = t.shape[0]
    w0a = per_bank(w0, nb, "w0", NAME).astype(np.float64) / 2.0 ** p.table_frac
    kga = per_bank(kg, nb, "kg", NAME).astype(np.float64)
    bk = np.zeros(n, dtype=np.int64) if bank is None else np.broadcast_to(np.asarray(bank, dtype=np.int64), (n,))
    B, D = p.b, p.d
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1     # y's s(ADC_W) range, as the normaliser's
    per = float(1 << p.fine_w)
    tf = 2.0 ** p.table_frac
    gk = 2.0 ** (2 * p.table_frac - p.kg_shift - p.ginv_w + 2)
    off = np.zeros(2)
    ginv = np.ones(2)
    ys = np.empty(n)
    yc = np.empty(n)
    phase = np.empty(n)
    e = np.empty((2, n))
    a = np.empty((2, n))
    states = [(0.0, 0.0, float(p.unity), float(p.unity))]
    updated = []
    applied = 0                 # updates applied since reset: the gear's count
    start, j = 0, 0
    while start < n:
        end = min(n, (j + 1) * B + D)
        y0 = np.clip((rs[start:end] - off[0]) * ginv[0], lo, hi)
        y1 = np.clip((rc[start:end] - off[1]) * ginv[1], lo, hi)
        ys[start:end], yc[start:end] = y0, y1
        ph = np.asarray(phase_of(y0, y1), dtype=np.float64)
        phase[start:end] = ph
        u = np.mod(ph, per) / 2.0 ** p.fb
        b = np.floor(u).astype(np.int64) % p.bins
        fr = u - np.floor(u)
        for k, y in ((0, y0), (1, y1)):
            slope, value = unpack_words(t[bk[start:end], k, b], p)
            a[k, start:end] = (value + slope * fr) / tf
            e[k, start:end] = y - w0a[bk[start:end], k] - a[k, start:end]
        start = end
        if j < n // B:
            sl = slice((j + 1) * B - p.w, (j + 1) * B)
            ph_b = phase[max((j + 1) * B - p.w - 1, 0):(j + 1) * B]
            d = np.mod(np.diff(ph_b) + per / 2, per) - per / 2
            sw = float(np.abs(d).sum())
            g = p.block_gear(sw, applied)
            ok = g is not None
            if ok:
                kgb = kga[bk[(j + 1) * B - 1]]
                applied += p.whole_period(sw)
                off = off + e[:, sl].mean(axis=1) * 2.0 ** (1 - g)
                ginv = ginv - (e[:, sl] * a[:, sl]).sum(axis=1) * kgb * gk * 2.0 ** (p.mu_log2 - g)
            states.append((off[0] * 2.0 ** p.ofs_frac, off[1] * 2.0 ** p.ofs_frac,
                           ginv[0] * p.unity, ginv[1] * p.unity))
            updated.append(ok)
            j += 1
    return {"y_sin": ys, "y_cos": yc, "phase": phase, "states": np.array(states).reshape(-1, 4),
            "updated": np.array(updated, dtype=bool)}
