"""Adding an effect to the loop's state (`apply`) and the re-calibrations that takes: the declared model calibrated
again with the added terms, tones or interference held out of it, the angle terms refitted jointly, the revolution's
offsets and gains fitted on the signals, and the online blocks' constants (drift tracker, canceller) chosen on the fit
data."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..calib.calibrate import calibrate
from ..dsp.calibration import Calibration
from ..dsp.effects import FINE_MAP_PREFIX, LIBRARY, Context, FittedEffect, make_context, parse_generic
from ..dsp.metrics import error_arcsec
from ..encoder import ARCSEC_PER_REV
from ..engine.pipeline import run_float, sample_times, tracked_readings, tracker_activity
from ..io.dataio import Measurement
from .candidates import describe
from .evaluation import LoopState, _design, covered, evaluate, shift_reference
from .noise import noise_sigma, sample_rate, uniform_run
from .significance import Test, test_terms
from .tones import channel_errors, lp_basis, refine_frequency


def apply(state: LoopState, t: Test, fit_data: Measurement) -> LoopState:
    new = LoopState(dataclasses.replace(state.cal, angle_terms=list(state.cal.angle_terms)), list(state.artefacts),
                    state.ref_lag_s)
    kind = {"tone": "artefact", "interference": "canceller"}.get(t.name) or \
        (describe(t.name)["correction"] if t.name.startswith("generic:") else LIBRARY[t.name].correction)
    fitted = FittedEffect(t.name, t.weights, t.tone_hz, "float" if kind == "float engine" else "core")
    if t.name == "ref_lag":
        # r = direction * speed * lag: shift the reference, calibrate again without the lag in it, and
        # repeat (the first calibration absorbed part of the lag into its long-period table)
        w = float(t.weights[0])
        for _ in range(8):     # each round leaves a fraction of the lag: iterate until it is negligible
            new.ref_lag_s += w * state.cal.direction / ARCSEC_PER_REV
            fresh = recalibrate(shift_reference(fit_data, new.ref_lag_s), state.cal)
            new.cal = carry_loop(fresh, state.cal)
            ev = evaluate(LoopState(new.cal, [], new.ref_lag_s), fit_data)
            w = float(test_terms(ev.r, LIBRARY["ref_lag"].design(ev.ctx), 1.0, "ref_lag").weights[0])
            if abs(w) * np.std(ev.ctx.speed) < 0.01 * noise_sigma(ev.r):
                break
    elif t.name == "rev_offset_gain":
        meas = shift_reference(fit_data, state.ref_lag_s)
        if new.cal.canceller:    # the offsets and gains of the readings, not of the interference the core cancels
            clean = interference_removed(new.cal, new, meas, new.cal.canceller["tone_hz"])
            meas = meas if clean is None else clean
        new.cal = fit_rev_offset_gain(new.cal, meas)
    elif kind in ("hardware", "float engine"):
        new.cal.angle_terms.append(fitted)
        meas = shift_reference(fit_data, state.ref_lag_s)
        tones = [a for a in new.artefacts if a.name == "tone"]
        # with tones found before, the declared model is calibrated again without them (as when they were
        # found): calibrated on readings that hold them, its long-period table would take part of them back
        new.cal = refit_around_tone(new.cal, tones, meas) if tones else refit_angle_terms(new.cal, meas, as_is=True)
    elif kind == "adaptive":
        new.cal = choose_tracker(dataclasses.replace(new.cal, adaptive=True), new, fit_data)
    elif kind == "canceller":
        meas = shift_reference(fit_data, state.ref_lag_s)
        fresh, tone_hz = refit_around_interference(new.cal, new, meas, t.tone_hz)
        new.cal = choose_canceller(fresh, new, meas, tone_hz)
    else:
        new.artefacts.append(fitted)
        if t.name == "tone":     # the declared model was fitted with the tone in its residual: fit it without
            new.cal = refit_around_tone(new.cal, [a for a in new.artefacts if a.name == "tone"],
                                        shift_reference(fit_data, state.ref_lag_s))
    return new


def polish_tones(state: LoopState, fit_data: Measurement) -> LoopState:
    """The vibration tones' frequencies estimated again on what the corrections added since leave of the fit
    recording (each tone with the others taken out), kept where the fit residual gets smaller. A tone found
    before the drift or the waveform was corrected is estimated beside their lines: near the electrical
    frequency they pull it off by a fraction of a bin, and a phase that drifts over the recording leaves much of
    the line (population 9053: a 583" vibration at 55.059 Hz, 52 Hz electrical, found at 55.003 Hz; the
    validation error 111" -> 43" with the frequency estimated again once the drift is tracked)."""
    for i, tone in enumerate(state.artefacts):
        if tone.name != "tone":
            continue
        others = [a for j, a in enumerate(state.artefacts) if j != i]
        ev = evaluate(LoopState(state.cal, others, state.ref_lag_s), fit_data)
        run = uniform_run(ev.ctx.t)
        t, x = ev.ctx.t[run], ev.r[run]
        f = refine_frequency(x, t, tone.tone_hz, sample_rate(t) / len(x), nuisance=lp_basis(ev.cal, ev.ctx.psi[run]))
        trial = LoopState(state.cal, [*others[:i], dataclasses.replace(tone, tone_hz=f), *others[i:]], state.ref_lag_s)
        if f != tone.tone_hz and evaluate(trial, fit_data).rms < evaluate(state, fit_data).rms:
            state = trial
    return state


def recalibrate(meas: Measurement, cal: Calibration, known_error_arcsec: np.ndarray | None = None) -> Calibration:
    """The declared model calibrated again, in the structure the loop chose for `cal` (the per-channel waveform
    inverse, or the phase-domain structure of `phase_domain`), with a known error held out of it."""
    from ..calib.calibrate import CalibrationOptions

    structure, centre = recalibration_structure(cal)
    fresh = calibrate(meas, cal.encoder, CalibrationOptions(structure=structure, gain_centre=centre,
                                                            known_error_arcsec=known_error_arcsec))
    if "model_choice" not in fresh.fit and "model_choice" in cal.fit:
        # the structure was given, not chosen again: the record of the choice stays, so that the next
        # re-calibration calibrates in it too (the phase table's centring, chosen once, was chosen again at
        # every round of refit_angle_terms: a third of the phase-domain remedy's time on population 9124)
        fresh.fit["model_choice"] = cal.fit["model_choice"]
    if cal.fit.get("phase_domain"):
        fresh.fit["phase_domain"] = True
    return fresh


def recalibration_structure(cal: Calibration) -> tuple:
    """The structure and gain-centre option `recalibrate` calibrates `cal`'s declared model in (all it reads of
    `cal` besides the encoder)."""
    from ..calib.calibrate import CANDIDATES, PHASE_TABLE, WAVEFORM

    chosen = cal.fit.get("model_choice", {}).get("chosen")
    if cal.fit.get("phase_domain"):    # whether to centre the phase table is chosen once, then kept
        return CANDIDATES[chosen] if chosen and CANDIDATES[chosen][0] == PHASE_TABLE else (PHASE_TABLE, None)
    # the structure the declared model's calibration chose on held-out data, not chosen again
    # (none chosen: a structure given to calibrate, or the reference-free calibration)
    return CANDIDATES[chosen] if chosen else (cal.fit.get("structure") or WAVEFORM, False)


def carry_loop(fresh: Calibration, cal: Calibration, **changes) -> Calibration:
    """A fresh calibration of the declared model with the closed loop's additions of `cal` carried over."""
    kept = dict(rev_norm=cal.rev_norm, adaptive=cal.adaptive, tracker=dict(cal.tracker),
                canceller=dict(cal.canceller), angle_terms=list(cal.angle_terms),
                start_speed_rev_s=cal.start_speed_rev_s, magnitude_smooth_log2=cal.magnitude_smooth_log2,
                speed_window_log2=cal.speed_window_log2)
    return dataclasses.replace(fresh, **{**kept, **changes})


