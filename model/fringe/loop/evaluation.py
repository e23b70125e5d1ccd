"""A calibration judged on a recording: the loop's state (the calibration and the measurement artefacts taken out of
the score), the residual it leaves (`evaluate`) and the error figures reported before and after
(`validation_figures`, in blocks on a long recording). The rest of the loop builds on these."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..dsp.calibration import Calibration
from ..dsp.effects import (
    LIBRARY,
    Context,
    FittedEffect,
    generic_design,
    interference_columns,
    make_context,
    tone_columns,
)
from ..dsp.metrics import error_arcsec, error_figures
from ..dsp.position import shifted, without_slips
from ..encoder import ARCSEC_PER_REV
from ..engine.pipeline import run_float, run_starts, sample_times
from ..io.dataio import Measurement
from .motion import reference_motion


@dataclass
class Evaluation:
    r: np.ndarray            # residual (arcsec), artefacts compensated
    ctx: Context
    figures: dict
    rms: float
    meas: Measurement | None = None     # the recording (its channels for the channel-domain tests)
    cal: Calibration | None = None
    ref_speed: np.ndarray | None = None  # the reference's speed over one electrical period (reference_motion)


@dataclass
class LoopState:
    cal: Calibration
    artefacts: list[FittedEffect] = field(default_factory=list)   # compensated in the evaluation only
    ref_lag_s: float = 0.0        # the reference's lag behind the ADC (a measurement artefact)


def shift_reference(meas: Measurement, lag_s: float) -> Measurement:
    """The reference as it would read if sampled with the ADC: ref(t + lag), on the unwrapped angle."""
    if not lag_s:
        return meas
    t = sample_times(len(meas), meas.t_s)
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(meas.ref_deg)))
    return dataclasses.replace(meas, ref_deg=np.mod(shifted(t, unwrapped, lag_s, span=16), 360.0))


REVOLUTION_SECTORS = 64     # a recording covers the revolution when it visits every one of these sectors


def covered(ctx: Context) -> Context:
    """ctx marked with whether the recording covers the revolution (as the long-period fit requires): terms over
    the revolution are fitted only where it does."""
    sectors = np.unique(np.floor(np.mod(ctx.psi, 2 * np.pi) / (2 * np.pi) * REVOLUTION_SECTORS).astype(int))
    return dataclasses.replace(ctx, revolution_covered=len(sectors) >= REVOLUTION_SECTORS)


def unslipped(r: np.ndarray, cal: Calibration, meas: Measurement) -> np.ndarray:
    """The error without the whole periods an incremental encoder's count slipped by across the holes of rows taken
    out of a recording (the loop's interleaved halves): across a hole the motion is unknown to it, and a fast one
    (a 32-row hole at 0.02 periods a row) moves it by more than it can follow. Within a run of consecutive rows a
    slip is the encoder's own error and stays."""
    lines = cal.encoder.lines_per_rev
    starts = run_starts(meas.t_s, len(r))
    if lines == 1 or (cal.encoder.coarse_bits and meas.coarse is not None) or starts is None or not starts.any():
        return r
    return without_slips(r, ARCSEC_PER_REV / lines, at=starts)


def evaluate(state: LoopState, meas: Measurement, res=None) -> Evaluation:
    """The residual of `meas` through state.cal (or `res`, another engine's result for `meas`), with
    the measurement artefacts compensated."""
    meas = shift_reference(meas, state.ref_lag_s)
    if res is None:
        res = run_float(state.cal, meas.sin, meas.cos, meas.coarse, meas.t_s)
    r = unslipped(error_arcsec(res.angle_deg, meas.ref_deg), state.cal, meas)
    ctx = covered(make_context(res.frac, res.position, state.cal.encoder.lines_per_rev,
                               sample_times(len(r), meas.t_s), res.magnitude, state.cal.start_speed_rev_s,
                               state.cal.magnitude_smooth_log2, state.cal.speed_window_log2))
    for art in state.artefacts:
        x = _design(art.name, ctx, art.tone_hz)
        x = x - x.mean(0)
        if art.name == "tone":
            # a tone's phase does not repeat between recordings, but a vibration's does within one: fitted on
            # each half and taken out of the other (a structure that only resembles a line, as a slowly
            # modulated fine-phase error at a steady speed, does not carry over, and is not credited)
            r = r - halves_cross_fit(x, r - r.mean())
            continue
        r = r - x @ art.weights          # everything else must repeat: the weights fitted on the fit data
    r = r - r.mean()
    fig = error_figures(r, res.frac, res.position / state.cal.encoder.lines_per_rev).to_dict()
    return Evaluation(r, ctx, fig, float(np.sqrt(np.mean(r * r))), meas, state.cal, reference_motion(meas, ctx))


def leans_on_vibrations(state: LoopState, trial: LoopState, meas: Measurement) -> bool:
    """Whether a correction the core makes (trial over state) fails to lower the error on `meas` once the vibration
    tones are left in the score. The tones are taken out of the score alone (a vibration between encoder and
    reference is the set-up's), so a term that only helps beside them models the tones, not the encoder: on a real
    Hall encoder a magnitude term took 1" off beside two tones near 249 Hz and added 7" to the core's output."""
    if not any(a.name == "tone" for a in trial.artefacts):
        return False
    def plain(s: LoopState) -> LoopState:
        return LoopState(s.cal, [a for a in s.artefacts if a.name != "tone"], s.ref_lag_s)
    return evaluate(plain(trial), meas).rms >= evaluate(plain(state), meas).rms


def cross_fit(x: np.ndarray, y: np.ndarray, blocks: int) -> np.ndarray:
    """x @ w for every row with w fitted on the other fold: the rows cut into `blocks` consecutive blocks, the
    folds every other block (2: two contiguous halves). No row's own value is in its fit."""
    fold = (np.arange(len(y)) * blocks // max(len(y), 1)) % 2
    out = np.empty(len(y))
    for f in (0, 1):
        w, *_ = np.linalg.lstsq(x[fold != f], y[fold != f], rcond=None)
        out[fold == f] = x[fold == f] @ w
    return out


def halves_cross_fit(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    """x @ w with w fitted on the other half of the rows (two contiguous halves)."""
    return cross_fit(x, r, 2)


def _design(name: str, ctx: Context, tone_hz: float = 0.0) -> np.ndarray:
    if name == "tone":
        return tone_columns(ctx, tone_hz)
    if name == "interference":
        return interference_columns(ctx, tone_hz)
    if name.startswith("generic:"):
        return generic_design(name, ctx)
    return LIBRARY[name].design(ctx)


EVAL_ROWS = 1 << 18      # the error before and after on a long validation recording: evaluated this many rows at
EVAL_LEAD = 1 << 14      # a time, each block run in from this many rows before it (speed window, drift tracker)


def _uses_time(state: LoopState) -> bool:
    return any(t.name.startswith("generic:time:") for t in state.cal.angle_terms + state.artefacts)


def validation_figures(state: LoopState, meas: Measurement) -> dict:
    """The error figures of `meas` through the state, in blocks of EVAL_ROWS rows (bounded memory however long
    the recording). Each block is run in from the EVAL_LEAD rows before it and joined to the previous block on
    the second half of that overlap, where both see the same samples with settled state: an incremental
    encoder's period count restarts with every block, and each block's mean is its own, so the offset is taken
    out there, and the figures are those of the whole recording as one."""
    n = len(meas)
    if n <= EVAL_ROWS + EVAL_LEAD or _uses_time(state):
        return _figs(evaluate(state, meas))
    r, frac, rev = np.empty(n), np.empty(n), np.empty(n)
    for start in range(0, n, EVAL_ROWS):
        a, b = max(0, start - EVAL_LEAD), min(n, start + EVAL_ROWS)
        sub = meas.subset(slice(a, b))
        if meas.t_s is None:     # the rows' own numbers as time, as for the whole recording
            sub = dataclasses.replace(sub, t_s=np.arange(a, b, dtype=float))
        ev = evaluate(state, sub)
        block = ev.r
        if start:
            join = slice(start - EVAL_LEAD // 2, start)
            block = block - float(np.median(block[join.start - a:join.stop - a] - r[join]))
        r[start:b], frac[start:b] = block[start - a:], ev.ctx.phi[start - a:] / (2 * np.pi)
        rev[start:b] = ev.ctx.psi[start - a:] / (2 * np.pi)
    r -= r.mean()
    return _report_figures(r, error_figures(r, frac, rev).to_dict())


def _report_figures(r: np.ndarray, figures: dict) -> dict:
    return {"rms_arcsec": round(float(np.sqrt(np.mean(r * r))), 4), "pp_arcsec": round(float(np.ptp(r)), 4),
            "interp_pp_arcsec": figures["interp_pp_arcsec"], "lp_pp_arcsec": figures["lp_pp_arcsec"]}


def _figs(ev: Evaluation) -> dict:
    return _report_figures(ev.r, ev.figures)
