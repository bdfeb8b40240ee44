"""flexmbd's version, in one place: the package metadata (pyproject.toml reads it from here),
`flexmbd.__version__`, `flexmbd --version` and the in-house solver's `version()`."""

__version__ = "0.1.0"
