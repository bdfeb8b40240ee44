"""The one place that compiles: numba's njit and cfunc with an on-disk cache, quiet about small matmuls.

Every compiled function in flexmbd is decorated with `njit` (or, for the kernel's one entry,
`cfunc`) from here, so the verification tests and the benchmarks run the same machine code.

numba's cache notices edits to a function's own file but not to the functions it calls from
other files, so the cache lives in a folder named after a hash of every source file that holds
compiled code (`compiled_sources`: the compiled package's and those that import from this module)
and of the Model layout in model.py: any edit to them starts a fresh cache, and a stale compiled kernel can never be loaded. Each function's cache
(`Cache`) lives in that folder only, never beside the sources, and an entry that cannot be loaded
(a file cut short or overwritten) is removed and compiled again.
"""

import atexit
import gc
import glob
import hashlib
import os
import shutil
import sys
import tempfile
import warnings
from contextlib import contextmanager, suppress
from pathlib import Path

import numba
from numba.core import sigutils
from numba.core.caching import CompileResultCacheImpl, FunctionCache, UserProvidedCacheLocator
from numba.core.ccallback import CFunc
from numba.core.errors import NumbaPerformanceWarning

from flexmbd.mbd.cache import user_cache

warnings.filterwarnings("ignore", category=NumbaPerformanceWarning)

_SOURCE = Path(__file__).resolve().parent.parent      # the solver's package, flexmbd/mbd


def compiled_sources() -> list[Path]:
    """The source files the compiled code depends on, sorted: this file (the compile options),
    the compiled package's files, every file that imports from this module (those with compiled
    functions) and model.py (the Model layout)."""
    out = []
    for p in sorted(_SOURCE.rglob("*.py")):
        rel = p.relative_to(_SOURCE).as_posix()
        if rel == "model.py" or rel.startswith("compiled/") \
                or b"from flexmbd.mbd.compiled.jit import" in p.read_bytes():
            out.append(p)
    return out


def source_hash() -> str:
    """Hash (16 hex digits) of the files with compiled code (`compiled_sources`)."""
    h = hashlib.sha256()
    for p in compiled_sources():
        h.update(p.relative_to(_SOURCE).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def unwritable(folder: Path) -> str:
    """'' when compiled code can be kept in `folder` (made when missing, and a file written there
    and removed: numba's own test of a cache folder), else why not."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as e:
        return f"{e.filename or folder}: {e.strerror or type(e).__name__}"
    return ""


def _chosen() -> Path:
    """This source version's cache folder, `user_cache`/numba-VERSION-HASH; when that is not a
    writable folder ($XDG_CACHE_HOME a file, or read-only), one of the same name in a temporary
    folder of this process's own, removed when the process ends, said in one line on stderr.

    Not a refusal (exit 2): the cache only saves time, most commands (list, import, report
    --no-run, every other solver) compile nothing, and the figures' cache in the same place is
    drawn around too (`report.figures.kept`); nor numba's own fallback, the `__pycache__` beside the
    sources, where an edit to a callee in another file is never noticed (a stale kernel) and which
    the package's folder must not hold."""
    kept = user_cache(f"numba-{numba.__version__}-{source_hash()}")
    why = unwritable(kept)
    if not why:
        return kept
    own = Path(tempfile.mkdtemp(prefix="flexmbd-cache-"))
    atexit.register(shutil.rmtree, own, True)           # a forked worker ends by os._exit: the parent's alone
    print(f"flexmbd: the cache folder ($XDG_CACHE_HOME/flexmbd, else ~/.cache/flexmbd) cannot hold compiled code "
          f"({why}); it is kept in {own} until this command ends", file=sys.stderr, flush=True)
    return own / kept.name


_CACHE_DIR = _chosen()


def cache_dir() -> Path:
    """Where compiled code is kept (`_chosen`, once per process)."""
    return _CACHE_DIR


# numba reads its settings again from the environment whenever a NUMBA_ variable differs from what
# it read last (a worker started with NUMBA_NUM_THREADS=1: harness/executor.py); a CACHE_DIR set only on
# numba.config would then be lost. Set in the environment, it holds through every reload (and for
# child processes).
os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]


class _InCacheDir(CompileResultCacheImpl):
    """numba's cache of compile results, located in `cache_dir` (numba.config.CACHE_DIR) only:
    never numba's fallbacks beside the sources (the package's `__pycache__`)."""

    _locator_classes = [UserProvidedCacheLocator]


class Cache(FunctionCache):
    """The on-disk cache of one compiled function (numba's, `_InCacheDir`). An entry that cannot be
    loaded (an index or data file cut short, overwritten, or from a damaged disk: pickle's errors,
    or any other) is a miss: its files are removed (`discard`), one line says so on stderr (once a
    process), and numba compiles the function and saves it again."""

    _impl_class = _InCacheDir
    told = False                                        # the line said, in this process

    def load_overload(self, sig, target_context):
        try:
            return super().load_overload(sig, target_context)
        except Exception as e:                          # noqa: BLE001 - whatever a damaged file raises
            self.discard(e)
            return None

    def discard(self, e: Exception) -> None:
        """Remove this function's index (.nbi) and data files (.N.nbc), saying so once a process."""
        base = Path(self.cache_path, glob.escape(self._impl.filename_base))
        for p in glob.glob(f"{base}.nbi") + glob.glob(f"{base}.*.nbc"):
            with suppress(OSError):                     # gone already, or kept: numba's save says so then
                os.remove(p)
        if not Cache.told:
            Cache.told = True
            msg = " ".join(str(e).split())[:80]
            print(f"flexmbd: compiled code cached in {self.cache_path} could not be loaded ({type(e).__name__}"
                  f"{': ' + msg if msg else ''}); removed, compiling it again", file=sys.stderr, flush=True)


def _cached(compiled, fn):
    """A dispatcher or C function, not compiled yet, with its code kept in `cache_dir` (`Cache`; in
    place of numba's `enable_caching`, whose cache falls back to the sources' folder)."""
    compiled._cache = Cache(fn)
    return compiled


# NUMBA_DISABLE_JIT=1: every compiled function runs as plain Python on numpy arrays (the same
# algorithm, for reading and stepping through in a debugger; far slower, for small models)
PURE_PYTHON = bool(numba.config.DISABLE_JIT)


def njit(fn=None, **kw):
    """numba.njit(cache=True, error_model="numpy", ...); usable bare (@njit) or with options
    (@njit(...)). With numpy's error model a division by zero gives inf or nan, as in numpy, and
    no division carries a zero test and a raise path; the integrators check the state is finite."""
    opts = {"error_model": "numpy", **kw}
    cache = opts.pop("cache", True)

    def compiled(f):
        d = numba.njit(**opts)(f)
        return _cached(d, f) if cache and not PURE_PYTHON else d

    return compiled if fn is None else compiled(fn)


@contextmanager
def compiling():
    """Python's cyclic garbage collector paused while numba compiles: its passes over numba's
    many objects took about 13 % of a first compilation's CPU time (docs/performance.md).
    Collection resumes after."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def cfunc(signature, fn):
    """numba.cfunc(signature, cache=True, error_model="numpy")(fn): a C function, compiled (or
    loaded from the cache) now, whose address compiled code calls without linking its body in."""
    with compiling():
        f = _cached(CFunc(fn, sigutils.normalize_signature(signature), locals={}, options={"error_model": "numpy"}),
                    fn)
        f.compile()
        return f


def is_cached() -> bool:
    """True when this source version's kernel was compiled before on this machine."""
    d = cache_dir()
    return d.is_dir() and any(d.rglob("entry.evaluate-*.nbi"))
