"""The candidates of one iteration of the loop: the library's effects that can be tested and are not the encoder's own
noise, the lines in time, and the general dictionary's shapes chosen by cross-validation; then the names they go by
(a shape widened to, or named after, a library effect) and what each name means."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..dsp.effects import (
    GENERIC,
    GENERIC_FACTORS,
    GENERIC_PHASE_ORDERS,
    GENERIC_REV_ORDERS,
    INTERFERENCE,
    LIBRARY,
    REV_ORDERS,
    Context,
    _legendre_time,
    amplitude_phase_columns,
    factor_columns,
    generic_design,
    generic_name,
    parse_generic,
)
from .evaluation import Evaluation, _design, cross_fit
from .significance import (
    CHUNK,
    MIN_GAIN,
    P_VALUE,
    Test,
    revolution_untestable,
    test_library_effect,
    test_terms,
    testable,
)
from .tones import tone_candidates

GENERIC_ABOVE_FLOOR = 1.05
SEARCH_ROWS = 1 << 17    # the term tests run on at most this many rows (evenly strided): ample power, bounded time


def strided(ev: Evaluation) -> Evaluation:
    """Every k-th row of a long evaluation, for the term tests (the tone search keeps every sample)."""
    step = -(-len(ev.r) // SEARCH_ROWS)
    if step <= 1:
        return ev
    sl = slice(None, None, step)
    r = ev.r[sl]
    return Evaluation(r, ev.ctx.rows(sl), ev.figures, float(np.sqrt(np.mean(r * r))), None, ev.cal,
                      None if ev.ref_speed is None else ev.ref_speed[sl])


SMOOTH_BLOCKS = 64    # interleaved blocks: the magnitude's slow shape is fitted on every other one


def smooth_magnitude(ctx: Context) -> np.ndarray:
    """The magnitude's changes without its per-sample noise: its projection on fine-phase orders 0..AMPLITUDE_ORDERS
    crossed with slow functions of time and the first revolution harmonics (where a gain over the revolution, a
    drift or a skew at a changing speed moves it), fitted on every other block of samples and evaluated on the
    blocks between, so that no sample's own noise is in its value. The static shape of the radius over the fine
    phase is left out (a change of nothing: it leaves static fine-phase error)."""
    m = ctx.magnitude - ctx.magnitude.mean()
    slow = _slow_time(ctx) + (_slow_revolution(ctx) if ctx.lines > 1 else [])
    return ctx.magnitude.mean() + cross_fit(_magnitude_shapes(ctx, slow), m, SMOOTH_BLOCKS)


def _slow_time(ctx: Context) -> list[np.ndarray]:
    return list(_legendre_time(ctx, 3))


def _slow_revolution(ctx: Context, orders: int = 2) -> list[np.ndarray]:
    """Revolution harmonics 1..orders (cos, sin)."""
    return [f(k * ctx.psi) for k in range(1, orders + 1) for f in (np.cos, np.sin)]


def _magnitude_shapes(ctx: Context, slow: list[np.ndarray]) -> np.ndarray:
    """Fine-phase orders 0..AMPLITUDE_ORDERS (the amplitude term's shape) times each slow function."""
    return np.column_stack([p * q for p in amplitude_phase_columns(ctx.phi) for q in slow])


def magnitude_follows_time(ctx: Context) -> bool:
    """Whether the magnitude's changes (fine-phase orders 0..AMPLITUDE_ORDERS times slow shapes, held out on
    interleaved blocks) follow time better than the place in the revolution: what a drift tracker leaves (it
    follows the gains late) against a gain tied to the revolution (air gap, eccentricity)."""
    if ctx.lines <= 1:
        return True
    m = ctx.magnitude - ctx.magnitude.mean()

    def held_out(slow) -> float:
        return float(np.sum((m - cross_fit(_magnitude_shapes(ctx, slow), m, SMOOTH_BLOCKS)) ** 2))

    return held_out(_slow_time(ctx)) < held_out(_slow_revolution(ctx))


def magnitude_follows_revolution(ctx: Context) -> float:
    """The share of the magnitude's changes that the place in the revolution explains (its harmonics
    1..REV_ORDERS, fitted on every other block of samples and evaluated on the blocks between): 0 where the
    revolution is not covered. Near 1, a gain over the revolution and an amplitude-dependent waveform give the
    same error in this recording: the magnitude is then a function of the place in the revolution."""
    if not ctx.revolution_covered:
        return 0.0
    m = ctx.magnitude - ctx.magnitude.mean()
    total = float(np.sum(m * m))
    if total <= 0:
        return 0.0
    x = np.column_stack([np.ones_like(m)] + _slow_revolution(ctx, REV_ORDERS))
    return max(0.0, 1.0 - float(np.sum((m - cross_fit(x, m, SMOOTH_BLOCKS)) ** 2)) / total)


NOISE_SHARE = 0.25    # of what the term explains, the noise-free magnitude must explain this much (variance)


def magnitude_noise_only(ev: Evaluation, t: Test, sigma: float) -> bool:
    """Whether an amplitude term explains the residual only through the magnitude's noise: the radial noise of a
    sample moves its reading along the waveform tables' curve (calibrated at the mean amplitude) and so its angle;
    the term then corrects noise sample by sample, a small real gain but not an amplitude effect. Judged by the same
    term on the noise-free magnitude (smooth_magnitude): it must be significant and explain NOISE_SHARE of what the
    term explains."""
    if t.explained_rms <= 0:
        return False
    quiet = dataclasses.replace(ev, ctx=dataclasses.replace(ev.ctx, magnitude=smooth_magnitude(ev.ctx)))
    slow = test_library_effect(quiet, LIBRARY["amplitude"], sigma)
    return slow.p_value >= P_VALUE or slow.explained_rms ** 2 < NOISE_SHARE * t.explained_rms ** 2


def reference_context(ev: Evaluation) -> Context | None:
    """The context with the motion (speed, acceleration, direction) of the reference instead of the encoder's own
    estimate. The encoder's speed is a difference of its own positions, so it carries the noise of the sample being
    corrected: on a noisy encoder a speed term fitted to it cancels part of that noise (it acts as a smoothing
    filter) and passes for a speed effect. The reference's motion is free of the encoder's noise, and a physical
    speed or direction effect shows against it as well."""
    if ev.ref_speed is None or ev.cal is None or len(ev.r) < 3:
        return None
    v = ev.cal.direction * ev.ref_speed           # the reference may count the other way
    return dataclasses.replace(ev.ctx, speed=v, accel=np.gradient(v, ev.ctx.t), direction=np.where(v >= 0, 1, -1))


def in_own_noise(ev: Evaluation, moving: Context | None, name: str, t: Test, sigma: float) -> bool:
    """Whether a significant motion effect shows only through the encoder's own motion estimate (its noise): against
    the reference's motion it is not testable (a direction that changes only in the encoder's estimate), not
    significant, or would not lower the residual by MIN_GAIN. The encoder's estimate carries the physical
    effect and the noise alike, so the share they explain is not compared, only whether the physical one is
    there at all."""
    effect = LIBRARY[name]
    if moving is None or t.p_value >= P_VALUE or not {"speed", "direction"} & set(effect.needs):
        return False
    if testable(name, moving, ev.cal, ev.ref_speed):
        return True
    ref = test_library_effect(dataclasses.replace(ev, ctx=moving), effect, sigma)
    return ref.p_value >= P_VALUE or ref.rms_after > (1 - MIN_GAIN) * ev.rms


def candidates(ev_full: Evaluation, sigma: float, exclude: set) -> tuple[list[Test], dict]:
    tests, skipped = [], {}
    ev = strided(ev_full)
    moving = reference_context(ev)
    for name in LIBRARY:
        if name in exclude:
            continue
        why = testable(name, ev.ctx, ev.cal, ev.ref_speed)
        if why:
            skipped[name] = why
            continue
        t = test_library_effect(ev, LIBRARY[name], sigma)
        # (not behind an online correction: what the tracker or the canceller leaves moves the magnitude in time,
        # outside the slow shapes the check knows, and magnitude_cause names it)
        online = ev.cal is not None and (ev.cal.adaptive or ev.cal.canceller)
        if name == "amplitude" and not online and magnitude_noise_only(ev, t, sigma):
            skipped[name] = ("it follows the magnitude's noise, not its changes: the radial noise of the sample being "
                             "corrected, read through the waveform tables' curvature, not a change of amplitude")
            continue
        if in_own_noise(ev, moving, name, t, sigma):
            skipped[name] = ("it shows against the encoder's own speed estimate but not against the reference's "
                             "motion: the noise of the sample being corrected, which a speed term would smooth, "
                             "not a physical effect")
            continue
        tests.append(t)
    known_hz = [float(e.split("@")[1]) for e in exclude if "@" in e]
    lines, notes = tone_candidates(ev_full, known_hz)
    for name, f, p_line, harmonic in lines:
        t = test_terms(ev_full.r, _design(name, ev_full.ctx, f), sigma, name, f)
        t.p_value = max(t.p_value, p_line)      # the line must stand out of its neighbours, and the term explain
        t.ambiguous = harmonic
        tests.append(t)
    if notes:
        skipped["tones"] = "; ".join(notes)
    if ev.rms > GENERIC_ABOVE_FLOOR * sigma:      # near the floor nothing is left for a shape without a name
        tests += generic_candidates(ev, sigma, exclude)
    return tests, skipped


GENERIC_NEEDS = {"speed": "speed", "speed2": "speed", "direction": "direction", "revolution": "periods",
                 "time": "time"}
# the library effect whose conditions gate a factor (the revolution factor has its own: revolution_untestable)
GENERIC_PROBE = {"speed": "ref_lag", "direction": "hysteresis", "time": "drift"}
CV_BLOCKS = 200     # interleaved blocks of the two-fold cross-validation


def _fold_grams(ev: Evaluation, design, width: int):
    """Normal equations of a design (plus a constant) on each half of the two-fold cross-validation."""
    r, n = ev.r, len(ev.r)
    fold = (np.arange(n) * CV_BLOCKS // n) % 2
    grams = [np.zeros((width + 1,) * 2) for _ in range(2)]
    rhs = [np.zeros(width + 1) for _ in range(2)]
    for start in range(0, n, CHUNK):
        sl = slice(start, min(n, start + CHUNK))
        xa = np.column_stack([design(sl), np.ones(sl.stop - sl.start)])
        for f in (0, 1):
            m = fold[sl] == f
            grams[f] += xa[m].T @ xa[m]
            rhs[f] += xa[m].T @ r[sl][m]
    rr = [float(r[fold == f] @ r[fold == f]) for f in (0, 1)]
    return grams, rhs, rr


def _held_out(grams, rhs, rr, idx) -> tuple[float, float]:
    """Held-out sum of squares of the columns idx (the constant last), and of the constant alone."""
    held = base = 0.0
    for a, b in ((0, 1), (1, 0)):
        g, y = grams[a][np.ix_(idx, idx)], rhs[a][idx]
        sc = np.sqrt(np.maximum(np.diag(g), 1e-300))
        w = np.linalg.lstsq(g / np.outer(sc, sc), y / sc, rcond=1e-12)[0] / sc
        gb, yb = grams[b][np.ix_(idx, idx)], rhs[b][idx]
        held += rr[b] - 2 * w @ yb + w @ gb @ w
        mean_a = rhs[a][-1] / grams[a][-1, -1]
        base += rr[b] - 2 * mean_a * rhs[b][-1] + mean_a ** 2 * grams[b][-1, -1]
    return float(held), float(base)


def cv_held_out(ev: Evaluation, design, width: int) -> float:
    grams, rhs, rr = _fold_grams(ev, design, width)
    return _held_out(grams, rhs, rr, list(range(width + 1)))[0]


def generic_cv(ev: Evaluation, factor: str) -> tuple[float, float, str]:
    """The factor's best orders by two-fold cross-validation: (held-out SSE, held-out SSE of a constant, name)."""
    ctx = ev.ctx
    kmax = max(GENERIC_PHASE_ORDERS) if factor != "revolution" else 4
    mmax = max(GENERIC_REV_ORDERS[:3]) if factor == "revolution" else 0
    nf = len(factor_columns(factor, ctx.rows(slice(0, 1)), mmax))
    npc = 2 * kmax + (factor != "1")
    grams, rhs, rr = _fold_grams(ev, lambda sl: generic_design(generic_name(factor, kmax, mmax), ctx.rows(sl)),
                                 nf * npc)
    best = None
    for k in [k for k in GENERIC_PHASE_ORDERS if k <= kmax]:
        for mm in ([m for m in GENERIC_REV_ORDERS if m <= mmax] or [0]):
            keep_f = 2 * mm if factor == "revolution" else nf
            keep_p = 2 * k + (factor != "1")
            idx = [fi * npc + pj for fi in range(keep_f) for pj in range(keep_p)] + [nf * npc]
            held, base = _held_out(grams, rhs, rr, idx)
            if best is None or held < best[0]:
                best = (held, base, generic_name(factor, k, mm))
    return best


def generic_candidates(ev: Evaluation, sigma: float, exclude: set) -> list[Test]:
    """The general dictionary: for each factor, fine-phase orders 0..K (and revolution orders 1..M) chosen by
    two-fold cross-validation on interleaved blocks of the fit data (fitted on one half, scored on the other,
    and the other way round); the best order of each factor is offered as a "generic" term when it lowers
    the held-out error by at least MIN_GAIN."""
    ctx, r = ev.ctx, ev.r
    if len(r) < 2000:
        return []
    out = []
    moving = reference_context(ev)
    for factor in GENERIC_FACTORS:
        need = GENERIC_NEEDS.get(factor)
        why = revolution_untestable(ctx, ev.cal) if need == "periods" else \
            need and testable(GENERIC_PROBE[need], ctx, ev.cal, ev.ref_speed)
        if why:
            continue
        if any(e.startswith(f"generic:{factor}:") for e in exclude):
            continue
        held, base, name = generic_cv(ev, factor)
        if held > (1 - MIN_GAIN) ** 2 * base:
            continue
        if need in ("speed", "direction") and moving is not None:
            # as in_own_noise for the library's motion effects: a motion shape must also predict held-out data
            # against the reference's motion, or it is the encoder's own noise (a speed estimate carries the
            # sample being corrected, and the angle error's own changes) that it smooths
            held_ref, base_ref, _ = generic_cv(dataclasses.replace(ev, ctx=moving), factor)
            if held_ref > (1 - MIN_GAIN) ** 2 * base_ref:
                continue
        out.append(test_terms(r, lambda sl, nm=name: generic_design(nm, ctx.rows(sl)), sigma, name))
    return out


#: library effects carried as angle terms, and the factor of the general dictionary their signature lies in
SHAPE_FACTOR = {"sampling_skew": "speed", "hysteresis": "direction", "amplitude": "magnitude"}


def widen(best: Test, ev: Evaluation, sigma: float) -> Test:
    """A named effect with the shape the data asks for: when the general dictionary's block of the same factor
    (orders chosen by cross-validation) predicts held-out data better than the library's fixed shape by at
    least MIN_GAIN, the name stays and the block is the correction (e.g. a large channel skew needs more than
    the one-term shape)."""
    factor = SHAPE_FACTOR.get(best.name)
    if factor is None or len(ev.r) < 2000:
        return best
    held, _, name = generic_cv(ev, factor)
    lib = LIBRARY[best.name]
    width = lib.design(ev.ctx.rows(slice(0, 1))).shape[1]
    lib_held = cv_held_out(ev, lambda sl: lib.design(ev.ctx.rows(sl)), width)
    if held > (1 - MIN_GAIN) ** 2 * lib_held:
        return best
    t = test_terms(ev.r, lambda sl: generic_design(name, ev.ctx.rows(sl)), sigma, name)
    t.label = best.name
    return t


#: the general dictionary's factors whose shapes belong to one library effect
FACTOR_EFFECT = {"magnitude": "amplitude", "magnitude2": "amplitude", "direction": "hysteresis",
                 "speed": "sampling_skew"}


def generic_effect(name: str) -> str | None:
    """The library effect whose wider form a shape of the general dictionary is (by its factor), if any."""
    return FACTOR_EFFECT.get(parse_generic(name)[0])


FAMILY_SHARE = 0.5      # of the variance a general shape explains, a library effect of its factor explaining this
                        # much is the better first step (the rest shows in the next iteration)


def family_holds(shape: Test, good: list[Test]) -> bool:
    """Whether a library effect whose shape lies in the same factor as a general-dictionary shape explains most of
    what the shape explains: then the name goes in by itself (a reference lag is speed x order 0, inside every
    speed shape), and the shape may not stand in for another effect of that factor."""
    need = GENERIC_NEEDS.get(parse_generic(shape.name)[0])
    return any(need in LIBRARY[t.name].needs and t.explained_rms ** 2 >= FAMILY_SHARE * shape.explained_rms ** 2
               for t in good if t.name in LIBRARY and not t.ambiguous)


def speed_holds(shape: Test, good: list[Test]) -> bool:
    """Whether a magnitude shape of the general dictionary may be a speed effect seen through the magnitude (a
    channel skew changes the corrected magnitude in proportion to speed): a speed shape, named or not, explains
    half of what it does."""
    if generic_effect(shape.name) != "amplitude":
        return False
    return any(t.explained_rms ** 2 >= FAMILY_SHARE * shape.explained_rms ** 2 for t in good
               if (t.name in LIBRARY and "speed" in LIBRARY[t.name].needs)
               or (t.name.startswith("generic:") and GENERIC_NEEDS.get(parse_generic(t.name)[0]) == "speed"))


def named_shape(best: Test, tests: list[Test], rms: float) -> Test:
    """A shape of the general dictionary is the wider form of the library effect of its factor when that effect
    is itself present (its fixed shape significant, and it matters): the name goes with it (as `widen` does the
    other way round)."""
    if not best.name.startswith("generic:") or best.label:
        return best
    effect = generic_effect(best.name)
    if any(t.name == effect and t.p_value < P_VALUE and t.rms_after < (1 - MIN_GAIN) * rms for t in tests):
        best.label = effect
    return best


TONE_EFFECT = dict(cause="a tone in time: vibration between encoder and reference, or interference",
                   correction="artefact", where="the measurement set-up; nothing in the hardware")


def describe(name: str) -> dict:
    if name.startswith("generic:"):
        factor, k, m = parse_generic(name)
        carried = GENERIC_FACTORS[factor]
        what = f"fine-phase orders 0..{k} times {factor}" + (f" (revolution orders 1..{m})" if m else "")
        return {**GENERIC, "signature": what + "; unexplained by name",
                "correction": "hardware" if carried else "float engine",
                "where": "fringe_trim's tables" if carried else "the float engine (no core block carries it)"}
    if name == "tone":
        return TONE_EFFECT
    if name == "interference":
        return INTERFERENCE
    e = LIBRARY[name]
    return {"cause": e.cause, "signature": e.signature, "correction": e.correction, "where": e.where}
