"""flexmbd/harness/progress.py: the bar of a call that says nothing while it runs (`Ticking`)."""

import pytest
import threading

from flexmbd.harness.progress import Ticking

pytestmark = pytest.mark.kernel_free


def test_ticking_draws_elapsed_time_against_the_estimate_while_the_call_runs(capsys):
    """The thread draws its first line while the block still runs (waited for, not slept for),
    and is gone when the block ends."""
    with Ticking(30.0, "every mode of 10 DOFs", after_s=0.0) as tk:
        drawn = threading.Event()
        for _ in range(200):                        # at most 10 s: the thread draws every 0.5 s
            if tk.bar.shown:
                drawn.set()
                break
            threading.Event().wait(0.05)
        assert drawn.is_set()
    assert not tk.thread.is_alive()
    err = capsys.readouterr().err
    assert "every mode of 10 DOFs [" in err and "/30 s (estimated)" in err
