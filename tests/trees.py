"""Random trees as case dicts (validated like any case file), for the dynamics tests."""

import numpy as np

from flexmbd import cases

STEEL = {"E": 2.06e11, "nu": 0.29, "rho": 7820.0}


def random_inertia(rng, mass):
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] of a random solid (principal moments obey the triangle rule)."""
    a, b, c = rng.uniform(0.2, 1.0, 3) * mass * 0.05
    d = np.array([b + c, a + c, a + b])
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    I = Q @ np.diag(d) @ Q.T
    return [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]


def random_beam(rng, boundary=None, modes=None):
    L = rng.uniform(0.4, 1.2)
    boundary = boundary or str(rng.choice(["clamped-free", "free-free", "craig-bampton"]))
    modes = {"count": int(modes or rng.integers(2, 6)), "boundary": boundary}
    if boundary == "craig-bampton":
        modes["interfaces"] = [0.0, L]
    return {"type": "beam", "material": "steel", "length": L, "elements": int(rng.integers(6, 14)),
            "section": {"shape": "rectangle", "b": rng.uniform(0.02, 0.04), "h": rng.uniform(0.02, 0.05)},
            "modes": modes, "damping_ratio": 0.0,
            "stiffening": False}          # the oracle's kinematics are the linear modal ones


def one_beam(body: dict, material: dict = STEEL):
    """The typed beam (`cases.Beam`) of a raw body table, validated as the one body of a small case
    (hung from the ground on a fixed joint; its material named by the table, with `material`'s values)."""
    raw = {"title": "one beam", "duration": 1.0, "materials": {body["material"]: dict(material)},
           "bodies": {"b": body}, "joints": {"root": {"type": "fixed", "parent": "ground", "child": "b"}},
           "channels": {"energy": {"kind": "energy"}}}
    return cases.Case(name="one_beam", path=None, data=cases.validate(raw, "one beam")).bodies["b"]


def random_case(rng, n_bodies, joint_types, flexible=0.0, gravity=(0.0, -9.81, 0.3)):
    """A validated case: body k+1 hangs from a random earlier body (or ground) on a random joint;
    with probability `flexible` a body is a beam (children of beams sit on random nodes)."""
    bodies, joints = {}, {}
    for k in range(n_bodies):
        name = f"b{k}"
        if rng.uniform() < flexible:
            bodies[name] = random_beam(rng)
        else:
            mass = rng.uniform(0.5, 3.0)
            bodies[name] = {"type": "rigid", "mass": mass, "com": list(rng.uniform(-0.2, 0.2, 3)),
                            "inertia": random_inertia(rng, mass)}
        parent = "ground" if k == 0 else str(rng.choice(["ground"] + list(bodies)[:-1]))
        jt = str(rng.choice(joint_types))
        j = {"type": jt, "parent": parent, "child": name,
             "axis": list(rng.normal(size=3)), "rpy": list(rng.uniform(-1, 1, 3))}
        if parent != "ground" and bodies[parent]["type"] == "beam":
            b = bodies[parent]
            j["at"] = b["length"] * int(rng.integers(1, b["elements"] + 1)) / b["elements"]
        else:
            j["at"] = list(rng.uniform(-0.3, 0.3, 3))
        joints[f"j{k}"] = j
    raw = {"title": "random tree", "duration": 1.0, "gravity": list(gravity),
           "materials": {"steel": dict(STEEL)}, "bodies": bodies, "joints": joints,
           "channels": {"energy": {"kind": "energy"}}}
    return cases.Case(name="random", path=None, data=cases.validate(raw, "random"))


def random_state(rng, model, scale_q=1.0, scale_eta=1e-3):
    """Random (q, v) with unit quaternions, modal amplitudes of order scale_eta."""
    from flexmbd.mbd.joints import FREE, SPHERICAL
    q = rng.normal(size=model.nq) * scale_q
    v = rng.normal(size=model.nv)
    for i in range(1, model.nb + 1):
        k = model.jnt_qadr[i]
        if model.jnt_type[i] in (SPHERICAL, FREE):
            q[k:k + 4] /= np.linalg.norm(q[k:k + 4])
        a, n = model.body_madr[i], model.body_nm[i]
        q[a:a + n] *= scale_eta
        v[a:a + n] *= scale_eta * 10
    return q, v
