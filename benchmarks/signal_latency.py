"""How soon SIGINT / SIGTERM end a flexmbd command: the time from the signal to the process's exit,
for `report` (page building), `run` with flexmbd (set-up and integration) and with exudyn-beam
(Exudyn's native solver), at several moments after the start. Run from the repository root:

    .venv/bin/python benchmarks/signal_latency.py [repeats]

It prints one line per command and signal: median and largest latency in seconds, and the exit
statuses seen (130 / 143: ended by the signal; 0: finished first). The tests check what the
signal does (tests/cli/test_faults.py); how long it takes is measured here, not asserted there.
"""

import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

COMMANDS = {
    "report analytic": ["report", "--cases", "cantilever_step", "--solvers", "analytic,fe-linear"],
    "run flexmbd": ["run", "pendulum", "--solver", "flexmbd"],
    "run exudyn-beam": ["run", "pendulum", "--solver", "exudyn-beam"],
}
DELAYS = (0.8, 1.5, 2.5, 3.5)                 # s after the start


def latency(argv, sig, delay) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as out:
        p = subprocess.Popen([sys.executable, "-m", "flexmbd", *argv, "--out", out], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        time.sleep(delay)
        sent = time.perf_counter()
        p.send_signal(sig)
        p.wait(timeout=60)
        return time.perf_counter() - sent, p.returncode


def main(repeats: int = 2) -> None:
    for name, argv in COMMANDS.items():
        for sig in (signal.SIGINT, signal.SIGTERM):
            got = [latency(argv, sig, d) for d in DELAYS for _ in range(repeats)]
            ended = [t for t, code in got if code == 128 + sig]
            codes = sorted({code for _, code in got})
            print(f"{name:18s} {signal.Signals(sig).name:7s} median {np.median(ended) if ended else np.nan:.2f} s, "
                  f"largest {max(ended, default=np.nan):.2f} s over {len(ended)} interrupted runs; exit {codes}",
                  flush=True)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2)
