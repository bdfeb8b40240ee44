"""Plain numpy references for the body-level tests: the spatial cross operators as matrices, and
a reduced body's mass matrix and quadratic velocity forces summed over its nodes.

Imports nothing from flexmbd. A body is anything with the FlexBody arrays x0 (N, 3), m (N,),
J (N, 3, 3) and Phi (N, 6, nm) (rows [rot x,y,z; trans x,y,z]).
"""

import numpy as np


def skew(a):
    """a~ (3, 3): a~ b = a x b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def crm(v):
    """Motion cross operator v x (6, 6) of v = [w; u]: [[w~, 0], [u~, w~]]."""
    C = np.zeros((6, 6))
    C[:3, :3] = C[3:, 3:] = skew(v[:3])
    C[3:, :3] = skew(v[3:])
    return C


def crf(v):
    """Force cross operator v x* (6, 6) of v = [w; u]: [[w~, u~], [0, w~]]."""
    C = np.zeros((6, 6))
    C[:3, :3] = C[3:, 3:] = skew(v[:3])
    C[:3, 3:] = skew(v[3:])
    return C


def node_mass_matrix(fb, eta):
    """M(eta) (6+nm, 6+nm) over [w; v; eta_d], body frame, node by node.

    Node p at r_p = x0_p + Phi_t,p eta: B_p = [[1, 0, Phi_r], [-r~, 1, Phi_t]] maps [w; v; eta_d]
    to its [angular; linear] velocity, and M = sum B_p^T diag(J_p, m_p 1) B_p.
    """
    nm = fb.Phi.shape[2]
    M = np.zeros((6 + nm, 6 + nm))
    for p in range(fb.x0.shape[0]):
        Pr, Pt = fb.Phi[p, :3], fb.Phi[p, 3:]
        B = np.zeros((6, 6 + nm))
        B[:3, :3], B[:3, 6:] = np.eye(3), Pr
        B[3:, :3], B[3:, 3:6], B[3:, 6:] = -skew(fb.x0[p] + Pt @ eta), np.eye(3), Pt
        D = np.zeros((6, 6))
        D[:3, :3], D[3:, 3:] = fb.J[p], fb.m[p] * np.eye(3)
        M += B.T @ D @ B
    return M


def mass_matrix_dot(fb, eta, eta_d, h=1.0):
    """dM/dt (6+nm, 6+nm) along eta_d: a central difference of `node_mass_matrix`, exact up to
    round-off since M is quadratic in eta."""
    return (node_mass_matrix(fb, eta + h * eta_d) - node_mass_matrix(fb, eta - h * eta_d)) / (2 * h)


def quadratic_forces(fb, eta, v, eta_d, h=1.0):
    """Centrifugal and Coriolis forces (6+nm,) of the free body, from its kinetic energy
    T = 1/2 nu^T M(eta) nu, nu = [v; eta_d], by Lagrange's equations in the body-frame
    quasi-velocities v and the coordinates eta:

        h_r = v x* (M nu)_r + (M' nu)_r,   h_m = (M' nu)_m - dT/deta   (dT/deta at fixed nu)

    with every derivative of M a central difference (exact: M is quadratic in eta).
    """
    nm = eta.size
    nu = np.r_[v, eta_d]
    Mdnu = mass_matrix_dot(fb, eta, eta_d, h) @ nu
    dT = np.array([0.5 * nu @ (node_mass_matrix(fb, eta + h * e) - node_mass_matrix(fb, eta - h * e)) @ nu / (2 * h)
                   for e in np.eye(nm)]).reshape(nm)
    out = Mdnu.copy()
    out[:6] += crf(v) @ (node_mass_matrix(fb, eta) @ nu)[:6]
    out[6:] -= dT
    return out
