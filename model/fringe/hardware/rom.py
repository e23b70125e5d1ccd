"""ROM images for synthesis (`fringe rom`): .mem ($readmemh), Intel .mif, Xilinx .coe, VHDL package.

Every image holds bank 0 then bank 1 (both loaded with the same calibration), every word is
range-checked before anything is written, and the output is deterministic: a header names the
command, the configuration and the format, never a date.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from .. import __version__
from ..fixed import canceller as cancel_mod
from ..fixed import drift as drift_mod
from ..fixed import long_period as lp_mod
from ..fixed import trim as trim_mod
from ..fixed import wave_lut as wave_mod
from ..fixed.config import CoreConfig, long_period_params
from ..fixed.core import CoreTables
from ..fixed.regmap import REG_W, REGISTERS, register_words
from ..fixed.table_ram import format_hex
from ..io.outputs import atomic_dir

FORMATS = ("mem", "mif", "coe", "vhdl")


@dataclass
class Image:
    name: str            # file stem, also the VHDL constant name
    words: np.ndarray    # unsigned words, bank 0 then bank 1
    width: int
    what: str


def register_values(t: CoreTables) -> dict[str, int]:
    q = t.quad
    return {"K_SS": q.k_ss, "K_SC": q.k_sc, "K_CC": q.k_cc, "OFS_S": q.ofs_s, "OFS_C": q.ofs_c,
            "MID_S": t.branch_sin[0], "THR_HI_S": t.branch_sin[1], "THR_LO_S": t.branch_sin[2],
            "MID_C": t.branch_cos[0], "THR_HI_C": t.branch_cos[1], "THR_LO_C": t.branch_cos[2],
            "COARSE_OFS": t.coarse_ofs, "ZERO": t.zero, "DIR": t.direction,
            "AMP_LOW": t.amp_low, "AMP_HIGH": t.amp_high,
            "W0_S": 0 if t.drift is None else int(t.drift.w0[0]), "W0_C": 0 if t.drift is None else int(t.drift.w0[1]),
            "KG_S": 0 if t.drift is None else int(t.drift.kg[0]), "KG_C": 0 if t.drift is None else int(t.drift.kg[1]),
            "CANCEL_FREQ": t.cancel_freq}


def images(t: CoreTables, cfg: CoreConfig) -> list[Image]:
    """All table images of a configuration, range-checked."""
    wl = cfg.wave_lut()
    two_banks = lambda w: np.concatenate([w, w]).astype(np.int64)  # noqa: E731
    lpp = long_period_params(cfg)
    out = [
        Image("wave_sin", two_banks(wave_mod.pack_words(t.wave_sin, wl)), wl.word_w,
              "sine waveform inverse {slope, value}, branch 0 then 1"),
        Image("wave_cos", two_banks(wave_mod.pack_words(t.wave_cos, wl)), wl.word_w,
              "cosine waveform inverse {slope, value}, branch 0 then 1"),
        Image("long_period", two_banks(lp_mod.pack_words(t.lp, lpp)), 2 * cfg.lp_w,
              "long-period correction {slope, value} over the revolution"),
        Image("regs", two_banks(register_words(register_values(t), cfg)), REG_W,
              "registers (docs/architecture.md register map)"),
    ]
    if cfg.trim:
        if t.trim is None:
            raise ValueError("TRIM = 1: the core tables hold no fringe_trim tables")
        tp = cfg.trim_params()
        out += [Image("trim_map", two_banks(trim_mod.pack_words(t.trim.map, tp)), tp.word_w,
                      "fringe_trim error map {slope, value} at {dir, sector, bin} (docs/blocks/fringe_trim.md)"),
                Image("trim_speed", two_banks(trim_mod.pack_words(t.trim.speed, tp)), tp.word_w,
                      "fringe_trim speed gain {slope, value} per fine-phase bin"),
                Image("trim_amp", two_banks(trim_mod.pack_words(t.trim.amp, tp)), tp.word_w,
                      "fringe_trim magnitude gain {slope, value} per fine-phase bin")]
    if cfg.drift:
        if t.drift is None:
            raise ValueError("DRIFT = 1: the core tables hold no drift tracker tables")
        dp = cfg.drift_params()
        out += [Image(f"drift_fwd_{k}", two_banks(drift_mod.pack_words(t.drift.fwd[i], dp)), 2 * dp.table_w,
                      f"fringe_drift_observer forward {k} waveform minus its mean {{slope, value}} per fine-phase bin")
                for i, k in enumerate(("sin", "cos"))]
    if cfg.cancel:      # a constant table, one image (not banked)
        cp = cfg.cancel_params()
        out.append(Image("cancel_lut", cancel_mod.sine_table(cp) & ((1 << cp.c_w) - 1), cp.c_w,
                         "fringe_canceller sine table, one turn (not banked: a constant)"))
    return out


def _header(command: str, cfg: CoreConfig, fmt: str, image: Image) -> list[str]:
    return [f"fringe {__version__} rom: {image.what}",
            f"command: {command}",
            f"config: {json.dumps(cfg.to_dict(), sort_keys=True)}",
            f"format: {fmt}, {len(image.words)} words of {image.width} bits (bank 0 then bank 1)"]


def _reg_notes(image: Image) -> list[str]:
    if image.name != "regs":
        return []
    notes = []
    for r in REGISTERS:
        word = int(image.words[r.index])
        notes.append(f"word {r.index}: {r.name} = {_signed(word, REG_W) if r.signed else word} ({r.meaning})")
    return notes


def _signed(v: int, w: int) -> int:
    return v - (1 << w) if v >> (w - 1) else v


def render(image: Image, fmt: str, cfg: CoreConfig, command: str) -> str:
    head = _header(command, cfg, fmt, image) + _reg_notes(image)
    digits = (image.width + 3) // 4
    words = [f"{int(v):0{digits}x}" for v in image.words]
    if fmt == "mem":
        return format_hex(image.words, image.width, head)
    if fmt == "mif":
        lines = [f"-- {h}" for h in head]
        lines += [f"DEPTH = {len(words)};", f"WIDTH = {image.width};", "ADDRESS_RADIX = HEX;",
                  "DATA_RADIX = HEX;", "CONTENT BEGIN"]
        lines += [f"  {i:x} : {w};" for i, w in enumerate(words)]
        return "\n".join(lines + ["END;"]) + "\n"
    if fmt == "coe":
        lines = [f"; {h}" for h in head]
        lines += ["memory_initialization_radix=16;", "memory_initialization_vector="]
        lines += [w + ("," if i < len(words) - 1 else ";") for i, w in enumerate(words)]
        return "\n".join(lines) + "\n"
    raise ValueError(f"unknown format {fmt}")


def vhdl_package(imgs: list[Image], cfg: CoreConfig, command: str) -> str:
    lines = [f"-- fringe {__version__} rom: VHDL package of all table images",
             f"-- command: {command}", f"-- config: {json.dumps(cfg.to_dict(), sort_keys=True)}",
             "library ieee;", "use ieee.std_logic_1164.all;", "", "package fringe_rom_pkg is"]
    for im in imgs:
        lines.append(f"  -- {im.what}")
        lines.append(f"  type {im.name}_rom_t is array (0 to {len(im.words) - 1}) of "
                     f"std_logic_vector({im.width - 1} downto 0);")
        lines.append(f"  constant {im.name.upper()}_ROM : {im.name}_rom_t := (")
        body = [f'    {i} => b"{int(w):0{im.width}b}"' for i, w in enumerate(im.words)]
        lines.append(",\n".join(body))
        lines.append("  );")
    lines.append("end package fringe_rom_pkg;")
    return "\n".join(lines) + "\n"


def render_roms(t: CoreTables, cfg: CoreConfig, formats=("mem",), command: str = "fringe rom") -> dict[str, str]:
    """Every file's text, rendered before anything is written (a range error leaves nothing behind)."""
    imgs = images(t, cfg)
    files = {}
    for fmt in formats:
        if fmt not in FORMATS:
            raise ValueError(f"unknown format '{fmt}' (known: {', '.join(FORMATS)})")
        if fmt == "vhdl":
            files["fringe_rom_pkg.vhd"] = vhdl_package(imgs, cfg, command)
        else:
            for im in imgs:
                files[f"{im.name}.{fmt}"] = render(im, fmt, cfg, command)
    files["core.json"] = json.dumps({"config": cfg.to_dict(), "hdl_parameters": cfg.hdl_parameters(),
                                     "command": command}, indent=2, sort_keys=True) + "\n"
    return files


def write_roms(t: CoreTables, cfg: CoreConfig, out_dir: str, formats=("mem",), command: str = "fringe rom",
               inputs=()) -> list[str]:
    return write_rendered(render_roms(t, cfg, formats, command), out_dir, command, inputs)


def write_rendered(files: dict[str, str], out_dir: str, command: str = "fringe rom", inputs=()) -> list[str]:
    """The rendered files as one ROM folder, moved into place when complete."""
    with atomic_dir(out_dir, "rom", inputs, command) as tmp:
        for name, text in files.items():
            with open(os.path.join(tmp, name), "w", encoding="ascii", newline="\n") as f:
                f.write(text)
    return sorted(files)
