"""Bit-exact CORDIC model (fringe.fixed.cordic) against float arithmetic and its error budget."""

from __future__ import annotations

import math
import re
from decimal import ROUND_HALF_UP, Decimal, getcontext
from pathlib import Path

import numpy as np
import pytest
from hdl_text import REPO, missing_checks

from fringe.fixed.cordic import (
    ATAN62,
    CordicParams,
    atan_table,
    cordic,
    cordic_gain,
    error_budget,
    mag_error_bound,
    phase_error_bound,
)

PARAMS = [
    CordicParams(18, 16, 18, 3),
    CordicParams(12, 12, 13, 2),
    CordicParams(10, 9, 8, 0),
    CordicParams(8, 8, 4, 0),
    CordicParams(16, 20, 21, 4),
    CordicParams(30, 30, 32, 8),
    CordicParams(24, 12, 32, 8),
]


def _pid(p: CordicParams) -> str:
    return f"IN{p.in_w}-F{p.fine_w}-S{p.stages}-G{p.guard}"


# ---------------------------------------------------------------------------- helpers


def _atan_decimal(i: int) -> Decimal:
    """atan(2^-i) / (2 pi) with 100+ significant digits (Machin's pi, Taylor series)."""
    getcontext().prec = 120

    def atan_small(x: Decimal) -> Decimal:
        s, t, k, x2 = Decimal(0), x, 0, x * x
        while True:
            term = t / (2 * k + 1)
            if abs(term) < Decimal(10) ** -110:
                return s
            s += -term if k % 2 else term
            t *= x2
            k += 1

    pi = 4 * (4 * atan_small(Decimal(1) / 5) - atan_small(Decimal(1) / 239))
    a = pi / 4 if i == 0 else atan_small(Decimal(1) / (Decimal(2) ** i))
    return a / (2 * pi)


def reference_cordic(x: int, y: int, p: CordicParams) -> tuple[int, int]:
    """The contract of docs/architecture.md, literally, on Python integers (one sample)."""
    g, n = p.guard, p.acc_w
    if x < 0:
        x, y, z = -x, -y, 1 << (n - 1)
    else:
        z = 0
    x, y = x << g, y << g
    for i, a in enumerate(atan_table(p)):
        if y >= 0:
            x, y, z = x + (y >> i), y - (x >> i), z + a
        else:
            x, y, z = x - (y >> i), y + (x >> i), z - a
    rnd = (1 << (g - 1)) if g else 0
    return ((z + rnd) >> g) % (1 << p.fine_w), (x + rnd) >> g


def wrapped_phase_error(phase, x, y, fine_w: int) -> np.ndarray:
    ref = np.arctan2(np.asarray(y, float), np.asarray(x, float)) / (2 * np.pi) * 2.0 ** fine_w
    period = 2.0 ** fine_w
    return (np.asarray(phase, float) - ref + period / 2) % period - period / 2


