"""The `mujoco` peer on closed loops: cut joints closed by MuJoCo equality constraints.

Checked against models independent of the adapter and of MuJoCo: the rigid four-bar as three bar
angles with the loop's two multipliers (Lagrange), reduced to the crank angle by the closed-form
closure (a circle intersection) and integrated by scipy at rtol 1e-12; and, for the cut joint types
in space, a body on a ball joint held by the cut joint: the moment the cut joint exerts is what
Euler's equations about the ball's centre leave to it, at MuJoCo's own state and acceleration.
Planar vectors are complex numbers: e^(i a) the unit vector at angle a.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from flexmbd import cases
from flexmbd.harness import registry
from flexmbd.mbd import spatial

mujoco = pytest.importorskip("mujoco")

from flexmbd.solvers import common, mujoco_rigid  # noqa: E402

pytestmark = pytest.mark.kernel_free

PRISM = ['solvers.mujoco.beam_mass="prism"']        # the oracle's bars: homogeneous prisms
BARS = ("crank", "coupler", "rocker")


# ---------------------------------------------------------------------------------------------
# the rigid four-bar, independently


class FourBar:
    """The planar four-bar of a case in absolute bar angles th (3,) from +x: the crank from the
    origin, the coupler from the crank's tip, the rocker from the pivot G; bar k has length L,
    mass m = rho b h L, inertia about its centre m (L^2 + h^2) / 12 (h across the bar in the
    plane), its centre at half its length."""

    def __init__(self, case):
        self.L = np.array([case.bodies[n].length for n in BARS])
        b = np.array([case.bodies[n].section.b for n in BARS])
        h = np.array([case.bodies[n].section.h for n in BARS])
        self.m = case.bodies["crank"].material.rho * b * h * self.L
        self.I = self.m * (self.L ** 2 + h ** 2) / 12
        self.G = complex(*case.joints["rocker_pivot"].offset[:2])
        self.g = complex(*case.gravity[:2])
        # centre of bar k: base_k + sum_j C_kj e^(i th_j)
        self.C = np.array([[0.5, 0, 0], [1, 0.5, 0], [0, 0, 0.5]]) * self.L
        self.base = np.array([0, 0, self.G])
        self.K = np.array([1.0, 1.0, -1.0]) * self.L                             # closure: sum_j K_j e^(i th_j) = G
        q = [case.joints[n].q0[0] for n in ("crank_pivot", "crank_pin", "rocker_pivot")]
        guess = self.L[0] * np.exp(1j * q[0]) + self.L[1] * np.exp(1j * (q[0] + q[1]))
        self.branch = min((1, -1), key=lambda s: abs(self.tip(q[0], s) - guess))

    def tip(self, th1: float, branch: int) -> complex:
        """The coupler's far end (the rocker pin) at crank angle th1: the intersection of the
        circles about the crank tip (radius L2) and G (radius L3) on side `branch` of their line."""
        P = self.L[0] * np.exp(1j * th1)
        D = self.G - P
        c = (self.L[1] ** 2 + abs(D) ** 2 - self.L[2] ** 2) / (2 * self.L[1] * abs(D))
        return P + self.L[1] * np.exp(1j * (np.angle(D) + branch * np.arccos(c)))

    def angles(self, th1: float) -> np.ndarray:
        Q = self.tip(th1, self.branch)
        return np.array([th1, np.angle(Q - self.L[0] * np.exp(1j * th1)), np.angle(Q - self.G)])

    def rates(self, th, w1: float) -> np.ndarray:
        """(3,) bar rates from the crank's: d/dt sum_j K_j e^(i th_j) = 0."""
        Kd = 1j * self.K * np.exp(1j * th)
        A = np.array([[Kd[1].real, Kd[2].real], [Kd[1].imag, Kd[2].imag]])
        return np.array([w1, *np.linalg.solve(A, -w1 * np.array([Kd[0].real, Kd[0].imag]))])

    def accelerations(self, th, w) -> tuple[np.ndarray, complex]:
        """(bar accelerations (3,), F): Lagrange's equations with the closure's multipliers, F the
        force (world, complex) the rocker pin exerts on the rocker, -F on the coupler."""
        e = np.exp(1j * th)
        V = 1j * self.C * e                                 # d centre_k / d th_j
        Kd = 1j * self.K * e
        M = np.diag(self.I) + np.einsum("k,kj,kl->jl", self.m, V.conj(), V).real
        rhs = np.einsum("k,kj,k->j", self.m, V.conj(), self.g + (self.C * e) @ w ** 2).real
        A = np.zeros((5, 5))
        A[:3, :3], A[:3, 3], A[:3, 4] = M, Kd.real, Kd.imag
        A[3, :3], A[4, :3] = Kd.real, Kd.imag
        closure = (self.K * e) @ w ** 2
        x = np.linalg.solve(A, [*rhs, closure.real, closure.imag])
        return x[:3], complex(x[3], x[4])

    def energy(self, th, w) -> float:
        e = np.exp(1j * th)
        v = (1j * self.C * e) @ w
        centre = self.base + (self.C * e) @ np.ones(3)
        potential = -self.m @ (self.g.conjugate() * centre).real
        return float(0.5 * self.m @ np.abs(v) ** 2 + 0.5 * self.I @ w ** 2 + potential)

    def run(self, th1: float, w1: float, t) -> dict:
        """Crank, rocker angles, energy and the pin force in the rocker's frame (x + i y) at t (n,)."""
        def f(_, y):
            th = self.angles(y[0])
            return [y[1], self.accelerations(th, self.rates(th, y[1]))[0][0]]
        sol = solve_ivp(f, (t[0], t[-1]), [th1, w1], method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
        out = {"crank": sol.y[0], "rocker": [], "energy": [], "force": [], "kinetic": []}
        for a, w1 in sol.y.T:
            th = self.angles(a)
            w = self.rates(th, w1)
            out["rocker"].append(th[2])
            out["energy"].append(self.energy(th, w))
            out["force"].append(self.accelerations(th, w)[1] * np.exp(-1j * th[2]))
            out["kinetic"].append(self.energy(th, w) - self.energy(th, 0 * w))
        return {k: np.array(v) for k, v in out.items()}


def mujoco_at(case, dt=1e-4):
    """MuJoCo's model and data of the case with the loops closed (`close_loops`, residual < 1e-13 m),
    and the equality constraints."""
    bodies = common.rigid_bodies(case)
    cuts = mujoco_rigid.cut_equalities(case)
    m = mujoco_rigid.compile_model(bodies, case.gravity, dt, cuts)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = mujoco_rigid.initial_state(bodies, m)
    assert mujoco_rigid.close_loops(case, m, d) < 1e-13
    return m, d, cuts


@pytest.fixture(scope="module")
def four_bar_swing():
    case = cases.load("four_bar_swing_rigid", PRISM)
    r = registry.run(case, "mujoco")
    assert r.ok, r.status
    bar = FourBar(case)
    return case, r, bar, bar.run(np.pi / 2, 20.0, r.t)


def test_four_bar_angles_energy_and_pin_force_match_the_lagrange_model(four_bar_swing):
    """Over the case's 1 s (about four crank turns) at MuJoCo's default step: the crank and rocker
    angles within 1e-7 rad (observed 3e-9), the energy within 1e-6 of the largest kinetic energy
    from the model's, and conserved to that (observed 5e-10 both), the pin force within 1e-6 of
    its largest (observed 3.5e-8)."""
    case, r, bar, ref = four_bar_swing
    ch = r.channels
    assert np.abs(ch["crank_angle"] - ref["crank"]).max() < 1e-7
    assert np.abs(ch["rocker_angle"] - ref["rocker"]).max() < 1e-7
    scale = ref["kinetic"].max()
    assert np.abs(ch["energy"] - ref["energy"]).max() < 1e-6 * scale
    assert np.abs(ch["energy"] - ch["energy"][0]).max() < 1e-6 * scale
    F = ch["pin_force_x"] + 1j * ch["pin_force_y"]
    assert np.abs(F - ref["force"]).max() < 1e-6 * np.abs(ref["force"]).max()


def test_four_bar_outputs_close_the_loop(four_bar_swing):
    """At every output the rocker angle is the closure's of the crank angle (observed 1.2e-10 rad)."""
    case, r, bar, _ = four_bar_swing
    closed = np.array([bar.angles(a)[2] for a in r.channels["crank_angle"]])
    assert np.abs(r.channels["rocker_angle"] - closed).max() < 1e-8


def test_assembly_keeps_the_crank_and_closes_the_loop_from_the_guesses():
    """The case's crank_pin and rocker_pivot angles are guesses: the closure replaces them and
    their rates (the last two one-coordinate joints of the tree: rank 2), the crank's angle and
    rate are kept."""
    case = cases.load("four_bar_swing_rigid", PRISM)
    m, d, _ = mujoco_at(case)
    th = FourBar(case).angles(np.pi / 2)
    w = FourBar(case).rates(th, 20.0)
    assert np.allclose(d.qpos, [th[0], th[1] - th[0], th[2]], rtol=0, atol=1e-13)
    assert np.allclose(d.qvel, [w[0], w[1] - w[0], w[2]], rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# cut joints in space: a block on a ball joint at the origin, held by the cut joint

BLOCK = """
title = "a block on a ball joint held by a loop joint"
duration = 0.1
gravity = [0.0, -9.81, 0.0]
[materials.steel]
E = 2.0e11
nu = 0.3
rho = 7850.0
[bodies.block]
type = "rigid"
mass = 1.3
com = [0.2, 0.05, 0.1]
inertia = [0.02, 0.03, 0.04, 0.002, -0.003, 0.004]
[joints.ball]
type = "spherical"
parent = "ground"
child = "block"
q0 = {q0}
qd0 = {qd0}
[joints.cut]
parent = "ground"
child = "block"
loop = true
{cut}
[channels.energy]
kind = "energy"
[integrator]
method = "dopri5"
rtol = 1e-9
atol = 1e-12
output_dt = 1e-3
"""
RPY = [0.3, -0.2, 0.5]                  # the cut's input triad
# MuJoCo's constraint force is -(J qacc - aref) / R; with R at ~1e-8 of J M^-1 J^T (the loops'
# regularization) it keeps about 8 digits of the force that its qacc holds
FORCE_TOL = 1e-7
AXIS = np.array([0.0, 0.0, 1.0])


def toml(x) -> str:
    return "[" + ", ".join(repr(float(v)) for v in x) + "]"


def block(tmp_path, cut: str, R, w):
    """The block case with the cut joint `cut` (TOML lines), the ball at rotation R (3, 3) and
    angular velocity w (3,, body frame): a ball joint's coordinates are never dependent (flexmbd's
    choice), so the case gives them closed."""
    path = tmp_path / "block.toml"
    path.write_text(BLOCK.replace("{cut}", cut).replace("{q0}", toml(Rotation.from_matrix(R).as_rotvec()))
                    .replace("{qd0}", toml(w)))
    return cases.load(str(path))


def euler_moment(case, m, d) -> np.ndarray:
    """(3,) body frame: the moment about the ball's centre that the block's motion needs beyond
    gravity's, I_O dw/dt + w x I_O w - c x m g (w, dw/dt: the ball's qvel, qacc, body frame)."""
    mass, c, Ic = common.rigid_body_inertia(case.bodies["block"])
    I_O = Ic + mass * (c @ c * np.eye(3) - np.outer(c, c))
    w, dw = d.qvel[:3], d.qacc[:3]
    g = d.xmat[1].reshape(3, 3).T @ np.asarray(case.gravity)
    return I_O @ dw + np.cross(w, I_O @ w) - mass * np.cross(c, g)


def sampled(case, steps=(0, 300, 300)):
    """(m, d, [(the cut's reaction [moment; force], Euler's moment)]) after each run of `steps`
    MuJoCo steps, the last state in d."""
    m, d, cuts = mujoco_at(case)
    out = []
    for n in steps:
        for _ in range(n):
            mujoco.mj_step(m, d)
        mujoco.mj_forward(m, d)
        out.append((mujoco_rigid.cut_reactions(case, cuts, m, d)["cut"], euler_moment(case, m, d)))
    return m, d, out


def revolute_block(tmp_path):
    """The block turning at 4 rad/s about the axis z of a tilted triad at the ball's centre."""
    T = spatial.rotation_rpy(RPY)
    return block(tmp_path, f'type = "revolute"\nrpy = {toml(RPY)}\naxis = {toml(AXIS)}',
                 T @ Rotation.from_rotvec(0.7 * AXIS).as_matrix(), 4.0 * AXIS)


def test_revolute_cut_in_space_holds_its_axis_and_exerts_eulers_moment(tmp_path):
    """The block turns about the revolute cut's axis only (two connects along it: the ball's two
    other rotations stay at 1e-10 rad/s); the cut's moment about the centre is what Euler's
    equations need (the ball exerts none), its force indeterminate beside the ball's."""
    case = revolute_block(tmp_path)
    m, d, out = sampled(case)
    axis = np.array(case.loops["cut"].triad) @ AXIS
    assert np.allclose(d.xmat[1].reshape(3, 3).T @ axis, AXIS, rtol=0, atol=1e-10)
    assert np.allclose(d.qvel[:2], 0, atol=1e-9) and abs(d.qvel[2]) > 1.0
    for moment_force, need in out:
        assert np.allclose(moment_force[:3], need, rtol=0, atol=FORCE_TOL * np.abs(need).max())
        assert np.abs(need[:2]).max() > 0.1                 # the cut does carry a moment


def test_weld_cut_holds_the_block_at_rest_against_gravity(tmp_path):
    """A fixed cut at the ball's centre (the tilted triad, the block on it at rest): the block
    stays; the cut's moment about the centre holds gravity's, its rotation rows mapped by
    `weld_torque`."""
    T = spatial.rotation_rpy(RPY)
    case = block(tmp_path, f'type = "fixed"\nrpy = {toml(RPY)}', T, np.zeros(3))
    m, d, out = sampled(case)
    assert np.allclose(d.xmat[1].reshape(3, 3), T, rtol=0, atol=1e-10)    # the soft weld's sag: 2e-11 rad
    assert np.allclose(d.qvel, 0, atol=1e-11)
    mass, c, _ = common.rigid_body_inertia(case.bodies["block"])
    hold = -mass * np.cross(c, T.T @ np.asarray(case.gravity))
    for moment_force, need in out:
        assert np.allclose(need, hold, rtol=1e-6, atol=0)      # soft: 8e-8 at the start
        assert np.allclose(moment_force[:3], need, rtol=FORCE_TOL, atol=0)


def test_spherical_cut_force_gives_eulers_moment_about_the_ball(tmp_path):
    """A spherical cut joining the block's point p (child_at) to the ground point where the block
    puts it, the block turning about the line through the ball's centre and p: the cut's moment
    about p is zero, its force at p has Euler's moment about the centre, p x F."""
    p = np.array([0.3, 0.1, -0.2])
    R = Rotation.from_rotvec([0.3, -0.1, 0.5]).as_matrix()
    case = block(tmp_path, f'type = "spherical"\nat = {toml(R @ p)}\nchild_at = {toml(p)}', R, 5.0 * p)
    m, d, out = sampled(case)
    assert np.allclose(d.xmat[1].reshape(3, 3) @ p, R @ p, rtol=0, atol=1e-10)
    for moment_force, need in out:
        assert np.allclose(moment_force[:3], 0, atol=1e-12)
        assert np.allclose(np.cross(p, moment_force[3:]), need, rtol=0, atol=FORCE_TOL * np.abs(need).max())
        assert np.abs(need).max() > 0.1


def test_energy_of_a_spatial_loop_is_conserved(tmp_path):
    """The revolute-cut block over the case's 0.1 s: MuJoCo's energy within 1e-6 of its kinetic
    energy (the cut does no work)."""
    case = revolute_block(tmp_path)
    r = registry.run(case, "mujoco")
    assert r.ok, r.status
    m, d, _ = mujoco_at(case)
    mujoco.mj_forward(m, d)
    E = r.channels["energy"]
    assert np.abs(E - E[0]).max() < 1e-6 * d.energy[1]


def test_cuts_without_an_equality_and_driven_loops_are_not_applicable(tmp_path):
    case = block(tmp_path, f'type = "prismatic"\naxis = {toml(AXIS)}', np.eye(3), np.zeros(3))
    assert registry.status_for(case, "mujoco") == (
        "not applicable: loop joint 'cut' is prismatic: MuJoCo's equality constraints hold a point "
        "(connect) or a frame (weld), none leaves a slide free")
    assert "prescribed motion" in registry.status_for(cases.load("slider_crank"), "mujoco")
