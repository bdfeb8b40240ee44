"""Writing files so that nothing is lost or mixed: every file flexmbd writes goes through
`atomic_write` (a temporary beside the file, then one rename), a folder of pages through
`generation` (built beside the old one, swapped in at the end), and an output location is
checked with `writable_dir` before any work starts.

An unusable location (a file where a folder should be, no permission, a full disk, the file size
limit) is an InputError naming the path; nothing half-written is left behind.

SIGINT and SIGTERM have one handler per command (`signals_handled`, installed by cli.main); the
stretches `signals_held`, `signals_exit` and `signals_kept` only change what it does, so no
signal is lost between two handlers. Temporaries and staging folders are made with the signals
held and removed on every path, a signal's included. A signal ignored when the process starts
(SIG_IGN, as a background job inherits SIGINT) stays ignored everywhere.

Every JSON text flexmbd writes or prints is strict JSON (`json_text`): a number that is not finite
is null, never NaN or Infinity (which JSON does not have); readers take null where a number may be
unknown.
"""

from __future__ import annotations

import _thread
import errno
import functools
import json
import math
import os
import re
import secrets
import shutil
import signal
import socket
import sys
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

from flexmbd.core.errors import InputError, Interrupted
from flexmbd.mbd.cache import user_cache  # noqa: F401 - the user's cache folder, the solver's and the harness's

REASONS = {
    errno.ENOSPC: "no space left on the device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EFBIG: "file too large (the file size limit, ulimit -f, was reached)",
    errno.EACCES: "not writable (permission denied)",
    errno.EPERM: "not writable (operation not permitted)",
    errno.EROFS: "on a read-only file system",
    errno.ENOTDIR: "a file lies where a folder is needed",
    errno.EEXIST: "a file is there, not a folder",
    errno.EISDIR: "a folder is there, not a file",
    errno.ENOENT: "no such file or folder",
}


def json_text(x, **kw) -> str:
    """Strict JSON text of x (`jsonable`, then json.dumps(allow_nan=False, **kw))."""
    return json.dumps(jsonable(x), allow_nan=False, **kw)


def jsonable(x):
    """x with numpy numbers and arrays as Python's, every number that is not finite as None, and
    any other object that is not a number by its str()."""
    if hasattr(x, "tolist"):                                 # a numpy number or array
        x = x.tolist()
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if x is None or isinstance(x, (str, bool, int)):
        return x
    try:
        f = float(x)
    except (TypeError, ValueError):
        return str(x)
    return f if math.isfinite(f) else None


def unusable(path, e: OSError, what: str = "") -> InputError:
    """The InputError for an OSError met at `path`: one line naming the path and why."""
    why = REASONS.get(e.errno) or (e.strerror or type(e).__name__).lower()
    return InputError(f"{path}: {what + ': ' if what else ''}{why}")


def writable_dir(path, what: str = "") -> Path:
    """`path` as a folder that exists or can be created, and is writable; else an InputError
    naming it (`what`: the option it was given with)."""
    p = Path(path)
    where = lambda why: InputError(f"{p}: {what + ': ' if what else ''}{why}")
    up = p
    while not os.path.lexists(up) and up != up.parent:
        up = up.parent
    if up == p and not p.is_dir():
        raise where("a file is there, not a folder")
    if up != p and not up.is_dir():
        raise where(f"lies under {up}, which is a file")
    if not os.access(up, os.W_OK | os.X_OK):
        raise where("not writable (permission denied)" if up == p else f"cannot be created: {up} is not writable")
    return p


