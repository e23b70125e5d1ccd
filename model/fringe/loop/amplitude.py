"""An amplitude that changes: its remedies (the magnitude term, the phase-domain structure with or without it, the
amplitude normaliser) compared on the validation data, on the bit-exact engine where the core runs them all, and the
cause a magnitude-dependent correction is reported under."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

from ..calib.calibrate import PHASE_TABLE
from ..dsp.calibration import Calibration
from ..dsp.effects import (
    AMPLITUDE_ORDERS,
    FINE_MAP_PREFIX,
    GENERIC,
    Context,
    FittedEffect,
    generic_design,
    generic_name,
    magnitude_average,
)
from ..errors import FringeInputError
from ..io.dataio import Measurement
from .candidates import (
    _fold_grams,
    _held_out,
    cv_held_out,
    magnitude_follows_revolution,
    magnitude_follows_time,
    strided,
)
from .evaluation import Evaluation, LoopState, _design, evaluate, shift_reference
from .refit import apply, carry_loop, choose_tracker, recalibrate, recalibration_structure, refit_angle_terms
from .significance import MIN_GAIN, REVOLUTION_MIN_LINES, Test, revolution_untestable, test_terms

PHASE_DOMAIN_ORDERS = (2, 4, 6, 8, 12, 16, 24, 32)   # fine-phase orders of the phase-domain map (chosen by CV)
AMPLITUDE_TERMS = ("amplitude", "generic:magnitude:", "generic:magnitude2:")


#: the effects an error tied to both the magnitude and the place in the revolution could be, each the other's twin
REVOLUTION_TWIN = {"amplitude": "rev_offset_gain", "rev_offset_gain": "amplitude"}
AMBIGUOUS_SHARE = 0.5   # of the magnitude's changes, the place in the revolution explaining this much: ambiguous


def with_revolution_ambiguity(entry: dict, ctx: Context, cal: Calibration) -> dict:
    """An amplitude or revolution-offsets entry marked ambiguous (`ambiguous_with`, and said in its evidence) where
    the magnitude follows the place in the revolution in this recording: a waveform that changes with the amplitude
    and offsets and gains over the revolution then give the same error, and the name taken is the one whose shape
    fitted first (held-out 9202 and 9208 name one and let it take the other's part). Only where both can be named
    (an absolute encoder of REVOLUTION_MIN_LINES periods or more, the revolution covered): without a coarse code the
    offsets over the revolution are no candidate, and an amplitude term is the correction the core can make."""
    other = REVOLUTION_TWIN.get(entry["name"])
    if other is None or ctx.lines < REVOLUTION_MIN_LINES or revolution_untestable(ctx, cal) is not None:
        return entry
    share = magnitude_follows_revolution(ctx)
    if share < AMBIGUOUS_SHARE:
        return entry
    return {**entry, "ambiguous_with": other,
            "evidence": entry["evidence"] + f"; ambiguous with {other}: the place in the revolution explains "
                        f"{share:.0%} of the magnitude's changes in this recording, so an amplitude-dependent "
                        "waveform and offsets and gains over the revolution look alike here (a recording whose "
                        "amplitude changes otherwise, at another air gap, tells them apart)"}


def unnamed_amplitude(entry: dict, lines: int) -> dict:
    """A magnitude-dependent correction on an encoder of fewer than REVOLUTION_MIN_LINES periods: kept, but reported
    as structure no name explains, not as "amplitude": with so few periods an amplitude change over the revolution
    is a waveform that differs from period to period, as testable() holds for the revolution's offsets and gains."""
    return {**entry, "name": generic_name("magnitude", AMPLITUDE_ORDERS), "cause": GENERIC["cause"],
            "signature": f"an error that follows the signal magnitude; unexplained by name (with {lines} signal "
                         "period(s) per revolution an amplitude change over the revolution cannot be told from a "
                         "waveform that differs between periods)"}


def amplitude_like(t: Test) -> bool:
    return any((t.label or t.name).startswith(a) for a in AMPLITUDE_TERMS)


#: the magnitude averages a magnitude term may read (fringe_trim's MAG_SMOOTH_LOG2: ~2^k samples; 0 the sample's own)
MAGNITUDE_AVERAGES = (0, 1, 2, 3, 4, 5, 6, 8, 10, 12)


def read_on_the_better_magnitude(state: LoopState, best: Test, trial: LoopState, val_after: Evaluation,
                                 ev_fit: Evaluation, sigma: float, fit_data: Measurement, val_data: Measurement
                                 ) -> tuple[LoopState, Evaluation, Test]:
    """The first magnitude term on the sample's own magnitude (`trial`) or on the average `choose_magnitude_average`
    picks on the fit data, whichever leaves less error on the validation data (on the bit-exact engine where the
    core runs both): the average lags the amplitude by a trajectory's worth of samples, and the validation
    recording moves another way (held-out 9219: chosen on the fit data alone, 1.00 -> 1.11x the floor)."""
    state_m, best_m = choose_magnitude_average(state, best, ev_fit, sigma)
    if state_m is state:
        return trial, val_after, best
    trial_m = apply(state_m, best_m, fit_data)
    val_m = evaluate(trial_m, val_data)
    core = [engine_rms(trial, val_data), engine_rms(trial_m, val_data)]
    own, averaged = core if all(c is not None for c in core) else (val_after.rms, val_m.rms)
    if averaged < (1 - 0.5 * MIN_GAIN) * own:
        return trial_m, val_m, best_m
    return trial, val_after, best


def choose_magnitude_average(state: LoopState, best: Test, ev_fit: Evaluation, sigma: float
                             ) -> tuple[LoopState, Test]:
    """The magnitude the first magnitude term reads: the sample's own, or its running average over ~2^k samples
    (Calibration.magnitude_smooth_log2, fringe_trim's MAG_SMOOTH_LOG2), whichever predicts held-out data best
    (two-fold cross-validation on interleaved blocks of the fit data, by MIN_GAIN over the sample's own). The
    sample's magnitude carries its noise, and a waveform whose shape changes with the amplitude puts a ripple
    over the fine phase on it that grows with the amplitude: a term in it then fits neither (development case 9111,
    fitted on one recording and scored on another: the term on the sample's magnitude left 11.2" of 26.1", on an
    average over 4 samples 1.5").
    What a skew does to the magnitude is itself a ripple over the fine phase, corrected per sample: there the
    sample's own wins. Chosen once, with the first magnitude term; the state and the term re-tested with it."""
    if not amplitude_like(best) or state.cal.magnitude_smooth_log2 or \
            any(any(t.name.startswith(a) for a in AMPLITUDE_TERMS) for t in state.cal.angle_terms):
        return state, best
    raw = ev_fit.ctx.magnitude
    width = _design(best.name, ev_fit.ctx.rows(slice(0, 1))).shape[1]

    def held(k: int) -> tuple[float, Evaluation]:
        ev = strided(dataclasses.replace(ev_fit, ctx=dataclasses.replace(ev_fit.ctx,
                                                                          magnitude=magnitude_average(raw, k))))
        return cv_held_out(ev, lambda sl: _design(best.name, ev.ctx.rows(sl)), width), ev

    scores = {k: held(k) for k in MAGNITUDE_AVERAGES}
    k = min(scores, key=lambda j: scores[j][0])
    if k == 0 or scores[k][0] > (1 - MIN_GAIN) ** 2 * scores[0][0]:
        return state, best
    ev = scores[k][1]
    t = test_terms(ev.r, lambda sl: _design(best.name, ev.ctx.rows(sl)), sigma, best.name)
    t.label = best.label
    smoothed = dataclasses.replace(state.cal, magnitude_smooth_log2=k)
    return LoopState(smoothed, list(state.artefacts), state.ref_lag_s), t


def phase_orders(ev: Evaluation) -> str:
    """The fine-phase map's orders 1..K with the least two-fold held-out error."""
    kmax = max(PHASE_DOMAIN_ORDERS)
    grams, rhs, rr = _fold_grams(ev, lambda sl: generic_design(generic_name("1", kmax), ev.ctx.rows(sl)), 2 * kmax)
    held = {k: _held_out(grams, rhs, rr, list(range(2 * k)) + [2 * kmax])[0] for k in PHASE_DOMAIN_ORDERS}
    return generic_name("1", min(held, key=held.get))


def phase_domain(state: LoopState, meas: Measurement, keep_amplitude: bool,
                 fresh_by_key: dict | None = None) -> LoopState:
    """The remedy for an amplitude that changes, where the per-channel waveform inverse cannot serve: the waveform
    stage straight and the conic (a common gain then moves no angle: atan2 of two channels scaled alike is
    unchanged), and the phase error of the channels' shape corrected after the arctan, by the fine-phase map in
    fringe_trim (orders chosen on held-out data). With `keep_amplitude` the magnitude terms stay beside it (a
    waveform whose shape itself changes with the amplitude). `fresh_by_key` keeps the declared model's
    re-calibration between calls on the same readings: it depends on the reference's lag and the structure
    only, not on the angle terms (a third of this remedy's time)."""
    meas = shift_reference(meas, state.ref_lag_s)
    terms = [t for t in state.cal.angle_terms if not t.name.startswith(FINE_MAP_PREFIX)
             and (keep_amplitude or not any(t.name.startswith(a) for a in AMPLITUDE_TERMS))]
    marked = dataclasses.replace(state.cal, fit={**state.cal.fit, "phase_domain": True}, angle_terms=terms)
    key = (state.ref_lag_s, repr(recalibration_structure(marked)))
    cache = {} if fresh_by_key is None else fresh_by_key
    if key not in cache:
        cache[key] = recalibrate(meas, marked)
    # a copy: later steps may change a calibration's fit record in place
    cal = carry_loop(copy.deepcopy(cache[key]), marked)
    ev = strided(evaluate(LoopState(cal, state.artefacts), meas))
    name = phase_orders(ev)
    t = test_terms(ev.r, lambda sl: generic_design(name, ev.ctx.rows(sl)), 1.0, name)
    cal = dataclasses.replace(cal, angle_terms=terms + [FittedEffect(name, t.weights)])
    return LoopState(refit_angle_terms(cal, meas), list(state.artefacts), state.ref_lag_s)


PHASE_DOMAIN = "phase-domain structure"
NORMALISER = "amplitude normaliser"
NORMALISER_WHERE = ("fringe_drift_normaliser ahead of the tables: the channels' offsets and gains tracked online from "
                    "the signals")
PHASE_DOMAIN_WHERE = ("the waveform stage made straight (a common gain change then moves no angle), and the "
                      "phase error of the channels' shape in fringe_trim's fine-phase map after the arctan")


SKEW_MAGNITUDE_SHARE = 0.5   # of the magnitude's variance, the skew's signature must explain this much to own it


def skew_moves_magnitude(ev: Evaluation) -> bool:
    """Whether the corrected magnitude changes as a channel skew makes it change: sampling the cos channel tau
    late puts the Lissajous point off the circle by -(delta / 2) sin 2 phi (to first order), delta = 2 pi lines
    speed tau, so a magnitude term then corrects the skew per sample (the skew term works on the filtered speed)
    and is that effect's, not an amplitude's. Only where the speed varies (at a steady speed the conic owns it)."""
    ctx = ev.ctx
    v = ctx.speed - ctx.speed.mean()
    if np.std(v) < 0.05 * np.mean(np.abs(ctx.speed)):
        return False
    m = ctx.magnitude - ctx.magnitude.mean()
    x = np.column_stack([v * np.sin(2 * ctx.phi), v * np.cos(2 * ctx.phi)])
    w, *_ = np.linalg.lstsq(x, m, rcond=None)
    return float(np.sum((x @ w) ** 2)) >= SKEW_MAGNITUDE_SHARE * float(m @ m)


def magnitude_cause(state: LoopState, remedy: str, best: Test, ev: Evaluation) -> tuple[str, str]:
    """The name a magnitude-dependent correction is reported under ("" to keep the term's own), and why.

    An effect already corrected online changes the signals' magnitude by what its correction leaves: the drift
    tracker follows the gains late, the canceller converges from reset and leaves the tone's ripple on the
    Lissajous radius, and the revolution map corrects the angle after the arctan, not the signals, so the
    per-sector gains reach the waveform tables. The per-channel waveform inverse turns such magnitude changes
    into angle error, and the straight waveform stage of the phase-domain structure does not: then the remedy is
    that effect's correction, not a second cause. A skew moves the magnitude with the speed, and the drift
    tracker's leftovers follow time: a magnitude term (or a gain-invariant remedy) there corrects that effect.
    Gain invariance alone (the phase domain or the normaliser) is amplitude."""
    # the phase table, whether the loop's remedy or the structure calibrate chose, moves no angle with a common gain
    gain_invariant = remedy.startswith(PHASE_DOMAIN) or (not remedy and amplitude_like(best)
                                                         and state.cal.fit.get("structure") == PHASE_TABLE)
    if remedy.startswith(PHASE_DOMAIN) or (not remedy and amplitude_like(best)):
        # (the magnitude term itself, ahead of the per-channel inverse, corrects the same leftovers; the drift
        # tracker's only where they follow time, below)
        carried = ("drift" if state.cal.adaptive and gain_invariant else "interference" if state.cal.canceller
                   # the revolution map corrects the angle (fringe_trim), not the signals: the per-sector gains
                   # stay in what the waveform tables read
                   else "rev_offset_gain" if state.cal.rev_norm is not None else "")
        if carried:
            return carried, (f"; the magnitude changes that the {carried} correction leaves" + (
                ", made harmless by a gain-invariant waveform stage" if remedy else
                ", read through the phase table's fine-phase map" if gain_invariant else
                ", corrected by the magnitude term where the per-channel inverse reads them"))
    if amplitude_like(best) and state.cal.adaptive and magnitude_follows_time(ev.ctx):
        return "drift", ("; the magnitude changes it follows are the drift tracker's leftovers (slow functions of "
                         "time explain them better than the place in the revolution)")
    if amplitude_like(best) and skew_moves_magnitude(ev):
        # the correction stays (the magnitude term, or the gain-invariant remedy); the cause is the skew
        return "sampling_skew", ("; speed x (sin 2 phi, cos 2 phi) explains at least "
                                 f"{SKEW_MAGNITUDE_SHARE:.0%} of the magnitude's changes: the term corrects the "
                                 "skew per sample, through the magnitude it moves")
    return ("amplitude" if remedy in (PHASE_DOMAIN, NORMALISER) else ""), ""


def engine_rms(state: LoopState, meas: Measurement) -> float | None:
    """The validation RMS on the bit-exact engine (the core's own arithmetic, tables and block interplay), None
    where the core cannot run the calibration."""
    from ..hardware.closed_loop import unsupported
    from ..hardware.corefiles import core_config
    from ..hardware.tables import run_model

    if unsupported(state.cal):
        return None
    try:
        res = run_model(state.cal, core_config(state.cal), meas.sin, meas.cos, meas.coarse)
        return evaluate(state, meas, res).rms
    except (FringeInputError, ValueError, TypeError, KeyError, ArithmeticError, np.linalg.LinAlgError):
        return None     # a configuration the core cannot take: the candidates are compared on the float engine


def best_amplitude_remedy(state: LoopState, trial: LoopState, val_after: Evaluation, fit_data: Measurement,
                          val_data: Measurement, memo: dict | None = None) -> tuple[LoopState, Evaluation, str]:
    """Of the magnitude-dependent term (`trial`), the phase-domain structure (with and without that term) and the
    amplitude normaliser (the drift tracker), the one with the least error on the validation data: on the
    bit-exact engine where the core runs every candidate (the remedies live in different blocks, whose float
    twins do not show how they combine in the core), else on the float engine. `memo` keeps what depends on
    `state` alone (the remedies without the term, the re-calibration) between trials of one loop iteration."""
    memo = {} if memo is None else memo
    fresh_by_key = memo.setdefault("fresh_by_key", {})
    found = [("", trial, val_after, engine_rms(trial, val_data))]
    for keep, label in ((False, PHASE_DOMAIN), (True, PHASE_DOMAIN + " and magnitude term"), (None, NORMALISER)):
        if keep is not True and label in memo:
            found += memo[label]
            continue
        got = []
        try:
            if keep is None:      # the channels' gains tracked online ahead of the tables (fringe_drift_normaliser)
                if state.cal.adaptive:
                    continue
                alt = LoopState(choose_tracker(dataclasses.replace(state.cal, adaptive=True), state, fit_data),
                                list(state.artefacts), state.ref_lag_s)
            else:
                alt = phase_domain(trial if keep else state, fit_data, keep, fresh_by_key)
            got = [(label, alt, evaluate(alt, val_data), engine_rms(alt, val_data))]
        except (FringeInputError, ValueError, TypeError, KeyError, np.linalg.LinAlgError):
            pass
        if keep is not True:
            memo[label] = got
        found += got
    core = [c for *_, c in found]
    scores = core if all(c is not None for c in core) else [ev.rms for _, _, ev, _ in found]
    best = 0
    for k in range(1, len(found)):
        if scores[k] < (1 - 0.5 * MIN_GAIN) * scores[best]:
            best = k
    label, alt, ev, _ = found[best]
    return alt, ev, label
