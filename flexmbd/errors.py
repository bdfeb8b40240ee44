"""The one exception for bad input (the command line prints its message as one line, exit 2),
and the one for a signal that ends a command."""


class InputError(Exception):
    """Bad user input (case file, override, command-line value), already phrased for the user.

    The message names where the problem is (file and dotted key) and what was expected.
    """


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM, raised at the next safe point: `signum` says which (exit 128 + signum)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum
