"""Which solver models what: each solver's own `applies` (through `registry.status_for`) asked on
small probe cases, one feature each, so that the table cannot drift from the adapters.

A solver models a feature when it can run at least one of the feature's probes. The probes are
built here from plain dicts (a 1 m steel beam of 8 elements and 2 modes, a 1 kg rigid body or
point mass);
loops and solids are probed with the shipped cases `four_bar_swing`, `four_bar_swing_rigid`,
`cantilever_solid` and `brick_pendulum`. docs/solvers.md holds the table (`markdown`), and
`flexmbd list --solvers` prints it.
"""

from __future__ import annotations

import copy
from pathlib import Path

from flexmbd import cases
from flexmbd.harness import registry

STEEL = {"E": 2.06e11, "nu": 0.29, "rho": 7820.0}
BEAM = {"type": "beam", "material": "steel", "length": 1.0, "elements": 8,
        "section": {"shape": "rectangle", "b": 0.01, "h": 0.015}, "modes": {"count": 2}}
MASS = {"type": "rigid", "mass": 1.0, "inertia": [1e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0]}
POINT = {"type": "point_mass", "mass": 1.0}
TIP = {"kind": "deflection", "body": "beam", "at": 1.0}
GRAVITY = [0.0, -9.81, 0.0]
CLAMP = {"type": "fixed", "parent": "ground", "child": "beam"}
HINGE = {"type": "revolute", "parent": "ground", "child": "beam"}
HUB = {**HINGE, "motion": {"type": "spin_up", "W": 1.0, "T": 0.5}}
TIP_LOAD = {"type": "point_force", "body": "beam", "at": 1.0, "force": [0.0, -1.0, 0.0]}
MASS_AT_TIP = {"type": "fixed", "parent": "beam", "child": "mass", "at": 1.0}


def probe(joint: dict, gravity=(0.0, 0.0, 0.0), loads=(), mass=False, beam=None, stress=False,
          body=None, point=False) -> dict:
    """A small case as a dict: one body (the beam, or `body`) on `joint`, a tip deflection channel
    (a joint angle for a rigid body), optionally a rigid mass (`mass`) or a point mass (`point`)
    fixed at the beam's tip."""
    bodies = {"beam": {**BEAM, **(beam or {})}} if body is None else {"beam": body}
    joints = {"j": joint}
    chans = {"tip": TIP} if body is None else {"angle": {"kind": "joint_angle", "joint": "j"}}
    if mass or point:
        bodies["mass"], joints["m"] = POINT if point else MASS, MASS_AT_TIP
    if stress:
        chans["stress"] = {"kind": "stress_vm", "body": "beam", "at": 0.1}
    return {"title": "probe", "duration": 0.01, "gravity": list(gravity), "materials": {"steel": STEEL},
            "bodies": bodies, "joints": joints, "loads": {f"f{k}": ld for k, ld in enumerate(loads)},
            "channels": chans}


# feature -> its probes: dicts (`probe`) or names of shipped cases
FEATURES = {
    "rigid bodies": [probe(HINGE, GRAVITY, body=MASS | {"com": [0.5, 0.0, 0.0]})],
    "beams": [probe(CLAMP, loads=[TIP_LOAD]), probe(HINGE, GRAVITY)],
    "tip masses": [probe(CLAMP, GRAVITY, mass=True), probe(HUB, mass=True), probe(HINGE, GRAVITY, mass=True)],
    "point masses": [probe(CLAMP, GRAVITY, point=True), probe(HUB, point=True), probe(HINGE, GRAVITY, point=True)],
    "prescribed motion": [probe(HUB)],
    "gravity": [probe(CLAMP, GRAVITY), probe(HINGE, GRAVITY)],
    "loads": [probe(CLAMP, loads=[TIP_LOAD]), probe(HINGE, loads=[TIP_LOAD])],
    "split beams": [probe(CLAMP, loads=[TIP_LOAD], beam={"segments": 2}),
                    probe(HINGE, GRAVITY, beam={"segments": 2})],
    "stress": [probe(CLAMP, loads=[TIP_LOAD], stress=True), probe(HINGE, GRAVITY, stress=True)],
    "loops": ["four_bar_swing", "four_bar_swing_rigid"],
    "solids": ["cantilever_solid", "brick_pendulum"],
}


def case_of(p) -> cases.Case:
    """A probe as a Case: a shipped case by name, else the dict validated as a file would be."""
    if isinstance(p, str):
        return cases.load(p)
    where = "capabilities probe"
    return cases.Case(name="probe", path=Path(where), data=cases.validate(copy.deepcopy(p), where))


def table(names=None) -> dict:
    """{solver: {feature: "yes" / "rigid" / "no" / "unavailable"}} for `names` (default: every
    solver, plug-ins included)."""
    names = list(names or registry.NAMES)
    probes = {f: [case_of(p) for p in ps] for f, ps in FEATURES.items()}
    out = {}
    for s in names:
        if registry.unavailable_reason(s):
            out[s] = dict.fromkeys(FEATURES, "unavailable")
            continue
        rigid = getattr(registry.module(s), "RIGID", False)
        out[s] = {f: mark(any(registry.status_for(c, s) == "" for c in cs), f, rigid) for f, cs in probes.items()}
    return out


def mark(runs: bool, feature: str, rigid: bool) -> str:
    """A cell: "yes" / "no"; a rigid solver (module attribute RIGID) runs beams as rigid bodies
    ("rigid") and has no stress (its deformation channels are zero and never compared)."""
    if not runs:
        return "no"
    if rigid and feature in DEFORMING:
        return "no" if feature == "stress" else "rigid"
    return "yes"


# what a rigid solver models without deformation
DEFORMING = ("beams", "tip masses", "point masses", "split beams", "stress")


def markdown(tab: dict) -> str:
    """The table as Markdown: one row per solver, one column per feature."""
    head = ["solver", *FEATURES]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join([f"`{s}`", *(row[f] for f in FEATURES)]) + " |" for s, row in tab.items()]
    return "\n".join(lines) + "\n"
