"""The one place that compiles: numba's njit and cfunc with an on-disk cache, quiet about small matmuls.

Every compiled function in flexmbd is decorated with `njit` (or, for the kernel's one entry,
`cfunc`) from here, so the verification tests and the benchmarks run the same machine code.

numba's cache notices edits to a function's own file but not to the functions it calls from
other files, so the cache lives in a folder named after a hash of every source file that holds
compiled code (those that import from `kernel.jit`, and the kernel's files), of the Model layout
in model.py and of the constants in results.py: any edit to them starts a fresh cache, and a
stale compiled kernel can never be loaded.
"""

import hashlib
import os
import warnings
from pathlib import Path

import numba
from numba.core.errors import NumbaPerformanceWarning

warnings.filterwarnings("ignore", category=NumbaPerformanceWarning)

_SOURCE = Path(__file__).resolve().parent.parent


def source_hash() -> str:
    """Hash of the files with compiled code (and the layout and constants they import)."""
    h = hashlib.sha256()
    for p in sorted(_SOURCE.rglob("*.py")):
        text = p.read_bytes()
        rel = p.relative_to(_SOURCE).as_posix()
        if rel.startswith("kernel/") or rel in ("model.py", "results.py") or b"from flexmbd.kernel.jit import" in text:
            h.update(rel.encode())
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


def cfunc(signature, fn):
    """numba.cfunc(signature, cache=True, error_model="numpy")(fn): a C function, compiled (or
    loaded from the cache) now, whose address compiled code calls without linking its body in."""
    return numba.cfunc(signature, cache=True, error_model="numpy")(fn)


def is_cached() -> bool:
    """True when this source version's kernel was compiled before on this machine."""
    d = cache_dir()
    return d.is_dir() and any(d.rglob("entry.evaluate-*.nbi"))
