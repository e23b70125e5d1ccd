"""The correction engines behind `fringe correct --engine`, and the core files of a calibration."""

import json
import os

from .dataio import Measurement
from .errors import FringeInputError
from .pipeline import Calibration, Result, run_float

CORE_JSON = "core.json"
ROM_DIR = "rom"


def core_config(cal: Calibration, cal_dir: str | None = None, **overrides):
    """The core configuration of a calibration: CAL_DIR/core.json if present, else the defaults."""
    from .fixed.config import CoreConfig

    base = {}
    path = os.path.join(cal_dir, CORE_JSON) if cal_dir else None
    if path and os.path.exists(path):
        try:
            with open(path, encoding="utf-8") as f:
                base = json.load(f)["config"]
        except (OSError, ValueError, KeyError) as e:
            raise FringeInputError(f"core configuration damaged ({e})", path) from None
        enc = cal.encoder    # the encoder's description is the one source of these
        for key, value in (("adc_w", enc.adc_bits), ("lines", enc.lines_per_rev), ("coarse_w", enc.coarse_bits)):
            if key in base and base[key] != value:
                raise FringeInputError(f"'{key}' = {base[key]!r} disagrees with the calibration's encoder "
                                       f"({value}): the folder is mixed", path)
    base.update(overrides)
    try:
        cfg = CoreConfig.for_encoder(cal.encoder, **base)
        from .fixed.closed_loop import drift_config, trim_config
        if "trim" not in base:     # closed-loop corrections switch fringe_trim on, with gains sized for them
            cfg = trim_config(cal, cfg)
        if "drift" not in base:    # and the drift tracker fringe_drift
            cfg = drift_config(cal, cfg)
        if "lp_w" not in base and "lp_frac" not in base:    # the long-period table's format from its values
            cfg = long_period_config(cal, cfg)
        check_limits(cfg)
        return cfg
    except (TypeError, ValueError) as e:
        where = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in overrides.items()) or path
        raise FringeInputError(f"core configuration not possible: {e}", where or "core configuration") from None


MAX_LP_W = 24     # the widest long-period table word fringe_long_period accepts


def long_period_config(cal: Calibration, cfg):
    """cfg with the long-period table's format chosen for this calibration: at the configured LP_W the most
    fraction bits (LP_FRAC, from the configured value down to 0) with which every value and slope fits, a wider
    LP_W (up to 24) only when none does. Each choice is checked by building the table; unchanged when the
    calibration has no long-period correction or it fits as configured. ValueError when nothing fits."""
    import dataclasses

    import numpy as np

    from .encoder import ARCSEC_PER_REV
    from .fixed import long_period as lp_mod
    from .fixed.core import long_period_params

    if cal.long_period is None:
        return cfg
    counts = cfg.rev / ARCSEC_PER_REV
    last = None
    for width in range(cfg.lp_w, max(cfg.lp_w, MAX_LP_W) + 1):
        for frac in range(cfg.lp_frac, -1, -1):
            trial = dataclasses.replace(cfg, lp_w=width, lp_frac=frac)
            try:
                lp_mod.make_table(lambda pos: cal.long_period(2 * np.pi * pos / cfg.rev) * counts,
                                  long_period_params(trial))
                return trial
            except ValueError as e:
                last = e
    raise ValueError(f"{last}: the long-period correction does not fit at any LP_W <= {MAX_LP_W}")


def check_limits(cfg):
    """ValueError unless every block accepts its parameters (the limits the HDL checks at elaboration)."""
    from .fixed.core import long_period_params, period_count_params

    cfg.wave_lut(), cfg.quadrature(), cfg.cordic(), long_period_params(cfg), period_count_params(cfg)
    if cfg.trim:
        cfg.trim_params()
    if cfg.drift:
        cfg.drift_params()


def write_core_roms(cal: Calibration, cfg, out_dir: str, formats, command: str, inputs=(),
                    where: str = "core configuration") -> list[str]:
    """ROM images; a table that does not fit the configuration is named against `where` (its source)."""
    from .fixed.core import build_tables
    from .rom import render_roms, write_rendered

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

    from .fixed.closed_loop import unsupported

    files = {CORE_JSON: write_json}
    if not unsupported(cal):      # a correction the core does not carry: no ROM images (float engine only)
        files[ROM_DIR] = lambda path: write_core_roms(cal, cfg, path, ("mem",), command, where="the calibration")
    return files


def streamable(name: str, cal: Calibration, cal_dir: str):
    """For the bit-exact model without fringe_drift: a function from one piece of the recording to its
    (angle_deg, status), bit-exact with one run over the whole recording (`fixed.core.CoreStream`);
    else None (the engine runs on the whole recording at once)."""
    from .fixed.closed_loop import unsupported

    if name != "model" or unsupported(cal):
        return None
    cfg = core_config(cal, cal_dir)
    if cfg.drift:
        return None
    from .fixed.core import CoreStream, build_tables, to_adc_codes

    try:
        stream = CoreStream(build_tables(cal, cfg), cfg)
    except ValueError as e:
        raise FringeInputError(str(e), cal_dir) from None

    def step(m: Measurement):
        try:
            pos, status = stream.run(to_adc_codes(m.sin, cfg.adc_w, "sin"), to_adc_codes(m.cos, cfg.adc_w, "cos"),
                                     m.coarse)
        except ValueError as e:
            raise FringeInputError(str(e), m.path) from None
        return pos * (360.0 / cfg.rev), status

    return step


def run_engine(name: str, cal: Calibration, meas: Measurement, cal_dir: str) -> Result:
    if name == "float":
        return run_float(cal, meas.sin, meas.cos, meas.coarse, meas.t_s)
    from .fixed.closed_loop import unsupported
    from .fixed.core import run_model

    if unsupported(cal):
        raise FringeInputError("this calibration carries closed-loop corrections that the bit-exact core does not "
                               f"implement ({', '.join(unsupported(cal))}): use --engine float", cal_dir)
    cfg = core_config(cal, cal_dir)
    from .fixed.core import build_tables

    try:                       # a calibration the core cannot hold is the calibration's fault, not the data's
        tables = build_tables(cal, cfg)
    except ValueError as e:
        raise FringeInputError(str(e), cal_dir) from None
    try:
        if name == "model":
            return run_model(cal, cfg, meas.sin, meas.cos, meas.coarse, tables=tables)
    except ValueError as e:
        raise FringeInputError(str(e), meas.path) from None
    from .rtlsim import RtlSimulationError, run_rtl_result

    try:
        return run_rtl_result(cal, cfg, meas.sin, meas.cos, meas.coarse, name)
    except ValueError as e:
        raise FringeInputError(str(e), meas.path) from None
    except RtlSimulationError as e:
        raise FringeInputError(f"the {name} simulation failed: {str(e).splitlines()[0]}", "--engine") from None