def make_dir(path) -> Path:
    """Create a folder and its parents; an InputError naming it when that is not possible."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise unusable(e.filename or p, e) from None
    return p


# ---------------------------------------------------------------------------------------------
# SIGINT and SIGTERM: one handler, and stretches that say what it does

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_stretches = []         # the stretches in force, innermost last: [mode, the signals that came]
_live = []              # what `_made` made and has not yet removed (a signal's exit removes it)


def _on_signal(signum, frame):
    """The one handler of SIGINT and SIGTERM. Outside any stretch a signal raises Interrupted at
    the next safe point; within one, what its mode says: "held", noted and acted on when the
    stretch ends; "exit", the process is left at once with its one line and exit status (what
    `_made` made for an enclosing block, a report's staging folder, removed first);
    "kept", noted and raised (see `signals_kept`)."""
    if not _stretches:
        raise Interrupted(signum)
    mode, got = _stretches[-1]
    if mode == "exit":
        os.write(2, f"flexmbd: interrupted ({signal.Signals(signum).name})\n".encode())
        for p in list(_live):               # a staging folder or temporary of an enclosing block
            try:
                _remove(p)
            except OSError:
                pass
        os._exit(128 + signum)
    got.append(signum)
    if mode == "kept":
        raise Interrupted(signum)


def _take() -> dict:
    """Make `_on_signal` the handler of SIGINT and SIGTERM; the handlers it replaced {signal:
    handler}. A signal that is ignored (SIG_IGN: a background job's SIGINT) stays ignored, and
    one `_on_signal` already handles is left. The swap is made with both signals blocked: one
    that came before meets the old handler (signal.signal runs pending handlers first), one that
    comes during it waits and meets the new."""
    old = {}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        for s in SIGNALS:
            handler = signal.getsignal(s)
            if handler is not signal.SIG_IGN and handler is not _on_signal:
                old[s] = signal.signal(s, _on_signal)
    except BaseException:
        _give_back(old)
        raise
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    return old


def _give_back(old: dict) -> list:
    """Put back the handlers `_take` replaced, with both signals blocked; the signals that came
    meanwhile, noted for the caller to act on. Blocked, none is lost between the two handlers
    (CPython drops a signal caught under one handler and run under SIG_DFL: bpo-43406)."""
    got = []
    if not old:
        return got
    _stretches.append(["held", got])
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        for s, handler in old.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
    finally:
        _stretches.pop()
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    return got


@contextmanager
def signals_handled():
    """The one handler of SIGINT and SIGTERM for a whole command (cli.main): installed when the
    block starts and put back when it ends, so the stretches within only change what it does.
    A signal raises Interrupted at the next safe point (outside a finalizer: `_unraisable`); one
    that comes while the handlers are put back raises it after. A signal ignored when the block
    starts stays ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = _take()
    hook, sys.unraisablehook = sys.unraisablehook, functools.partial(_unraisable, sys.unraisablehook)
    try:
        yield
    except BaseException:
        _give_back(old)                     # the block already ends by an exception or a signal
        raise
    else:
        got = _give_back(old)
    finally:
        sys.unraisablehook = hook
    if got:
        raise Interrupted(got[0])


def _unraisable(previous, unraisable) -> None:
    """sys.unraisablehook during a command: an Interrupted that Python could not pass on (the
    handler raised it while a finalizer ran, and Python only prints such an exception) is the
    signal sent again, from a thread of its own so that it comes once the finalizer is left
    (sent from here, it would be handled here); anything else goes to `previous`."""
    if not isinstance(unraisable.exc_value, Interrupted):
        return previous(unraisable)
    try:
        _thread.start_new_thread(os.kill, (os.getpid(), unraisable.exc_value.signum))
    except RuntimeError:                        # no new thread (the interpreter is ending)
        previous(unraisable)


@contextmanager
def _stretch(mode: str):
    """The block with `mode` in force (`_on_signal`). Within a command only the mode changes;
    outside one the handler is installed for the block and the old ones put back after. A signal
    that comes while the stretch ends waits for its end; the first noted is then acted on: raised
    again for "kept", otherwise sent again to whatever handles it then (the enclosing stretch, the
    command, or outside a command the handler that was there). In a thread other than the main
    one, where handlers cannot be set, the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got = []
    entry, old = [mode, got], {}
    _stretches.append(entry)
    try:
        old = _take()
        yield
    finally:
        entry[0] = "held"
        try:
            got += _give_back(old)
        finally:
            _stretches[:] = [e for e in _stretches if e is not entry]
        if got and mode == "kept":
            raise Interrupted(got[0])
        if got:
            signal.raise_signal(got[0])


def signals_held():
    """Hold SIGINT and SIGTERM back until the block is done, then act on the first that came:
    for a stretch that must not be cut short (a swap, a removal)."""
    return _stretch("held")


def signals_exit():
    """For a stretch that writes nothing of flexmbd's but may run native code for long (a solver's
    run, numba compiling): SIGINT or SIGTERM ends the process at once with its one line and exit
    status. A Python exception raised inside native callbacks (LLVM's, while numba compiles) would
    be printed as ignored and lost; the process is left instead (numba writes its cache files by
    rename, so none is left half-written)."""
    return _stretch("exit")


def signals_kept():
    """For native code that runs Python's signal handlers but turns their exception into its own
    failure (Exudyn's solver does): a SIGINT or SIGTERM raises Interrupted as usual, and is raised
    again when the block ends, whatever the native code made of it."""
    return _stretch("kept")


# ---------------------------------------------------------------------------------------------
# temporaries and swaps: nothing half-written, mixed or left behind


def discard(*paths) -> None:
    """Remove what an unfinished write leaves (temporaries, a staging folder, old entries kept
    aside; None is skipped), with SIGINT and SIGTERM held. A signal whose exception came just
    before the hold does not stop the removal: it is done, then the exception raised again."""
    late = None
    while True:
        try:
            with signals_held():
                for p in paths:
                    _remove(p)
            break
        except KeyboardInterrupt as e:
            late = late or e
    if late is not None:
        raise late


def _remove(path) -> None:
    if path is None:
        return
    if _is_folder(path):
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            Path(path).unlink(missing_ok=True)
        except OSError:
            pass                                 # not ours to remove any more (a read-only folder)


def _is_folder(path) -> bool:
    return Path(path).is_dir() and not Path(path).is_symlink()


def forget_live() -> None:
    """In a process forked from one with staging folders or temporaries open, or inside a held
    or kept stretch: they are its parent's, which removes them and ends its stretches; a
    signal's exit here leaves them alone."""
    _live.clear()
    _stretches.clear()


@contextmanager
def _made(make):
    """What `make()` creates (a temporary file or folder: its path) for the block, removed when
    the block ends on any path (`discard`). It is made with SIGINT and SIGTERM held, so no signal
    comes between its making and its owning."""
    made = None
    try:
        with signals_held():
            made = make()
            _live.append(made)
        yield made
    finally:
        discard(made)
        if made in _live:
            _live.remove(made)


@contextmanager
def temporary(path, content):
    """`content` in a new temporary file beside `path` (mode 644) for the block: its name, to be
    put in place by `swap`. Whatever is left of it when the block ends is removed, on any path.
    `content` is text, bytes, or a function writing to an open binary file. An OSError becomes an
    InputError naming `path`."""
    path = Path(path)
    make_dir(path.parent)

    def make() -> str:
        try:
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        except OSError as e:
            raise unusable(path, e) from None
        os.close(fd)
        return tmp

    with _made(make) as tmp:
        try:
            with os.fdopen(os.open(tmp, os.O_WRONLY), "wb") as f:
                if callable(content):
                    content(f)
                else:
                    f.write(content.encode() if isinstance(content, str) else content)
            os.chmod(tmp, 0o644)
        except OSError as e:
            raise unusable(path, e) from None
        yield tmp


def swap(moves) -> None:
    """Replace files and folders together. `moves` is [(new, path)]: `new` a temporary or staged
    entry beside `path`, renamed into its place, or None to remove `path`. Every path is checked
    first (a folder where a file goes, or a file where a folder goes, is refused); then, with
    SIGINT and SIGTERM held, each old entry is kept aside until all are in place (a hard link of a
    file, which stays in place until it is replaced; a folder renamed), and a rename that fails
    undoes those done, so the paths hold the old set or the new one. An OSError becomes an
    InputError naming the path."""
    moves = [(None if new is None else Path(new), Path(path)) for new, path in moves]
    for new, path in moves:
        _check_kinds(new, path)
    with signals_held():
        kept, done = [], []                  # old entries kept aside; moves made (new, path, old)
        try:
            for k, (new, path) in enumerate(moves):
                failed, old = path, None
                if _is_folder(path) or (k < len(moves) - 1 and os.path.lexists(path)):
                    old = _aside(path) if _is_folder(path) else _link(path)
                    kept.append(old)
                try:
                    if new is None:
                        path.unlink(missing_ok=True)
                    else:
                        os.replace(new, path)
                except OSError:
                    done.append((None, path, old) if old is not None and not os.path.lexists(path) else None)
                    raise
                done.append((new, path, old))
        except OSError as e:
            for move in reversed(done):
                if move is not None and not _undo(*move):
                    kept.remove(move[2])             # not put back: it stays where it was kept
            raise unusable(failed, e) from None
        finally:
            discard(*kept)


def _check_kinds(new, path: Path) -> None:
    """An InputError when `path` holds a folder and a file (or nothing) is to take its place, or a
    file and a folder is to."""
    if not os.path.lexists(path):
        return
    if _is_folder(path) and (new is None or not _is_folder(new)):
        raise InputError(f"{path}: a folder is there, not a file")
    if new is not None and _is_folder(new) and not _is_folder(path):
        raise InputError(f"{path}: a file is there, not a folder")


def _undo(new, path: Path, old) -> bool:
    """Put the old entry `old` (None: there was none) back at `path`, in place of what `new` put
    there (None: nothing); False when that failed."""
    try:
        if new is not None and (old is None or _is_folder(path)):
            _remove(_aside(path) if _is_folder(path) else path)
        if old is not None:
            os.replace(old, path)
    except OSError:
        return False
    return True


def _kept_name(path: Path) -> Path:
    """A new hidden name beside `path` for its old entry."""
    return path.with_name(f".{path.name}.{secrets.token_hex(4)}.old")


def _link(path: Path) -> Path:
    """A hard link to the file at `path` under a new hidden name beside it (a copy where the file
    system has no hard links); that name."""
    while True:
        kept = _kept_name(path)
        try:
            os.link(path, kept, follow_symlinks=False)
            return kept
        except FileExistsError:
            continue
        except OSError:
            pass
        try:
            shutil.copy2(path, kept, follow_symlinks=False)
        except OSError:
            _remove(kept)
            raise
        return kept


def _aside(path: Path) -> Path:
    """The entry at `path` renamed to a new hidden name beside it; that name."""
    kept = _kept_name(path)
    while os.path.lexists(kept):
        kept = _kept_name(path)
    os.rename(path, kept)
    return kept


def atomic_write(path, content) -> Path:
    """Replace `path` by a file holding `content` (see `temporary`): readers see the old file or
    the new one, never a part."""
    with temporary(path, content) as tmp:
        swap([(tmp, path)])
    return Path(path)


@contextmanager
def generation(dest):
    """A staging folder inside `dest` to build a set of files and folders in; when the block
    ends normally they replace their namesakes in `dest` together (`swap`), so `dest` holds the
    old set or the new one. The staging folder and the old entries are removed on every path (an
    error, a signal); an OSError while building is an InputError naming its file. Its name holds
    its owner (`staging_prefix`), so that one left by a process killed outright (SIGKILL, a power
    cut) is removed by the next generation in `dest` (`stale`), and one a live process builds in
    is not."""
    dest = make_dir(dest)

    def make() -> Path:
        discard(*stale(dest))
        try:
            return Path(tempfile.mkdtemp(dir=dest, prefix=staging_prefix()))
        except OSError as e:
            raise unusable(dest, e) from None

    with _made(make) as stage:
        try:
            yield stage
        except OSError as e:
            raise unusable(e.filename or dest, e) from None
        swap([(item, dest / item.name) for item in sorted(stage.iterdir())])


def staging_prefix(pid: int | None = None) -> str:
    """The start of the name of a staging folder (`generation`) made by process `pid` (this one)
    of this machine: `.new-PID-HOST-`."""
    return f".new-{os.getpid() if pid is None else pid}-{socket.gethostname()}-"


def stale(dest) -> list:
    """The staging folders in `dest` that no live process owns: made on this machine (a folder of
    another machine on a shared file system is left to it) by a process that has ended. A folder
    of another form is left alone."""
    here = re.compile(r"\.new-([1-9]\d{0,8})-" + re.escape(socket.gethostname()) + r"-[^/]+")
    try:
        names = os.listdir(dest)
    except OSError:
        return []
    found = [(name, here.fullmatch(name)) for name in names]
    return [Path(dest, name) for name, m in found if m and not alive(int(m[1])) and _is_folder(Path(dest, name))]


def alive(pid: int) -> bool:
    """True when process `pid` exists (another user's too)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True
