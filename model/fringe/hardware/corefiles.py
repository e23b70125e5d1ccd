"""The core files of a calibration: CAL_DIR/core.json (the core configuration, `core_config`) and the
ROM images of its tables (CAL_DIR/rom/)."""

import dataclasses
import json
import os

import numpy as np

from ..dsp.calibration import Calibration, cancel_gear_offset
from ..dsp.canceller_float import TONE_MAX_LOG2
from ..encoder import ARCSEC_PER_REV
from ..errors import FringeInputError
from ..fixed import long_period as lp_mod
from ..fixed.config import CoreConfig, current_field_names, long_period_params
from .closed_loop import drift_config, trim_config, unsupported
from .rom import render_roms, write_rendered
from .tables import build_tables

CORE_JSON = "core.json"
ROM_DIR = "rom"


def core_config(cal: Calibration, cal_dir: str | None = None, **overrides):
    """The core configuration of a calibration: CAL_DIR/core.json if present, else the defaults. A core.json of
    an earlier version is read under today's field names (config.RENAMED_FIELDS: e.g. its speed_log2 is
    trim_speed_log2); core.json is written with today's names only."""
    base = saved_core_fields(cal, cal_dir)
    base.update(overrides)
    try:
        cfg = CoreConfig.for_encoder(cal.encoder, **base)
        if "trim" not in base:     # closed-loop corrections switch fringe_trim on, with gains sized for them
            cfg = trim_config(cal, cfg)
        if "drift" not in base:    # and the drift tracker (fringe_drift_normaliser, _observer)
            cfg = drift_config(cal, cfg)
        if "cancel" not in base and cal.canceller:    # and the interference canceller fringe_canceller
            cfg = cancel_config(cal, cfg)
        if "lp_w" not in base and "lp_frac" not in base:    # the long-period table's format from its values
            cfg = long_period_config(cal, cfg)
        return cfg
    except (TypeError, ValueError) as e:
        where = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in overrides.items()) or \
            (os.path.join(cal_dir, CORE_JSON) if base else "core configuration")
        raise FringeInputError(f"core configuration not possible: {e}", where) from None


def tracker_config(cal: Calibration) -> CoreConfig:
    """The core configuration as far as the drift tracker's float twin reads it (the encoder's defaults, the tracker
    switched on with its constants and table formats): fringe_trim's, the canceller's and the long-period table's
    formats do not enter the tracker, and sizing fringe_trim's tables is most of core_config's time."""
    try:
        return drift_config(cal, CoreConfig.for_encoder(cal.encoder))
    except (TypeError, ValueError) as e:
        raise FringeInputError(f"core configuration not possible: {e}", "core configuration") from None


def saved_core_fields(cal: Calibration, cal_dir: str | None) -> dict:
    """CAL_DIR/core.json's configuration fields (none without the file), checked against the calibration's
    encoder: a folder whose two files describe different encoders is refused, whatever the engine."""
    path = os.path.join(cal_dir, CORE_JSON) if cal_dir else None
    if not (path and os.path.exists(path)):
        return {}
    try:
        with open(path, encoding="utf-8") as f:
            saved = json.load(f)
        if not isinstance(saved, dict):
            raise ValueError(f"the file holds a JSON {type(saved).__name__}, not an object")
        base = current_field_names(saved["config"])
    except (OSError, ValueError, KeyError) as e:
        raise FringeInputError(f"core configuration damaged ({e})", path) from None
    enc = cal.encoder    # the encoder's description is the one source of these
    for key, value in (("adc_w", enc.adc_bits), ("lines", enc.lines_per_rev), ("coarse_w", enc.coarse_bits)):
        if key in base and base[key] != value:
            raise FringeInputError(f"'{key}' = {base[key]!r} disagrees with the calibration's encoder "
                                   f"({value}): the folder is mixed", path)
    return base


def cancel_config(cal: Calibration, cfg: CoreConfig) -> CoreConfig:
    """cfg with fringe_canceller on, its constants the calibration's, its coefficients able to hold a tone of up
    to 2^TONE_MAX_LOG2 of the calibrated radius (A_W = WAVE_W + A_FRAC - 1 + TONE_MAX_LOG2), as the float twin's."""
    return dataclasses.replace(cfg, cancel=1, cancel_a_w=min(32, cfg.wave_w + cfg.cancel_a_frac - 1 + TONE_MAX_LOG2),
                               cancel_gear_offset=cancel_gear_offset(cal.canceller),
                               **{k: cal.canceller[k] for k in ("cancel_block_log2", "cancel_mu_log2")})


MAX_LP_W = 24     # the widest long-period table word chosen for a calibration (fringe_long_period accepts 32)


def long_period_config(cal: Calibration, cfg: CoreConfig) -> CoreConfig:
    """cfg with the long-period table's format chosen for this calibration: at the configured LP_W the most
    fraction bits (LP_FRAC, from the configured value down to 0) with which every value and slope fits, a wider
    LP_W (up to MAX_LP_W) only when none does. Each choice is checked by building the table; unchanged when the
    calibration has no long-period correction or it fits as configured. ValueError when nothing fits."""
    if cal.long_period is None:
        return cfg
    counts = cfg.rev / ARCSEC_PER_REV
    last = None
    for width in range(cfg.lp_w, max(cfg.lp_w, MAX_LP_W) + 1):
        for frac in range(cfg.lp_frac, -1, -1):
            try:
                trial = dataclasses.replace(cfg, lp_w=width, lp_frac=frac)
                lp_mod.make_table(lambda pos: cal.long_period(2 * np.pi * pos / cfg.rev) * counts,
                                  long_period_params(trial))
                return trial
            except ValueError as e:
                last = e
    raise ValueError(f"{last}: the long-period correction does not fit at any LP_W <= {MAX_LP_W}")


def write_core_roms(cal: Calibration, cfg, out_dir: str, formats, command: str, inputs=(),
                    where: str = "core configuration") -> list[str]:
    """ROM images; a table that does not fit the configuration is named against `where` (its source)."""
    try:
        tables = build_tables(cal, cfg)
        images = render_roms(tables, cfg, formats, command)
    except ValueError as e:
        raise FringeInputError(str(e), where) from None
    return write_rendered(images, out_dir, command, inputs)


def core_files(cal: Calibration, command: str) -> dict:
    """Writers for CAL_DIR: the default core configuration and its ROM images (.mem)."""
    cfg = core_config(cal)

    def write_json(path):
        with open(path, "w", encoding="utf-8") as f:
            json.dump({"config": cfg.to_dict(), "hdl_parameters": cfg.hdl_parameters()}, f, indent=2, sort_keys=True)
            f.write("\n")

    files = {CORE_JSON: write_json}
    if not unsupported(cal):      # a correction the core does not carry: no ROM images (float engine only)
        files[ROM_DIR] = lambda path: write_core_roms(cal, cfg, path, ("mem",), command, where="the calibration")
    return files
