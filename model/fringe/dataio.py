"""Measured-data CSV (spec section 1): strict reading, atomic writing."""

import csv
import io
import os
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from .encoder import Encoder
from .errors import FringeInputError

REQUIRED = ("sin", "cos")
OPTIONAL = ("coarse", "ref_deg", "t_s")


@dataclass
class Measurement:
    """One recording. sin/cos are in ADC counts (float), whatever the file's units."""

    path: str
    sin: np.ndarray
    cos: np.ndarray
    coarse: np.ndarray | None = None   # int64
    ref_deg: np.ndarray | None = None
    t_s: np.ndarray | None = None
    comments: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.sin)

    def subset(self, mask_or_index) -> "Measurement":
        pick = lambda a: None if a is None else a[mask_or_index]  # noqa: E731
        return Measurement(self.path, self.sin[mask_or_index], self.cos[mask_or_index],
                           pick(self.coarse), pick(self.ref_deg), pick(self.t_s), self.comments)


def read_measurement(path: str, encoder: Encoder | None = None, min_samples: int = 1) -> Measurement:
    """Read and check a recording; every problem is a FringeInputError naming file and line."""
    try:
        with open(path, encoding="utf-8", newline="") as f:
            text = f.read()
    except OSError as e:
        raise FringeInputError(f"cannot read data file: {e.strerror}", path) from None
    except UnicodeDecodeError:
        raise FringeInputError("not a text (UTF-8) CSV file", path) from None

    lines = text.splitlines()
    comments, header_line = [], None
    for i, line in enumerate(lines):
        if line.lstrip().startswith("#"):
            comments.append(line.lstrip()[1:].strip())
            continue
        if line.strip():
            header_line = i
            break
    if header_line is None:
        raise FringeInputError("empty file: no header row", path)

    header = [h.strip() for h in next(csv.reader([lines[header_line]]))]
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        hint = _close_names(missing, header)
        raise FringeInputError(f"missing required column(s) {', '.join(missing)}{hint} "
                               f"(header has: {', '.join(header)})", path, f"line {header_line + 1}")
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise FringeInputError(f"duplicate column(s) {', '.join(dup)}", path, f"line {header_line + 1}")

    wanted = [c for c in REQUIRED + OPTIONAL if c in header]
    col_index = [header.index(c) for c in wanted]
    body = [(i + 1, ln) for i, ln in enumerate(lines[header_line + 1:], start=header_line + 1)
            if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise FringeInputError("no data rows after the header", path, f"line {header_line + 1}")

    line_of = np.array([b[0] for b in body])
    try:  # fast path: numpy's C parser; on any failure the slow path finds the line
        values = np.loadtxt(io.StringIO("\n".join(b[1] for b in body)), delimiter=",",
                            usecols=col_index, ndmin=2, comments=None)
        if values.shape[1] != len(wanted) or not all(b[1].count(",") == len(header) - 1 for b in body):
            raise ValueError
    except ValueError:
        values = _parse_slowly(body, header, wanted, col_index, path)
    finite = np.isfinite(values)
    if not finite.all():
        r, k = np.argwhere(~finite)[0]
        raise FringeInputError(f"column '{wanted[k]}': {values[r, k]} is not a finite number", path,
                               f"line {line_of[r]}")

    cols = {name: values[:, k] for k, name in enumerate(wanted)}
    if len(body) < min_samples:
        raise FringeInputError(f"too few samples: {len(body)} (need at least {min_samples})", path)

    coarse = None
    if "coarse" in cols:
        c = cols["coarse"]
        bad = np.flatnonzero((c != np.round(c)) | (c < 0))
        if bad.size:
            raise FringeInputError(f"column 'coarse': {c[bad[0]]!r} is not an unsigned integer", path,
                                   f"line {line_of[bad[0]]}")
        if encoder is not None and encoder.coarse_bits:
            over = np.flatnonzero(c >= (1 << encoder.coarse_bits))
            if over.size:
                raise FringeInputError(f"column 'coarse': {int(c[over[0]])} does not fit coarse_bits = "
                                       f"{encoder.coarse_bits}", path, f"line {line_of[over[0]]}")
        coarse = c.astype(np.int64)

    sin, cos = cols["sin"], cols["cos"]
    if encoder is not None:
        sin, cos = _to_counts(sin, cos, encoder, path, line_of)
    return Measurement(path, sin, cos, coarse, cols.get("ref_deg"), cols.get("t_s"), tuple(comments))


def _to_counts(sin, cos, enc: Encoder, path, line_of):
    """Float readings are scaled by full_scale; integer counts must fit the ADC."""
    lo, hi = -enc.adc_half_range, enc.adc_half_range - 1
    if enc.full_scale is not None:
        scale = enc.adc_half_range / enc.full_scale
        sin, cos = sin * scale, cos * scale
    for name, v in (("sin", sin), ("cos", cos)):
        out = np.flatnonzero((v < lo - 0.5) | (v > hi + 0.5))
        if out.size:
            raise FringeInputError(f"column '{name}': {v[out[0]]:g} counts is outside the {enc.adc_bits}-bit "
                                   f"ADC range [{lo}, {hi}] (wrong adc_bits or full_scale?)", path,
                                   f"line {line_of[out[0]]}")
    return sin, cos


def _close_names(missing, header):
    import difflib
    hints = []
    for m in missing:
        close = difflib.get_close_matches(m, header, n=1, cutoff=0.5)
        if close:
            hints.append(f"'{close[0]}' looks like '{m}'")
    return f" ({'; '.join(hints)})" if hints else ""


@contextmanager
def atomic_output(path: str, mode: str = "w"):
    """Write to a temporary file beside `path` and rename it into place only on success."""
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".tmp-", suffix=os.path.basename(path))
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else "utf-8", newline="" if "b" not in mode
                       else None) as f:
            yield f
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


@contextmanager
def atomic_dir(out_dir: str, prefix: str = ".tmp-"):
    """Build a folder under a temporary name beside `out_dir`; it replaces `out_dir` only on success."""
    import shutil

    parent = os.path.dirname(os.path.abspath(out_dir))
    os.makedirs(parent, exist_ok=True)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise FringeInputError("exists and is not a directory", out_dir)
    tmp = tempfile.mkdtemp(dir=parent, prefix=prefix)
    try:
        yield tmp
        if os.path.isdir(out_dir):
            shutil.rmtree(out_dir)
        os.replace(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def write_csv(path: str, columns: dict, comments: tuple[str, ...] = (), formats: dict | None = None):
    """Write columns (equal-length arrays) as the spec's CSV, atomically."""
    names = list(columns)
    formats = formats or {}
    fmt = [formats.get(n, "%.10g") for n in names]
    data = np.column_stack([np.asarray(columns[n]) for n in names])
    with atomic_output(path) as f:
        for c in comments:
            f.write(f"# {c}\n")
        f.write(",".join(names) + "\n")
        np.savetxt(f, data, fmt=fmt, delimiter=",")


def _parse_slowly(body, header, wanted, col_index, path):
    values = np.empty((len(body), len(wanted)))
    for row_no, (line_no, text) in enumerate(body):
        rec = next(csv.reader([text]))
        if len(rec) != len(header):
            raise FringeInputError(f"has {len(rec)} fields, the header has {len(header)}", path,
                                   f"line {line_no}")
        for k, (name, j) in enumerate(zip(wanted, col_index, strict=True)):
            cell = rec[j].strip()
            try:
                values[row_no, k] = float(cell)
            except ValueError:
                raise FringeInputError(f"column '{name}': not a number: {cell!r}", path,
                                       f"line {line_no}") from None
    return values
