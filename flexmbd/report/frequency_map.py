"""A case's frequency map (its `[frequency_map]` table, docs/formulation.md §10): the system
linearized at each value of one setting (`linearize.sweep`), flexmbd's modes tracked by their
shapes (`linearize.tracked`), and the peers' own eigen-solves of the same case at the same values
(each solver's `system_frequencies`) set beside them: the table OUT/CASE/frequency_map.csv, the
figure and the page's section."""

from __future__ import annotations

import csv
import io
from typing import NamedTuple

import numpy as np

from flexmbd.core import files
from flexmbd.core.errors import InputError


class Map(NamedTuple):
    key: str
    values: np.ndarray      # (n,) the swept values
    tracks: list            # flexmbd's tracks (`linearize.tracked`): label, freq_hz (n,), mac (n,)
    peers: dict             # solver -> (n, count) its lowest frequencies at each value, Hz, ascending
    refused: dict           # solver -> why it gives none (one line)
    sensitivity: list = []  # `sensitivity` rows at the first value


MAPS = {}       # (case name, case hash) -> Map, once per process


def peer_functions(names) -> tuple[dict, dict]:
    """({solver: its system_frequencies}, {solver: why none}) for the solvers named."""
    from flexmbd.harness import registry
    got, refused = {}, {}
    for name in names:
        mod = registry.module(name) if name in registry.MODULES else None
        f = getattr(mod, "system_frequencies", None)
        if f is None:
            refused[name] = ("not installed" if name in registry.REFUSED or mod is None
                             else "it has no eigen-solve of the assembled system")
        else:
            got[name] = f
    return got, refused


def taken(case, progress=None) -> Map | None:
    """The case's map (None without a `[frequency_map]` table), once per case version: the case with
    the table's `set` overrides, swept over `key`. A peer that cannot take the case is left out,
    with its reason."""
    fm = case.frequency_map
    if fm is None:
        return None
    hit = MAPS.get((case.name, case.sha256, tuple(case.overrides)))
    if hit is not None:
        return hit
    from flexmbd import cases
    from flexmbd.solvers import linearize
    here = cases.load(str(case.path), [*case.overrides, *fm["set"]])
    values = np.linspace(fm["start"], fm["stop"], fm["values"])
    peers, refused = peer_functions(fm["peers"])
    steps = None
    while steps is None:
        try:
            with files.signals_held():      # may compile the kernel: a signal waits for it, then acts
                steps = linearize.sweep(here, fm["key"], values, peers=peers, progress=progress)
        except InputError as e:
            bad = next((n for n in peers if n in str(e)), None)
            if bad is None:
                raise
            refused[bad] = str(e)
            peers.pop(bad)
    tracks = linearize.tracked(steps)
    got = {n: np.array([s[3][n] for s in steps]) for n in peers}
    first = cases.load(str(here.path), [*here.overrides, *[f"joints.{j}.q0={q!r}" for j, q in steps[0][2].items()],
                                        f"{fm['key']}={float(values[0])!r}"])
    with files.signals_held():
        sens = sensitivity(first, fm["tracks"], peers)
    MAPS[(case.name, case.sha256, tuple(case.overrides))] = m = Map(fm["key"], values, tracks, got, refused, sens)
    return m


# what each model's discretization is changed by in `sensitivity`: flexmbd's retained modes doubled
# (`spectra.finer`), a peer's elements per beam halved and doubled
COARSER, FINER = 0.5, 2.0


def resized(case, factor: float):
    """The case with every beam's `elements` times `factor` (at least 1), or None when that
    cannot load."""
    from flexmbd import cases
    over = [f"bodies.{n}.elements={max(1, int(round(b.elements * factor)))}" for n, b in case.bodies.items()
            if b.type == "beam"]
    beam = dict(case.solvers.get("exudyn-beam", {})).get("elements", 64)     # its own default: 64 a beam
    over += [f"solvers.exudyn-beam.elements={max(1, int(round(beam * factor)))}"]
    try:
        return cases.load(str(case.path), [*case.overrides, *over])
    except InputError:
        return None


