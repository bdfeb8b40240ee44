"""The system modes a case page's spectral peaks are matched against (docs/formulation.md §10):
the case's system linearized about its initial state (`system_modes`), the same case with FINER
times the retained modes (`finer`, `spectral_modes`), the system frozen at instants of a run
(`frozen_modes`), each filtered to the modes that can move a deflection channel's point
(`channel_modes`); and the bodies' own retained frequencies (`fe_frequencies`).
"""

from __future__ import annotations

import sys

import numpy as np

from flexmbd.core import files
from flexmbd.fe import flexbody
from flexmbd.core.errors import InputError


def fe_frequencies(case) -> dict:
    """Body -> natural frequencies (Hz) of its retained modes (pre-processing, no solver is run)."""
    return {n: fb.freq_hz.tolist() for n, fb in flexbody.for_case(case).items()}


SYSTEM = {}     # (case name, case hash) -> system_modes(case), once per process


def system_modes(case) -> list:
    """[(frequency Hz, label)] of the case's linearized system about its initial state
    (solvers/linearize.py), computed once per case version. The command line computes them before the
    pages are built (`prepare`), where a signal may end the process at once."""
    from flexmbd.solvers import linearize
    key = (case.name, case.sha256)
    if key not in SYSTEM:
        with files.signals_held():      # may compile the kernel: a signal waits for it, then acts
            SYSTEM[key] = [(m.freq_hz, m.label) for m in linearize.for_case(case)]
    return SYSTEM[key]


FINER = 2       # the finer mode set of the spectra: this many times each beam's retained modes


def finer(case):
    """The case with FINER times the retained modes of every unsplit flexible beam (as far as its
    mesh allows), against whose system a finer solver's peaks are matched; None when no beam can
    take more (a beam split into segments keeps its modes)."""
    from flexmbd import cases
    more, fine = [], None
    for name, b in case.bodies.items():
        if b.type == "beam" and b.segments == 1 and b.modes.count:
            item = f"bodies.{name}.modes.count={FINER * b.modes.count}"
            try:
                fine = cases.load(str(case.path), list(case.overrides) + more + [item])
                more.append(item)
            except InputError:                          # more modes than the mesh holds: keep this beam's
                continue
    return fine


def spectral_modes(case) -> tuple[dict, dict]:
    """(own, finer): deflection channel -> the system modes [(Hz, label)] its spectral peaks are
    matched against (`channel_modes`), of the case and of the case with FINER times the retained
    modes (`finer`), those labelled '... (N modes)': a peak of a finer solver (exudyn-beam,
    fe-linear, mujoco-rod) that matches only these is a mode the retained set truncates or places
    too high."""
    own, fine = channel_modes(case, system_modes(case)), {}
    more = finer(case)
    try:
        system_modes(more) if more is not None else None
    except InputError as e:                             # the finer set's loop does not close: match the own only
        print(f"flexmbd: warning: {case.name}: the system with {FINER} x the modes is not linearized ({e}); "
              f"spectral peaks are matched against the case's own modes only", file=sys.stderr)
        more = None
    if more is not None:
        n = {b.modes.count for b in more.bodies.values() if b.type == "beam" and b.modes.count}
        tag = f"{'/'.join(map(str, sorted(n)))} modes"
        fine = {ch: [(f, f"{lab} ({tag})") for f, lab in modes]
                for ch, modes in channel_modes(more, system_modes(more)).items()}
    return own, fine


def channel_modes(case, system: list) -> dict:
    """Deflection channel -> the system modes [(Hz, label)] that can move its point in its
    direction (`moving_modes`): those led by a joint, or by a retained mode the channel's
    filter keeps."""
    return filtered(moving_modes(case), system)


def moving_modes(case) -> dict:
    """Deflection channel -> {body: labels of its retained modes that can move the channel's
    point in its direction}: of the channel's body (or of one of its segments), the modes whose
    shape moves that node in that direction; of another body, those that move any of its nodes in
    that direction of its own frame (in a planar system, the same plane: beam1's in-plane bending
    shakes beam2's tip in-plane, its out-of-plane bending does not)."""
    bodies = flexbody.for_case(case)

    def labels(fb, w) -> set:
        return {str(lab) for lab, x in zip(fb.labels, w) if x > 1e-6 * w.max()} if w.max() > 0 else set()

    out = {}
    for ch, c in case.channels.items():
        if c.kind != "deflection" or c.body not in bodies:
            continue
        axis = 3 + "xyz".index(c.component)
        fb = bodies[c.body]
        out[ch] = {name: labels(other, np.abs(other.Phi[:, axis]).max(axis=0)) for name, other in bodies.items()}
        out[ch][c.body] = labels(fb, np.abs(fb.Phi[c.point.node, axis]))       # its snapped node, or interface
    return out


