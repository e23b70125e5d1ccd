"""The core files of a calibration: CAL_DIR/core.json (the core configuration, `core_config`) and the
ROM images of its tables (CAL_DIR/rom/)."""

import json
import os

from ..calibration import Calibration
from ..errors import FringeInputError
from ..fixed.config import CoreConfig
from .closed_loop import drift_config, trim_config, unsupported
from .rom import render_roms, write_rendered
from .tables import build_tables

CORE_JSON = "core.json"
ROM_DIR = "rom"


def core_config(cal: Calibration, cal_dir: str | None = None, **overrides):
    """The core configuration of a calibration: CAL_DIR/core.json if present, else the defaults."""
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
        if "trim" not in base:     # closed-loop corrections switch fringe_trim on, with gains sized for them
            cfg = trim_config(cal, cfg)
        if "drift" not in base:    # and the drift tracker fringe_drift
            cfg = drift_config(cal, cfg)
        return cfg
    except (TypeError, ValueError) as e:
        where = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in overrides.items()) or path
        raise FringeInputError(f"core configuration not possible: {e}", where or "core configuration") from None


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
