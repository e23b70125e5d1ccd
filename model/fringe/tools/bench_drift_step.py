"""The drift tracker's loop gain inside the core, measured on the bit-exact model
(``python -m fringe.tools.bench_drift_step [factors|startup|tracking|dither|all]``).

Inside the core the phase is computed from the same normalised codes the observer checks, so an error
of the normaliser moves the phase too and the observer sees only its part across the Lissajous figure
(the radial part, after the quadrature correction makes the figure a circle). ``factors`` measures what
the observer sees of an injected offset / gain error (mean e / offset, SEA / (eps sum a^2)) against
the analysis in docs/drift.md; ``startup`` measures the start-up from reset and the
steady error, the step as specified now ("after") against the step before the loop-gain calibration
("before": the offset shift one larger, KG without the 4/3), on the stream of
tests/test_fixed_drift.py::test_startup_is_shorter_than_before and on a randomised population
(fixed seeds), in one run.

The stand-in for the core's phase is the exact one of a calibrated core: the normalised codes minus W0,
through the inverse of the ellipse (the quadrature correction), atan2, quantised to FINE_W bits.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from ..fixed.drift import (
    DriftParams,
    drift_run,
    kg_for,
    largest_kg_shift,
    make_fwd_table,
    pack_words,
)
from ..fixed.drift_normaliser import normalise
from ..fixed.drift_observer import observe


class OldStep(DriftParams):
    """The step before the calibration: the offset shift one larger (half the step)."""

    def off_shift(self, g: int) -> int:
        return super().off_shift(g) + 1


def old_kg(kg: int) -> int:
    """KG without the 4/3 (kg_for's value before: round(x), now round(4/3 x))."""
    return int(round(kg * 3 / 4))


@dataclasses.dataclass
class Figure:
    """An encoder's ideal Lissajous figure W0 + M (sin, cos) (ADC codes), the calibrated waveform."""

    w0: tuple[float, float]
    m: np.ndarray            # 2 x 2: rows sin, cos; columns the sin / cos of the true phase

    @classmethod
    def make(cls, amp: float, w0=(30.0, -20.0), ratio: float = 1.0, skew: float = 0.0) -> Figure:
        """amp on the sine, amp * ratio on the cosine, which leads by 90 degrees + skew (radians)."""
        return cls(w0, np.array([[amp, 0.0], [ratio * amp * np.sin(skew), ratio * amp * np.cos(skew)]]))

    def ideal(self, theta):
        u = np.stack([np.sin(theta), np.cos(theta)])
        v = self.m @ u
        return self.w0[0] + v[0], self.w0[1] + v[1]

    def tables(self, p: DriftParams):
        fs = make_fwd_table(lambda ph: self.ideal(2 * np.pi * ph)[0], p)
        fc = make_fwd_table(lambda ph: self.ideal(2 * np.pi * ph)[1], p)
        vals = (fs[0], fc[0])
        return vals, np.stack([pack_words(v, p) for v in vals]), (fs[1], fc[1])

    def phase_of(self, p: DriftParams, w0q):
        """The calibrated core's phase: (y - W0) through M^-1, atan2, u(FINE_W)."""
        inv = np.linalg.inv(self.m)
        tf = 2.0 ** p.table_frac
        ws, wc = w0q[0] / tf, w0q[1] / tf

        def phase_of(ys, yc):
            d = np.stack([np.asarray(ys, float) - ws, np.asarray(yc, float) - wc])
            u = inv @ d
            x = np.mod(np.arctan2(u[0], u[1]) / (2 * np.pi), 1.0)
            return np.floor(x * 2.0 ** p.fine_w).astype(np.int64) & ((1 << p.fine_w) - 1)

        return phase_of


# ---------------------------------------------------------------------------- what the observer sees

P_F = DriftParams(adc_w=14, fine_w=16, block_log2=8, mu_log2=3, ofs_frac=4, ginv_w=18, fwd_w=8, table_w=18,
                  table_frac=2, kg_w=18, kg_shift=38)


def observed(fig: Figure, theta, off=(0.0, 0.0), gain=(1.0, 1.0), noise: float = 0.0, seed: int = 1,
             p: DriftParams = P_F):
    """(mean e_k in codes per code of offset, SEA_k / (eps sum a_k^2)) matrices over the samples theta:
    columns the injected error on the sine / cosine channel (one at a time), from the bit-exact normaliser
    (reset state) and observer. off in codes, gain the relative error eps per channel."""
    vals, tables, w0 = fig.tables(p)
    phase_of = fig.phase_of(p, w0)
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    rng = np.random.default_rng(seed)
    ideal = fig.ideal(theta)
    nz = [rng.normal(0, noise, theta.size) if noise else 0.0 for _ in range(2)]
    tf = 2.0 ** p.table_frac
    state = (0, 0, p.unity, p.unity)

    def run(o, g):
        raw = [np.clip(np.round(o[k] + g[k] * ideal[k] + nz[k]), lo, hi).astype(np.int64) for k in (0, 1)]
        ys, yc, _ = normalise(raw[0], raw[1], state, p)
        es, ec, as_, ac = observe(phase_of(ys, yc), ys, yc, np.zeros(theta.size, dtype=np.int64),
                                  tables[None], np.array([w0]), p)
        return (es, ec), (as_, ac)

    (b_s, b_c), (a_s, a_c) = run((0.0, 0.0), (1.0, 1.0))     # the baseline (quantisation, noise)
    a = (a_s, a_c)
    off_m = np.zeros((2, 2))
    gain_m = np.zeros((2, 2))
    for j in (0, 1):
        if off[j]:
            o = [0.0, 0.0]
            o[j] = off[j]
            (es, ec), _ = run(o, (1.0, 1.0))
            off_m[:, j] = [(es - b_s).mean() / tf / off[j], (ec - b_c).mean() / tf / off[j]]
        if gain[j] != 1.0:
            g = [1.0, 1.0]
            g[j] = gain[j]
            # the gain of W0 + a: its W0 part is an offset (eps W0); a has zero mean
            (es, ec), (as2, ac2) = run((0.0, 0.0), g)
            eps = gain[j] - 1
            gain_m[:, j] = [((es - b_s) * a[0]).sum() / (eps * (a[0].astype(float) ** 2).sum()),
                            ((ec - b_c) * a[1]).sum() / (eps * (a[1].astype(float) ** 2).sum())]
    return off_m, gain_m


def arc_eigs(periods: float) -> tuple[float, float]:
    """Analysis: eigenvalues of the mean radial projection over a uniform sweep of ``periods`` periods,
    1/2 -+ |sin(2 pi L)| / (4 pi L)."""
    d = abs(np.sin(2 * np.pi * periods)) / (4 * np.pi * periods)
    return 0.5 - d, 0.5 + d


def factors() -> None:
    amp = 0.3 * 2 ** 13
    n = 1 << 16
    uniform = 2 * np.pi * (np.arange(n) * 0.0137 + 0.21)              # ~900 periods, uniform
    cases = [("circle", Figure.make(amp)), ("ellipse 0.8, 12 deg skew", Figure.make(amp, ratio=0.8, skew=0.21)),
             ("ellipse 1.3, -25 deg skew", Figure.make(amp, w0=(-300.0, 150.0), ratio=1.3, skew=-0.44))]
    print("Full uniform sweep (65536 samples, ~900 periods), offsets 40 / -30 codes, gains 1.03 / 0.97:")
    print("  analysis: offset matrix 1/2 I; gain matrix [[3/4, 1/4], [1/4, 3/4]] (any ellipse; the common-mode")
    print("  gain eigenvalue 1, the differential 1/2)")
    for name, fig in cases:
        for noise in (0.0, 2.0):
            om, gm = observed(fig, uniform, off=(40.0, -30.0), gain=(1.03, 0.97), noise=noise)
            print(f"  {name:28s} noise {noise:.0f}: offset [[{om[0, 0]:.3f}, {om[0, 1]:+.3f}], [{om[1, 0]:+.3f}, "
                  f"{om[1, 1]:.3f}]]  gain [[{gm[0, 0]:.3f}, {gm[0, 1]:.3f}], [{gm[1, 0]:.3f}, {gm[1, 1]:.3f}]]")
    print("Offset factor of one window (W = 256 samples) that sweeps L periods uniformly (circle, offset on"
          " the sine; eigenvalues of the measured 2x2 matrix vs analysis 1/2 -+ |sin 2 pi L| / (4 pi L)):")
    fig = cases[0][1]
    for L in (1.0, 1.125, 1.25, 1.5, 2.25, 4.0):
        th = 2 * np.pi * (np.arange(256) * L / 256 + 0.1)
        om, _ = observed(fig, th, off=(40.0, 40.0))
        ev = np.sort(np.linalg.eigvals(om).real)
        lo, hi = arc_eigs(L)
        print(f"  L = {L:5.3f}: measured {ev[0]:.3f} / {ev[1]:.3f}, analysis {lo:.3f} / {hi:.3f}; doubled step: "
              f"loop gain up to {2 * ev[1]:.3f}")
    print("Windows that pass the sweep test (SWEEP >= one period) without a uniform sweep:")
    for name, th in (
            ("speed ramp 0 -> 2.05 periods per window", 2 * np.pi * 1.025 * (np.arange(256) / 256) ** 2),
            ("a quarter period back and forth x2", 2 * np.pi * 0.26 * np.abs(np.sin(np.pi * np.arange(256) / 128))),
            ("a tenth period back and forth x5", 2 * np.pi * (0.25 + 0.105 * np.abs(np.sin(5 * np.pi * np.arange(256)
                                                                                         / 256))))):
        sweep = np.abs(np.diff(th)).sum() / (2 * np.pi)
        om, _ = observed(fig, th, off=(40.0, 40.0))
        ev = np.sort(np.linalg.eigvals(om).real)
        print(f"  {name:36s} (sweep {sweep:.2f}): eigenvalues {ev[0]:.3f} / {ev[1]:.3f}; doubled step: loop gain "
              f"up to {2 * ev[1]:.3f}")


# ---------------------------------------------------------------------------- start-up and steady error


def settle_samples(ys, yc, ideal_s, ideal_c, floor: float, win: int = 32) -> int:
    """Samples until the RMS error of the normalised codes (windows of ``win``) stays below 3 floors
    (tests/test_fixed_drift.py::_settle_samples)."""
    err = (np.asarray(ys, float) - ideal_s) ** 2 + (np.asarray(yc, float) - ideal_c) ** 2
    m = err.size // win * win
    rms = np.sqrt(err[:m].reshape(-1, win).mean(axis=1) / 2)
    bad = np.flatnonzero(rms > 3 * floor)
    return 0 if bad.size == 0 else int(bad[-1] + 1) * win


def startup_case(p: DriftParams, fig: Figure, theta, off, gain, noise: float, seed: int, *, old: bool):
    """(samples to stay within 3x the floor, steady RMS error / floor over the second half) of one stream."""
    n = theta.size
    rng = np.random.default_rng(seed)
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    ideal = fig.ideal(theta)
    raw = [np.clip(np.round(off[k] + gain[k] * ideal[k] + rng.normal(0, noise, n)), lo, hi).astype(np.int64)
           for k in (0, 1)]
    floor = np.sqrt(sum((((raw[k] - off[k]) / gain[k] - ideal[k]) ** 2).mean() for k in (0, 1)) / 2)
    vals, tables, w0 = fig.tables(p)
    q = largest_kg_shift(p, vals)
    kg = [kg_for(v, q) for v in vals]
    if old:
        q = OldStep(**dataclasses.asdict(q))
        kg = [old_kg(k) for k in kg]
    r = drift_run(raw[0], raw[1], fig.phase_of(q, w0), q, tables, w0, kg)
    tail = np.sqrt((((r.y_sin - ideal[0]) ** 2 + (r.y_cos - ideal[1]) ** 2)[n // 2:]).mean() / 2)
    return settle_samples(r.y_sin, r.y_cos, ideal[0], ideal[1], floor), tail / floor


P_S = DriftParams(adc_w=14, fine_w=16, block_log2=5, mu_log2=2, ofs_frac=4, ginv_w=18, fwd_w=6, table_w=18,
                  table_frac=2, kg_w=18, kg_shift=34, hold=1)


def test_stream(n: int = 12_000):
    """The stream of test_startup_is_shorter_than_before (seed 11 / noise seed 12, speed 0.05)."""
    rng = np.random.default_rng(11)
    t = np.arange(n)
    theta = 2 * np.pi * (t * 0.05 + 0.3 * np.sin(t * 1e-4) + rng.uniform())
    return theta


def draw(seed: int, n: int):
    """A random encoder: offsets up to 500 codes, gains 0.8..1.25, an ellipse (ratio 0.7..1.4, skew up to
    20 degrees), noise 0.5..8 codes, a speed of 1.1..4 periods per 32 samples (B = 32) with a slow
    variation. Returns (fig, theta, off, gain, noise)."""
    rng = np.random.default_rng(seed)
    amp = rng.uniform(0.15, 0.35) * 2 ** 13
    fig = Figure.make(amp, w0=tuple(rng.uniform(-300, 300, 2)), ratio=float(np.exp(rng.uniform(np.log(0.7),
                      np.log(1.4)))), skew=float(np.radians(rng.uniform(-20, 20))))
    speed = rng.uniform(1.1, 4.0) / 32
    t = np.arange(n)
    theta = 2 * np.pi * (t * speed * (1 + 0.1 * np.sin(t * 2e-3 + rng.uniform(0, 6))) + rng.uniform())
    off = tuple(rng.uniform(-500, 500, 2))
    gain = tuple(np.exp(rng.uniform(np.log(0.8), np.log(1.25), 2)))
    noise = float(np.exp(rng.uniform(np.log(0.5), np.log(8.0))))
    return fig, theta, off, gain, noise


def startup(population: int = 30, n: int = 12_000) -> dict:
    """Start-up and steady error, before and after, on the test's stream and on the population; printed, and
    returned for ``make bench`` (section drift_startup)."""
    amp = 0.3 * 2 ** 13
    fig = Figure.make(amp)
    th = test_stream(n)
    out = {"test_stream": {}, "population": {"encoders": population, "seeds": [5000, 5000 + population - 1],
                                             "block": 32, "mu_log2": 2, "fwd_w": 8}}
    print("Start-up (samples to stay within 3x the floor) and steady error (second half, RMS / floor):")
    print("  the test's stream (offsets 200 / -150, gains 1.1 / 0.92, noise 2 codes, circle), HOLD = 1, B = 32:")
    for mu in (0, 1, 2, 3):
        p = dataclasses.replace(P_S, mu_log2=mu)
        res = {old: startup_case(p, fig, th, (200.0, -150.0), (1.1, 0.92), 2.0, 12, old=old) for old in (True, False)}
        out["test_stream"][f"mu_log2_{mu}"] = {
            name: {"startup_samples": int(res[old][0]), "steady_over_floor": round(float(res[old][1]), 3)}
            for name, old in (("before", True), ("after", False))}
        print(f"    MU_LOG2 = {mu}: before {res[True][0]:5d} samples, steady {res[True][1]:.3f}; "
              f"after {res[False][0]:5d} samples, steady {res[False][1]:.3f}")
    # the population's tables with 2^8 bins (the core's default): the 64-bin tables' interpolation error
    # (up to ~2 codes) would set the floor of the quietest encoders
    pp = dataclasses.replace(P_S, fwd_w=8)
    print(f"  population of {population} random encoders (seeds 5000..{5000 + population - 1}), B = 32, MU_LOG2 = 2, "
          "FWD_W = 8:")
    rows = []
    for s in range(5000, 5000 + population):
        fig_r, th_r, off, gain, noise = draw(s, n)
        b = startup_case(pp, fig_r, th_r, off, gain, noise, s + 1, old=True)
        a = startup_case(pp, fig_r, th_r, off, gain, noise, s + 1, old=False)
        rows.append((*b, *a))
    r = np.array(rows, dtype=float)
    for name, cols in (("before", (0, 1)), ("after", (2, 3))):
        su, st = r[:, cols[0]], r[:, cols[1]]
        out["population"][name] = {
            "startup_samples": {"median": float(np.median(su)), "p90": float(np.percentile(su, 90)),
                                "max": float(su.max())},
            "steady_over_floor": {"median": round(float(np.median(st)), 3),
                                  "p90": round(float(np.percentile(st, 90)), 3), "max": round(float(st.max()), 3)}}
        print(f"    {name:6s}: start-up median {np.median(su):.0f}, p90 {np.percentile(su, 90):.0f}, max {su.max():.0f}"
              f" samples; steady error median {np.median(st):.3f}, p90 {np.percentile(st, 90):.3f}, max {st.max():.3f}"
              " floors")
    shorter, equal = int((r[:, 2] < r[:, 0]).sum()), int((r[:, 2] == r[:, 0]).sum())
    out["population"].update(after_shorter=shorter, equal=equal)
    print(f"    after < before in {shorter} of {population}, equal in {equal}")
    return out


# ---------------------------------------------------------------------------- tracking a drift


P_T = DriftParams(adc_w=14, fine_w=16, block_log2=8, mu_log2=3, ofs_frac=4, ginv_w=18, fwd_w=6, table_w=18,
                  table_frac=2, kg_w=18, kg_shift=38)


def drifting(p: DriftParams, n: int, seed: int):
    """tests/test_fixed_drift.py's Encoder (drift 1): offsets 200 + 100 t/n and -150 + 80 sin(3 t/n) codes,
    gains 1.1 - 0.05 t/n and 0.92 + 0.04 t/n, W0 (30, -20), amplitude 0.3 of full scale, noise-free.
    Returns (raw_sin, raw_cos, fig, theta, truth (os, oc, gs, gc))."""
    rng = np.random.default_rng(seed)
    fig = Figure.make(0.3 * 2 ** (p.adc_w - 1))
    t = np.arange(n)
    theta = 2 * np.pi * (t * 0.013 + 0.3 * np.sin(t * 1e-4) + rng.uniform())
    os_, oc = 200 + 100 * t / n, -150 + 80 * np.sin(t / n * 3)
    gs, gc = 1.1 - 0.05 * t / n, 0.92 + 0.04 * t / n
    ideal = fig.ideal(theta)
    lo, hi = -(1 << (p.adc_w - 1)), (1 << (p.adc_w - 1)) - 1
    rs = np.clip(np.round(os_ + gs * ideal[0]), lo, hi).astype(np.int64)
    rc = np.clip(np.round(oc + gc * ideal[1]), lo, hi).astype(np.int64)
    return rs, rc, fig, (os_, oc, gs, gc)


def tracking() -> None:
    """test_tracker_converges_on_drifting_signal's figures (seed 7, 400 k samples, the last 3/4 of the
    updates), before and after, HOLD = 1 and 0."""
    n = 400_000
    print("Tracking a drift (test_tracker_converges_on_drifting_signal: B = 256, MU_LOG2 = 3, 400 k samples):")
    for hold in (1, 0):
        p = dataclasses.replace(P_T, hold=hold, kg_shift=P_T.kg_shift - 1 + hold)
        rs, rc, fig, (os_, oc, gs, gc) = drifting(p, n, 7)
        vals, tables, w0 = fig.tables(p)
        for old in (True, False):
            q, kg = p, [kg_for(v, p) for v in vals]
            if old:
                q, kg = OldStep(**dataclasses.asdict(p)), [old_kg(k) for k in kg]
            r = drift_run(rs, rc, fig.phase_of(q, w0), q, tables, w0, kg)
            at = np.minimum(r.apply_at, n - 1)
            late = np.arange(len(at)) >= len(at) // 4
            oe = np.abs(r.states[1:, :2] / 2.0 ** p.ofs_frac - np.stack([os_[at], oc[at]], 1))[late]
            ge = np.abs(r.states[1:, 2:] / p.unity * np.stack([gs[at], gc[at]], 1) - 1)[late]
            print(f"  HOLD = {hold} {'before' if old else 'after ':6s}: offset error max {oe.max():.2f} codes (RMS "
                  f"{np.sqrt((oe ** 2).mean()):.2f}), gain error max {100 * ge.max():.3f} % (RMS "
                  f"{100 * np.sqrt((ge ** 2).mean()):.3f} %)")


def dither() -> None:
    """Windows that pass the sweep test on a short arc swept back and forth (B = 256, offsets 200 / -150,
    noise 2 codes, 64 blocks): RMS offset / gain error over the second half, before and after. No step
    identifies offset and gain there (README: a partial arc biases the offsets); the point is MU_LOG2 = 0."""
    fig = Figure.make(0.3 * 2 ** 13)
    n = 64 * 256
    t = np.arange(n)
    off = (200.0, -150.0)
    print("Dithering motion (B = 256, offsets 200 / -150 codes, noise 2 codes; RMS over the second half):")
    for name, th in (("0.13 period back and forth x5 per block", 2 * np.pi * (0.25 + 0.13 * np.abs(np.sin(5 * np.pi * t
                                                                                                          / 256)))),
                     ("0.3 period back and forth x2 per block", 2 * np.pi * (0.25 + 0.3 * np.abs(np.sin(2 * np.pi * t
                                                                                                        / 256)))),
                     ("uniform, 1.25 periods per block", 2 * np.pi * 1.25 * t / 256)):
        for mu in (0, 1, 3):
            p = dataclasses.replace(P_F, mu_log2=mu)
            res = []
            for old in (True, False):
                rng = np.random.default_rng(3)
                ideal = fig.ideal(th)
                raw = [np.round(off[k] + ideal[k] + rng.normal(0, 2.0, n)).astype(np.int64) for k in (0, 1)]
                vals, tables, w0 = fig.tables(p)
                q = largest_kg_shift(p, vals)
                kg = [kg_for(v, q) for v in vals]
                if old:
                    q, kg = OldStep(**dataclasses.asdict(q)), [old_kg(k) for k in kg]
                r = drift_run(raw[0], raw[1], fig.phase_of(q, w0), q, tables, w0, kg)
                h = slice(r.states.shape[0] // 2, None)
                oe = r.states[h, :2] / 2.0 ** q.ofs_frac - np.array(off)
                ge = r.states[h, 2:] / q.unity - 1
                o_rms, g_rms = np.sqrt((oe ** 2).mean()), 100 * np.sqrt((ge ** 2).mean())
                res.append(f"offset {o_rms:7.2f} codes, gain {g_rms:6.3f} % ({r.updated.mean():.0%} updated)")
            print(f"  {name}, MU_LOG2 = {mu}: before {res[0]}; after {res[1]}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="fringe.tools.bench_drift_step", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", nargs="?", default="all", choices=("factors", "startup", "tracking", "dither", "all"))
    ap.add_argument("--population", type=int, default=30)
    a = ap.parse_args(argv)
    if a.what in ("factors", "all"):
        factors()
    if a.what in ("startup", "all"):
        startup(a.population)
    if a.what in ("tracking", "all"):
        tracking()
    if a.what in ("dither", "all"):
        dither()


if __name__ == "__main__":
    main()
