"""The user's cache folder of flexmbd, where what costs time to make again is kept between
processes: the solver's compiled code (`compiled.jit`) and, for the harness, the report's drawn
figures (`files.user_cache` is this)."""

from __future__ import annotations

import os
from pathlib import Path


def user_cache(*parts) -> Path:
    """A path in flexmbd's folder of the user's cache ($XDG_CACHE_HOME, else ~/.cache). An empty
    or relative $XDG_CACHE_HOME is ignored, as the XDG specification says (relative, it would put
    the cache wherever the command runs: in a checkout, `flexmbd/` is the package)."""
    base = os.environ.get("XDG_CACHE_HOME", "")
    return Path(base if os.path.isabs(base) else Path.home() / ".cache", "flexmbd", *parts)
