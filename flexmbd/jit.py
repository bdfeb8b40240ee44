"""The one place that compiles: numba's njit with an on-disk cache, quiet about small matmuls.

Every compiled function in flexmbd is decorated with `njit` from here, so the verification
tests and the benchmarks run the same machine code.

numba's cache notices edits to a function's own file but not to the functions it calls from
other files, so the cache lives in a folder named after a hash of every source file that holds
compiled code (those that import this module, and this one): any edit to them starts a fresh
cache, and a stale compiled kernel can never be loaded.
"""

import hashlib
import os
import warnings
from pathlib import Path

import numba
from numba.core.errors import NumbaPerformanceWarning

warnings.filterwarnings("ignore", category=NumbaPerformanceWarning)

_SOURCE = Path(__file__).resolve().parent


def source_hash() -> str:
    """Hash of the files with compiled code (and the constants they import from model.py and
    results.py)."""
    h = hashlib.sha256()
    for p in sorted(_SOURCE.rglob("*.py")):
        text = p.read_bytes()
        if p.name in ("jit.py", "model.py", "results.py") or b"from flexmbd.jit import" in text:
            h.update(p.relative_to(_SOURCE).as_posix().encode())
            h.update(text)
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "flexmbd" / f"numba-{numba.__version__}-{source_hash()}"


numba.config.CACHE_DIR = str(cache_dir())

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


def is_cached() -> bool:
    """True when this source version's kernels were compiled before on this machine."""
    d = cache_dir()
    return d.is_dir() and any(d.rglob("dynamics.aba-*.nbi"))
