"""The system's small vibrations of a case (docs/formulation.md §10): its Model linearized about its
initial state or its static equilibrium (`for_case`), or about the recorded states of a run,
frozen (`along`), by the solver's linearization (`flexmbd.mbd.linearize`, whose names this module
hands on); what the solver cannot take becomes a one-line input error naming the case."""

from __future__ import annotations

import numpy as np

from flexmbd.solvers import build
from flexmbd.fe import flexbody
from flexmbd.solvers.build import from_case
from flexmbd.core.errors import InputError
from flexmbd.mbd import constraints, dynamics
from flexmbd.mbd.linearize import (ROUNDOFF, STEP, NotLinearized, SystemMode, accelerations, closing,  # noqa: F401
                                   coordinate_groups, coordinates, damping_resolution, energy_shares, equilibrium,
                                   family, labelled, lead, mass_matrix, momenta, perturbed, refined, state_matrix,
                                   system_modes, mac)
from flexmbd.mbd.model import Model
from flexmbd.harness.progress import Progress


def model_of(case) -> Model:
    """The Model `flexmbd` integrates: the tree the modal solvers model (`case.modelled`)."""
    return from_case(case.modelled, flexbody.for_case(case.modelled))


def loops_of(case, model: Model) -> constraints.Loops | None:
    """The case's cut joints on its Model (None without loops)."""
    return build.loops(model, case.modelled)


def for_case(case, about: str = "initial", progress: bool = False, model: Model | None = None) -> list:
    """System modes of a case about its initial state (t = 0) or its static equilibrium at rest;
    with `progress`, a bar on stderr over the coordinates of the state matrix (4 evaluations
    each: `cost.system`) when they take more than a couple of seconds. `model`: the case's Model
    (`model_of`) when the caller has it."""
    model = model_of(case) if model is None else model
    loops = loops_of(case, model)
    q, v = model.q0.copy(), model.v0.copy()
    if about == "equilibrium":
        if loops:
            raise InputError("modes --system --about equilibrium: not for a closed loop; use --about initial")
        q, v = solved(case, equilibrium, model, q), np.zeros(model.nv)
    if loops:
        q, v = closed(case, loops, 0.0, q, v)
    bar = Progress(coordinates(model, loops).size, f"{case.name} / linearizing", unit="coordinates") \
        if progress else None
    try:
        return solved(case, system_modes, model, q, v, 0.0, bar, loops)
    finally:
        if bar:
            bar.close()


def solved(case, f, *args):
    """f(*args), one of the solver's linearization functions; what it cannot take (`NotLinearized`)
    an InputError naming the case file."""
    try:
        return f(*args)
    except NotLinearized as e:
        raise InputError(f"{case.path}: {e}") from None


def closed(case, loops: constraints.Loops, t: float, q, v):
    """(q, v) closed on the loops' dependent coordinates; an InputError when they cannot close."""
    try:
        return loops.close(t, q, v)
    except constraints.NotClosed as e:
        raise InputError(f"{case.path}: joints.{e.args[0]}: the loop cannot close (residual {e.args[1]:.3g})") from None


def frozen_joints(model: Model, recorded, loops: constraints.Loops | None = None) -> bool:
    """Whether the joint coordinates `recorded` (names) fix the configuration of every free joint
    (each free joint moves one coordinate and is recorded; with loops, each independent one) and
    something moves: a free joint or a prescribed one."""
    moving = [i for i in range(1, model.nb + 1) if model.jnt_nv[i]]
    dep = set() if loops is None else set(loops.dep.tolist())
    free = [i for i in moving if not model.jnt_prescribed[i] and model.jnt_vadr[i] not in dep]
    return bool(moving) and all(model.jnt_nv[i] == 1 and model.jnt_names[i] in recorded for i in free)


def along(case, t, coords: dict, instants, model: Model | None = None) -> list:
    """[(instant s, [SystemMode])]: the system linearized about the states of a run at `instants`,
    frozen: each free joint at its recorded coordinate and rate (`coords`: joint name -> (n,)
    coordinate at the samples t (n,); rates by differences), every modal coordinate and rate at
    zero, prescribed joints on their profile. A swinging or spinning system's vibration
    frequencies change with its configuration and rate; these are their values at each instant
    (a frozen-time approximation, which the elastic deformation itself does not enter). An
    InputError when `coords` do not fix every free joint (`frozen_joints`). `model`: the case's
    (`model_of`), when the caller has it."""
    model = model_of(case) if model is None else model
    loops = loops_of(case, model)
    guess = closed(case, loops, 0.0, model.q0, model.v0)[0] if loops else model.q0
    if not frozen_joints(model, coords, loops):
        raise InputError(f"{case.path}: the recorded joint coordinates ({', '.join(coords) or 'none'}) do not fix "
                         f"every free joint (each must be a one-coordinate joint with a joint_angle channel)")
    t = np.asarray(t, dtype=float)
    rates = {name: np.gradient(np.asarray(y, dtype=float), t) for name, y in coords.items()}
    out = []
    for s in instants:
        k = int(np.argmin(np.abs(t - s)))
        q, v = guess.copy(), np.zeros(model.nv)             # modal coordinates of q0: zero (a loop's
        #                                                     dependent ones: the last instant's, Newton's guess)
        for i in range(1, model.nb + 1):
            name = model.jnt_names[i]
            if name in coords and model.jnt_nv[i] == 1 and not model.jnt_prescribed[i]:
                q[model.jnt_qadr[i]], v[model.jnt_vadr[i]] = coords[name][k], rates[name][k]
        if loops:
            q, v = closed(case, loops, float(t[k]), q, v)
            guess = q
        out.append((float(t[k]), solved(case, system_modes, model, q, v, float(t[k]), None, loops)))
    return out


