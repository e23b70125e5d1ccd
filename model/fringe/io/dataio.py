"""Measured data (spec section 1): strict, fast reading (pyarrow's CSV reader), atomic writing."""

import csv
import os
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ..encoder import Encoder
from ..errors import FringeInputError

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
    row_lines: object = None           # where row r stands in the file: a callable, an array of line numbers

    def __len__(self) -> int:
        return len(self.sin)

    def row_line(self, r: int) -> str:
        """'line N' (or 'row N') of row r, for messages."""
        return _row_line(self.row_lines, r) if self.row_lines is not None else f"row {r + 1}"

    def runs(self, rows: int, runs: int) -> "Measurement":
        """`runs` evenly spaced runs of consecutive rows, `rows` in all (self when it is not longer): every part of
        the motion and of the time span is represented. Without t_s the runs keep their row numbers as time,
        so the gaps between them stay visible."""
        n = len(self)
        if n <= rows:
            return self
        run = rows // runs
        starts = np.linspace(0, n - run, runs).astype(np.int64)
        index = (starts[:, None] + np.arange(run)[None, :]).ravel()
        return self.subset(index)

    def subset(self, mask_or_index) -> "Measurement":
        """The rows picked. Without t_s they keep their row numbers as time, so the gaps between them stay
        visible (the coarse/fine track, pipeline.run_starts, must not bridge them)."""
        pick = lambda a: None if a is None else a[mask_or_index]  # noqa: E731
        t = self.t_s if self.t_s is not None else np.arange(len(self), dtype=float)
        return Measurement(self.path, self.sin[mask_or_index], self.cos[mask_or_index],
                           pick(self.coarse), pick(self.ref_deg), t[mask_or_index], self.comments)


