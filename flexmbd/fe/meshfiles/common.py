"""What every mesh-file reader shares: the unit systems, a file's text, the place of a message
("FILE:LINE"), the checked number readers (integers up to NUMBER_MAX, finite reals in NASTRAN's
forms too), the ranges of set members (THRU, GENERATE) and the lookup of file numbers."""

from __future__ import annotations

import re

import numpy as np

from flexmbd.core.errors import InputError

# file units -> (length to m, E to Pa, rho to kg/m^3)
UNITS = {"m": (1.0, 1.0, 1.0), "mm": (1e-3, 1e6, 1e12)}

# the largest node, element, property or set number read (the numbers are kept as int64)
NUMBER_MAX = int(np.iinfo(np.int64).max)

# a range of set members (THRU, GENERATE) longer than the file has lines lists numbers the file
# cannot define, and is refused before it is expanded; one of up to this many members is expanded
# anyway, so that the member that is not defined is named
RANGE_EXPANDED = 100_000


def check_units(source, units) -> None:
    """InputError unless `units` is one of UNITS."""
    if units not in UNITS:
        raise InputError(f"{source}: units {units!r} unknown (use one of: {', '.join(UNITS)})")


def text(source) -> str:
    """The file's text (undecodable bytes replaced); InputError when it cannot be read."""
    try:
        with open(source, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError as e:
        raise InputError(f"{source}: cannot read the file ({e.strerror or e})") from None


def readable(source) -> None:
    """InputError, the same as `text`'s, when the file cannot be opened."""
    try:
        open(source, "rb").close()
    except OSError as e:
        raise InputError(f"{source}: cannot read the file ({e.strerror or e})") from None


def place(source, line) -> str:
    """"FILE:LINE" of a message, or "FILE" where the line is not known (0)."""
    return f"{source}:{line}" if line else source


def is_int(token) -> bool:
    return re.fullmatch(r"[+-]?\d+", token.strip()) is not None


def is_real(token) -> bool:
    try:
        float(token)
        return True
    except ValueError:
        return False


def integer(field, at, what) -> int:
    """An integer field (of either format): a number of at most NUMBER_MAX in size."""
    if not is_int(field):
        raise InputError(f"{at}: {what}: {field!r} is not an integer")
    value = int(field)
    if abs(value) > NUMBER_MAX:
        raise InputError(f"{at}: {what}: {field.strip()} is too large (numbers up to {NUMBER_MAX} are read)")
    return value


def real(field, at, what) -> float:
    """A NASTRAN real, finite: also '1.5-3' and '2.+5' (exponent without E) and D exponents."""
    s = field.strip().upper().replace("D", "E")
    m = re.fullmatch(r"([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)", s)
    if m:
        s = f"{m.group(1)}E{m.group(2)}"
    try:
        value = float(s)
    except ValueError:
        raise InputError(f"{at}: {what}: {field!r} is not a number") from None
    if not np.isfinite(value):
        raise InputError(f"{at}: {what}: {field!r} is not a finite number")
    return value


def members(first, last, step, at, what, n_lines) -> range:
    """first, first + step, ..., last: the numbers of a range of set members (`what`, as the file
    gives it), ascending; refused before any list of them is made when it holds more numbers than
    the file's `n_lines` lines could define (a node or an element takes a line at least; RANGE_EXPANDED)."""
    if step < 1 or last < first:
        raise InputError(f"{at}: {what} is not an ascending range")
    numbers = range(first, last + 1, step)
    if len(numbers) > max(n_lines, RANGE_EXPANDED):
        raise InputError(f"{at}: {what} holds {len(numbers)} numbers, more than a file of {n_lines} lines can "
                         "define (a node or an element takes a line at least, and a set's members must be defined)")
    return numbers


def lookup(numbers):
    """A function mapping file numbers (any shape) to their positions in `numbers`, -1 where absent."""
    numbers = np.asarray(numbers, dtype=np.int64)
    order = np.argsort(numbers, kind="stable")
    s = numbers[order]

    def rows(wanted):
        wanted = np.asarray(wanted, dtype=np.int64)
        if s.size == 0:
            return np.full(wanted.shape, -1, dtype=np.int64)
        pos = np.minimum(np.searchsorted(s, wanted), s.size - 1)
        return np.where(s[pos] == wanted, order[pos], -1)
    return rows