def random_inputs(rng: np.random.Generator, in_w: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Uniform codes, and log-uniform magnitudes from 1 LSB to full scale at uniform angles."""
    lo, hi = -(1 << (in_w - 1)), (1 << (in_w - 1)) - 1
    x1 = rng.integers(lo, hi + 1, n // 2)
    y1 = rng.integers(lo, hi + 1, n // 2)
    r = 2.0 ** rng.uniform(0, in_w - 1, n - n // 2)
    a = rng.uniform(-np.pi, np.pi, n - n // 2)
    x2 = np.clip(np.round(r * np.cos(a)), lo, hi).astype(np.int64)
    y2 = np.clip(np.round(r * np.sin(a)), lo, hi).astype(np.int64)
    return np.concatenate([x1, x2]), np.concatenate([y1, y2])


# ---------------------------------------------------------------------------- the angle table


def test_atan62_table_is_atan_over_two_pi():
    """The shared 62-bit constants are round(atan(2^-i) / (2 pi) * 2^62), i = 0..31."""
    assert len(ATAN62) == 32
    for i, v in enumerate(ATAN62):
        exact = int((_atan_decimal(i) * Decimal(2) ** 62).to_integral_value(rounding=ROUND_HALF_UP))
        assert v == exact, f"ATAN62[{i}]"


def test_atan_table_rounding_is_not_double_rounding():
    """Rounding the 62-bit table to N bits equals rounding the exact value, for every N used."""
    exact = [_atan_decimal(i) for i in range(32)]
    for fine_w in range(8, 31):
        for guard in (0, 8) if fine_w < 30 else range(0, 9):
            p = CordicParams(12, fine_w, 32, guard)
            want = [int((e * Decimal(2) ** p.acc_w).to_integral_value(rounding=ROUND_HALF_UP))
                    for e in exact]
            assert atan_table(p) == want, _pid(p)


def _hdl_table(path: Path, pattern: str) -> list[int]:
    return [int(h, 16) for h in re.findall(pattern, path.read_text())]


def test_hdl_tables_match_model():
    """One table in three places: the Verilog function, the VHDL constant, the model."""
    v = _hdl_table(REPO / "rtl/verilog/fringe_cordic.v", r"\d+: atan62 = 64'h([0-9A-Fa-f]{16});")
    h = _hdl_table(REPO / "rtl/vhdl/fringe_cordic.vhd", r'x"([0-9A-Fa-f]{16})"')
    assert v == list(ATAN62)
    assert h == list(ATAN62)


# ---------------------------------------------------------------------------- model vs contract


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_vectorised_model_matches_scalar_contract(p):
    rng = np.random.default_rng(7)
    x, y = random_inputs(rng, p.in_w, 600)
    lo, hi = -(1 << (p.in_w - 1)), (1 << (p.in_w - 1)) - 1
    extremes = [lo, lo + 1, -1, 0, 1, hi]
    ex = np.array([a for a in extremes for _ in extremes], dtype=np.int64)
    ey = np.array([b for _ in extremes for b in extremes], dtype=np.int64)
    x, y = np.concatenate([x, ex]), np.concatenate([y, ey])
    phase, mag = cordic(x, y, p)
    for i in range(x.size):
        assert (phase[i], mag[i]) == reference_cordic(int(x[i]), int(y[i]), p), (x[i], y[i])
    assert phase.min() >= 0 and phase.max() < (1 << p.fine_w)
    assert mag.min() >= 0 and mag.max() < (1 << (p.in_w + 1))


# ---------------------------------------------------------------------------- model vs float


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_model_within_error_budget(p):
    rng = np.random.default_rng(2024)
    x, y = random_inputs(rng, p.in_w, 200_000)
    phase, mag = cordic(x, y, p)
    r = np.hypot(x.astype(float), y.astype(float))
    err = np.abs(wrapped_phase_error(phase, x, y, p.fine_w))
    bound = phase_error_bound(p, r)
    bounded = np.isfinite(bound)
    assert np.all(bounded[r >= 2.0 ** (p.in_w // 2)])  # unbounded only for tiny vectors
    worst = np.argmax(err[bounded] / bound[bounded])
    assert np.all(err[bounded] <= bound[bounded]), (
        f"phase error {err[bounded][worst]:.3f} LSB > bound {bound[bounded][worst]:.3f} at "
        f"x={x[bounded][worst]}, y={y[bounded][worst]}")
    # Large vectors (above a quarter of full scale): the fixed part of the budget dominates.
    big = r >= 2.0 ** (p.in_w - 3)
    assert err[big].max() <= phase_error_bound(p, 2.0 ** (p.in_w - 3))
    b = error_budget(p)
    merr = np.abs(mag - b["gain"] * r)
    assert np.all(merr <= mag_error_bound(p, r))


def test_error_budget_terms():
    p = CordicParams(18, 16, 18, 3)
    b = error_budget(p)
    assert b["residual"] == pytest.approx(math.atan(2.0 ** -17) / (2 * math.pi) * 2 ** 16)
    assert b["rounding"] == 0.5
    assert 0 < b["table"] <= 18 * 0.5 / 8
    assert b["fixed"] == pytest.approx(b["table"] + b["residual"] + b["rounding"])
    assert b["gain"] == pytest.approx(cordic_gain(18)) and 1.6467 < b["gain"] < 1.6468
    # More stages or guard bits never loosen the large-signal bound.
    def bound(*args: int) -> float:
        return float(phase_error_bound(CordicParams(*args), 2.0 ** 16))

    assert bound(18, 16, 18, 3) < bound(18, 16, 12, 3)
    assert bound(18, 16, 18, 4) < bound(18, 16, 18, 0)
    assert error_budget(CordicParams(18, 16, 18, 0))["rounding"] == 0.0


def test_full_precision_config_is_within_two_lsb_at_full_scale():
    """The main configuration resolves its 16 phase bits to about one LSB near full scale."""
    p = CordicParams(18, 16, 18, 3)
    a = np.linspace(-np.pi, np.pi, 100_001)
    r = 0.9 * 2 ** 17
    x = np.round(r * np.cos(a)).astype(np.int64)
    y = np.round(r * np.sin(a)).astype(np.int64)
    phase, _ = cordic(x, y, p)
    err = np.abs(wrapped_phase_error(phase, x, y, p.fine_w))
    assert err.max() < 2.0
    assert err.max() <= phase_error_bound(p, r * 0.99)


# ---------------------------------------------------------------------------- edge cases


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_axes_and_quadrant_boundaries(p):
    hi = (1 << (p.in_w - 1)) - 1
    q = 1 << (p.fine_w - 2)  # a quarter turn
    vs = [hi, hi // 3, 1 << (p.in_w - 3)]
    cases = []
    for v in vs:
        cases += [((v, 0), 0), ((0, v), q), ((-v, 0), 2 * q), ((0, -v), 3 * q),
                  ((v, v), q // 2), ((-v, v), 3 * q // 2), ((-v, -v), 5 * q // 2), ((v, -v), 7 * q // 2)]
    x = np.array([c[0][0] for c in cases])
    y = np.array([c[0][1] for c in cases])
    want = np.array([c[1] for c in cases])
    phase, mag = cordic(x, y, p)
    err = (phase - want + (1 << (p.fine_w - 1))) % (1 << p.fine_w) - (1 << (p.fine_w - 1))
    bound = phase_error_bound(p, np.hypot(x, y))
    assert np.all(np.abs(err) <= bound)
    # x < 0 with y = 0 is half a turn (the pre-rotation), not a wrap to 0
    assert np.all(np.abs(err[2::8]) <= bound[2::8])


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_most_negative_codes(p):
    lo, hi = -(1 << (p.in_w - 1)), (1 << (p.in_w - 1)) - 1
    x = np.array([lo, lo, 0, lo, hi, lo])
    y = np.array([0, lo, lo, hi, lo, -1])
    phase, mag = cordic(x, y, p)
    err = np.abs(wrapped_phase_error(phase, x, y, p.fine_w))
    r = np.hypot(x.astype(float), y.astype(float))
    assert np.all(err <= phase_error_bound(p, r))
    assert np.all(np.abs(mag - cordic_gain(p.stages) * r) <= mag_error_bound(p, r))
    assert mag.max() < 1 << (p.in_w + 1)
    assert phase[0] == 1 << (p.fine_w - 1) or abs(int(phase[0]) - (1 << (p.fine_w - 1))) <= 2


@pytest.mark.parametrize("p", PARAMS, ids=_pid)
def test_zero_vector_documented_output(p):
    """x = y = 0: mag 0, phase = round(sum ATAN) >>> GUARD (every stage takes y >= 0)."""
    phase, mag = cordic(np.array([0]), np.array([0]), p)
    rnd = (1 << (p.guard - 1)) if p.guard else 0
    assert mag[0] == 0
    assert phase[0] == ((sum(atan_table(p)) + rnd) >> p.guard) % (1 << p.fine_w)
    total = sum(math.atan(2.0 ** -i) for i in range(p.stages)) / (2 * math.pi)
    assert abs(phase[0] / 2 ** p.fine_w - total) <= (p.stages * 0.5 + 1) / 2 ** p.fine_w


def test_scalar_and_shape():
    p = CordicParams(12, 12, 13, 2)
    ph, mg = cordic(100, 0, p)
    assert ph.shape == () and mg.shape == ()
    x = np.arange(-6, 6).reshape(3, 4)
    ph, mg = cordic(x, x[::-1], p)
    assert ph.shape == (3, 4) and ph.dtype == np.int64 and mg.dtype == np.int64
    ph0, mg0 = cordic(np.array([], dtype=np.int64), np.array([], dtype=np.int64), p)
    assert ph0.size == 0 and mg0.size == 0


# ---------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "args, msg",
    [
        ((7, 16, 18, 3), "fringe_cordic: IN_W = 7 out of range 8..30"),
        ((31, 16, 18, 3), "fringe_cordic: IN_W = 31 out of range 8..30"),
        ((18, 7, 18, 3), "fringe_cordic: FINE_W = 7 out of range 8..30"),
        ((18, 31, 18, 3), "fringe_cordic: FINE_W = 31 out of range 8..30"),
        ((18, 16, 3, 3), "fringe_cordic: STAGES = 3 out of range 4..32"),
        ((18, 16, 33, 3), "fringe_cordic: STAGES = 33 out of range 4..32"),
        ((18, 16, 18, -1), "fringe_cordic: GUARD = -1 out of range 0..8"),
        ((18, 16, 18, 9), "fringe_cordic: GUARD = 9 out of range 0..8"),
        ((18.0, 16, 18, 3), "fringe_cordic: IN_W must be an integer"),
        ((18, 16, True, 3), "fringe_cordic: STAGES must be an integer"),
    ],
)
def test_parameter_validation(args, msg):
    with pytest.raises(ValueError, match=re.escape(msg)):
        CordicParams(*args)


def test_hdl_messages_match_model():
    """The HDL checks carry the model's messages (plus the instance path in Verilog)."""
    ranges = (("IN_W", "8..30"), ("FINE_W", "8..30"), ("STAGES", "4..32"), ("GUARD", "0..8"))
    assert not missing_checks("fringe_cordic", ranges)


def test_input_validation():
    p = CordicParams(12, 12, 13, 2)
    with pytest.raises(ValueError, match="x outside s"):
        cordic(np.array([2048]), np.array([0]), p)
    with pytest.raises(ValueError, match="y outside s"):
        cordic(np.array([0]), np.array([-2049]), p)
    with pytest.raises(ValueError, match="shapes differ"):
        cordic(np.array([0, 1]), np.array([0]), p)
    with pytest.raises(ValueError, match="must be integers"):
        cordic(np.array([0.5]), np.array([0.0]), p)


def test_latency_constant():
    assert CordicParams(18, 16, 18, 3).latency == 20
    assert CordicParams(12, 12, 13, 2).latency == 15


# ---------------------------------------------------------------------------- speed


