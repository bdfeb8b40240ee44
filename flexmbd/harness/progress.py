"""Progress on stderr, one place for both bars: the bar of one piece of work that takes longer
than a couple of seconds (`Progress`: a run's simulated time, a linearization's coordinates), and
the k-of-n bar over a command's jobs (`job`, `jobs_done`: runs, pages, baselines).
"""

from __future__ import annotations

import sys
import threading
import time

_shown = [True]         # False in a worker process of the executor: its parent shows the job bar


def silence() -> None:
    """No run's own bar from this process (an executor's worker: runs side by side would mix
    their bars; the parent's job bar says which are running)."""
    _shown[0] = False


class Progress:
    """A progress bar on stderr for work that takes longer than a couple of seconds: the first line
    `after_s` past the start, then one every `every_s` (redrawn in place on a terminal; elsewhere
    a new line every 10 s). `update(t)` says how far the work is: t of `t_end`, a simulated time
    in s, or, with another `unit`, a count of that unit ('coordinates')."""

    def __init__(self, t_end: float, label: str, after_s: float = 2.0, every_s: float | None = None,
                 unit: str = "s"):
        self.t_end, self.label, self.after, self.unit = t_end, label, after_s, unit
        self.tty = sys.stderr.isatty()
        self.every = every_s if every_s is not None else (0.5 if self.tty else 10.0)
        self.start, self.last = time.perf_counter(), float("-inf")
        self.shown = False

    def due(self, now: float) -> bool:
        """Whether a line is due at `now` (time.perf_counter(), s): from `after` past the start, one
        every `every` (never in a silenced process: `silence`)."""
        return _shown[0] and now - self.start >= self.after and now - self.last >= self.every

    def update(self, t: float) -> None:
        now = time.perf_counter()
        if not self.due(now):
            return
        self.last, self.shown = now, True
        frac = min(max(t / self.t_end, 0.0), 1.0) if self.t_end > 0 else 1.0
        bar = "#" * int(30 * frac)
        eta = (now - self.start) * (1 - frac) / max(frac, 1e-9)
        end = "\r" if self.tty else "\n"
        at = f"t = {t:.3f}/{self.t_end:g} s" if self.unit == "s" else f"{t:.0f}/{self.t_end:g} {self.unit}"
        sys.stderr.write(f"{self.label} [{bar:<30}] {at}, {now - self.start:.0f} s, ~{eta:.0f} s left{end}")
        sys.stderr.flush()

    def tracking(self, f):
        """The right-hand side f(t, y), updating the bar with the time of each evaluation: the bar
        moves within an output interval too, and shows the simulated time standing still when an
        adaptive method's step size collapses (a model nearing a singular configuration). Once f
        has raised (Stop), the bar is left alone: VODE goes on calling back with the exception
        pending until it returns, and a clock read then would fail (SystemError)."""
        raised = [False]

        def g(t, y):
            try:
                yd = f(t, y)
            except BaseException:
                raised[0] = True
                raise
            if not raised[0]:
                self.update(t)
            return yd
        return g

    def close(self) -> None:
        if self.shown and self.tty:
            sys.stderr.write("\n")


class Ticking:
    """A bar for one call that says nothing while it runs (a dense LAPACK eigensolution, which
    releases the GIL): a thread draws the elapsed time against the call's estimate `seconds`
    (`harness/cost.py`'s) until the `with` block ends."""

    def __init__(self, seconds: float, label: str, after_s: float = 2.0):
        self.bar = Progress(max(seconds, 1.0), label, after_s=after_s, unit="s (estimated)")
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.tick, daemon=True)

    def tick(self) -> None:
        while not self.stop.wait(0.5):
            self.bar.update(time.perf_counter() - self.bar.start)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.thread.join()
        self.bar.close()


def job(k: int, n: int, label: str, elapsed: float) -> None:
    """The k-of-n job bar: job k of n (`label`) starting, `elapsed` s since the first; one line on
    stderr (redrawn in place on a terminal)."""
    bar = "#" * int(20 * (k - 1) / n)
    end = "\r" if sys.stderr.isatty() else "\n"
    sys.stderr.write(f"[{bar:<20}] {k}/{n} {label:<40} {elapsed:6.1f} s{end}")
    sys.stderr.flush()


def jobs_done(n: int, elapsed: float) -> None:
    """The job bar's last line: all n jobs done in `elapsed` s."""
    sys.stderr.write(f"[{'#' * 20}] {n}/{n} done{'':<36} {elapsed:6.1f} s\n")