def filtered(moving: dict, system: list) -> dict:
    """Deflection channel -> the system modes [(Hz, label)] led by a joint or by a body's family
    of which the channel's `moving` sets hold a mode (labels 'joint pivot', 'beam1: bending xy 2',
    'block: mode 1 (y)'; `linearize.labelled`)."""
    from flexmbd.solvers.linearize import family

    def mine(label: str, sets: dict) -> bool:
        body, led, fam = label.partition(": ")
        return not led or family(fam) in {family(m) for m in sets.get(body, ())}
    return {ch: [(f, lab) for f, lab in system if mine(lab, sets)] for ch, sets in moving.items()}


FROZEN = (41, 11)       # instants of the frozen linearization: up to 64 coordinates, and beyond


def frozen_modes(case, ok: dict) -> tuple[str, list] | None:
    """(the solver whose run gave the states, [(instant s, [(Hz, label)])]): the system linearized
    about the states of a run at evenly spaced instants (`linearize.along`: the joints at their
    recorded angles and rates, prescribed joints on their profile, a loop's dependent joints by
    its closure), from the reference's run or else the first ok run that records every free
    (independent) joint's angle. None when no run does, when
    nothing is driven and the joints hardly move (below 0.05 rad), or when the frequencies do not
    move (a steady spin): then the initial state's modes hold throughout."""
    from flexmbd.solvers import linearize
    angles = {n: c.joint for n, c in case.channels.items() if c.kind == "joint_angle"}
    model = linearize.model_of(case)
    loops = linearize.loops_of(case, model)
    if loops:                                           # its dependent coordinates follow by closure
        linearize.closed(case, loops, 0.0, model.q0, model.v0)
    if not linearize.frozen_joints(model, set(angles.values()), loops):
        return None
    driven = bool(model.jnt_prescribed[1:].any())
    order = [case.report.reference] + [s for s in ok if s != case.report.reference]
    for s in order:
        r = ok.get(s)
        if r is None or not all(n in r.channels for n in angles) or len(r.t) < 3:
            continue
        coords = {j: r.channels[n] for n, j in angles.items()}
        if not driven and max(np.ptp(y) for y in coords.values()) < 0.05:
            return None
        n = FROZEN[0] if model.nv <= 64 else FROZEN[1]
        sweep = linearize.along(case, r.t, coords, np.linspace(r.t[0], r.t[-1], n), model)
        first = [m.freq_hz for m in sweep[0][1]]
        if all(np.allclose([m.freq_hz for m in modes], first, rtol=1e-6) if len(modes) == len(first) else False
               for _, modes in sweep):
            return None                                  # a steady spin: the initial state's modes hold throughout
        return s, [(at, [(m.freq_hz, m.label) for m in modes]) for at, modes in sweep]
    return None


def frozen_channel_modes(case, sweep: list) -> dict:
    """Deflection channel -> the frozen system modes that move its point (`channel_modes` at each
    instant), labelled '... at t = T s (frozen)'."""
    out, moving = {}, moving_modes(case)
    for at, modes in sweep:
        for ch, ms in filtered(moving, modes).items():
            out.setdefault(ch, []).extend((f, f"{lab} at t = {at:.3g} s (frozen)") for f, lab in ms)
    return out


def prepare(chosen_cases, notice=None) -> None:
    """What page building needs that may run long native code (the system modes: the first one
    compiles flexmbd's kernel), done before any page is staged: SIGINT / SIGTERM end it at once.
    `notice(line)` is told when the kernel is not yet compiled for this source version."""
    from flexmbd.mbd.compiled import jit
    if notice and chosen_cases and not jit.is_cached():
        from flexmbd.solvers import inhouse
        notice(inhouse.compiling(", to linearize the cases for their spectra"))
    with files.signals_exit():
        for case in chosen_cases:
            spectral_modes(case)
