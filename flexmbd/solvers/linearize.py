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
from flexmbd.mbd import constraints
from flexmbd.mbd.linearize import (ROUNDOFF, STEP, NotLinearized, SystemMode, accelerations, closing,  # noqa: F401
                                   coordinate_groups, coordinates, damping_resolution, energy_shares, equilibrium,
                                   family, labelled, lead, mass_matrix, momenta, perturbed, refined, state_matrix,
                                   system_modes)
from flexmbd.mbd.model import Model
from flexmbd.harness.progress import Progress


def model_of(case) -> Model:
    """The Model `flexmbd` integrates: the tree the modal solvers model (`case.modelled`)."""
    return from_case(case.modelled, flexbody.for_case(case.modelled))


def loops_of(case, model: Model) -> constraints.Loops | None:
    """The case's cut joints on its Model (None without loops)."""
    return build.loops(model, case.modelled)


def for_case(case, about: str = "initial", progress: bool = False) -> list:
    """System modes of a case about its initial state (t = 0) or its static equilibrium at rest;
    with `progress`, a bar on stderr over the coordinates of the state matrix (4 evaluations
    each: `cost.system`) when they take more than a couple of seconds."""
    model = model_of(case)
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
