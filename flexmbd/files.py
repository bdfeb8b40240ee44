"""Writing files so that nothing is lost or mixed: every file flexmbd writes goes through
`atomic_write` (a temporary beside the file, then one rename), a folder of pages through
`generation` (built beside the old one, swapped in at the end), and an output location is
checked with `writable_dir` before any work starts.

An unusable location (a file where a folder should be, no permission, a full disk, the file size
limit) is an InputError naming the path; nothing half-written is left behind.
"""

from __future__ import annotations

import errno
import os
import shutil
import signal
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

from flexmbd.errors import InputError, Interrupted

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


@contextmanager
def signals_held():
    """Hold SIGINT and SIGTERM back until the block is done, then deliver the first that came.

    A handler that only records the signal (any thread may receive a process signal, so a
    thread's signal mask is not enough); outside the main thread, where handlers cannot be
    set, the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got = []
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    for s in old:
        signal.signal(s, lambda signum, frame: got.append(signum))
    try:
        yield
    finally:
        restore(old)
        if got:
            signal.raise_signal(got[0])


@contextmanager
def signals_exit():
    """For a stretch that writes nothing of flexmbd's but may run native code for long (a solver's
    run, numba compiling): SIGINT or SIGTERM ends the process at once with its one line and exit
    status. A Python exception raised inside native callbacks (LLVM's, while numba compiles) would
    be printed as ignored and lost; the process is left instead (numba writes its cache files by
    rename, so none is left half-written)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def leave(signum, frame):
        os.write(2, f"flexmbd: interrupted ({signal.Signals(signum).name})\n".encode())
        os._exit(128 + signum)

    old = {s: signal.signal(s, leave) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        restore(old)


@contextmanager
def signals_kept():
    """For native code that runs Python's signal handlers but turns their exception into its own
    failure (Exudyn's solver does): a SIGINT or SIGTERM raises Interrupted as usual, and is raised
    again when the block ends, whatever the native code made of it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got = []

    def note(signum, frame):
        got.append(signum)
        raise Interrupted(signum)

    old = {s: signal.signal(s, note) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        restore(old)
        if got:
            raise Interrupted(got[0])


def restore(handlers: dict) -> None:
    """Put back signal handlers {signal: handler} as getsignal / signal returned them."""
    for s, handler in handlers.items():
        signal.signal(s, handler if handler is not None else signal.SIG_DFL)


def temporary(path, content) -> str:
    """`content` in a new temporary file beside `path` (mode 644); its name. `content` is text,
    bytes, or a function writing to an open binary file. An OSError becomes an InputError naming
    `path`, and the temporary is removed."""
    path = Path(path)
    make_dir(path.parent)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as e:
        raise unusable(path, e) from None
    try:
        with os.fdopen(fd, "wb") as f:
            if callable(content):
                content(f)
            else:
                f.write(content.encode() if isinstance(content, str) else content)
        os.chmod(tmp, 0o644)
    except OSError as e:
        Path(tmp).unlink(missing_ok=True)
        raise unusable(path, e) from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


def atomic_write(path, content) -> Path:
    """Replace `path` by a file holding `content` (see `temporary`): readers see the old file or
    the new one, never a part."""
    tmp = temporary(path, content)
    try:
        os.replace(tmp, path)
    except OSError as e:
        raise unusable(path, e) from None
    finally:
        Path(tmp).unlink(missing_ok=True)
    return Path(path)


@contextmanager
def generation(dest):
    """A staging folder inside `dest` to build a set of files and folders in; when the block
    ends normally each of them replaces its namesake in `dest`, all together with SIGINT and
    SIGTERM held, so `dest` holds the old set or the new one. On any error or interruption the
    staging folder is removed and `dest` is left as it was."""
    dest = make_dir(dest)
    try:
        stage = Path(tempfile.mkdtemp(dir=dest, prefix=".new-"))
    except OSError as e:
        raise unusable(dest, e) from None
    old = []
    try:
        yield stage
        with signals_held():
            for item in sorted(stage.iterdir()):
                target = dest / item.name
                if target.is_dir() and not target.is_symlink():
                    old.append(target.rename(dest / f".old-{stage.name[5:]}-{item.name}"))
                os.replace(item, target)
    except OSError as e:
        raise unusable(e.filename or dest, e) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        for p in old:
            shutil.rmtree(p, ignore_errors=True)