def with_own_fine_map(fresh: Calibration, cal: Calibration) -> list:
    """cal's angle terms with the fine-phase map (the phase-table structure's declared angle term) of the fresh
    calibration in place of cal's, where it has one: fitted on the readings the fresh calibration saw."""
    own = [t for t in fresh.angle_terms if t.name.startswith(FINE_MAP_PREFIX)]
    return [t for t in cal.angle_terms if not (own and t.name.startswith(FINE_MAP_PREFIX))] + own


MOTION_NEEDS = {"speed", "direction"}


def motion_terms(cal: Calibration) -> list[str]:
    """The names of cal's angle terms that read the speed window's speed or direction."""
    from .candidates import GENERIC_NEEDS

    def reads_motion(name: str) -> bool:
        if name.startswith("generic:"):
            return GENERIC_NEEDS.get(parse_generic(name)[0]) in MOTION_NEEDS
        return name in LIBRARY and bool(MOTION_NEEDS & set(LIBRARY[name].needs))
    return [t.name for t in cal.angle_terms if reads_motion(t.name)]


def choose_speed_window(state: LoopState, trial: LoopState, val_after, val_data: Measurement, min_gain: float):
    """The speed window of the motion terms (fringe_trim's SPEED_LOG2), where `trial` added one: the generator's
    longest (2^5 samples at most) or a shorter one, whichever leaves less error on the validation data, by
    min_gain. The direction of a window's speed turns half a window after a reversal: a direction term corrects
    the wrong way until then (population 9017, hysteresis at reversals: the 145 samples of 16384 with the wrong
    direction held the whole excess over the floor, 36.7" RMS against 3.3"). A shorter window turns sooner and
    passes more of the position noise into the speed: the validation data weigh the two. Returns (state,
    validation) with the window chosen."""
    from ..fixed.trim import speed_window_log2

    if motion_terms(trial.cal) == motion_terms(state.cal):
        return trial, val_after
    longest = speed_window_log2(trial.cal.encoder.lines_per_rev)
    now = longest if trial.cal.speed_window_log2 is None else trial.cal.speed_window_log2
    best = (val_after.rms, trial, val_after)
    for k in range(longest, 0, -1):
        if k == now:
            continue
        alt = dataclasses.replace(trial, cal=dataclasses.replace(trial.cal, speed_window_log2=k))
        ev = evaluate(alt, val_data)
        if ev.rms < (1 - min_gain) * best[0]:
            best = (ev.rms, alt, ev)
    return best[1], best[2]


