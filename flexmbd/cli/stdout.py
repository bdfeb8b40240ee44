"""stdout: what a command prints is its answer, so a stdout that cannot take it is an unusable
location (exit 2, one line naming stdout), as a file would be."""

from __future__ import annotations

import functools
import os
import sys

from flexmbd.core import files
from flexmbd.core.errors import InputError


def stdout_checked(command):
    """`command` (a cmd_ function) with its output checked: a closed stdout is refused before any
    work, and a write to stdout that fails ends the command (`Stdout`), each as one line naming
    stdout (InputError: exit 2); what the command wrote to files before is complete."""
    @functools.wraps(command)
    def checked(args) -> int:
        if sys.stdout is None or getattr(sys.stdout, "closed", False):
            raise InputError("stdout: closed (the command's output goes there: redirect it to a file or "
                             "/dev/null instead)")
        real, sys.stdout = sys.stdout, Stdout(sys.stdout)
        try:
            code = command(args)
            sys.stdout.flush()
        finally:
            sys.stdout = real
        return code
    return checked


class Stdout:
    """sys.stdout while a command runs: a write or flush that fails (a full device, a descriptor
    not open for writing) is an InputError naming stdout and why, and what is left unwritten is
    dropped, so that the interpreter does not try again at its exit and print a second error. A
    reader that left (BrokenPipeError) is `main`'s to handle."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text):
        return self._checked(self.stream.write, text)

    def flush(self):
        return self._checked(self.stream.flush)

    def _checked(self, call, *a):
        try:
            return call(*a)
        except BrokenPipeError:
            raise
        except OSError as e:
            drop_output(self.stream)
            raise files.unusable("stdout", e) from None

    def __getattr__(self, name):
        return getattr(self.stream, name)


def drop_output(stream) -> None:
    """Send what is left of a stream's output to /dev/null (its descriptor, when it has one)."""
    try:
        fd = stream.fileno()
    except (OSError, ValueError):
        return
    os.dup2(os.open(os.devnull, os.O_WRONLY), fd)
