"""flexmbd's version, in one place: the package metadata (pyproject.toml reads it from here),
`flexmbd.__version__`, `flexmbd --version` and the in-house solver's `version()`; and the hash of
the source it runs (`source_sha256`), which pins the code where no git commit does (an installed
package) or does not (a checkout with uncommitted changes)."""

import functools
import hashlib
from pathlib import Path

__version__ = "0.1.0"


@functools.cache
def source_sha256() -> str:
    """SHA-256 (hex) of flexmbd's own source: every .py file of the package, by path and content,
    wherever the package is (a checkout or an installed package); read once per process."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()