# fringe_drift_observer's update block and final step (its gear shift starts at 1): together the settled tracker's time
# constant, 2^(block + mu) samples. Short blocks start up soon after reset (with DRIFT_HOLD = 1 each update applies at
# the next block's first sample): until the first update the readings carry all of the drift at power-up, which can
# be most of a recording's excess error (9214: 12" in the first 32 samples against a 0.44" floor); long ones update
# with the gear's large first steps on a slower motion (a block of less than a period takes the final step only,
# and one of less than a sixteenth of a period none)
TRACKER_BLOCK_LOG2 = (4, 5, 6, 7, 8, 10, 12)
# The same true loop gains as (0, 1, 2, 4) before the offset step was doubled; MU_LOG2 = 0 keeps a step of 1, whose
# offset gain reaches 2 on a block that sweeps a short arc back and forth (docs/drift.md, "Loop gain");
# blocks of less than a period update only from MU_LOG2 = 2 on ("Partial sweeps": at 1 an arc swept back and forth
# near a channel's peak drove the gain to 0), which the choice on the fit recording took wherever most blocks were
# partial
TRACKER_MU_LOG2 = (1, 2, 3, 5)


def choose_tracker(cal: Calibration, state: LoopState, meas: Measurement) -> Calibration:
    """The drift tracker's constants that leave the least error on the fit data: a fast tracker follows a fast
    drift but passes more noise into the phase, a slow one the reverse; the best trade-off depends on the drift
    and the noise of this encoder, so it is measured, not fixed. (The tracker has no fitted weights: its
    in-sample error is a fair score.)"""
    best = None
    for block in TRACKER_BLOCK_LOG2:
        for mu in TRACKER_MU_LOG2:
            trial = dataclasses.replace(cal, tracker={"drift_block_log2": block, "drift_mu_log2": mu})
            rms = evaluate(LoopState(trial, state.artefacts, state.ref_lag_s), meas).rms
            if best is None or rms < best[0]:
                best = (rms, trial)
    return best[1]


def tracker_note(cal: Calibration, fit: Measurement, val: Measurement) -> str:
    """How the drift tracker of cal ran on the two recordings, for a report that says why it did not help: a
    tracker whose blocks never pass their sweep test never updates (a slow motion sweeps too little of the
    Lissajous figure per block to tell drift from the waveform; held-out 9253, 3 lines at 0.9 rev/s)."""
    updated, sweeps = tracker_activity(cal, val.sin, val.cos)
    block = 1 << cal.tracker["drift_block_log2"]
    if updated.any():
        return f"the drift tracker (blocks of {block} samples) updated in {int(updated.sum())} of {len(updated)} blocks"
    note = (f"the drift tracker's blocks of {block} samples never updated on the validation data: each swept "
            f"{float(np.median(sweeps)):.2f} signal periods (median; {float(sweeps.max()):.2f} at most), too little "
            "of the Lissajous figure to tell drift from the waveform")
    if not tracker_activity(cal, fit.sin, fit.cos)[0].any():
        # choose_tracker kept the setting with the least error on the fit data, and it never updates there either
        note += "; no setting whose blocks update on this motion lowered the error on the fit data"
    return note


CANCEL_BLOCK_LOG2 = (4, 5, 6)          # fringe_canceller's update block
CANCEL_MU_LOG2 = (4, 6, 8, 10)         # its final step
CANCEL_GEAR_OFFSET = (0, 2, 4)         # and how many gears lower its gear shift starts (offset 0: at 1/2)
CANCEL_STARTS = 4                      # resets the constants are scored from: at 0, 1/4, 1/2, 3/4 of the recording


