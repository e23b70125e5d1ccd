"""The encoder description (spec section 2): what the hardware is, not how it errs."""

import json
import math
from dataclasses import asdict, dataclass

from .errors import FringeInputError

ARCSEC_PER_REV = 360.0 * 3600.0


@dataclass(frozen=True)
class Encoder:
    lines_per_rev: int           # signal periods per revolution, >= 1
    adc_bits: int                # ADC width; codes -2^(adc_bits-1) .. 2^(adc_bits-1)-1
    coarse_bits: int = 0         # coarse (absolute) code width; 0 = none, count periods
    full_scale: float | None = None  # reading that means ADC full scale, for float data
    offset_binary: bool = False      # codes are unsigned 0 .. 2^adc_bits-1 (mid-scale = zero), as loggers write

    @property
    def adc_half_range(self) -> int:
        return 1 << (self.adc_bits - 1)

    @property
    def reading_full_scale(self) -> float:
        return float(self.full_scale) if self.full_scale is not None else float(self.adc_half_range)

    @property
    def period_arcsec(self) -> float:
        return ARCSEC_PER_REV / self.lines_per_rev

    def to_dict(self) -> dict:
        d = asdict(self)
        if d["full_scale"] is None:
            del d["full_scale"]
        if not d["offset_binary"]:
            del d["offset_binary"]
        return d

    def validate(self, where: str = "encoder") -> "Encoder":
        def bad(field, problem):
            raise FringeInputError(f"'{field}' {problem}", where)

        if not _is_int(self.lines_per_rev) or self.lines_per_rev < 1:
            bad("lines_per_rev", f"must be an integer >= 1, got {self.lines_per_rev!r}")
        if self.lines_per_rev > (1 << 24):
            bad("lines_per_rev", f"must be <= 2^24, got {self.lines_per_rev}")
        if not _is_int(self.adc_bits) or not 4 <= self.adc_bits <= 24:
            bad("adc_bits", f"must be an integer from 4 to 24, got {self.adc_bits!r}")
        if not _is_int(self.coarse_bits) or not 0 <= self.coarse_bits <= 24:
            bad("coarse_bits", f"must be an integer from 0 to 24, got {self.coarse_bits!r}")
        if self.coarse_bits and (1 << self.coarse_bits) < self.lines_per_rev:
            bad("coarse_bits", f"= {self.coarse_bits} cannot number {self.lines_per_rev} periods "
                "(needs 2^coarse_bits >= lines_per_rev)")
        if self.full_scale is not None:
            fs = self.full_scale
            if isinstance(fs, bool) or not isinstance(fs, (int, float)) or not math.isfinite(fs) or fs <= 0:
                bad("full_scale", f"must be a positive finite number, got {fs!r}")
        if not isinstance(self.offset_binary, bool):
            bad("offset_binary", f"must be true or false, got {self.offset_binary!r}")
        if self.offset_binary and self.full_scale is not None:
            bad("offset_binary", "applies to integer ADC codes and cannot be combined with full_scale")
        return self


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


KNOWN_KEYS = {"lines_per_rev", "adc_bits", "coarse_bits", "full_scale", "offset_binary"}
IGNORED_KEYS = {"written_by", "comment"}   # information for people: which command wrote the file


def encoder_from_dict(d: dict, where: str = "encoder") -> Encoder:
    if not isinstance(d, dict):
        raise FringeInputError("must be a JSON object", where)
    for key in ("lines_per_rev", "adc_bits"):
        if key not in d:
            raise FringeInputError(f"missing required key '{key}'", where)
    unknown = set(d) - KNOWN_KEYS - IGNORED_KEYS
    if unknown:
        raise FringeInputError(f"unknown key(s) {', '.join(sorted(unknown))} "
                               f"(known: {', '.join(sorted(KNOWN_KEYS))})", where)
    return Encoder(lines_per_rev=d["lines_per_rev"], adc_bits=d["adc_bits"],
                   coarse_bits=d.get("coarse_bits", 0), full_scale=d.get("full_scale"),
                   offset_binary=d.get("offset_binary", False)).validate(where)


def load_encoder(path: str) -> Encoder:
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_ENCODER_BYTES + 1)
    except OSError as e:
        raise FringeInputError(f"cannot read encoder description: {e.strerror}", path) from None
    if len(raw) > MAX_ENCODER_BYTES:
        raise FringeInputError(f"too large for an encoder description (over {MAX_ENCODER_BYTES} bytes)", path)
    try:
        text = raw.decode("utf-8-sig")        # a byte-order mark (Windows editors write one) is fine
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        raise FringeInputError("not a text (UTF-8) JSON file", path, f"line {line}") from None
    if not text.strip():
        raise FringeInputError("empty file: expected a JSON object such as "
                               '{"lines_per_rev": 256, "adc_bits": 12}', path)
    try:
        d = json.loads(text, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as e:
        raise FringeInputError(f"not valid JSON: {e.msg}", path, f"line {e.lineno}") from None
    except _DuplicateKey as e:
        raise FringeInputError(f"key '{e.args[0]}' is given twice: say it once", path) from None
    except RecursionError:
        raise FringeInputError("not an encoder description: nested too deeply", path) from None
    return encoder_from_dict(d, path)


MAX_ENCODER_BYTES = 1 << 20


class _DuplicateKey(ValueError):
    pass


def _unique_keys(pairs):
    d = {}
    for k, v in pairs:
        if k in d:
            raise _DuplicateKey(k)
        d[k] = v
    return d
