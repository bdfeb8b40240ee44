"""flexmbd: a validation and benchmarking harness for flexible multibody dynamics."""

__version__ = "0.1.0"