def available_memory() -> int:
    """Bytes the system can still give (MemAvailable), or a large number where it cannot tell."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 1 << 62


def check_memory(rows: float, bytes_per_row: int, what: str, where: str):
    """Refuse work that will not fit in memory before allocating for it."""
    need, free = rows * bytes_per_row, available_memory()
    if need > 0.8 * free:
        raise FringeInputError(f"{what}: about {rows:.3g} rows need about {need / 2**30:.1f} GiB of memory, "
                               f"{free / 2**30:.1f} GiB are free", where)


class FractionalReadings(FringeInputError):
    """Readings within +-2 with fractions, for an encoder without 'full_scale': normalised floats."""

    def __init__(self, path, peak, where="in the encoder description"):
        self.path, self.peak = path, peak
        super().__init__(f"the readings are fractions within +-{peak:.3g}: normalised floats? give 'full_scale' "
                         f"(the reading that means ADC full scale) {where}", path)

    def for_calibration(self) -> "FractionalReadings":
        """The same, for a calibration of counts: its encoder is the one to change."""
        return FractionalReadings(self.path, self.peak, "in the encoder description and calibrate again (this "
                                  "calibration's encoder has none: it reads ADC counts)")


def read_measurement(path: str, encoder: Encoder | None = None, min_samples: int = 1) -> Measurement:
    """Read and check a recording (CSV, or .npy/.parquet with the same column names); every problem
    is a FringeInputError naming the file and line."""
    if not os.path.isfile(path):
        raise FringeInputError("data file not found" if not os.path.exists(path) else "is not a regular file",
                               path)
    ext = os.path.splitext(path)[1].lower()
    if ext in (".npy", ".parquet"):
        cols, line_of, comments = _read_binary(path, ext)
    else:
        cols, line_of, comments = _read_csv(path)
    n = len(cols["sin"])
    if n < min_samples:
        raise FringeInputError(f"too few samples: {n} (need at least {min_samples})", path)
    return _checked(path, cols, line_of, comments, encoder)


def _row_line(line_of, r) -> str:
    return line_of(r) if callable(line_of) else f"line {int(line_of[r])}"


def _checked(path, cols, line_of, comments, encoder, t_before=None):
    for name, v in cols.items():
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise FringeInputError(f"column '{name}': {v[bad[0]]} is not a finite number", path,
                                   _row_line(line_of, bad[0]))
    t = cols.get("t_s")
    if t is not None and t_before is not None and len(t) and t[0] <= t_before:
        what = "repeats" if t[0] == t_before else "goes back from"
        raise FringeInputError(f"column 't_s': {float(t[0]):.10g} {what} {float(t_before):.10g} on the row before "
                               "(time stamps must increase)", path, _row_line(line_of, 0))
    if t is not None and len(t) > 1:
        back = np.flatnonzero(np.diff(t) <= 0)
        if back.size:
            r = back[0] + 1
            what = "repeats" if t[r] == t[r - 1] else "goes back from"
            raise FringeInputError(f"column 't_s': {float(t[r]):.10g} {what} {float(t[r - 1]):.10g} on the row before "
                                   "(time stamps must increase)", path, _row_line(line_of, r))
        if np.ptp(t) > MAX_SPAN_S or np.abs(t).max() > MAX_SPAN_S:
            raise FringeInputError(f"column 't_s': spans {np.ptp(t):.3g} s; time stamps must be seconds", path)
    ref = cols.get("ref_deg")
    if ref is not None:
        big = np.flatnonzero(np.abs(ref) > MAX_REF_DEG)
        if big.size:
            raise FringeInputError(f"column 'ref_deg': {ref[big[0]]:g} is not a plausible angle in degrees", path,
                                   _row_line(line_of, big[0]))

    coarse = None
    if "coarse" in cols:
        c = cols["coarse"]
        bad = np.flatnonzero((c != np.round(c)) | (c < 0))
        if bad.size:
            raise FringeInputError(f"column 'coarse': {float(c[bad[0]]):.10g} is not an unsigned integer", path,
                                   _row_line(line_of, bad[0]))
        if encoder is not None and encoder.coarse_bits:
            over = np.flatnonzero(c >= (1 << encoder.coarse_bits))
            if over.size:
                raise FringeInputError(f"column 'coarse': {int(c[over[0]])} does not fit coarse_bits = "
                                       f"{encoder.coarse_bits}", path, _row_line(line_of, over[0]))
        coarse = c.astype(np.int64)

    sin, cos = cols["sin"], cols["cos"]
    if encoder is not None:
        sin, cos = _to_counts(sin, cos, encoder, path, line_of)
    return Measurement(path, sin, cos, coarse, ref, t, tuple(comments), line_of)


MAX_SPAN_S = 1e9          # about 30 years: beyond that the column is not seconds
MAX_REF_DEG = 1e9         # about 2.8 million turns
MIN_RANGE_USED = 1 / 256  # a signal swinging less than this fraction of the ADC's range: wrong adc_bits?


def _to_counts(sin, cos, enc: Encoder, path, line_of):
    """Float readings are scaled by full_scale; offset-binary codes are centred; counts must fit the ADC."""
    lo, hi = -enc.adc_half_range, enc.adc_half_range - 1
    if enc.full_scale is not None:   # to the codes the core's ADC input holds: calibrate on what it will see
        scale = enc.adc_half_range / enc.full_scale
        sin, cos = np.round(sin * scale), np.round(cos * scale)
    else:
        peak = max(np.max(np.abs(sin)), np.max(np.abs(cos)))
        fractional = np.any(sin != np.round(sin)) or np.any(cos != np.round(cos))
        if fractional and peak <= 2.0:
            raise FractionalReadings(path, peak)
        if enc.offset_binary:
            sin, cos = sin - enc.adc_half_range, cos - enc.adc_half_range
    for name, v in (("sin", sin), ("cos", cos)):
        out = np.flatnonzero((v < lo - 0.5) | (v > hi + 0.5))
        if out.size:
            hint = "offset_binary, " if not enc.offset_binary and v[out[0]] > 0 and np.min(v) >= 0 else ""
            raise FringeInputError(f"column '{name}': {v[out[0]]:g} counts is outside the {enc.adc_bits}-bit "
                                   f"ADC range [{lo}, {hi}] (wrong {hint}adc_bits or full_scale?)", path,
                                   _row_line(line_of, out[0]))
    return sin, cos


def check_signal_scale(meas: Measurement, enc: Encoder):
    """For calibration: a signal far below the declared ADC range means a wrong adc_bits or full_scale
    (a recording to correct may rest, and then only its noise swings)."""
    swing = max(np.ptp(meas.sin), np.ptp(meas.cos)) / 2
    if 2.0 < swing < MIN_RANGE_USED * enc.adc_half_range:
        raise FringeInputError(f"the signals swing only +-{swing:.4g} counts of the declared {enc.adc_bits}-bit "
                               f"ADC's +-{enc.adc_half_range}: wrong adc_bits or full_scale?", meas.path)


SAME_SIGNAL_SHARE = 0.95   # sin within a count of +-cos on this share of the rows: one signal in both columns


def check_channels(meas: Measurement):
    """For calibration: the same signal in both columns (a copied column, one input wired twice) is named as
    such, not as a recording that covers too little of the Lissajous figure."""
    for sign, what in ((1, "equal"), (-1, "opposite")):
        same = np.count_nonzero(np.abs(meas.sin - sign * meas.cos) <= 1.0)
        if same >= SAME_SIGNAL_SHARE * len(meas):
            raise FringeInputError(f"columns 'sin' and 'cos' are {what} on {same} of {len(meas)} rows: the same "
                                   "signal in both columns (a copied column, or one input wired twice)?", meas.path)


def _header(path):
    """(byte offset of the header row, its line number, its column names, the comment lines before it)."""
    comments, offset, line_no = [], 0, 0
    try:
        with open(path, "rb") as f:
            first = True
            for raw in f:
                line_no += 1
                if first and raw.startswith(BOM):   # Excel writes one before the header
                    offset, raw = len(BOM), raw[len(BOM):]
                first = False
                text = raw.decode("utf-8").strip()
                if "\r" in text:     # csv cannot split it; pyarrow would read it as a row break
                    what = "line" if text.startswith("#") else "header line"
                    raise FringeInputError(f"a carriage return inside the {what} (mixed or old Mac line endings): "
                                           "save the file with one kind of line ending", path, f"line {line_no}")
                if text.startswith("#"):
                    comments.append(text[1:].strip())
                elif text:
                    header = [h.strip() for h in _fields(text, path, line_no)]
                    return offset, line_no, header, comments
                offset += len(raw)
    except OSError as e:
        raise FringeInputError(f"cannot read data file: {e.strerror}", path) from None
    except UnicodeDecodeError:
        raise FringeInputError(f"not a text (UTF-8) CSV file{_binary_kind(path)}", path, f"line {line_no}") from None
    raise FringeInputError("empty file: no header row", path)


_MAGIC = ((b"\x1f\x8b", "gzip-compressed: decompress it first"), (b"PK\x03\x04", "a ZIP archive (or .xlsx "
          "workbook): export or extract the CSV first"), (b"\xff\xfe", "UTF-16 text: save it as UTF-8"),
          (b"\xfe\xff", "UTF-16 text: save it as UTF-8"), (b"BZh", "bzip2-compressed: decompress it first"),
          (b"\xfd7zXZ", "xz-compressed: decompress it first"))


def _binary_kind(path) -> str:
    """' (it is ...)' for a file whose first bytes say what it is, else ''."""
    try:
        with open(path, "rb") as f:
            head = f.read(8)
    except OSError:
        return ""
    return next((f" (it is {what})" for magic, what in _MAGIC if head.startswith(magic)), "")


BOM = b"\xef\xbb\xbf"


def _wanted_columns(header, path, line_no):
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        hint = _separator_hint(header) or _close_names(missing, header)
        raise FringeInputError(f"missing required column(s) {', '.join(missing)}{hint} "
                               f"(header has: {', '.join(header)})", path, f"line {line_no}")
    dup = sorted({h for h in header if header.count(h) > 1 and h in REQUIRED + OPTIONAL})   # others are ignored
    if dup:
        raise FringeInputError(f"duplicate column(s) {', '.join(dup)}", path, f"line {line_no}")
    return [c for c in REQUIRED + OPTIONAL if c in header]


def _csv_options(header, wanted, **read):
    """pyarrow's CSV options for the spec's files: our header names, wanted columns as float64, no
    missing values and no blank lines (anything else fails here and the slow path names the line)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    names = [h if h in wanted else f"\0{k}" for k, h in enumerate(header)]   # ignored names may repeat or be ''
    return dict(read_options=pacsv.ReadOptions(column_names=names, skip_rows=1, **read),
                parse_options=pacsv.ParseOptions(ignore_empty_lines=False),
                convert_options=pacsv.ConvertOptions(include_columns=wanted,
                                                     column_types={c: pa.float64() for c in wanted},
                                                     null_values=[], strings_can_be_null=False,
                                                     quoted_strings_can_be_null=False))


