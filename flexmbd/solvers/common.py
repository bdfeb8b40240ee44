"""Facts about a case that several adapters need, computed one way."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexmbd.harness import channels


def clamped_beam(case, solids: bool = False, masses: bool = False) -> tuple[str, str]:
    """(beam name, '') when the case is one beam (or, with `solids`, one solid) clamped to ground
    at its root (its frame), with `masses` point masses fixed to it, else ('', why)."""
    bodies, joints = case.bodies, case.joints
    if masses:
        points = [n for n, b in bodies.items() if b.type == "point_mass"]
        for n in points:
            if case.joint_of(n).parent == "ground":
                return "", f"point mass {n!r} is fixed to ground: only point masses on the beam are modelled"
        bodies = {n: b for n, b in bodies.items() if n not in points}
        joints = {n: j for n, j in joints.items() if j.child not in points}
    what = "beam or solid" if solids else "beam"
    if len(bodies) != 1 or len(joints) != 1:
        return "", f"needs exactly one {what} on one joint"
    (name, body), (jname, joint) = next(iter(bodies.items())), next(iter(joints.items()))
    if not (body.type == "beam" and not body.rigid or solids and body.type == "solid"):
        return "", f"body {name!r} is not a flexible {what}"
    if joint.type != "fixed" or joint.parent != "ground":
        return "", f"joint {jname!r} is not a fixed joint to ground (fixed-base cases only)"
    return name, ""


def body_force(case, load) -> np.ndarray:
    """A load's (`cases.Load`) force (3,) in the body frame of a beam clamped to ground (no motion
    of the frame)."""
    f = np.asarray(load.force, dtype=float)
    if load.frame == "global":
        f = np.array(clamp(case).triad).T @ f
    return f


def gravity_body(case) -> np.ndarray:
    """Gravity (3,) in the body frame of a beam clamped to ground, m/s^2."""
    return np.array(clamp(case).triad).T @ np.asarray(case.gravity, dtype=float)


def clamp(case):
    """The joint that clamps the beam of a case of `clamped_beam` to ground."""
    return next(j for j in case.joints.values() if j.parent == "ground")


def sample_times(case, t_end: float) -> np.ndarray:
    """Output instants 0, dt, ..., t_end of the case's output_dt."""
    dt = case.integrator.output_dt
    n = int(round(t_end / dt))
    return np.linspace(0.0, n * dt, n + 1)


def component_index(c: str) -> int:
    return "xyz".index(c)


def rigid_trajectory(case, t, coordinate, energy) -> channels.Trajectory:
    """The trajectory of a rigid-limit solver: the coordinate (n,) of each joint the channels
    need from `coordinate(joint name)`, the total energy from `energy()` (n,); no beam deforms
    (no Beam), reactions are not recovered."""
    traj = channels.Trajectory(t=t)
    for jname in channels.joints_needed(case):
        traj.joints[jname] = coordinate(jname)
    if channels.wants_energy(case):
        traj.energy = {"total": energy()}
    return traj


# ---------------------------------------------------------------------------------------------
# the rigid limit of a case, read from the case itself (the rigid peers `pinocchio`, `mujoco`;
# docs/peers.md, docs/formulation.md "rigid limit of a beam for the rigid peers"). Nothing here
# reads flexmbd's Model: an error in `build.from_case` is not copied into the peers.

BEAM_MASS = ("prism", "lumped")     # the rigid peers' setting `beam_mass` (see `beam_inertia`)


@dataclass(frozen=True)
class RigidBody:
    """One body of a case's rigid limit and the joint to its parent, in the case's own terms.

    The joint's input triad has axes `R` (columns: the triad's x, y, z in the parent frame, i.e.
    R maps triad to parent coordinates; `rotation_rpy(rpy)`) and origin `r` in the parent frame:
    the point `at` on ground or a rigid parent, on a beam parent the node `at` snaps to,
    [x, 0, 0] along its axis (`case.joints[name].x`, the node flexmbd uses). The body
    frame is the joint's output triad: it coincides with the input triad at zero coordinates and
    moves relative to it by the joint's motion (revolute: R(axis, q); prismatic: axis q; spherical:
    R(quaternion); free: R(quaternion) and the origin at p in the triad)."""

    name: str
    parent: str             # parent body, "ground" for the world
    joint: str              # name of the joint to the parent
    type: str               # revolute, prismatic, fixed, spherical, free
    R: np.ndarray           # (3, 3) input triad -> parent coordinates
    r: np.ndarray           # (3,) input triad origin in the parent frame, m
    axis: np.ndarray        # (3,) unit joint axis in the triad (revolute, prismatic)
    mass: float             # kg
    com: np.ndarray         # (3,) centre of mass in the body frame, m
    inertia: np.ndarray     # (3, 3) rotational inertia about the centre of mass, body axes, kg m^2
    q0: tuple               # the case's initial values: revolute/prismatic (q,); spherical a
    qd0: tuple              # rotation vector; free [rotation vector; p]; qd0: [w] / [w; v] body frame
    motion: dict | None     # prescribed motion profile (1-DOF joints), None when free