def sensitivity(case, n: int, peers: dict) -> list[dict]:
    """The lowest n frequencies of the case (one value of its map) by each model at its own
    discretization and at a changed one: flexmbd with its retained modes and with FINER times them
    (`spectra.finer`), each peer at its elements and at COARSER and FINER times them (exudyn-beam's
    `elements` setting, the case's beams' `elements` for fe-linear's frame and exudyn-ffrf's reduced
    bodies). Rows {model, setting, freq_hz (n,)}."""
    from flexmbd.report import spectra
    from flexmbd.solvers import linearize
    rows = [{"model": "flexmbd", "setting": "the case's modes",
             "freq_hz": np.sort([m.freq_hz for m in linearize.for_case(case)])[:n]}]
    fine = spectra.finer(case)
    if fine is not None:
        rows.append({"model": "flexmbd", "setting": f"{spectra.FINER} x the modes",
                     "freq_hz": np.sort([m.freq_hz for m in linearize.for_case(fine)])[:n]})
    for name, f in peers.items():
        for factor, said in ((1.0, "the case's elements"), (COARSER, f"{COARSER:g} x the elements"),
                             (FINER, f"{FINER:g} x the elements")):
            c = case if factor == 1.0 else resized(case, factor)
            if c is None:
                continue
            try:
                rows.append({"model": name, "setting": said, "freq_hz": np.asarray(f(c, n), dtype=float)})
            except InputError:
                continue
    return rows


def table(m: Map) -> str:
    """The map as CSV: one row per (solver, track or rank, value); flexmbd's rows carry the
    track's label and its MAC with the value before, a peer's its rank among its frequencies."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([m.key, "solver", "track", "label", "freq_hz [Hz]", "mac"])
    for j, t in enumerate(m.tracks):
        w.writerows([repr(float(x)), "flexmbd", j + 1, t["label"], repr(float(t["freq_hz"][k])),
                     repr(float(t["mac"][k]))] for k, x in enumerate(m.values))
    for name, F in m.peers.items():
        w.writerows([repr(float(x)), name, r + 1, "", repr(float(F[k, r])), ""]
                    for r in range(F.shape[1]) for k, x in enumerate(m.values))
    return buf.getvalue()


def agreement(m: Map, n: int) -> list[dict]:
    """At each value, flexmbd's n lowest frequencies (its tracks sorted) and each peer's n lowest,
    and the largest relative difference |f_peer / f - 1| of a peer's frequency from the nearest of
    all flexmbd's at that value, over the peer's n lowest that lie within flexmbd's range (to 5 %
    above its highest): a peer that models families flexmbd's mode sets leave out (a planar frame
    has no out-of-plane bending, a finer mesh has modes above the retained ones) is compared on
    what both have, not rank by rank."""
    out = []
    for k, x in enumerate(m.values):
        every = np.sort([t["freq_hz"][k] for t in m.tracks])
        row = {"value": float(x), "flexmbd": every[:n]}
        for name, F in m.peers.items():
            g = F[k, :n]
            row[name] = g
            row[f"{name} diff"] = nearest(g, every)
        out.append(row)
    return out


def nearest(g, every) -> float:
    """The largest relative difference |g / f - 1| of each of a peer's frequencies g (Hz) from the
    nearest of flexmbd's `every` (Hz), over those within flexmbd's range (to 5 % above its
    highest); NaN when none is."""
    every = np.sort(np.asarray(every, dtype=float))
    g = np.asarray(g, dtype=float)
    g = g[g <= 1.05 * every[-1]] if every.size else g[:0]
    return float(max(np.min(np.abs(f / every - 1)) for f in g)) if g.size else np.nan


def write(m: Map, folder, case: str, tracks: int) -> tuple[str, str]:
    """(figure, table) file names of the map written into `folder`."""
    from flexmbd.report import figures
    files.atomic_write(folder / "frequency_map.csv", table(m))
    img = figures.frequency_map(m.values, m.tracks[:tracks], m.key, folder / "frequency_map.png", case,
                                peers={n: F for n, F in m.peers.items()}, log=False)
    return img, "frequency_map.csv"