def _read_csv(path):
    import pyarrow as pa

    offset, header_line, header, comments = _header(path)
    wanted = _wanted_columns(header, path, header_line)
    size = os.path.getsize(path)
    check_memory(size / 12, BYTES_PER_ROW, "the recording is too large", path)
    try:
        rows_at_most = _lines_at_most(path, offset)
        cols = {c: np.empty(rows_at_most) for c in wanted}   # pages never written are never resident
        done = 0
        for batch in _csv_batches(path, offset, header, wanted, READ_ROWS):
            for c in wanted:
                cols[c][done:done + batch.num_rows] = batch.column(c).to_numpy(zero_copy_only=False)
            done += batch.num_rows
        cols = {c: v[:done] for c, v in cols.items()}
        if not len(cols["sin"]):
            raise FringeInputError("no data rows after the header", path, f"line {header_line}")
        return cols, lambda r: f"line {header_line + 1 + r}", comments
    except (pa.ArrowInvalid, ValueError):   # the slow path finds the line and says what is wrong
        cols, line_of = _read_csv_slowly(path, header_line, header, wanted)
        return cols, line_of, comments


READ_ROWS = 1 << 15   # rows per piece of the streaming reader: pyarrow's buffers stay bounded by a piece


def _csv_batches(path, offset, header, wanted, rows):
    """pyarrow's streaming CSV reader from the header's end, in record batches of about `rows` rows."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    pool = pa.system_memory_pool()      # malloc's: what the reader frees, release_freed_memory gives back
    with pa.OSFile(path, "r", memory_pool=pool) as src:   # not memory-mapped: mapped pages count as held
        src.seek(offset)
        for batch in pacsv.open_csv(src, **_csv_options(header, wanted, block_size=rows * 48, use_threads=False),
                                    memory_pool=pool):
            yield batch
            del batch
            release_freed_memory()


def release_freed_memory():
    """Give the heap that glibc's malloc keeps after frees back to the system (it would otherwise stay
    resident, about the size of the text read so far); a no-op elsewhere."""
    global _malloc_trim
    if _malloc_trim is None:
        try:
            import ctypes
            _malloc_trim = ctypes.CDLL("libc.so.6").malloc_trim
        except (OSError, AttributeError):
            _malloc_trim = False
    if _malloc_trim:
        _malloc_trim(0)


_malloc_trim = None


def _lines_at_most(path, offset) -> int:
    """An upper bound of the rows after the header (every line break counted, CR and LF alike), found
    in bounded pieces: the reader fills arrays of this length without copies."""
    breaks = 0
    with open(path, "rb") as f:
        f.seek(offset)
        while piece := f.read(1 << 22):
            breaks += piece.count(b"\n") + piece.count(b"\r")
    return breaks + 1


def iter_measurement(path: str, encoder: Encoder, rows: int = 1 << 18):
    """The recording in pieces of about `rows` rows, each checked as `read_measurement` checks the whole
    (time stamps across the pieces too): memory bounded by a piece. A CSV that pyarrow's streaming reader
    cannot take row by row (comment lines among the rows, a broken row) is read whole, which finds and
    names the line; binary recordings are read whole."""
    import pyarrow as pa

    if os.path.splitext(path)[1].lower() in (".npy", ".parquet") or not os.path.isfile(path):
        yield read_measurement(path, encoder)
        return
    offset, header_line, header, comments = _header(path)
    wanted = _wanted_columns(header, path, header_line)
    done, t_last = 0, None
    try:
        for batch in _csv_batches(path, offset, header, wanted, rows):
            cols = {c: batch.column(c).to_numpy(zero_copy_only=False) for c in wanted}
            first = header_line + 1 + done
            m = _checked(path, cols, lambda r, first=first: f"line {first + r}", comments, encoder, t_last)
            done += len(m)
            if m.t_s is not None and len(m):
                t_last = m.t_s[-1]
            if len(m):
                yield m
    except (pa.ArrowInvalid, ValueError):
        whole = read_measurement(path, encoder)   # names the line, or reads what pyarrow could not
        if done < len(whole):
            yield whole.subset(slice(done, None))
        return
    if not done:
        raise FringeInputError("no data rows after the header", path, f"line {header_line}")


def _read_csv_slowly(path, header_line, header, wanted):
    with open(path, "rb") as f:
        raw = f.read()
    try:
        lines = raw.decode("utf-8-sig").splitlines()
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        raise FringeInputError("not a text (UTF-8) CSV file", path, f"line {line}") from None
    body = [(i + 1, ln) for i, ln in enumerate(lines[header_line:], start=header_line)
            if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise FringeInputError("no data rows after the header", path, f"line {header_line}")
    values = _parse_slowly(body, header, wanted, [header.index(c) for c in wanted], path)
    cols = {name: values[:, k] for k, name in enumerate(wanted)}
    line_of = np.array([b[0] for b in body])
    return cols, line_of


BYTES_PER_ROW = 400   # what calibrate and loop hold per input row at most, with margin


def _read_binary(path, ext):
    """A .npy structured array or a Parquet table with the CSV's column names."""
    try:
        if ext == ".npy":
            arr = np.load(path, allow_pickle=False, mmap_mode="r")
            names = list(arr.dtype.names or ())
            get = lambda c: np.asarray(arr[c], dtype=float)  # noqa: E731
        else:
            import pyarrow.parquet as pq
            table = pq.read_table(path)
            names = table.column_names
            get = lambda c: table.column(c).to_numpy().astype(float)  # noqa: E731
    except (OSError, ValueError) as e:
        raise FringeInputError(f"cannot read {ext[1:]} recording: {str(e).splitlines()[0]}", path) from None
    if ext == ".npy" and not names:
        raise FringeInputError("a .npy recording must be a structured array with named fields (sin, cos, ...)",
                               path)
    wanted = _wanted_columns(names, path, "columns")
    try:
        cols = {c: get(c) for c in wanted}
    except (TypeError, ValueError) as e:
        raise FringeInputError(f"columns must be numeric ({e})", path) from None
    if not len(cols["sin"]):
        raise FringeInputError("no data rows", path)
    return cols, lambda r: f"row {r + 1}", ()


