"""`python -m flexmbd` and the `flexmbd` command. SIGINT and SIGTERM that come while the modules
load (before `cli.main` installs its handlers; up to a second or two on a loaded machine) end the
command with its one line and exit status, as they do later, instead of a traceback."""

import os
import signal
import sys


def _while_loading(signum, frame):
    sys.stderr.write(f"flexmbd: interrupted ({signal.Signals(signum).name})\n")
    os._exit(128 + signum)                   # nothing is written yet


def run() -> None:
    previous = {s: signal.signal(s, _while_loading) for s in (signal.SIGINT, signal.SIGTERM)}
    from flexmbd.cli import exit_with, main
    for s, old in previous.items():
        signal.signal(s, old)
    exit_with(main())


if __name__ == "__main__":
    run()
