"""Bit-exact model of ``fringe_quadrature``: offsets, gains and quadrature (seed 001 eq. 21).

Mirrors ``rtl/verilog/fringe_quadrature.v`` and ``rtl/vhdl/fringe_quadrature.vhd`` (formats in
``docs/architecture.md``)::

    s = sat((k_ss*(xs-ofs_s) + k_sc*(xc-ofs_c) + 2^(COEF_FRAC-1)) >> COEF_FRAC)
    c = sat((k_cc*(xc-ofs_c) + 2^(COEF_FRAC-1)) >> COEF_FRAC)

``xs, xc, ofs_*, s, c`` are s(WAVE_W) with ``WAVE_FRAC = WAVE_W - 2`` fractional bits,
``k_*`` s(COEF_W) with ``COEF_FRAC = COEF_W - 2``; ``>>`` is the arithmetic (floor) shift,
``sat`` clamps to s(WAVE_W) and raises the flag. The seed's form is ``k_ss = 1/cos(a)``,
``k_sc = tan(a)``, ``k_cc = 1`` with zero offsets. Vectorised numpy int64 (the widest sum,
s(27) * s(33) * 2, fits in 61 bits).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .limits import check_integers, check_range

__all__ = [
    "LATENCY",
    "QuadratureCoefs",
    "QuadratureParams",
    "error_budget",
    "quadrature",
    "quantise_coefs",
]

#: Clock enables from ``in_valid`` to ``out_valid`` in the RTL (differences, products, products
#: assembled with the rounding constant (partial products of a split multiply summed), sine sum,
#: shift/saturate).
LATENCY = 5
#: SHARED_MUL = 1 (the compact core's): the three products through one multiplier at stages 2..4, so the
#: next sample may enter 4 clock enables after the last one at the earliest
SHARED_MIN_CLOCKS = 4

_COEF_NAMES = ("k_ss", "k_sc", "k_cc")
_OFS_NAMES = ("ofs_s", "ofs_c")


@dataclass(frozen=True)
class QuadratureParams:
    """Parameters of ``fringe_quadrature`` (same names and limits as the HDL)."""

    wave_w: int  # WAVE_W: data, offset and output width, 8..32
    coef_w: int  # COEF_W: gain coefficient width, 8..27

    def __post_init__(self) -> None:
        block = "fringe_quadrature"
        check_integers(block, self, ("wave_w", "coef_w"))
        check_range(block, "WAVE_W", self.wave_w, 8, 32)
        check_range(block, "COEF_W", self.coef_w, 8, 27)

    @property
    def wave_frac(self) -> int:
        """WAVE_FRAC: fractional bits of xs, xc, offsets, s and c."""
        return self.wave_w - 2

    @property
    def coef_frac(self) -> int:
        """COEF_FRAC: fractional bits of the gains."""
        return self.coef_w - 2

    def hdl_parameters(self) -> dict[str, int]:
        """The HDL parameters/generics of this configuration."""
        return {"WAVE_W": self.wave_w, "COEF_W": self.coef_w}


@dataclass(frozen=True)
class QuadratureCoefs:
    """Integer coefficient codes (scalars, or arrays broadcast against the samples)."""

    k_ss: object   # s(COEF_W), COEF_FRAC fractional bits
    k_sc: object   # s(COEF_W)
    k_cc: object   # s(COEF_W)
    ofs_s: object  # s(WAVE_W), WAVE_FRAC fractional bits
    ofs_c: object  # s(WAVE_W)

    def as_float(self, params: QuadratureParams) -> tuple[np.ndarray, ...]:
        """(k_ss, k_sc, k_cc, ofs_s, ofs_c) in real units."""
        kc = float(1 << params.coef_frac)
        wc = float(1 << params.wave_frac)
        return (np.asarray(self.k_ss) / kc, np.asarray(self.k_sc) / kc, np.asarray(self.k_cc) / kc,
                np.asarray(self.ofs_s) / wc, np.asarray(self.ofs_c) / wc)


def _signed_range(w: int) -> tuple[int, int]:
    return -(1 << (w - 1)), (1 << (w - 1)) - 1


def _check_codes(name: str, v, w: int) -> np.ndarray:
    a = np.asarray(v)
    if a.dtype.kind not in "iu":
        raise ValueError(f"{name}: integer codes expected, got dtype {a.dtype}")
    a = a.astype(np.int64, copy=False)
    lo, hi = _signed_range(w)
    if a.size and (a.min() < lo or a.max() > hi):
        bad = a[(a < lo) | (a > hi)].flat[0]
        raise ValueError(f"{name}: code {int(bad)} out of range s({w}) = {lo}..{hi}")
    return a


def quantise_coefs(k_ss, k_sc, k_cc, ofs_s, ofs_c, params: QuadratureParams) -> QuadratureCoefs:
    """Round float coefficients (real units) to codes, half up; ValueError names the bad one.

    Gains ``k_*`` become s(COEF_W) codes with COEF_FRAC fractional bits (range [-2, 2)),
    offsets s(WAVE_W) codes with WAVE_FRAC fractional bits (range [-2, 2)).
    """
    out = {}
    for name, v, w, frac in ((("k_ss", k_ss, params.coef_w, params.coef_frac)),
                             (("k_sc", k_sc, params.coef_w, params.coef_frac)),
                             (("k_cc", k_cc, params.coef_w, params.coef_frac)),
                             (("ofs_s", ofs_s, params.wave_w, params.wave_frac)),
                             (("ofs_c", ofs_c, params.wave_w, params.wave_frac))):
        f = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(f)):
            raise ValueError(f"{name} = {v!r} is not finite")
        q = np.floor(f * float(1 << frac) + 0.5)
        lo, hi = _signed_range(w)
        if np.any((q < lo) | (q > hi)):
            bad = f[(q < lo) | (q > hi)].flat[0]
            raise ValueError(f"{name} = {float(bad)!r} out of range [-2, 2) "
                             f"(s({w}) with {frac} fractional bits: "
                             f"{lo / (1 << frac):g} .. {hi / (1 << frac):.9g})")
        q = q.astype(np.int64)
        out[name] = int(q) if q.ndim == 0 else q
    return QuadratureCoefs(**out)


def quadrature(xs, xc, coefs: QuadratureCoefs, params: QuadratureParams
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bit-exact output of ``fringe_quadrature``: ``(s, c, sat)`` (int64, int64, bool)."""
    xs = _check_codes("xs", xs, params.wave_w)
    xc = _check_codes("xc", xc, params.wave_w)
    k_ss, k_sc, k_cc = (_check_codes(n, getattr(coefs, n), params.coef_w) for n in _COEF_NAMES)
    ofs_s, ofs_c = (_check_codes(n, getattr(coefs, n), params.wave_w) for n in _OFS_NAMES)
    f = params.coef_frac
    rnd = 1 << (f - 1)
    qs = xs - ofs_s
    qs *= k_ss
    dc = xc - ofs_c
    qs += k_sc * dc
    qs += rnd
    qs >>= f
    dc *= k_cc
    dc += rnd
    dc >>= f
    lo, hi = _signed_range(params.wave_w)
    s = np.clip(qs, lo, hi)
    c = np.clip(dc, lo, hi)
    sat = (s != qs) | (c != dc)
    return s, c, sat


