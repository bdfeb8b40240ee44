"""The `flexmbd` command, as README.md ("Using it") documents it: `main` runs one command and
returns its exit status (`status`: one meaning each), `exit_with` ends the process with it.

`arguments` builds the parser (the shared options declared once, each command's own arguments),
`commands` holds the commands (cmd_NAME, looked up here when the parser is built), `shared` what
several of them use, and `stdout` the check of what they print.

It imports every package below it; nothing imports it but `__main__`.
"""

from __future__ import annotations

import datetime
import os
import signal
import sys
import tempfile
import threading
import traceback
from pathlib import Path

from flexmbd.core import files
from flexmbd.cli.arguments import parser
from flexmbd.cli.commands.catalogue import cmd_completion, cmd_list, cmd_modes, system_modes
from flexmbd.cli.commands.frames import cmd_animate, cmd_export
from flexmbd.cli.commands.records import cmd_bench, cmd_history
from flexmbd.cli.commands.runs import cmd_compare, cmd_regress, cmd_report, cmd_run
from flexmbd.cli.commands.studies import cmd_import, cmd_study
from flexmbd.cli.shared import _case, check_all, run_checked
from flexmbd.cli.status import BAD_INPUT, DIFFERENT, EXIT, INTERNAL, OK
from flexmbd.core.errors import InputError

# the commands, which `arguments.parser` looks up here (one replaced here is the one that runs), and
# what other modules and the tests use
__all__ = ["main", "exit_with", "parser", "EXIT", "OK", "DIFFERENT", "BAD_INPUT", "INTERNAL",
           "cmd_animate", "cmd_bench", "cmd_compare", "cmd_completion", "cmd_export", "cmd_history", "cmd_import",
           "cmd_list", "cmd_modes", "cmd_regress", "cmd_report", "cmd_run", "cmd_study",
           "_case", "check_all", "run_checked", "system_modes"]


def save_traceback(e: BaseException) -> Path:
    """The full traceback of an internal error in a file under the temporary folder; its path."""
    folder = Path(tempfile.gettempdir()) / "flexmbd-errors"
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = folder / f"{stamp}-{os.getpid()}.txt"
    text = f"flexmbd {' '.join(sys.argv[1:])}\n" + "".join(traceback.format_exception(e))
    try:
        files.atomic_write(path, text)
    except (InputError, OSError):
        return Path("(not saved: " + str(folder) + " is not writable)")
    return path


def main(argv=None) -> int:
    """Run one command; its exit status (`status`). One handler takes SIGINT and SIGTERM for the
    whole command (files.signals_handled): a signal ends it with one line and status 128 + the
    signal, at once or once a swap of files is done; a signal ignored when the command starts (a
    background job's SIGINT) stays ignored."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        with files.signals_handled():
            return _command(argv, "--debug" in argv)
    except KeyboardInterrupt as e:                          # Interrupted, or SIGINT outside the main thread
        signum = getattr(e, "signum", signal.SIGINT)
        print(f"flexmbd: interrupted ({signal.Signals(signum).name})", file=sys.stderr)
        return 128 + signum


def _command(argv: list, debug: bool) -> int:
    """The command's exit status, with every error but a signal's told in its one line (main)."""
    here = threading.current_thread() is threading.main_thread()         # where handlers can be set
    xfsz = signal.signal(signal.SIGXFSZ, signal.SIG_IGN) if here else None  # the file size limit: EFBIG, not a kill
    try:
        args = parser().parse_args(argv)
        return args.func(args)
    except InputError as e:
        print(f"flexmbd: {' '.join(str(e).split())}", file=sys.stderr)
        return BAD_INPUT
    except BrokenPipeError:                                 # the reader of stdout left (| head): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except OSError as e:
        if e.filename is None:
            return _internal(e, debug)
        print(f"flexmbd: {files.unusable(e.filename, e)}", file=sys.stderr)
        return BAD_INPUT
    except Exception as e:                                  # noqa: BLE001 - the one place
        return _internal(e, debug)
    finally:
        if here:
            signal.signal(signal.SIGXFSZ, signal.SIG_DFL if xfsz is None else xfsz)


def _internal(e: BaseException, debug: bool) -> int:
    """An internal error: one line naming it and where its traceback was saved (on the terminal
    too with --debug)."""
    if debug:
        traceback.print_exception(e, file=sys.stderr)
    where = save_traceback(e)
    msg = " ".join(str(e).split())[:200]
    print(f"flexmbd: internal error: {type(e).__name__}{': ' + msg if msg else ''} (traceback saved to {where})",
          file=sys.stderr)
    return INTERNAL


def exit_with(code: int):
    """End the process with `code`. After an interruption the interpreter is left at once (output
    flushed): Python may otherwise end itself by the signal at shutdown when a KeyboardInterrupt
    passed through native code, and the status would read -2, not 130."""
    if code >= 128:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