def choose_canceller(cal: Calibration, state: LoopState, meas: Measurement, tone_hz: float) -> Calibration:
    """The interference canceller (fringe_canceller, ahead of the CORDIC) at the named tone, with the constants
    that leave the least error on the fit data: a fast canceller converges sooner after reset and follows a
    tone that wanders, a slow one passes less noise into the phase. Like the drift tracker it has no fitted
    weights (it estimates the tone from the signals on every run), so its in-sample error is a fair score, but
    its start-up depends on how the recording begins: each candidate runs from reset at CANCEL_STARTS points of
    the fit data, and the mean square over those runs scores it. Scored from the first sample alone, the fit
    recording of draw 9410 (starting at speed) chose the gear shift from 1/2, whose first blocks, too short to
    tell the tone from a common gain change of 8 % over the revolution, took 4 times the declared model's error
    on a validation recording that starts near standstill (82" against 38.5"); from four starts, a gear shift
    four gears lower: 28". The tone's frequency is in the recording's time units (cycles per sample without
    time stamps)."""
    t = sample_times(len(meas), meas.t_s)
    fs = sample_rate(t[uniform_run(t)])
    n = len(meas)
    starts = [meas.subset(slice(k * n // CANCEL_STARTS, None)) for k in range(CANCEL_STARTS)]
    best = None
    for block in CANCEL_BLOCK_LOG2:
        for mu in CANCEL_MU_LOG2:
            for offset in (o for o in CANCEL_GEAR_OFFSET if o < mu):
                trial = dataclasses.replace(cal, canceller={"tone_hz": float(tone_hz), "sample_rate_hz": float(fs),
                                                            "cancel_block_log2": block, "cancel_mu_log2": mu,
                                                            "cancel_gear_offset": offset})
                st = LoopState(trial, state.artefacts, state.ref_lag_s)
                score = float(np.mean([evaluate(st, part).rms ** 2 for part in starts]))
                if best is None or score < best[0]:
                    best = (score, trial)
    return best[1]


INTERFERENCE_ROUNDS = 8     # at most this many re-calibrations while the interference's frequency settles


def refit_around_interference(cal: Calibration, state: LoopState, meas: Measurement, tone_hz: float
                              ) -> tuple[Calibration, float]:
    """Re-calibrate the declared model on readings with the tone taken out, and the tone's frequency with it: the
    first calibration fitted its waveforms and long-period table to readings that held it (a strong tone bends both),
    and the canceller only removes it from the signals the core sees. The tone (cos, sin at its frequency) is fitted
    to each channel's reading minus the calibrated waveform at the reference's phase, the model calibrated again on
    the readings without it, and the frequency estimated again on the channel errors of that calibration, until it
    moves by less than a thousandth of a bin (at most INTERFERENCE_ROUNDS rounds). A waveform bent by the tone
    leaves errors at the harmonics of the electrical frequency in the channels, which a changing speed spreads
    over the tone's bins and pulls its estimate (population 9000: 5 % of full scale at 12.730 Hz on a slow
    7-line encoder, first estimated at 12.653 Hz, where the canceller left 1203" of 2279"; the rounds went
    12.696, 12.715, 12.723, 12.727, 12.730 Hz). Returns the calibration and the frequency."""
    plain = dataclasses.replace(cal, canceller={})
    t = sample_times(len(meas), meas.t_s)
    run = uniform_run(t)
    bin_hz = sample_rate(t[run]) / len(t[run])
    base = plain
    for _ in range(INTERFERENCE_ROUNDS):
        clean = interference_removed(base, state, meas, tone_hz)
        if clean is None:
            return plain, tone_hz
        fresh = carry_loop(recalibrate(clean, cal), plain)
        e = channel_errors(evaluate(LoopState(fresh, state.artefacts, state.ref_lag_s), meas))
        moved = refine_frequency(e[:, run], t[run], tone_hz, bin_hz) if e is not None else tone_hz
        base, settled, tone_hz = fresh, abs(moved - tone_hz) < 1e-3 * bin_hz, moved
        if settled:     # this round's calibration took the tone out within a thousandth of a bin of where it settled
            break
    else:
        clean = interference_removed(base, state, meas, tone_hz)
        fresh = carry_loop(recalibrate(clean, cal), plain)
    # vibrations already named stay out of the reference the declared model is fitted against; the angle terms
    # found before are refitted with it (a declared model calibrated again without their error held out takes
    # part of it, and they would correct it twice: held-out 9230, a skew found first, 1606" against 447")
    vibrations = [a for a in state.artefacts if a.name == "tone"]
    if vibrations:
        return refit_around_tone(fresh, vibrations, clean), tone_hz
    return (refit_angle_terms(fresh, clean) if fresh.angle_terms else fresh), tone_hz


def interference_removed(cal: Calibration, state: LoopState, meas: Measurement, tone_hz: float
                         ) -> Measurement | None:
    """The readings with the additive tone at tone_hz taken out: the tone (cos, sin at its frequency) fitted to
    each channel's reading minus `cal`'s waveform at the reference's phase (`cal` run without its canceller). What
    the declared model and the signal-domain terms are calibrated on once fringe_canceller removes the tone in
    the core; None where the channel errors cannot be formed."""
    t = sample_times(len(meas), meas.t_s)
    x = np.column_stack([np.ones_like(t), np.cos(2 * np.pi * tone_hz * t), np.sin(2 * np.pi * tone_hz * t)])
    e = channel_errors(evaluate(LoopState(dataclasses.replace(cal, canceller={}), state.artefacts, state.ref_lag_s),
                                meas))
    if e is None:
        return None
    w, *_ = np.linalg.lstsq(x, e.T, rcond=None)
    tone = x[:, 1:] @ w[1:]          # the offsets stay in the readings: the waveform fit has its own
    return dataclasses.replace(meas, sin=meas.sin - tone[:, 0], cos=meas.cos - tone[:, 1])


def refit_around_tone(cal: Calibration, tones: list[FittedEffect], meas: Measurement, rounds: int = 3) -> Calibration:
    """Re-calibrate the declared model, and refit the closed loop's angle terms, with the tones (in time, fitted on
    this recording) taken out of the reference. The first calibration absorbed part of the tones (its long-period
    table): each round fits them on the residual of the previous round's calibration, which held the previous
    estimate out, until neither takes the other's error. The angle terms are refitted with it
    (refit_angle_terms): a declared model calibrated again without their error held out would take part of it,
    and the terms would then correct it twice."""
    t = sample_times(len(meas), meas.t_s)
    x = np.column_stack([np.cos(2 * np.pi * tone.tone_hz * t) for tone in tones]
                        + [np.sin(2 * np.pi * tone.tone_hz * t) for tone in tones])
    x = x - x.mean(0)
    current = cal
    for _ in range(rounds):
        res = run_float(current, meas.sin, meas.cos, meas.coarse, meas.t_s)
        r = error_arcsec(res.angle_deg, meas.ref_deg)
        w = tone_weights(x, r - r.mean(), current, res.position / cal.encoder.lines_per_rev)
        # r = angle - reference: the reference plus the tone leaves the residual without it
        quiet = dataclasses.replace(meas, ref_deg=np.mod(meas.ref_deg + (x @ w) / 3600.0, 360.0))
        if cal.angle_terms:
            current = refit_angle_terms(current, quiet, rounds=1)
        else:
            current = carry_loop(recalibrate(quiet, cal), cal)
    return current


def tone_weights(x: np.ndarray, r: np.ndarray, cal: Calibration, rev: np.ndarray) -> np.ndarray:
    """The tones' weights in r (columns x), estimated beside the long-period table's harmonics (tones.lp_basis):
    the table fitted on the same recording took part of a vibration at a nearly steady speed, and what it left
    gives too small a tone (new draw 9408: 7.3" of 11.8"). Where the tones' columns lie within the table's span
    (tones.TONE_APART: the speed hardly changed), on r alone."""
    from .tones import TONE_APART, apart_share

    q = lp_basis(cal, 2 * np.pi * (rev % 1.0))
    if q is not None and apart_share(x, q) >= TONE_APART:
        w, *_ = np.linalg.lstsq(x - q @ (q.T @ x), r - q @ (q.T @ r), rcond=None)
        return w
    w, *_ = np.linalg.lstsq(x, r, rcond=None)
    return w


def fit_rev_offset_gain(cal: Calibration, meas: Measurement, rounds: int = 2) -> Calibration:
    """Signal-domain fit: offsets and gains over the revolution against the reference's phase, then the
    declared model re-calibrated on the normalised signals (its waveform was biased by the effect)."""
    from ..calib.calibrate import reference_phase
    from ..dsp.effects import fit_rev_normalisation

    new = cal
    for _ in range(rounds):
        res = run_float(new, meas.sin, meas.cos, meas.coarse, meas.t_s)
        rev = res.position / cal.encoder.lines_per_rev
        raw_norm = new.rev_norm
        # without a long-period table (calibrate found none) the reference's phase needs no correction
        phi = reference_phase(new if new.long_period is not None else
                              dataclasses.replace(new, long_period=np.zeros_like), meas, rev)
        psi = 2 * np.pi * (rev % 1.0)
        if cal.adaptive:
            # the core's drift tracker sits in front and follows part of them: the map takes out what it leaves
            # (pipeline.fine_phase); the declared model stays, the tracker's forward tables are made from it
            ys, yc = tracked_readings(new, meas.sin, meas.cos)
            norm = fit_rev_normalisation(new.waves, ys, yc, phi, psi) if raw_norm is None else \
                _compose(raw_norm, fit_rev_normalisation(new.waves, *raw_norm.apply(ys, yc, psi), phi, psi))
            new = dataclasses.replace(new, rev_norm=norm)
            continue
        norm = fit_rev_normalisation(new.waves, meas.sin, meas.cos, phi, psi) if raw_norm is None else \
            _compose(raw_norm, fit_rev_normalisation(new.waves, *raw_norm.apply(meas.sin, meas.cos, psi), phi, psi))
        s, c = norm.apply(meas.sin, meas.cos, psi)
        fresh = recalibrate(dataclasses.replace(meas, sin=s, cos=c), cal)
        # the map fitted on the normalised readings, not cal's from the readings before: carried over, it undid the
        # normalisation's fit (held-out 9212: fit data 58" -> 201"; with its own map 44"). (Everywhere else the loop
        # keeps carrying the map over: taking the fresh one in the lag's and the canceller's refits as well gained
        # accuracy on held-out 9250, 9256 but named a lag beside large skews: 76.7 % -> 71.7 % names right)
        new = carry_loop(fresh, cal, rev_norm=norm, angle_terms=with_own_fine_map(fresh, cal))
    return new


def joint_fit(r: np.ndarray, ctx: Context, terms: list[FittedEffect], gain: np.ndarray | None = None
              ) -> np.ndarray:
    """Least squares of r on the terms' columns together (test_terms: blockwise normal equations, no design matrix
    of the whole recording held), each column times `gain` (per sample: how much of a correction reaches the
    output, terms_gain) where given."""
    def design(sl):
        x = np.column_stack([_design(t.name, ctx.rows(sl), t.tone_hz) for t in terms])
        return x if gain is None else x * gain[sl, None]
    return test_terms(r, design, 1.0, "joint").weights


def terms_gain(cal: Calibration, ctx: Context) -> np.ndarray | None:
    """How much of an angle term's correction reaches the output angle, per sample: fringe_trim corrects the
    position before the long-period table, which is then read where the corrected position lies, so a
    correction c comes out as c (1 - LP'(psi)) to first order (LP' its slope in arcsec per arcsec of the
    revolution). A long-period table fitted with many orders on a slow recording can be steep: 4 % there made
    the terms' joint refit on the fit data miss by 4.4" RMS on 9252 (held out), more than the term it added
    explains. None without a table."""
    if cal.long_period is None:
        return None
    return 1.0 - cal.long_period.slope(ctx.psi) * (2 * np.pi / ARCSEC_PER_REV)


def refit_angle_terms(cal: Calibration, meas: Measurement, rounds: int = 2, as_is: bool = False) -> Calibration:
    """Re-calibrate the declared model with the terms' error held out of it, then refit the terms
    jointly on what the declared model leaves: neither absorbs the other's error.

    The core's terms come first: the declared model holds out only their error, and they are fitted together;
    the terms only the float engine runs are then fitted on what is left. Fitted all together, a float-only
    term (speed^2 over a narrow speed range is nearly a constant plus a speed term) would trade weight with the
    core's terms, and the core, which runs without it, would be left with the other half of the trade.

    The rounds alternate between two fits that do not minimise the same error (the phase table's conic comes
    from the channels' fundamentals, its centre from the gain changes), so they need not converge: on a gain
    that changes over the revolution (held-out 9252) each round grew the fine-phase map and the error on the
    fit data with it. Of the terms refitted after each round, the one with the least error on the fit data is
    kept; with `as_is`, also the terms refitted on cal's declared model as it is, where that is the loop's state
    (itself calibrated on these readings with the earlier terms held out). Not a fresh calibration that held no
    terms out (it took part of their error, and they would correct it twice: on held-out 9248, a canceller's
    re-calibration, it fitted the data better and validated 3.78x -> 4.71x the floor)."""
    terms = list(cal.angle_terms)
    in_core = [t.engine != "float" for t in terms]

    def fitted_on(base: Calibration, ctx) -> Calibration:
        """base with the terms refitted on what it leaves (core terms first, then the float engine's)."""
        new = list(terms)
        r = error_arcsec(run_float(base, meas.sin, meas.cos, meas.coarse, meas.t_s).angle_deg, meas.ref_deg)
        gain = terms_gain(base, ctx)
        for group in (True, False):
            idx = [k for k, c in enumerate(in_core) if c == group]
            if not idx:
                continue
            w = joint_fit(r, ctx, [new[k] for k in idx], gain)
            widths = [len(new[k].weights) for k in idx]
            for k, ww in zip(idx, np.split(w, np.cumsum(widths)[:-1]), strict=True):
                new[k] = dataclasses.replace(new[k], weights=ww)
            r = r - sum(new[k].predict(ctx) for k in idx) * (1.0 if gain is None else gain)
        return dataclasses.replace(base, angle_terms=new)

    def core_context(c: Calibration):
        # the context as the core sees it: without the float engine's terms
        core = [t for t, k in zip(c.angle_terms, in_core, strict=True) if k]
        res = run_float(dataclasses.replace(c, angle_terms=core), meas.sin, meas.cos, meas.coarse, meas.t_s)
        ctx = covered(make_context(res.frac, res.position, c.encoder.lines_per_rev,
                                   sample_times(len(res.frac), meas.t_s), res.magnitude, c.start_speed_rev_s,
                                   c.magnitude_smooth_log2, c.speed_window_log2))
        return ctx, core

    def error_rms(c: Calibration) -> float:
        e = error_arcsec(run_float(c, meas.sin, meas.cos, meas.coarse, meas.t_s).angle_deg, meas.ref_deg)
        return float(np.std(e))

    candidates = [fitted_on(dataclasses.replace(cal, angle_terms=[]), core_context(cal)[0])] if as_is else []
    for _ in range(rounds):
        ctx, core = core_context(cal)
        # output frame -> encoder frame
        known = cal.direction * sum(t.predict(ctx) for t in core) if core else None
        base = carry_loop(recalibrate(meas, cal, known), cal, angle_terms=[])
        cal = fitted_on(base, ctx)
        terms = list(cal.angle_terms)
        candidates.append(cal)
    return candidates[0] if len(candidates) == 1 else min(candidates, key=error_rms)


def _compose(first, second):
    """Normalisations applied one after the other, to first order in the (small) weights."""
    from ..dsp.effects import RevNormalisation
    return RevNormalisation({k: (first.weights[k][0] + second.weights[k][0], first.weights[k][1] + second.weights[k][1])
                             for k in ("sin", "cos")})
