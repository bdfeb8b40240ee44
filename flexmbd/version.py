"""flexmbd's version, in one place: the package metadata (pyproject.toml reads it from here),
`flexmbd.__version__`, `flexmbd --version` and the in-house solver's `version()`; the hash of
the source it runs (`source_sha256`), which pins the code where no git commit does (an installed
package) or does not (a checkout with uncommitted changes); and the one recipe of a cache key
(`cache_key`), which every key of the harness goes through."""

import functools
import hashlib
import json
from pathlib import Path

__version__ = "0.1.0"


@functools.cache
def source_sha256() -> str:
    """SHA-256 (hex) of flexmbd's own source: every .py file of the package, by path and content,
    wherever the package is (a checkout or an installed package); read once per process."""
    root = Path(__file__).resolve().parent
    return cache_key(*(part for p in sorted(root.rglob("*.py"))
                       for part in (p.relative_to(root).as_posix(), b"\0", p.read_bytes(), b"\0")))


def cache_key(*parts, digits: int = 64) -> str:
    """The one recipe of a key of what is stored or cached (a run's key, a case's hashes, a result's
    CSV, a page's or a figure's inputs, a study point's folder, a machine's name, this source's
    hash): the SHA-256 in hex, its first `digits`, of `parts` one after the other, each as bytes:
    bytes as they are, a str as UTF-8, any other value as its JSON text (keys sorted, what JSON
    cannot hold as its str()). The same parts give the same key in every process and on every
    machine; a stored key stays valid as long as the parts a caller passes do."""
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, str):
            part = part.encode()
        elif not isinstance(part, (bytes, bytearray)):
            part = json.dumps(part, sort_keys=True, default=str).encode()
        h.update(part)
    return h.hexdigest()[:digits]
