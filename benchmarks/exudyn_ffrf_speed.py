"""exudyn-ffrf's solve time (`Result.wall_s`) on whole cases, and its channels against those of
another checkout's run. Run from the repository root:

    .venv/bin/python benchmarks/exudyn_ffrf_speed.py save DIR [case,case,...] [repeats]
    .venv/bin/python benchmarks/exudyn_ffrf_speed.py compare DIR [case,case,...] [repeats]

`save` stores each case's channels in DIR/CASE.npz; `compare` runs the cases with this checkout
and prints, per case, the smallest wall_s of `repeats` runs and each channel's largest difference
from DIR's divided by that channel's largest magnitude there. To time a change, save from the
older checkout (e.g. `git archive COMMIT | tar -x -C /tmp/old`, run there with PYTHONPATH=/tmp/old)
and compare from the newer; both print their times, so alternate the two on a shared machine and
take the smallest. Default cases: those of docs/exudyn.md, "What is done to make exudyn-ffrf fast".
"""

import sys
from pathlib import Path

import numpy as np

from flexmbd import cases
from flexmbd.harness import registry

CASES = "cantilever_step,pendulum,double_pendulum,slewing_beam,spinup_beam"


def timed(name: str, repeats: int):
    """(smallest wall_s, the last Result) of `repeats` runs of exudyn-ffrf on case `name`."""
    runs = [registry.run(cases.load(name), "exudyn-ffrf") for _ in range(repeats)]
    return min(r.wall_s for r in runs), runs[-1]


def differences(r, stored) -> dict:
    """Channel -> max |r's - stored| / max |stored| over the samples both have."""
    n = min(r.t.size, stored["t"].size)
    out = {}
    for name, v in r.channels.items():
        ref = stored[f"ch_{name}"][:n]
        scale = np.abs(ref).max()
        out[name] = float(np.abs(np.asarray(v)[:n] - ref).max() / scale) if scale > 0 else 0.0
    return out


def main(mode: str, folder: str, names: str = CASES, repeats: int = 1) -> None:
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name in names.split(","):
        wall, r = timed(name, repeats)
        line = f"{name:16s} wall_s {wall:8.3f}  samples {r.t.size}  {r.status}"
        if mode == "save":
            np.savez(folder / f"{name}.npz", t=r.t, **{f"ch_{k}": np.asarray(v) for k, v in r.channels.items()})
        else:
            with np.load(folder / f"{name}.npz") as stored:
                d = differences(r, stored)
                same = "same samples" if stored["t"].size == r.t.size else f"samples {stored['t'].size} there"
            line += f"\n    {same}; max |difference| / max |channel|: " + ", ".join(f"{k} {v:.1e}" for k, v in d.items())
        print(line, flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], args[1], args[2] if len(args) > 2 else CASES, int(args[3]) if len(args) > 3 else 1)
