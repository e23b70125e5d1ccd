"""Output safety: fringe replaces only what it wrote itself, atomically, and never one of its inputs.

Every output folder carries `fringe-manifest.json` (its kind, the command that wrote it and a
SHA-256 of every file), so that a later run can tell its own folders from a user's, and a reader
can tell a complete folder from a mixed, truncated or edited one. Single output files carry a
first line (CSV `# fringe <kind>...`) or key (JSON `written_by`) that says the same.

Outputs are checked before any work starts (`check_output_dir`, `check_output_file`), built under
a hidden temporary name beside their target, given the permissions the umask allows, and swapped
in at the end: the new folder takes the old one's name in one rename, then the old one is removed.
The rename and its record (`COMMITTED`) happen with SIGINT, SIGTERM and SIGHUP held, so that the
command line's handler knows which side of the rename a signal came on: before it, nothing was
written; after it, the output is complete and the command finishes.
"""

import ctypes
import hashlib
import json
import os
import shutil
import signal
import stat
import tempfile
from contextlib import contextmanager

from .. import __version__
from ..errors import FringeInputError

MANIFEST = "fringe-manifest.json"
FORMAT = "fringe-output"
VERSION = 1
TMP_PREFIX = ".fringe-incomplete-"


#: the outputs this process has put in place: a signal after the first of them interrupts nothing (the command's
#: work is done; what is left is writing its last lines)
COMMITTED: list[str] = []
HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}