def _close_names(missing, header):
    import difflib
    hints, case = [], False
    for m in missing:
        same = [h for h in header if str(h).lower() == m]   # 'SIN', 'Sin': names are lower-case
        close = same or difflib.get_close_matches(m, [str(h).lower() for h in header], n=1, cutoff=0.5)
        if close:
            case = case or bool(same)
            name = same[0] if same else next(h for h in header if str(h).lower() == close[0])
            hints.append(f"'{name}' looks like '{m}'")
    return f" ({'; '.join(hints)}{': column names are lower-case' if case else ''})" if hints else ""


def _separator_hint(header) -> str:
    """' (the columns seem separated by ';' ...)' when one header field splits into sin and cos at another
    separator than the comma."""
    for h in header:
        for sep, name in ((";", "';'"), ("\t", "tabs"), ("|", "'|'"), (" ", "spaces")):
            parts = [p.strip().lower() for p in str(h).split(sep)]
            if len(parts) > 1 and all(r in parts for r in REQUIRED):
                return f" (the columns seem separated by {name}: fringe reads comma-separated CSV)"
    return ""


class CsvWriter:
    """Rows of the spec's CSV, written in pieces into a temporary file that replaces `path` when complete
    (`outputs.atomic_output`); comments[0] names the writing command ('fringe <kind> ...'), which marks
    the file as fringe's. Formats: '%d' writes integers, '%.Nf' rounds to N decimals, anything else
    writes the shortest exact decimal."""

    def __init__(self, f, names, formats):
        self.f, self.names, self.formats = f, list(names), formats or {}

    def write(self, columns: dict):
        import pyarrow as pa
        import pyarrow.csv as pacsv

        arrays = {}
        for name in self.names:
            v, fmt = np.asarray(columns[name]), self.formats.get(name, "")
            if fmt == "%d":
                v = v.astype(np.int64)
            elif fmt.startswith("%.") and fmt.endswith("f"):
                v = np.round(v.astype(float), int(fmt[2:-1]))
            arrays[name] = v
        table = pa.table(arrays)
        options = pacsv.WriteOptions(include_header=False, quoting_style="none")
        for start in range(0, table.num_rows, WRITE_ROWS):   # one chunk of text at a time
            buf = pa.BufferOutputStream()
            pacsv.write_csv(table.slice(start, WRITE_ROWS), buf, options)
            self.f.write(buf.getvalue().to_pybytes())