# ---------------------------------------------------------------------------------------------
# a frequency map: the system linearized at each value of one setting, its modes tracked by shape


def sweep_values(text: str) -> tuple[str, np.ndarray]:
    """(key, values) of a sweep 'KEY=START:STOP:N' (N >= 2 evenly spaced values, ends included);
    an InputError naming `--sweep` for any other text."""
    key, _, span = text.partition("=")
    parts = span.split(":")
    try:
        start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
        if len(parts) != 3 or n < 2 or not (np.isfinite(start) and np.isfinite(stop)):
            raise ValueError
    except (ValueError, IndexError):
        raise InputError(f"--sweep: {text!r}: expected KEY=START:STOP:N (numbers, N >= 2 values)") from None
    if not key:
        raise InputError(f"--sweep: {text!r}: expected KEY=START:STOP:N, a case key first")
    return key, np.linspace(start, stop, n)


def sweep(case, key: str, values, about: str = "initial", progress=None, peers: dict | None = None) -> list:
    """[(value, [SystemMode], {joint: coordinate}, {peer: frequencies (n,) Hz})]: `for_case` on the
    case with `key` set to each value in turn (after its own overrides), each mode labelled by what
    bends (`strained`) and its shape made physical (`physical`). On a closed loop each value starts
    from the loop's closed coordinates at the value before (`continued`), so that a crank turned
    step by step keeps the mechanism on the branch it was assembled on instead of closing onto its
    mirror image; the closed coordinates of the free one-coordinate joints are returned. `peers`:
    name -> f(case, count), another solver's own lowest `count` frequencies of the same case at the
    same value (the same loaded case: the assembly its loader closed), as many as flexmbd has modes.
    progress(k, n, value) before each."""
    from flexmbd import cases
    held(case, key)
    out, guesses = [], []
    for k, x in enumerate(values):
        if progress:
            progress(k, len(values), x)
        here = cases.load(str(case.path), [*case.overrides, *guesses, f"{key}={float(x)!r}"])
        model = model_of(here)
        at = continued(here, model)
        guesses = [f"joints.{j}.q0={q!r}" for j, q in at.items()] if here.loops else []
        modes = [m._replace(label=strained(model, m.shape) or m.label, shape=physical(here, model, m.shape))
                 for m in for_case(here, about, model=model)]
        others = {name: np.asarray(f(here, len(modes)), dtype=float) for name, f in (peers or {}).items()}
        out.append((float(x), modes, at, others))
    return out


STRAINED = 1e-6     # a mode whose strain energy is below this share of the softest mode's bends nothing
ALONE = 0.7         # a body mode holding this share of a mode's strain energy names it alone
SECOND = 0.1        # else the two largest name it, each holding at least this share


def strained(model: Model, shape) -> str:
    """What bends in a system mode (`SystemMode.shape`, over the free coordinates): the flexible
    body and retained mode that hold the largest share of its strain energy, 1/2 eta^T K_m eta per
    body split over its modal coordinates c as 1/2 Re(conj(eta_c) (K_m eta)_c): alone where it holds
    ALONE of it, 'coupler: bending xy 2 (97 %) of the strain energy', else with the second largest,
    'crank: bending xy 1 (45 %) + follower: bending xy 1 (31 %) of the strain energy'. A mechanism's mode moves its joints as its links
    bend, so its kinetic energy can sit mostly in a joint (the label `system_modes` gives); a map
    names it by the link that bends. '' when nothing bends: a rigid mode, whose strain energy
    (the shape of unit norm) is below STRAINED of the softest retained mode's at unit amplitude."""
    full = np.zeros(model.nv, dtype=complex)
    full[dynamics.free_velocities(model)] = shape
    parts, softest = {}, np.inf
    for i in range(1, model.nb + 1):
        a, n = int(model.body_madr[i]), int(model.body_nm[i])
        if not n:
            continue
        fb, eta = model.bodies[model.names[i]], full[a:a + n]
        e = 0.5 * np.real(np.conj(eta) * (fb.Km @ eta))
        softest = min(softest, 0.5 * float(np.min(np.diag(fb.Km))))
        for c in range(n):
            key = f"{model.names[i].partition(':')[0]}: {fb.labels[c]}"
            parts[key] = parts.get(key, 0.0) + float(e[c])
    strain = sum(parts.values())
    if not parts or strain <= STRAINED * softest:
        return ""
    ranked = sorted(parts, key=parts.get, reverse=True)
    said = [f"{k} ({100 * parts[k] / strain:.0f} %)" for k in ranked[:2] if parts[k] >= SECOND * strain]
    return " + ".join(said[:1] if parts[ranked[0]] >= ALONE * strain else said) + " of the strain energy"