@contextmanager
def _signals_held():
    """Hold the interrupting signals (they wait, then arrive) while an output is put in place and recorded."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def current_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _fail(problem: str, path: str):
    raise FringeInputError(problem, path or "''")


def _real(path: str) -> str:
    return os.path.realpath(os.path.abspath(path))


def _check_parent(path: str):
    """The nearest existing folder above `path` must be a writable folder."""
    parent = os.path.dirname(os.path.abspath(path))
    while not os.path.lexists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        _fail(f"cannot be created: {parent} is a file, not a folder", path)
    if not os.access(parent, os.W_OK | os.X_OK):
        _fail(f"cannot be written: the folder {parent} is not writable", path)


def _check_name(path: str):
    """A name the system can create: no part longer than the folder's NAME_MAX, the whole within PATH_MAX
    (refused before the work, naming what was given, not the temporary name beside it)."""
    parent = os.path.dirname(os.path.abspath(path))
    while not os.path.isdir(parent):
        parent = os.path.dirname(parent)
    try:
        name_max, path_max = os.pathconf(parent, "PC_NAME_MAX"), os.pathconf(parent, "PC_PATH_MAX")
    except (OSError, ValueError):
        name_max, path_max = 255, 4096
    longest = max((len(os.fsencode(p)) for p in os.path.abspath(path).split(os.sep)), default=0)
    if longest > name_max:
        _fail(f"a name in it is {longest} bytes long; this file system takes at most {name_max}", path)
    if len(os.fsencode(os.path.abspath(path))) >= path_max:
        _fail(f"is longer than this system's limit of {path_max} bytes for a path", path)


def _check_not_current(path: str):
    """The folder the command runs in (or one holding it) cannot be replaced whole."""
    out, here = _real(path), _real(os.getcwd())
    if here == out or here.startswith(out.rstrip(os.sep) + os.sep):
        _fail("is the current folder, or holds it: an output folder is replaced whole; give a new folder's "
              "name", path)


def _check_not_an_input(path: str, inputs, is_dir: bool):
    out = _real(path)
    for given in inputs:
        if not given:
            continue
        src = _real(given)
        if out == src:
            _fail(f"is also an input of this command ({given}): refusing to overwrite it", path)
        if is_dir and src.startswith(out + os.sep):
            _fail(f"holds an input of this command ({given}): refusing to replace it", path)
        if os.path.isdir(src) and out.startswith(src + os.sep):
            _fail(f"lies inside the folder {given}, which this command reads: refusing to write there", path)


def files_in(folder: str) -> set[str]:
    """Every file below `folder`, as relative paths with '/'."""
    found = set()
    for dirpath, _, names in os.walk(folder):
        for n in names:
            found.add(os.path.relpath(os.path.join(dirpath, n), folder).replace(os.sep, "/"))
    return found


def read_manifest(folder: str) -> dict | None:
    """The folder's manifest, or None when it has none or it is not fringe's."""
    try:
        with open(os.path.join(folder, MANIFEST), encoding="utf-8") as f:
            d = json.load(f)
    except (OSError, ValueError):
        return None
    if not isinstance(d, dict) or d.get("format") != FORMAT or not isinstance(d.get("files"), dict):
        return None
    return d


def check_output_dir(path: str, kind: str, inputs=()) -> None:
    """Refuse, before any work: an empty name, a link, a file, a folder fringe did not write as
    `kind`, a folder holding an input, a folder inside an input folder, an unwritable place."""
    if not path:
        _fail("the output folder name is empty", path)
    _check_name(path)
    _check_not_current(path)
    if os.path.islink(path):
        _fail("is a symbolic link: give the folder itself", path)
    if os.path.lexists(path):
        if not os.path.isdir(path):
            _fail("exists and is not a folder: refusing to replace it", path)
        _check_replaceable(path, kind)
    _check_parent(path)
    _check_not_an_input(path, inputs, is_dir=True)


def _check_replaceable(path: str, kind: str):
    try:
        entries = os.listdir(path)
    except OSError as e:
        _fail(f"cannot be read: {e.strerror}", path)
    if not entries:
        return
    man = read_manifest(path)     # before walking the folder: '/' or a home folder is refused at once
    if man is None:
        _fail(f"exists and is not a fringe {kind} folder (no {MANIFEST}): fringe replaces only its own "
              "outputs; choose another --out or remove it yourself", path)
    if man.get("kind") != kind:
        _fail(f"is a fringe {man.get('kind')} folder, not a {kind} folder: refusing to replace it", path)
    try:
        present = files_in(path)
    except OSError as e:
        _fail(f"cannot be read: {e.strerror}", path)
    listed = set(man["files"]) | {MANIFEST}
    # fringe writes regular files, and folders only to hold them: a link, or a folder that holds none of its
    # files (an empty one counts), is the user's
    holders = {"/".join(rel.split("/")[:k]) for rel in listed for k in range(1, rel.count("/") + 1)}
    try:
        links, folders = _links_and_folders(path)
    except OSError as e:
        _fail(f"cannot be read: {e.strerror}", path)
    extra = sorted((present - listed) | links | (folders - holders))
    if extra:
        _fail(f"holds {extra[0]}, which fringe did not write: refusing to replace the folder", path)


def _links_and_folders(folder: str) -> tuple[set[str], set[str]]:
    """The symbolic links (to anything) and the folders below `folder`, as relative paths with '/' (links to
    folders are not followed)."""
    links, folders = set(), set()
    for dirpath, dirnames, names in os.walk(folder):
        for n in dirnames + names:
            full = os.path.join(dirpath, n)
            rel = os.path.relpath(full, folder).replace(os.sep, "/")
            if os.path.islink(full):
                links.add(rel)
            elif n in dirnames:
                folders.add(rel)
    return links, folders


def written_by_fringe(path: str, kind: str) -> bool:
    """A file fringe wrote as `kind`: CSV whose first line is '# fringe <kind>', or JSON with written_by."""
    try:
        with open(path, "rb") as f:
            head = f.read(65536)
    except OSError:
        return False
    text = head.decode("utf-8", "replace")
    if text.startswith(f"# fringe {kind}"):
        return True
    try:
        d = json.loads(text)
    except ValueError:
        return False
    return isinstance(d, dict) and str(d.get("written_by", "")).startswith(f"fringe {kind}")


def _form(path: str) -> str:
    """'JSON' or 'CSV': what a file fringe wrote holds (a JSON document starts with '{')."""
    with open(path, "rb") as f:
        return "JSON" if f.read(64).lstrip().startswith(b"{") else "CSV"


def check_output_file(path: str, kind: str, inputs=(), form: str | None = None) -> None:
    """Refuse, before any work: an empty name, a folder, a link, a special file, a file fringe did not
    write as `kind` (or, with `form`, as another form: 'CSV' or 'JSON'), an input, a file inside an input
    folder, a missing or unwritable folder."""
    if not path:
        _fail("the output file name is empty", path)
    _check_name(path)
    if os.path.isdir(path):
        _fail("is a folder: give a file name", path)
    if path.endswith(("/", os.sep)):
        _fail("ends with '/', which names a folder: give a file name", path)
    if os.path.islink(path):
        _fail("is a symbolic link: give the file itself", path)
    if os.path.lexists(path):
        if not stat.S_ISREG(os.lstat(path).st_mode):
            _fail("is not a regular file (a device, FIFO or socket): refusing to write to it", path)
        if not written_by_fringe(path, kind):
            _fail(f"exists and was not written by fringe {kind}: refusing to overwrite it", path)
        if form and _form(path) != form:
            _fail(f"holds a {_form(path)} file fringe {kind} wrote; this output is a {form}: refusing to "
                  "replace it (give another name)", path)
    _check_parent(path)
    if not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        _fail("cannot be written: its folder does not exist", path)
    _check_not_an_input(path, inputs, is_dir=False)


def _permissions(root: str, mask: int):
    """What the umask allows (mkstemp/mkdtemp create 0600/0700)."""
    for dirpath, _, names in os.walk(root):
        os.chmod(dirpath, 0o777 & ~mask)
        for n in names:
            os.chmod(os.path.join(dirpath, n), 0o666 & ~mask)


def sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_manifest(folder: str, kind: str, command: str):
    files = {rel: {"sha256": sha256(os.path.join(folder, rel)), "bytes": os.path.getsize(os.path.join(folder, rel))}
             for rel in sorted(files_in(folder)) if rel != MANIFEST}
    with open(os.path.join(folder, MANIFEST), "w", encoding="utf-8") as f:
        json.dump({"format": FORMAT, "version": VERSION, "kind": kind, "fringe_version": __version__,
                   "command": command, "files": files}, f, indent=2)
        f.write("\n")


def verify_dir(folder: str, kind: str) -> dict:
    """Refuse a folder that is not a complete, unedited fringe `kind` folder, naming the file."""
    if not os.path.isdir(folder):
        _fail(f"is a file, not a {kind} folder" if os.path.exists(folder) else f"{kind} folder not found", folder)
    man = read_manifest(folder)
    if man is None:
        _fail(f"not a fringe {kind} folder: {MANIFEST} is missing or damaged (written by an older fringe? "
              "run fringe again to write it anew)", folder)
    if man.get("kind") != kind:
        inner = " (its calibration is the cal/ folder inside)" if man.get("kind") == "loop" else ""
        _fail(f"is a fringe {man.get('kind')} folder, not a {kind} folder{inner}", folder)
    for rel, entry in man["files"].items():
        path = os.path.join(folder, rel)
        if not os.path.isfile(path):
            _fail(f"missing from the {kind} folder (listed in its {MANIFEST})", path)
        try:
            ok = isinstance(entry, dict) and sha256(path) == entry.get("sha256")
        except OSError as e:
            _fail(f"cannot be read: {e.strerror}", path)
        if not ok:
            _fail(f"changed since fringe wrote it (checksum differs from {MANIFEST}): the folder is mixed, "
                  "truncated or edited; write it anew", path)
    return man


_RENAME_EXCHANGE = 2


def _exchange(a: str, b: str) -> bool:
    """Swap two paths in one step (Linux renameat2); False where the system cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    return fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE) == 0


