"""The one place that compiles: numba's njit and cfunc with an on-disk cache, quiet about small matmuls.

Every compiled function in flexmbd is decorated with `njit` (or, for the kernel's one entry,
`cfunc`) from here, so the verification tests and the benchmarks run the same machine code.

numba's cache notices edits to a function's own file but not to the functions it calls from
other files, so the cache lives in a folder named after a hash of every source file that holds
compiled code (`compiled_sources`: those that import from `flexmbd.jit`, this file and the
kernel's), of the Model layout in model.py and of the constants in results.py: any edit to them
starts a fresh cache, and a stale compiled kernel can never be loaded.
"""

import gc
import hashlib
import os
import warnings
from contextlib import contextmanager
from pathlib import Path

import numba
from numba.core.errors import NumbaPerformanceWarning

from flexmbd.files import user_cache

warnings.filterwarnings("ignore", category=NumbaPerformanceWarning)

_SOURCE = Path(__file__).resolve().parent             # the flexmbd package


def compiled_sources() -> list[Path]:
    """The source files the compiled code depends on, sorted: this file (the compile options),
    the kernel's files, every file that imports from `flexmbd.jit` (those with compiled
    functions), model.py (the Model layout) and results.py (the constants they use)."""
    out = []
    for p in sorted(_SOURCE.rglob("*.py")):
        rel = p.relative_to(_SOURCE).as_posix()
        if rel in ("jit.py", "model.py", "results.py") or rel.startswith("kernel/") \
                or b"from flexmbd.jit import" in p.read_bytes():
            out.append(p)
    return out


def source_hash() -> str:
    """Hash (16 hex digits) of the files with compiled code (`compiled_sources`)."""
    h = hashlib.sha256()
    for p in compiled_sources():
        h.update(p.relative_to(_SOURCE).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    return user_cache(f"numba-{numba.__version__}-{source_hash()}")


# numba reads its settings again from the environment whenever a NUMBA_ variable differs from what
# it read last (a worker started with NUMBA_NUM_THREADS=1: executor.py); a CACHE_DIR set only on
# numba.config would then fall back to caching next to the sources, where an edit to a callee is
# never noticed. Set in the environment, it holds through every reload (and for child processes).
os.environ["NUMBA_CACHE_DIR"] = str(cache_dir())
numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]

# NUMBA_DISABLE_JIT=1: every compiled function runs as plain Python on numpy arrays (the same
# algorithm, for reading and stepping through in a debugger; far slower, for small models)
PURE_PYTHON = bool(numba.config.DISABLE_JIT)


def njit(fn=None, **kw):
    """numba.njit(cache=True, error_model="numpy", ...); usable bare (@njit) or with options
    (@njit(...)). With numpy's error model a division by zero gives inf or nan, as in numpy, and
    no division carries a zero test and a raise path; the integrators check the state is finite."""
    opts = {"cache": True, "error_model": "numpy", **kw}
    if fn is None:
        return lambda f: numba.njit(**opts)(f)
    return numba.njit(**opts)(fn)


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
        return numba.cfunc(signature, cache=True, error_model="numpy")(fn)


def is_cached() -> bool:
    """True when this source version's kernel was compiled before on this machine."""
    d = cache_dir()
    return d.is_dir() and any(d.rglob("entry.evaluate-*.nbi"))
