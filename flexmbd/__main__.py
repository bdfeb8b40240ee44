"""`python -m flexmbd` and the `flexmbd` command. SIGINT and SIGTERM that come while the modules
load (before `cli.main` installs its handler; up to a second or two on a loaded machine) end the
command with its one line and exit status, as they do later, instead of a traceback; a signal
ignored when the process starts stays ignored (README.md, "Exit statuses").

FLEXMBD_READY_FILE=PATH: the file PATH is created once these handlers are in place, for a
supervisor (or a test) that signals the command and must know it will be answered."""

import os
import signal
import sys

SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _while_loading(signum, frame):
    os.write(2, f"flexmbd: interrupted ({signal.Signals(signum).name})\n".encode())
    os._exit(128 + signum)                   # nothing is being written


def _ready() -> None:
    """Create the file FLEXMBD_READY_FILE names, if it is set; exit 2 naming it when that fails."""
    path = os.environ.get("FLEXMBD_READY_FILE")
    if not path:
        return
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT, 0o644))
    except OSError as e:
        sys.stderr.write(f"flexmbd: {path}: FLEXMBD_READY_FILE: {(e.strerror or type(e).__name__).lower()}\n")
        sys.exit(2)


def run() -> None:
    """Handlers for the loading (installed with the signals blocked, so none comes between two
    handlers), then the command: `cli.main` takes the signals over and hands them back."""
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    for s in SIGNALS:
        if signal.getsignal(s) is not signal.SIG_IGN:
            signal.signal(s, _while_loading)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    _ready()
    from flexmbd.cli import exit_with, main
    exit_with(main())


if __name__ == "__main__":
    run()