@dataclass(frozen=True)
class RigidLoad:
    """A point load of the case on its body, in the body frame."""

    body: str
    point: np.ndarray       # (3,) m: `at` on a rigid body; on a beam its snapped node [x, 0, 0]
    force: np.ndarray       # (3,) N, in the body frame or the global one (`glob`)
    glob: bool
    profile: object         # the load's time profile (`profiles.load_factor`)


def rigid_limit_text(beam_mass: str) -> str:
    """The rigid peers' model, in one line for a result's settings."""
    return ("rigid limit from the case: every beam a rigid prism (closed-form inertia)" if beam_mass == "prism" else
            "rigid limit from the case: every beam rigid, inertia of its lumped mesh (flexmbd's beam declared rigid)")


def section_moments(section) -> tuple[float, float, float]:
    """(A, Iy, Iz) of a case section, closed form: area and second moments of area
    Iy = int z^2 dA, Iz = int y^2 dA (about the body's y and z axes). Rectangle with extent
    `h` along `h_axis` and `b` along the other axis (ey x ez): A = ey ez, Iy = ey ez^3 / 12,
    Iz = ez ey^3 / 12; circle of diameter d: A = pi d^2 / 4, Iy = Iz = pi d^4 / 64."""
    if section.shape == "circle":
        d = section.d
        return math.pi * d * d / 4.0, math.pi * d ** 4 / 64.0, math.pi * d ** 4 / 64.0
    ey, ez = (section.h, section.b) if section.h_axis == "y" else (section.b, section.h)
    return ey * ez, ey * ez ** 3 / 12.0, ez * ey ** 3 / 12.0


def beam_inertia(body, beam_mass: str = "prism") -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass (3,), rotational inertia about it (3, 3)) of a case beam in the
    rigid limit, body frame (the beam along +x from its root), in closed form.

    "prism": the homogeneous prism of length L, density rho and the section's A, Iy, Iz
    (`section_moments`): m = rho A L, com = [L/2, 0, 0],

        I_c = diag( rho L (Iy + Iz),  m L^2 / 12 + rho L Iy,  m L^2 / 12 + rho L Iz )

    (the slender rod's m L^2 / 12 across the beam plus the sections' rotary inertia rho I dx
    summed along it; about the axis the polar rho (Iy + Iz) L).
    "lumped": the beam as its case mesh of n = `elements` equal elements with lumped node masses
    (rho A l / 2 at the two ends, rho A l at the inner nodes, the sections' rotary inertia alike),
    which is what flexmbd integrates for a beam declared rigid: the same mass, com and rotary
    terms, and across the beam sum_p m_p (x_p - L/2)^2 = m L^2 / 12 (1 + 2 / n^2) (the
    trapezoidal rule's error on int (x - L/2)^2 dm is exactly m L^2 / (6 n^2))."""
    L, rho = float(body.length), float(body.material.rho)
    A, Iy, Iz = section_moments(body.section)
    m = rho * A * L
    across = m * L * L / 12.0
    if beam_mass == "lumped":
        across += m * L * L / (6.0 * body.elements ** 2)
    elif beam_mass != "prism":
        raise ValueError(f"beam_mass {beam_mass!r}: expected one of {BEAM_MASS}")
    I_c = np.diag([rho * L * (Iy + Iz), across + rho * L * Iy, across + rho * L * Iz])
    return m, np.array([L / 2.0, 0.0, 0.0]), I_c


def rigid_body_inertia(body) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, com (3,), inertia about the com (3, 3)) of a case rigid body, as the case gives them:
    `inertia` = [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] are the entries of the inertia matrix."""
    xx, yy, zz, xy, xz, yz = (float(x) for x in body.inertia)
    return (float(body.mass), np.asarray(body.com, dtype=float),
            np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))


def rigid_bodies(case, beam_mass: str = "prism") -> list[RigidBody]:
    """The case's rigid limit, body by body in tree order (parents first): every beam, flexible
    or declared rigid, is rigid (`beam_inertia`), every rigid body as the case gives it (a point
    mass: its mass at the origin, a zero inertia); joints placed as `RigidBody` says."""
    out = []
    for link in case.tree:
        body, j = case.bodies[link.name], case.joint_of(link.name)
        r = np.asarray(j.offset, dtype=float)          # on a beam parent its snapped node [x, 0, 0]
        m, c, Ic = beam_inertia(body, beam_mass) if body.type == "beam" else rigid_body_inertia(body)
        out.append(RigidBody(name=link.name, parent=j.parent, joint=j.name, type=j.type,
                             R=np.array(j.triad, dtype=float), r=r, axis=np.array(j.axis, dtype=float),
                             mass=m, com=c, inertia=Ic, q0=tuple(float(x) for x in j.q0),
                             qd0=tuple(float(x) for x in j.qd0), motion=j.motion))
    return out


def rigid_loads(case) -> list[RigidLoad]:
    """The case's point loads in their bodies' frames: at `at` on a rigid body, on a beam at the
    node `at` snaps to (the case's `offset`, snapped once), [x, 0, 0]."""
    return [RigidLoad(body=ld.body, point=np.asarray(ld.offset, dtype=float), force=np.asarray(ld.force, dtype=float),
                      glob=ld.frame == "global", profile=ld.profile) for ld in case.loads.values()]