def error_budget(params: QuadratureParams, k_ss, k_sc, k_cc, d_max: float = 4.0) -> tuple[float, float]:
    """Bound on |model - float| in output LSBs (2^-WAVE_FRAC) for s and c, away from saturation.

    The model with the quantised coefficients, against ``dsp.quadrature_float`` with the float
    coefficients (``k_*`` real; offsets real), for inputs with ``|x - ofs| <= d_max`` (real
    units; 4.0 covers every input):

    - output rounding: 1/2 LSB (the only rounding inside the block);
    - gain quantisation: 2^-(COEF_FRAC+1) per gain, times ``d_max * 2^WAVE_FRAC`` LSBs;
    - offset quantisation: 1/2 LSB per offset, times the (quantised) gain that multiplies it.

    With coefficients that are already codes (``QuadratureCoefs.as_float``) only the first
    term remains: the model is the float result rounded half up.
    """
    ek = 2.0 ** -(params.coef_frac + 1)           # gain quantisation, real units
    dq = ek * d_max * float(1 << params.wave_frac)
    bs = 0.5 + 2 * dq + 0.5 * (abs(k_ss) + abs(k_sc) + 2 * ek)
    bc = 0.5 + dq + 0.5 * (abs(k_cc) + ek)
    return float(bs), float(bc)