@contextmanager
def atomic_dir(out_dir: str, kind: str, inputs=(), command: str = ""):
    """Build a `kind` folder under a temporary name; it takes `out_dir`'s place only when complete."""
    check_output_dir(out_dir, kind, inputs)
    mask = current_umask()
    parent = os.path.dirname(os.path.abspath(out_dir))
    os.makedirs(parent, exist_ok=True)
    tmp = tempfile.mkdtemp(dir=parent, prefix=TMP_PREFIX + kind + "-")
    try:
        yield tmp
        write_manifest(tmp, kind, command or f"fringe {kind}")
        _permissions(tmp, mask)
        check_output_dir(out_dir, kind, inputs)      # again: it may have changed while we worked
        previous = None
        with _signals_held():
            if os.path.isdir(out_dir) and os.listdir(out_dir):
                if _exchange(tmp, out_dir):           # tmp now holds the previous output
                    previous = tmp
                else:
                    previous = tempfile.mkdtemp(dir=parent, prefix=TMP_PREFIX + "old-")
                    os.rename(out_dir, os.path.join(previous, "previous"))
                    os.rename(tmp, out_dir)
            else:
                os.replace(tmp, out_dir)              # onto nothing or an empty folder
            COMMITTED.append(out_dir)
        if previous:
            shutil.rmtree(previous)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


@contextmanager
def atomic_output(path: str, kind: str, inputs=(), mode: str = "w"):
    """Write a file under a temporary name beside `path`; it replaces `path` in one rename on success."""
    check_output_file(path, kind, inputs)
    mask = current_umask()
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=TMP_PREFIX,
                                suffix="-" + os.path.basename(path)[:40])
    try:
        binary = "b" in mode
        with os.fdopen(fd, mode, encoding=None if binary else "utf-8", newline=None if binary else "") as f:
            yield f
        os.chmod(tmp, 0o666 & ~mask)
        check_output_file(path, kind, inputs)
        if os.path.lexists(path) and _form(path) != _form(tmp):   # simulate writes a CSV and a JSON
            _fail(f"holds a {_form(path)} file fringe {kind} wrote; this output is a {_form(tmp)}: refusing to "
                  "replace it (give another name)", path)
        with _signals_held():
            os.replace(tmp, path)
            COMMITTED.append(path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
