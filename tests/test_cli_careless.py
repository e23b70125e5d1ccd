"""A careless user's sweep across the five commands (issue 8): odd inputs drawn at random.

Each case runs `fringe` in this process with FRINGE_DEBUG=1 (a fault of fringe itself then shows as the
exception, not as its one-line 'internal error'). Every case must end with exit 0 and its output, or
with exit 2 and one line on stderr; nothing that existed before the case may change (every file under
the case's folder is hashed before and after). Valid variants of the recording (byte-order mark, CRLF)
must give the same corrected rows as the plain file.

The test runs a fixed subset (CASES, fast); FRINGE_CARELESS_CASES=N runs N cases, FRINGE_CARELESS_SEED
picks the draw (printed, so a failure can be replayed).
"""

import contextlib
import hashlib
import io
import json
import os
import shutil

import numpy as np
import pytest

from fringe.cli.cli import main

CASES = int(os.environ.get("FRINGE_CARELESS_CASES", "14"))
SEED = int(os.environ.get("FRINGE_CARELESS_SEED", "20261202"))
COMMANDS = ("simulate", "calibrate", "correct", "rom", "loop")


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A user's folder: a recording, its encoder description, a calibration from it, and notes of theirs."""
    root = tmp_path_factory.mktemp("careless")
    user = root / "user"
    user.mkdir()
    (user / "notes").mkdir()
    (user / "notes" / "todo.txt").write_text("calibrate the spindle\n")
    with _in(root):
        assert _run(["simulate", "--preset", "seed-encoder", "--samples", "20000", "--out", "user/rec.csv",
                     "--encoder-out", "user/enc.json", "--seed", "1"])[0] == 0
        assert _run(["calibrate", "user/rec.csv", "--encoder", "user/enc.json", "--out", "user/cal"])[0] == 0
        assert _run(["correct", "user/rec.csv", "--cal", "user/cal", "--out", "plain.csv"])[0] == 0
    return root


@contextlib.contextmanager
def _in(folder):
    before = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in argv])
    return status, out.getvalue(), err.getvalue()


def _snapshot(folder):
    state = {}
    for dirpath, dirs, files in os.walk(folder):
        for name in dirs + files:
            p = os.path.join(dirpath, name)
            rel = os.path.relpath(p, folder)
            if os.path.isdir(p):
                state[rel] = "dir"
            else:
                with open(p, "rb") as f:
                    state[rel] = hashlib.sha256(f.read()).hexdigest()
    return state


def _rows(path):
    with open(path, "rb") as f:
        return [ln for ln in f.read().splitlines() if ln and not ln.startswith(b"#")]


# ---------------------------------------------------------------- the draws

def _bad_file(rng, rec: bytes) -> bytes:
    kind = rng.choice(["truncated", "garbage", "header only", "empty column", "bom crlf", "nul", "latin1"])
    if kind == "truncated":
        return rec[:int(rng.integers(0, len(rec)))]
    if kind == "garbage":
        return bytes(rng.integers(0, 256, int(rng.integers(1, 5000)), dtype=np.uint8))
    lines = rec.split(b"\n")
    head = next(i for i, ln in enumerate(lines) if not ln.startswith(b"#"))
    if kind == "header only":
        return b"\n".join(lines[:head + 1]) + b"\n"
    if kind == "empty column":
        k = int(rng.integers(0, 5))
        body = [b",".join(b"" if j == k else v for j, v in enumerate(ln.split(b","))) if ln and i > head and
                rng.random() < 0.3 else ln for i, ln in enumerate(lines)]
        return b"\n".join(body)
    if kind == "bom crlf":
        return b"\xef\xbb\xbf" + rec.replace(b"\n", b"\r\n")
    if kind == "nul":
        at = int(rng.integers(0, len(rec)))
        return rec[:at] + b"\0" + rec[at:]
    return rec.replace(b"sin", "sín".encode("latin-1"), 1)


