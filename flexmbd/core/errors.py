"""The one exception for bad input (the command line prints its message as one line, exit 2),
and the one for a signal that ends a command."""


class InputError(Exception):
    """Bad user input (case file, override, command-line value), already phrased for the user.

    The message names where the problem is (file and dotted key) and what was expected. It is
    made `printable` when raised, so that echoing user text can neither break it over lines nor
    fail to print.
    """

    def __init__(self, message: str):
        super().__init__(printable(str(message)))


def printable(text: str) -> str:
    """`text` with every character that cannot be shown within one line escaped: line breaks and
    other control characters as Python escapes, and the surrogates that stand for undecodable
    bytes of a command-line argument as the byte (\\xe9)."""
    return "".join(ch if ch.isprintable() else _escape(ch) for ch in text)


def _escape(ch: str) -> str:
    code = ord(ch)
    if 0xDC80 <= code <= 0xDCFF:                        # os.fsdecode's stand-in for byte code - 0xDC00
        return f"\\x{code - 0xDC00:02x}"
    return ch.encode("unicode_escape", "backslashreplace").decode("ascii")

class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM, raised at the next safe point: `signum` says which (exit 128 + signum)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum
