"""``fringe_canceller``'s float twin: ``fixed/canceller.py`` (``CancelStream``, the bit-exact model) without
rounding, for the float engine (``dsp.calibration.float_canceller``)."""

from __future__ import annotations

import numpy as np

from ..fixed.canceller import NCO_W

__all__ = ["TONE_MAX_LOG2", "CancelFloat"]

#: The largest tone the coefficients hold, 2^TONE_MAX_LOG2 radii: the core's CANCEL_A_W follows from it
#: (hardware.corefiles.cancel_config), and the float twin saturates there too.
TONE_MAX_LOG2 = -1
#: The core's words s(WAVE_W) on the circle of radius 2^(WAVE_W-2) span +-2 radii: the outputs and the radial
#: error saturate there (fringe_canceller), so a canceller driven unstable stays bounded, as in the core.
WORD_MAX = 2.0


class CancelFloat:
    """The float twin (the float engine's canceller, `calibration.static_phase`): the same equations on the
    unit circle without rounding, the LUT replaced by exact cos/sin of the same 32-bit NCO phase; the
    coefficients step by (2 / B) 2^-G_j times the block sums. The saturations are the core's: outputs and radial
    error at +-WORD_MAX, coefficients at +-2^TONE_MAX_LOG2 (unbounded, a step too large for the tone diverged to
    inf and NaN: population 9000, a 64-sample block with MU_LOG2 = 2). A stream in pieces gives the same values."""

    def __init__(self, freq: int, block_log2: int, mu_log2: int, gear_offset: int = 0):
        self.freq, self.b, self.mu_log2, self.gear_offset = int(freq), 1 << block_log2, mu_log2, gear_offset
        self.n = 0
        self.rows = [np.zeros(4), np.zeros(4)]
        self.sums = np.zeros(4)

    def run(self, c, s):
        """(c_out, s_out) of the next piece (unit-circle floats)."""
        c, s = np.asarray(c, float), np.asarray(s, float)
        n = len(c)
        idx = self.n + np.arange(n, dtype=np.uint64)
        theta = 2 * np.pi * ((idx * np.uint64(self.freq)) & np.uint64((1 << NCO_W) - 1)) / 2.0 ** NCO_W
        cw, sw = np.cos(theta), np.sin(theta)
        out_c, out_s = np.empty(n), np.empty(n)
        start = 0
        while start < n:
            k, pos = divmod(self.n, self.b)
            r = slice(start, min(n, start + self.b - pos))
            a_c, b_c, a_s, b_s = self.rows[k]
            yc = np.clip(c[r] - (a_c * cw[r] + b_c * sw[r]), -WORD_MAX, WORD_MAX)
            ys = np.clip(s[r] - (a_s * cw[r] + b_s * sw[r]), -WORD_MAX, WORD_MAX)
            out_c[r], out_s[r] = yc, ys
            e = np.clip(yc * yc + ys * ys - 1.0, -WORD_MAX, WORD_MAX)
            uc, us = e * yc, e * ys
            self.sums += [uc @ cw[r], uc @ sw[r], us @ cw[r], us @ sw[r]]
            taken = r.stop - r.start
            self.n += taken
            start = r.stop
            if pos + taken == self.b:
                step = 2.0 / self.b * 2.0 ** -min(self.mu_log2, self.gear_offset + (k + 1).bit_length())
                limit = 2.0 ** TONE_MAX_LOG2
                self.rows.append(np.clip(self.rows[k + 1] + step * self.sums, -limit, limit))
                self.sums = np.zeros(4)
        return out_c, out_s
