"""The one place that compiles: numba's njit with an on-disk cache, quiet about small matmuls.

Every compiled function in flexmbd is decorated with `njit` from here, so the verification
tests and the benchmarks run the same machine code.

numba's cache notices edits to a function's own file but not to the functions it calls from
other files, so the cache lives in a folder named after a hash of all of flexmbd's sources:
any edit starts a fresh cache, and a stale compiled kernel can never be loaded.
"""

import hashlib
import os
import time
import warnings
from pathlib import Path

import numba
from numba.core.errors import NumbaPerformanceWarning

warnings.filterwarnings("ignore", category=NumbaPerformanceWarning)

_SOURCE = Path(__file__).resolve().parent


def source_hash() -> str:
    h = hashlib.sha256()
    for p in sorted(_SOURCE.rglob("*.py")):
        h.update(p.relative_to(_SOURCE).as_posix().encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "flexmbd" / f"numba-{numba.__version__}-{source_hash()}"


numba.config.CACHE_DIR = str(cache_dir())


def njit(fn=None, **kw):
    """numba.njit(cache=True, ...); usable bare (@njit) or with options (@njit(...))."""
    opts = {"cache": True, **kw}
    if fn is None:
        return lambda f: numba.njit(**opts)(f)
    return numba.njit(**opts)(fn)


def is_cached() -> bool:
    """True when this source tree's kernels were compiled before (the cache folder has entries)."""
    d = cache_dir()
    return d.is_dir() and any(d.rglob("*.nbi"))


def warm_up() -> float:
    """Compile (or load from the cache) every kernel by running one small model; seconds taken."""
    t0 = time.perf_counter()
    from flexmbd import dynamics  # noqa: F401  (imports define the kernels)
    dynamics.warm_up()
    return time.perf_counter() - t0