def _bad_encoder(rng, enc: dict) -> str:
    kind = rng.choice(["not json", "value", "missing", "extra", "list"])
    d = dict(enc)
    if kind == "not json":
        text = json.dumps(d)
        return text[:int(rng.integers(0, len(text)))]
    if kind == "list":
        return json.dumps([d])
    if kind == "missing":
        d.pop(str(rng.choice(["lines_per_rev", "adc_bits"])))
    elif kind == "extra":
        d[str(rng.choice(["lines", "adc_bit", "coarse"]))] = 9
    else:
        key = str(rng.choice(["lines_per_rev", "adc_bits", "coarse_bits", "full_scale", "offset_binary"]))
        d[key] = [-1, 0, 1, 3.5, 24, 40, 1e30, "12", None, True, float("nan")][int(rng.integers(0, 11))]
    return json.dumps(d)


def _edited_cal(rng, cal):
    files = sorted(p for p in os.listdir(cal) if os.path.isfile(os.path.join(cal, p)))
    name = str(rng.choice(files))
    p = os.path.join(cal, name)
    data = open(p, "rb").read()
    kind = rng.choice(["truncate", "digit", "delete", "append"])
    if kind == "delete":
        os.remove(p)
    elif kind == "truncate":
        open(p, "wb").write(data[:len(data) // 2])
    elif kind == "append":
        open(p, "ab").write(b"1,2,3\n")
    else:
        digits = [i for i, b in enumerate(data) if 48 <= b <= 57]
        i = digits[int(rng.integers(0, len(digits)))]
        open(p, "wb").write(data[:i] + bytes([48 + (data[i] - 47) % 10]) + data[i + 1:])
    return f"{kind} {name}"


def draw_case(rng, root):
    """(what, argv, kind) of one careless case, its files made under root/case."""
    rec = (root / "user" / "rec.csv").read_bytes()
    enc = json.loads((root / "user" / "enc.json").read_text())
    command = str(rng.choice(COMMANDS))
    kind = str(rng.choice(["bad file", "bad encoder", "out at a user's file", "edited cal", "odd option",
                           "valid variant"]))
    data, encf, cal, out = "user/rec.csv", "user/enc.json", "user/cal", f"new-{command}"
    what = kind
    if kind == "bad file":
        (root / "user" / "odd.csv").write_bytes(_bad_file(rng, rec))
        data, command = "user/odd.csv", str(rng.choice(["calibrate", "correct", "loop"]))
    elif kind == "bad encoder":
        (root / "user" / "odd.json").write_text(_bad_encoder(rng, enc))
        encf, what = "user/odd.json", f"encoder {(root / 'user' / 'odd.json').read_text()[:80]}"
        command = str(rng.choice(["calibrate", "loop"]))
    elif kind == "out at a user's file":
        out = str(rng.choice(["user/rec.csv", "user/enc.json", "user", ".", "user/cal", "user/notes",
                              "user/notes/todo.txt", "user/cal/calibration.json", "", "user/rec.csv/x"]))
        what = f"--out {out!r}"
    elif kind == "edited cal":
        shutil.copytree(root / "user" / "cal", root / "user" / "cal2")
        what = _edited_cal(rng, str(root / "user" / "cal2"))
        cal, command = "user/cal2", str(rng.choice(["correct", "rom"]))
    elif kind == "odd option":
        command = str(rng.choice(["simulate", "rom"]))
        options = ((("--samples", [-5, 0, 10**12, "1e3", "x"]), ("--seed", [-1, 2**64, "x"]))
                   if command == "simulate" else
                   (("--cordic-stages", [0, 1000, -3]), ("--format", ["", "xyz", "mem,,", ","]),
                    ("--wave-w", [1, 1000]), ("--fine-w", [0, 99]), ("--lp-addr-w", [40])))
        name, choices = options[int(rng.integers(0, len(options)))]
        value = choices[int(rng.integers(0, len(choices)))]
        what = f"{name} {value!r}"
        extra = [name, value]
    else:
        body = rec.replace(b"\n", b"\r\n") if rng.random() < 0.5 else rec
        (root / "user" / "odd.csv").write_bytes((b"\xef\xbb\xbf" if rng.random() < 0.5 else b"") + body)
        data, command, what = "user/odd.csv", "correct", "BOM/CRLF variant"
    argv = {"simulate": ["simulate", "--preset", "seed-encoder", "--samples", "2000", "--out", out + ".csv"
                         if out.startswith("new") else out],
            "calibrate": ["calibrate", data, "--encoder", encf, "--out", out],
            "correct": ["correct", data, "--cal", cal, "--out", out + ".csv" if out.startswith("new") else out],
            "rom": ["rom", cal, "--out", out],
            "loop": ["loop", data, "--encoder", encf, "--out", out]}[command]
    if kind == "odd option":
        argv = argv + extra
    return what, argv, kind


def _check(root, what, argv, kind, monkeypatch):
    before = _snapshot(root)
    monkeypatch.setenv("FRINGE_DEBUG", "1")
    with _in(root):
        status, out, err = _run(argv)
    after = _snapshot(root)
    label = f"{what}: fringe {' '.join(map(str, argv))}"
    assert status in (0, 2), f"{label}: exit {status}"
    if status == 2:
        assert err.count("\n") == 1 and err.startswith("fringe: "), f"{label}: {err!r}"
    changed = [k for k, v in before.items() if after.get(k) != v]
    assert not changed, f"{label}: changed or removed {changed}"
    if kind == "valid variant":
        assert status == 0, f"{label}: {err}"
        assert _rows(root / argv[-1]) == _rows(root / "plain.csv"), label
    return status, err.strip()


@pytest.mark.parametrize("case", range(CASES))
def test_a_careless_user_loses_nothing(world, tmp_path, monkeypatch, case):
    rng = np.random.default_rng([SEED, case])
    print("seed", SEED, "case", case)
    root = tmp_path / "w"
    shutil.copytree(world, root)
    what, argv, kind = draw_case(rng, root)
    status, err = _check(root, what, argv, kind, monkeypatch)
    print(what, "->", status, err)


# ---------------------------------------------------------------- what a randomised sweep found (each failed before)

def _fails_with(argv, *words, cwd=None):
    """Exit 2, one line on stderr holding every word, no 'internal error'; returns the line."""
    with _in(cwd or os.getcwd()):
        status, _, err = _run(argv)
    assert status == 2 and err.count("\n") == 1 and "internal error" not in err, err
    for w in words:
        assert w in err, err
    return err


def _enc_file(tmp_path, raw: bytes):
    p = tmp_path / "enc.json"
    p.write_bytes(raw)
    return p


def test_an_encoder_description_with_a_byte_order_mark_is_read(tmp_path):
    from fringe.encoder import load_encoder
    enc = load_encoder(str(_enc_file(tmp_path, b'\xef\xbb\xbf{"lines_per_rev": 256, "adc_bits": 12}')))
    assert (enc.lines_per_rev, enc.adc_bits) == (256, 12)


@pytest.mark.parametrize("raw, words", [
    (b'{"lines_per_rev": 100, "adc_bits": 12, "lines_per_rev": 7}', ("enc.json", "'lines_per_rev'", "twice")),
    (b'\xff\xfe{\x00}\x00', ("enc.json", "line 1", "UTF-8")),
    (b"[" * 5000, ("enc.json", "nested")),
    (b" \n", ("enc.json", "empty file")),
])
def test_a_broken_encoder_description_is_named_not_an_internal_error(world, tmp_path, raw, words):
    enc = _enc_file(tmp_path, raw)
    _fails_with(["calibrate", world / "user" / "rec.csv", "--encoder", enc, "--out", tmp_path / "cal"], *words)
    assert not (tmp_path / "cal").exists()


@pytest.mark.parametrize("command", ["calibrate", "loop"])
def test_an_encoder_no_core_can_hold_is_named_before_the_fit(world, tmp_path, command):
    """32768 lines with a 15-bit coarse code need a 32-bit position: said of the encoder file, before any work."""
    enc = _enc_file(tmp_path, b'{"lines_per_rev": 32768, "adc_bits": 16, "coarse_bits": 15}')
    _fails_with([command, world / "user" / "rec.csv", "--encoder", enc, "--out", tmp_path / "out"],
                "enc.json", "no core configuration holds this encoder", "position of 32 bits")
    assert not (tmp_path / "out").exists()


def _csv(tmp_path, raw: bytes, name="rec.csv"):
    p = tmp_path / name
    p.write_bytes(raw)
    return p


@pytest.mark.parametrize("raw, words, not_words", [
    (b"# note\r# lines_per_rev: 256\rsin,cos\r1,2\r3,4\r", ("line 1", "carriage return"), ("empty file",)),
    (b"sin,cos,coarse\n1,2,-3\n", ("line 2", "'coarse': -3 is not"), ("np.",)),
    (b"t_s;sin;cos\n0;1;2\n", ("line 1", "separated by ';'"), ()),
    (b"t_s\tsin\tcos\n0\t1\t2\n", ("line 1", "separated by tabs"), ()),
    (b"T_S,SIN,COS\n0,1,2\n", ("line 1", "'SIN' looks like 'sin'", "'COS' looks like 'cos'", "lower-case"), ()),
    # mtime=0: the same bytes in every xdist worker (a time stamp in the test's id made their collections differ)
    (__import__("gzip").compress(b"sin,cos\n1,2\n", mtime=0), ("line 1", "gzip"), ()),
], ids=["carriage-returns", "negative-coarse", "semicolons", "tabs", "upper-case", "gzip"])
def test_a_careless_recording_gets_a_message_that_names_the_cause(tmp_path, raw, words, not_words):
    from fringe.errors import FringeInputError
    from fringe.io.dataio import read_measurement
    with pytest.raises(FringeInputError) as e:
        read_measurement(str(_csv(tmp_path, raw)))
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(tmp_path / "rec.csv")), msg
    for w in words:
        assert w in msg, msg
    for w in not_words:
        assert w not in msg, msg


def test_a_folder_given_as_an_input_is_named_not_the_output(world, tmp_path):
    """`fringe calibrate . ...` blamed --out ('lies inside the folder ., which this command reads')."""
    user = world / "user"
    _fails_with(["calibrate", ".", "--encoder", "enc.json", "--out", "newcal"], ".: is a folder", cwd=user)
    _fails_with(["calibrate", "rec.csv", "--encoder", ".", "--out", "newcal"], ".: is a folder", cwd=user)
    _fails_with(["loop", "rec.csv", "--encoder", "enc.json", "--validate", ".", "--out", "newloop"],
                ".: is a folder", cwd=user)
    _fails_with(["correct", "rec.csv", "--cal", ".", "--out", "new.csv"], ".: not a fringe calibration", cwd=user)
    _fails_with(["rom", ".", "--out", "newrom"], ".: not a fringe calibration", cwd=user)
    _fails_with(["rom", "enc.json", "--out", "newrom"], "enc.json: is a file, not a calibration folder", cwd=user)
    assert not any((user / n).exists() for n in ("newcal", "newloop", "new.csv", "newrom"))


def test_a_users_big_folder_as_out_is_refused_without_walking_it(world, tmp_path, monkeypatch):
    """`--out /` walked the whole file system (25 s and more) before it saw there was no manifest."""
    from fringe.io import outputs

    def walked(folder):
        raise AssertionError(f"walked {folder}")
    monkeypatch.setattr(outputs, "files_in", walked)
    _fails_with(["rom", world / "user" / "cal", "--out", world / "user"], "no fringe-manifest.json")
    _fails_with(["calibrate", world / "user" / "rec.csv", "--encoder", world / "user" / "enc.json", "--out", "/"],
                "holds it")      # '/' holds the current folder, whatever that is


def test_rom_format_names_are_case_blind_and_repeats_harmless(world, tmp_path):
    with _in(world):
        status, out, err = _run(["rom", "user/cal", "--out", tmp_path / "rom", "--format", "MEM,mem, Mif"])
    assert status == 0, err
    names = sorted(os.listdir(tmp_path / "rom"))
    assert any(n.endswith(".mem") for n in names) and any(n.endswith(".mif") for n in names), names


def test_an_output_file_name_ending_in_a_slash_is_not_called_an_existing_folder(tmp_path):
    err = _fails_with(["simulate", "--preset", "seed-encoder", "--samples", "100", "--out", f"{tmp_path}/new/"],
                      "ends with '/'")
    assert "is a folder" not in err and not (tmp_path / "new").exists()


def _with_ref(world, tmp_path, fn):
    """user/rec.csv with ref_deg replaced by fn(ref_deg), as tmp_path/ref.csv."""
    lines = (world / "user" / "rec.csv").read_text().splitlines()
    head = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    k = lines[head].split(",").index("ref_deg")
    out = lines[:head + 1]
    for ln in lines[head + 1:]:
        v = ln.split(",")
        v[k] = repr(fn(float(v[k])))
        out.append(",".join(v))
    p = tmp_path / "ref.csv"
    p.write_text("\n".join(out) + "\n")
    return p


@pytest.mark.parametrize("fn, words, not_words", [
    (lambda r: 12.5, ("column 'ref_deg'", "12.5 on every row"), ("times as far",)),
    (lambda r: r * 1e-9, ("column 'ref_deg'", "times as far"), ("?) (or", "degrees? (or")),
])
def test_a_still_or_unrelated_reference_is_named_plainly(world, tmp_path, fn, words, not_words):
    """A constant ref_deg was 'moves 0 times as far as the signals ...: is ref_deg in degrees? (or ref_deg is
    not in degrees)'."""
    err = _fails_with(["calibrate", _with_ref(world, tmp_path, fn), "--encoder", world / "user" / "enc.json",
                       "--out", tmp_path / "cal"], *words)
    for w in not_words:
        assert w not in err, err
    assert not (tmp_path / "cal").exists()


@pytest.mark.parametrize("where, value, words", [
    (("stages", "output", "zero_deg"), 1e300, ("zero_deg", "plausible")),
    (("stages", "status", "amp_low"), 5.0, ("amp_low",)),
    (("stages", "coarse", "offset_periods"), 1e12, ("offset_periods",)),
    (("stages", "waveform", "cos", "inverse", "step_counts"), -1.0, ("stages.waveform.cos.inverse", "step_counts")),
])
@pytest.mark.parametrize("engine", ["model", "float"])
def test_a_calibration_edited_to_impossible_values_is_refused_by_name(world, tmp_path, where, value, words, engine):
    """An edited calibration.json with a manifest written anew ran: zero_deg = 1e300 gave the float engine
    errors of a quarter turn, step_counts <= 0 or amp_low > amp_high flagged every sample, a huge coarse offset
    stopped the model engine with a message that blamed the recording."""
    from fringe.io.outputs import write_manifest
    cal = tmp_path / "cal"
    shutil.copytree(world / "user" / "cal", cal)
    d = json.loads((cal / "calibration.json").read_text())
    o = d
    for k in where[:-1]:
        o = o[k]
    o[where[-1]] = value
    (cal / "calibration.json").write_text(json.dumps(d))
    write_manifest(str(cal), "calibration", "edited by hand")
    err = _fails_with(["correct", world / "user" / "rec.csv", "--cal", cal, "--out", tmp_path / "o.csv",
                       "--engine", engine], "calibration.json", *words)
    assert "rec.csv" not in err and not (tmp_path / "o.csv").exists()


def _with_cols(world, tmp_path, fn):
    """user/rec.csv with each data row's fields (a dict by column name) changed by fn, as tmp_path/cols.csv."""
    lines = (world / "user" / "rec.csv").read_text().splitlines()
    head = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    names = lines[head].split(",")
    out = lines[:head + 1]
    for ln in lines[head + 1:]:
        row = dict(zip(names, ln.split(","), strict=True))
        fn(row)
        out.append(",".join(row[n] for n in names))
    p = tmp_path / "cols.csv"
    p.write_text("\n".join(out) + "\n")
    return p


def _set(**kw):
    def fn(row):
        for k, f in kw.items():
            row[k] = f(row)
    return fn


@pytest.mark.parametrize("fn, words, not_words", [
    (_set(cos=lambda r: r["sin"]), ("'sin' and 'cos' are equal", "same signal"), ("octants",)),
    (_set(cos=lambda r: str(-int(r["sin"]))), ("'sin' and 'cos' are opposite",), ("octants",)),
    (_set(cos=lambda r: "17"), ("column 'cos' is 17 on every row",), ()),
    (_set(sin=lambda r: "2047" if int(r["sin"]) > 1200 else r["sin"]), ("clipped", "(first: line "), ("data row",)),
])
def test_a_calibration_refusal_names_the_column_or_line_and_the_real_cause(world, tmp_path, fn, words, not_words):
    """sin == cos (or -cos) was 'the samples cover only 3 of 8 octants ... must span at least one full signal
    period'; a constant channel was 'a channel never changes' (which?); clipping named a 'data row', not a line."""
    err = _fails_with(["calibrate", _with_cols(world, tmp_path, fn), "--encoder", world / "user" / "enc.json",
                       "--out", tmp_path / "cal"], "cols.csv", *words)
    for w in not_words:
        assert w not in err, err
    assert not (tmp_path / "cal").exists()


@pytest.mark.parametrize("text", ["sin,cos,note,note\n1,2,a,b\n5,6,c,d\n", "sin,cos,,\n1,2,,\n5,6,,\n",
                                  "t_s,sin,cos,,,\n0,1,2,,,\n1,5,6,,,\n"])
def test_repeated_or_empty_names_of_ignored_columns_are_ignored(tmp_path, text):
    """Unknown columns are ignored (spec 1), but two of the same name (or the empty names of a spreadsheet's
    trailing separators) were refused as 'duplicate column(s) ' before."""
    from fringe.io.dataio import read_measurement
    m = read_measurement(str(_csv(tmp_path, text.encode())))
    assert list(m.sin) == [1, 5] and list(m.cos) == [2, 6]


def test_simulate_with_one_name_for_both_outputs_says_so(tmp_path):
    """--out X --encoder-out X was refused as 'is also an input of this command (X)': X is no input."""
    err = _fails_with(["simulate", "--preset", "seed-encoder", "--samples", "100", "--out", tmp_path / "s.csv",
                       "--encoder-out", tmp_path / "s.csv"], "--encoder-out names the same file as --out")
    assert "input" not in err and not (tmp_path / "s.csv").exists()


def test_loop_on_a_short_recording_counts_the_files_rows(tmp_path):
    """70 rows gave 'too few samples: 40 (calibration needs at least 64)': the rows of one interleaved half."""
    assert _run(["simulate", "--preset", "seed-encoder", "--samples", "100", "--out", tmp_path / "s.csv",
                 "--encoder-out", tmp_path / "e.json"])[0] == 0
    err = _fails_with(["loop", tmp_path / "s.csv", "--encoder", tmp_path / "e.json", "--out", tmp_path / "l"],
                      "s.csv", "too few samples for the closed loop: 100", "--validate")
    assert not (tmp_path / "l").exists(), err


@pytest.mark.parametrize("engine", ["model", "float"])
def test_correct_on_normalised_floats_says_to_calibrate_again(world, tmp_path, engine):
    """Float readings for a calibration of counts were told to 'give full_scale in the encoder description', but
    fringe correct reads no encoder description: the calibration's is the one to change."""
    def to_float(key):
        return lambda r: repr(int(r[key]) / 2048)
    data = _with_cols(world, tmp_path, _set(sin=to_float("sin"), cos=to_float("cos")))
    _fails_with(["correct", data, "--cal", world / "user" / "cal", "--out", tmp_path / "o.csv", "--engine", engine],
                "cols.csv", "full_scale", "calibrate again")
    assert not (tmp_path / "o.csv").exists()


def test_control_characters_in_a_header_are_shown_escaped_on_one_line(world, tmp_path):
    """A NUL or an escape sequence inside a column name was echoed raw into the terminal."""
    bad = tmp_path / "ctl.csv"
    bad.write_bytes(b"sin,c\x00os\x1b[2J\n1,2\n")
    err = _fails_with(["calibrate", bad, "--encoder", world / "user" / "enc.json", "--out", tmp_path / "cal"],
                      "ctl.csv", "c\\x00os")
    assert err.rstrip("\n").isprintable(), err
    assert not (tmp_path / "cal").exists()
