"""The one exception for bad input: the command line prints its message as one line, exit 2."""


class InputError(Exception):
    """Bad user input (case file, override, command-line value), already phrased for the user.

    The message names where the problem is (file and dotted key) and what was expected.
    """