@contextmanager
def csv_writer(path: str, names, comments: tuple[str, ...], formats: dict | None = None, inputs=()):
    from .outputs import atomic_output

    kind = comments[0].split()[1].rstrip(":")
    with atomic_output(path, kind, inputs, mode="wb") as f:
        for c in comments:
            f.write(f"# {c}\n".encode())
        f.write((",".join(names) + "\n").encode())
        yield CsvWriter(f, names, formats)


def _fields(text: str, path: str, line_no: int) -> list[str]:
    """One CSV line's fields; what the csv module cannot split (a field over its size limit, a stray quote) is
    named with the line."""
    try:
        return next(csv.reader([text]))
    except csv.Error as e:
        raise FringeInputError(f"cannot be split into CSV fields ({e})", path, f"line {line_no}") from None


def write_csv(path: str, columns: dict, comments: tuple[str, ...], formats: dict | None = None, inputs=()):
    """Write equal-length columns as the spec's CSV, atomically (see CsvWriter)."""
    with csv_writer(path, list(columns), comments, formats, inputs) as w:
        w.write(columns)


WRITE_ROWS = 1 << 17


def _parse_slowly(body, header, wanted, col_index, path):
    values = np.empty((len(body), len(wanted)))
    for row_no, (line_no, text) in enumerate(body):
        rec = _fields(text, path, line_no)
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
