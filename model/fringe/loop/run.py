"""The closed loop (`fringe loop`): calibrate the declared model, find what its residual still
holds, name the physical effect, add it, and report the error before and after.

Every test is against the noise floor estimated from the data itself (noise.noise_floor: the lowest of
the residual's spectral level away from lines, its successive differences and the spread of neighbours in
fine phase within short runs, with the Lissajous figure's radial scatter reported beside them). An effect is
added only when it is significant (chi-square of the explained sum of squares against that noise,
p < 1e-6), matters (it removes at least 1 % of the residual RMS), and lowers the error on validation data
(the --validate recording, or, without one, the interleaved half of the recording that was not used to fit).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..calib.calibrate import calibrate
from ..dsp.effects import AMPLITUDE_ORDERS, FINE_MAP_PREFIX, LIBRARY, Context
from ..encoder import Encoder
from ..errors import FringeInputError
from ..io.dataio import Measurement
from .amplitude import (
    NORMALISER,
    NORMALISER_WHERE,
    PHASE_DOMAIN_WHERE,
    amplitude_like,
    best_amplitude_remedy,
    magnitude_cause,
    read_on_the_better_magnitude,
    unnamed_amplitude,
    with_revolution_ambiguity,
)
from .candidates import candidates, describe, family_holds, generic_effect, named_shape, speed_holds, strided, widen
from .evaluation import Evaluation, LoopState, _design, _figs, evaluate, leans_on_vibrations, validation_figures
from .noise import noise_floor
from .refit import apply, choose_speed_window, polish_tones, tracker_note
from .significance import (
    MIN_GAIN,
    P_VALUE,
    REVOLUTION_MIN_LINES,
    absolute,
    revolution_untestable,
    test_fourier,
    test_terms,
    testable,
)
from .tones import tone_candidates, with_harmonic_ambiguity

MAX_EFFECTS = 8          # effects kept at most
MAX_TRIALS = 20          # candidates tried at most: a rejected one must not use up a kept one's turn
VALIDATION_BLOCKS = 500  # interleaved blocks when there is no --validate recording
DECISION_ROWS = 1 << 17  # a longer recording is decided on this many of its rows (fit and validation each)
DECISION_RUNS = 8        # taken as evenly spaced runs of consecutive rows
NAMED_SHARE = 0.1       # of the variance the best general shape explains, a named effect must explain this much
RIVAL_SHARE = 0.5       # of the variance the best effect explains, a simpler rival must explain this much to be tried


def decision_rows(meas: Measurement) -> Measurement:
    """The rows a long recording is decided on: DECISION_RUNS evenly spaced runs, unless they see less of the
    revolution than the whole recording (a slow one), which is then used whole."""
    sub = meas.runs(DECISION_ROWS, DECISION_RUNS)
    if sub is meas or meas.ref_deg is None:
        return sub

    def sectors(m):
        return len(np.unique(np.floor(np.mod(m.ref_deg, 360.0) / 360.0 * 64)))
    return sub if sectors(sub) >= sectors(meas) else meas


def split(meas: Measurement, blocks: int = VALIDATION_BLOCKS) -> tuple[Measurement, Measurement]:
    """Interleaved blocks: both halves cover the revolution and the whole time span."""
    idx = (np.arange(len(meas)) * blocks // len(meas)) % 2
    return meas.subset(idx == 0), meas.subset(idx == 1)


def start_speed(ctx: Context) -> float:
    """The speed the speed terms take for the first sample after reset, which has no speed window yet (fringe_trim's
    START_SPEED): the mean speed of the calibration recording, rev/s. A recording that starts in motion would
    otherwise have its first sample corrected as at standstill: a skew term's whole speed image on one sample
    (held-out 9237: 3154" on the first of 16384 samples, 1.48x the floor over the recording, 1.00x without it)."""
    return float(np.mean(ctx.speed[1:])) if len(ctx.speed) > 1 else 0.0


def run_loop(train: Measurement, enc: Encoder, validate: Measurement | None = None, shown: list | None = None
             ) -> tuple[LoopState, LoopState, dict]:
    """The closed loop on `train` (validated on `validate`, else on the interleaved half of `train` left out of
    the fit). `shown`, a list, receives the validation rows the decision was made on (for the plots). A caller
    that keeps no reference to `train` lets it go once it is split (bounded memory)."""
    if train.ref_deg is None:
        raise FringeInputError("the closed loop needs a reference (a ref_deg column) to measure the residual; "
                               "without one, run 'fringe calibrate' (reference-free: conic and waveform "
                               "against the smooth-motion phase)", train.path)
    data_path = train.path
    if validate is None:
        fit_data, val_data, val_name = (*split(train), "interleaved half of the recording")
        del train
    else:
        if validate.ref_deg is None:
            raise FringeInputError("the validation recording has no ref_deg column", validate.path)
        fit_data, val_data, val_name = train, validate, validate.path
    # a long recording is decided on evenly spaced runs of it (ample power for every test, bounded time and
    # memory); the error before and after is then measured on every validation row
    full_val = val_data
    fit_data, val_data = decision_rows(fit_data), decision_rows(val_data)
    state = base = LoopState(calibrate(fit_data, enc))
    ev_fit = evaluate(state, fit_data)
    base.cal.start_speed_rev_s = start_speed(ev_fit.ctx)
    ev_val = evaluate(state, val_data)
    sigma, floor_info = noise_floor(ev_fit)
    if shown is not None:
        shown.append(val_data)
    report = {"data": data_path, "validation": val_name, "noise_floor_arcsec": round(sigma, 4),
              "noise_floor_method": floor_info["used"], "noise_floor_estimates": floor_info,
              "before": _figs(ev_val), "effects_added": [], "effects_rejected": [], "iterations": []}
    excluded: set = set()
    for _ in range(MAX_TRIALS):
        if len(report["effects_added"]) >= MAX_EFFECTS:
            break
        tests, skipped = candidates(ev_fit, sigma, excluded)
        good = [t for t in tests if t.p_value < P_VALUE and t.rms_after < (1 - MIN_GAIN) * ev_fit.rms]
        # what the core carries first: a correction only the float engine runs is left for when nothing else is
        good = [t for t in good if describe(t.name)["correction"] != "float engine"] or good
        # the library's names first, where one explains at least NAMED_SHARE of what the best shape of the general
        # dictionary explains (a named effect beside a far larger unnamed structure would be fitted on top of
        # it); a line on a steady revolution harmonic is as well a position error: it competes with the shapes.
        # A shape of the general dictionary in the factor of a library effect that is itself present is that
        # effect in its wider form (named_shape): it competes as the name (a large skew beside the magnitude
        # changes it causes is a speed effect, though its one-term shape explains less than the magnitude's), if
        # it explains more than the plain fine-phase shapes (a factor with a mean, as the speed of a steady
        # motion, also carries a static fine-phase error). The magnitude's shapes only where no speed shape
        # explains half as much: a skew changes the corrected magnitude in proportion to speed, so they stand in
        # for a speed effect as well
        top = max((t.explained_rms for t in good if t.name.startswith("generic:")), default=0.0)
        plain = max((t.explained_rms for t in good if t.name.startswith(FINE_MAP_PREFIX)), default=0.0)
        present = {t.name for t in good if not t.name.startswith("generic:") and not t.ambiguous}
        named = [t for t in good if not t.ambiguous and t.explained_rms ** 2 >= NAMED_SHARE * top ** 2
                 and (not t.name.startswith("generic:")
                      or (generic_effect(t.name) in present and t.explained_rms > plain
                          and not family_holds(t, good) and not speed_holds(t, good)))]
        good = named or good
        report["iterations"].append({"residual_rms_arcsec": round(ev_fit.rms, 4), "tests": [
            {"effect": t.name, "explained_rms_arcsec": round(t.explained_rms, 4), "p_value": t.p_value,
             "dof": t.dof} for t in sorted(tests, key=lambda t: t.rms_after)], "not_testable": skipped})
        if not good:
            break
        # BIC: between effects that explain nearly the same, the one with fewer terms
        n = len(ev_fit.r)
        ranked = sorted(good, key=lambda t: n * np.log(t.rms_after ** 2) + t.dof * np.log(n))
        best = ranked[0]
        # the in-sample score favours a shape with more terms that also takes part of other structure: a simpler
        # effect next in line that explains at least RIVAL_SHARE of the variance the best explains is tried too,
        # and the validation data decide between them (population 9024: a reference lag at reversals; a 9-term
        # hysteresis explained more of the fit data than the 1-term lag, took part of a gain change with it, and
        # left 3.6x the floor on the validation recording; 9000: interference, 1 term, beside a vibration at one of
        # its sidebands, 2 terms). Only a simpler one: the validation recording is scored against the same
        # reference, and a skew (a hardware correction) tried beside the reference's lag (an artefact, kept out of
        # the correction) won on it by a few percent on 9007, 9013, 9043 and 9047, correcting the encoder to the
        # reference's lag
        rival = next((t for t in ranked[1:] if t.dof < best.dof and not t.name.startswith("generic:")
                      and not best.name.startswith("generic:")
                      and ev_fit.rms ** 2 - t.rms_after ** 2 >= RIVAL_SHARE * (ev_fit.rms ** 2 - best.rms_after ** 2)),
                     None)
        outcome, failure, memo = None, None, {}
        for option in [best] + ([rival] if rival is not None else []):
            option = named_shape(widen(option, strided(ev_fit), sigma), tests, ev_fit.rms)
            try:
                got = _trial(state, option, fit_data, val_data, ev_fit, sigma, memo)
            except (FringeInputError, ValueError, TypeError, KeyError, np.linalg.LinAlgError) as e:
                failure = failure or (option, e)
                continue
            if outcome is None or got[1].rms < outcome[1].rms:
                outcome = got
        if outcome is None:
            # never abort on the data: an effect whose fit fails is reported and left out
            best, e = failure
            excluded.update({f"{best.name}@{best.tone_hz!r}"} if best.tone_hz else {best.name, best.label} - {""})
            report["effects_rejected"].append({"name": best.name, **describe(best.name), "evidence": "",
                                               "why_not_kept": f"re-calibration with it failed: {e}"})
            continue
        trial, val_after, best, remedy = outcome
        # a line is excluded by its frequency (a recording may hold several), every other term by its name
        excluded.update({f"{best.name}@{best.tone_hz!r}"} if best.tone_hz else {best.name, best.label} - {""})
        entry = {"name": best.label or best.name, **describe(best.label or best.name),
                 **({"shape": describe(best.name)["signature"], "correction": describe(best.name)["correction"],
                     "where": describe(best.name)["where"]} if best.label else {}),
                 "evidence": f"explains {best.explained_rms:.3f}\" RMS of the residual ({best.dof} terms, "
                             f"p = {best.p_value:.1e} against the {sigma:.3f}\" noise floor)"
                             + (f"; tone at {best.tone_hz:.3f} Hz" if best.tone_hz else ""),
                 "rms_before_arcsec": round(ev_val.rms, 4), "rms_after_arcsec": round(val_after.rms, 4)}
        k = trial.cal.magnitude_smooth_log2
        if k != state.cal.magnitude_smooth_log2:
            entry["evidence"] += (f"; on the magnitude's running average over ~{1 << k} samples (fringe_trim "
                                  f"MAG_SMOOTH_LOG2 = {k}): it predicts held-out data better than the sample's own")
            entry["magnitude_smooth_log2"] = k
        f = trial.cal.canceller.get("tone_hz") if best.name == "interference" else None
        if f is not None and f != best.tone_hz:
            entry["evidence"] += (f"; its frequency estimated again on the channels of the model calibrated without "
                                  f"it: {f:.3f} Hz")
        if best.tone_hz:
            entry["tone_hz"] = float(f or best.tone_hz)
        w = trial.cal.speed_window_log2
        if w != state.cal.speed_window_log2:
            entry["evidence"] += (f"; on a speed window of {1 << w} samples (fringe_trim SPEED_LOG2 = {w}): its "
                                  "direction turns sooner after a reversal, and it left less error on the validation "
                                  "data than the longer window")
            entry["speed_window_log2"] = w
        cause, why = magnitude_cause(state, remedy, best, ev_fit)
        if cause:
            entry.update(name=cause, **{k: v for k, v in describe(cause).items() if k != "where"})
            if cause == "sampling_skew":
                entry["signature"] = describe(best.name)["signature"] + " (the magnitude changes a channel skew makes)"
            entry["evidence"] += why
        if remedy:
            entry.update(where=NORMALISER_WHERE if remedy == NORMALISER else PHASE_DOMAIN_WHERE, remedy=remedy,
                         correction="adaptive" if remedy == NORMALISER else "hardware")
        if entry["name"] == "amplitude" and state.cal.encoder.lines_per_rev < REVOLUTION_MIN_LINES:
            entry = unnamed_amplitude(entry, state.cal.encoder.lines_per_rev)
        entry = with_harmonic_ambiguity(with_revolution_ambiguity(entry, ev_fit.ctx, state.cal), best)
        why_not = "" if val_after.rms < (1 - 0.5 * MIN_GAIN) * ev_val.rms else \
            f"did not lower the error on the validation data ({val_name})"
        if not why_not and best.name != "tone" and leans_on_vibrations(state, trial, val_data):
            why_not = (f"lowered the error on the validation data ({val_name}) only with the vibration tones taken "
                       "out of the score, which the core does not do")
        if not why_not:
            report["effects_added"].append(entry)
            state, ev_val = trial, val_after
            if best.name != "tone":     # what the new correction takes out may have pulled a tone's frequency
                polished = polish_tones(state, fit_data)
                if polished is not state:
                    state, ev_val = polished, evaluate(polished, val_data)
            ev_fit = evaluate(state, fit_data)
            sigma = min(sigma, noise_floor(ev_fit)[0])     # a cleaner residual inflates the floor less
        else:
            if entry["name"] == "drift" and trial.cal.adaptive and not state.cal.adaptive:
                why_not += "; " + tracker_note(trial.cal, fit_data, val_data)
            entry["why_not_kept"] = why_not
            report["effects_rejected"].append(entry)
    report["after"] = _figs(ev_val)
    if len(full_val) > len(val_data):
        report["decided_on_rows"] = {"fit": len(fit_data), "validation": len(val_data), "runs": DECISION_RUNS}
        report["before"], report["after"] = validation_figures(base, full_val), validation_figures(state, full_val)
    report["noise_floor_arcsec"] = round(sigma, 4)
    # the hardware tables' error budget (hardware.closed_loop.choose_map_psi_w) is set against this floor
    state = dataclasses.replace(state, cal=dataclasses.replace(
        state.cal, provenance={**state.cal.provenance, "noise_floor_arcsec": round(sigma, 6)}))
    report["unexplained"] = unexplained(ev_fit, sigma)
    report["artefacts"] = [a.to_dict() for a in state.artefacts]
    from ..hardware.closed_loop import float_only
    report["float_engine_only"] = float_only(state.cal)
    if state.ref_lag_s:
        report["artefacts"].append({"name": "ref_lag", "lag_s": state.ref_lag_s,
                                    "correction": "artefact", "where": LIBRARY["ref_lag"].where})
    return base, state, report


def _trial(state: LoopState, best, fit_data: Measurement, val_data: Measurement, ev_fit: Evaluation, sigma: float,
           memo: dict):
    """The state with `best` applied, its validation, the effect as applied, and the amplitude remedy taken
    (`memo`: what the remedies share between the trials on one state)."""
    remedy = ""
    trial = apply(state, best, fit_data)
    val_after = evaluate(trial, val_data)
    # the magnitude the first magnitude term reads (the state carries it, from this term on)
    trial, val_after, best = read_on_the_better_magnitude(state, best, trial, val_after, ev_fit, sigma,
                                                          fit_data, val_data)
    if amplitude_like(best) and not state.cal.fit.get("phase_domain"):
        trial, val_after, remedy = best_amplitude_remedy(state, trial, val_after, fit_data, val_data, memo)
    trial, val_after = choose_speed_window(state, trial, val_after, val_data, 0.5 * MIN_GAIN)
    return trial, val_after, best, remedy


def unexplained(ev: Evaluation, sigma: float) -> list[dict]:
    """What is still significant, by domain (or why a domain could not be tested)."""
    ctx = ev.ctx
    from ..dsp.effects import _legendre_time

    domains = {     # name: (columns of a block of rows, why the domain cannot be tested, number of columns)
        "fine phase": ((ctx.phi, range(1, 33)), None, 64),
        "revolution": ((ctx.psi, range(1, 65)), None, 128),
        "fine phase x revolution": (lambda sl: LIBRARY["rev_offset_gain"].design(ctx.rows(sl)),
                                    revolution_untestable(ctx, None), 32),
        "time (trend)": (lambda sl: np.column_stack(_legendre_time(ctx.rows(sl))), None, 3),
        "speed": (lambda sl: np.column_stack([ctx.speed[sl], ctx.speed[sl] ** 2]),
                  testable("ref_lag", ctx, None, ev.ref_speed), 2),
        "acceleration": (lambda sl: ctx.accel[sl, None], testable("acceleration", ctx, None, ev.ref_speed), 1),
        "direction": (lambda sl: ctx.direction[sl, None].astype(float),
                      testable("hysteresis", ctx, None, ev.ref_speed), 1),
        "amplitude": (lambda sl: LIBRARY["amplitude"].design(ctx.rows(sl)), None, 1 + 2 * AMPLITUDE_ORDERS),
    }
    out = []
    for domain, (design, why, width) in domains.items():
        if why:
            out.append({"domain": domain, "description": f"not tested: {why}", "rms_arcsec": None})
            continue
        x = design
        if len(ev.r) < 4 * width:
            out.append({"domain": domain, "description": "not tested: too few samples for this domain",
                        "rms_arcsec": None})
            continue
        t = test_fourier(ev.r, *x, sigma, domain) if isinstance(x, tuple) else test_terms(ev.r, x, sigma, domain)
        if t.p_value < P_VALUE and t.explained_rms > 0.1 * sigma:
            tied = "revolution" in domain and not absolute(ev.cal)
            out.append({"domain": domain, "description": f"significant structure left ({t.dof} terms, "
                        f"p = {t.p_value:.1e}); " + ("the encoder has no coarse code, so it cannot be corrected (the "
                                                     "place in the revolution is not known in another recording)"
                                                     if tied else "no effect in the library explains it"),
                        "rms_arcsec": round(t.explained_rms, 4)})
    lines, notes = tone_candidates(ev)
    for name, f, p_line, _ in lines:
        t = test_terms(ev.r, _design(name, ctx, f), sigma, name, f)
        if max(t.p_value, p_line) < P_VALUE and t.explained_rms > 0.1 * sigma:
            what = "in the channels (additive interference)" if name == "interference" else "in the angle only"
            out.append({"domain": "time (tones)", "description": f"a line at {f:.3f} Hz {what}",
                        "rms_arcsec": round(t.explained_rms, 4)})
    for note in notes:
        out.append({"domain": "time (tones)", "description": note, "rms_arcsec": None})
    out.append({"domain": "noise", "description": "random part (the floor)", "rms_arcsec": round(sigma, 4)})
    return out