def held(case, key: str) -> None:
    """A sweep of a joint's coordinate (`joints.NAME.q0`) needs the joint held: a prescribed one
    (its `motion`; a driven crank with its rate set to 0), about which the rest of the system
    vibrates. A free joint's coordinate is not a setting of the system but one of its states (it
    would swing away from all but its equilibria), and a loop's dependent one is fixed by the
    closure; each is an InputError naming `--sweep`."""
    parts = key.split(".")
    if len(parts) != 3 or parts[0] != "joints" or parts[2] not in ("q0", "qd0"):
        return
    j = case.joints.get(parts[1])
    if j is None:
        return                                          # the loader names the unknown joint
    if j.motion is None:
        said = "it closes a loop" if j.loop else "the loop's closure sets it" if parts[1] in dependent(case) else \
            "it is free"
        raise InputError(f"--sweep: {key}: {said}; a map over a joint's coordinate needs the joint held (a motion, "
                         f"e.g. --set joints.{parts[1]}.motion.type=\"constant_rate\" --set "
                         f"joints.{parts[1]}.motion.rate=0.0)")


def dependent(case) -> set:
    """The names of the case's tree joints whose coordinate a loop's closure sets."""
    if not case.loops:
        return set()
    model = model_of(case)
    dep = set(loops_of(case, model).partition(model.q0, model.v0).tolist())
    return {model.jnt_names[i] for i in range(1, model.nb + 1) if model.jnt_nv[i] and model.jnt_vadr[i] in dep}


def continued(case, model: Model) -> dict:
    """{joint: its coordinate} of the case's free one-coordinate tree joints at the initial state,
    the loops closed: where the next value of a sweep starts."""
    q = model.q0.copy()
    loops = loops_of(case, model)
    if loops:
        q, _ = closed(case, loops, 0.0, q, model.v0.copy())
    return {model.jnt_names[i]: float(q[model.jnt_qadr[i]]) for i in range(1, model.nb + 1)
            if model.jnt_nv[i] == 1 and not model.jnt_prescribed[i] and model.jnt_names[i] in case.joints}


def physical(case, model: Model, shape) -> np.ndarray:
    """A system mode's shape over the free coordinates (`SystemMode.shape`) as joint
    coordinates and node translations: each flexible body's modal part replaced by its nodes'
    displacements Phi_t eta (N x 3, m), so that shapes compare across mode sets that a swept
    setting reorders or changes (a section's two bending planes trading places); unit norm."""
    full = np.zeros(model.nv)
    full[dynamics.free_velocities(model)] = shape
    keep, parts = np.ones(model.nv, dtype=bool), []
    for name, fb in flexbody.for_case(case.modelled).items():
        if name in model.names:
            i = model.index(name)
            a, n = int(model.body_madr[i]), int(model.body_nm[i])
            parts.append((fb.Phi[:, 3:, :n] @ full[a:a + n]).ravel())
            keep[a:a + n] = False
    x = np.concatenate([full[keep], *parts])
    return x / np.linalg.norm(x)


DEGENERATE = 1e-6      # relative: two frequencies this close are one (a symmetric section's two planes)


def tracked(steps: list) -> list[dict]:
    """The modes of a sweep (`sweep`) followed from value to value by their shapes, not their order:
    at each value the modes are assigned to the tracks so that the sum of the MAC of each with the
    track's shape at the previous value is largest (`scipy.optimize.linear_sum_assignment`). A
    mode whose frequency another one shares (to DEGENERATE) has no shape of its own there, any mix
    of the two being one: its track keeps the shape it had before. A track per mode of the first
    value: {label (at the first value), freq_hz (n,), mac (n,): the MAC with the shape it was
    assigned by (1 at the first), NaN where no mode was left for it}."""
    from scipy.optimize import linear_sum_assignment
    first = steps[0][1]
    tracks = [{"label": m.label, "freq_hz": [m.freq_hz], "mac": [1.0], "shape": m.shape} for m in first]
    for _, modes, *_ in steps[1:]:
        C = np.array([[mac(t["shape"], m.shape) if t["shape"] is not None and m.shape.size == t["shape"].size else 0.0
                       for m in modes] for t in tracks]).reshape(len(tracks), len(modes))
        rows, cols = linear_sum_assignment(-C) if C.size else ([], [])
        got = dict(zip(rows, cols))
        f = np.array([m.freq_hz for m in modes])
        shared = [bool(np.sum(np.abs(f - x) <= DEGENERATE * x) > 1) for x in f]
        for i, t in enumerate(tracks):
            m = modes[got[i]] if i in got else None
            t["freq_hz"].append(m.freq_hz if m else np.nan)
            t["mac"].append(C[i, got[i]] if m else np.nan)
            t["shape"] = m.shape if m and not shared[got[i]] else t["shape"]
    return [{"label": t["label"], "freq_hz": np.array(t["freq_hz"]), "mac": np.array(t["mac"])} for t in tracks]
