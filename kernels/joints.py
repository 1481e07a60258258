"""Kernels of the penalty joints between two line ends: spherical, hinge and fixed.

After the Elastica documentation page on joints (Zhang et al. 2019; Gazzola et al. 2018): a
joint holds the ends of two lines together by a stiff spring instead of an exact junction.
Notation (all vectors lab frame): the line ends a and b sit at x_a, x_b (their attachment points
r + D xi on their nodes (1.1)) and carry the line-end frames E_a, E_b = D X (1.3), whose third
axis is the tangent at the end.

  spherical  eps = x_b - x_a;  V = k |eps - eps0|^2 / 2;
             f = k (eps - eps0) + nu (v_b - v_a) on end a, -f on end b
  hinge      spherical, plus V_t = kt s^2 / 2 with s = t_b . n, t_b = E_b e3 and n = E_a n_a
             (the plane normal turns with line a's end):
             tau = -kt s (t_b x n) on end b, -tau on end a  (the page's torque
             (d + eps_perp) x (k eps_perp), eps_perp = -(d . n) n, d = l t_b the end segment,
             is the same with kt = k l^2; the page's "r_2(j-1) - r_2j" fixes no sign that
             matters, as s^2 and s t_b do not change with the sign of t_b)
  fixed      spherical, plus V_t = kt |theta|^2 / 2, theta the rotation vector of the
             deviation R0^T E_a^T E_b from the rest relative rotation R0 (PyElastica's
             FixedJoint): tau = -kt E_b theta on end b, -tau on end a

Each torque is minus the exact derivative of V_t with respect to a rotation of that end, so a
joint with nu = nut = 0 conserves energy, and the pair is equal and opposite, so it keeps both
momenta. Torques act on the line-end frames, i.e. on the nodes the ends are attached to
(loads.node_tau, lab); forces act on the end vertices (loads.f), which gather_node moves
to the nodes with their lever arms (4.3)/(4.4). The optional dampers nu, nut act on the relative
velocity and angular velocity of the two ends (equal and opposite: they only dissipate).

Every params record holds the arrays of k joints of one kind (attachments 2 l + 0 / 1 for the
start / end of line l).
"""

from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY
from .compose import load_kernel
from .elastic import end_frame
from .compiler import CACHED, CACHED_INLINE
from .rotations import cross, quat_mul, quat_rotate, relative_rotation


class SphericalJointParams(NamedTuple):
    attach_a: np.ndarray  # (k,) int64 attachment of end a
    attach_b: np.ndarray  # (k,) int64 attachment of end b
    k: np.ndarray         # (k,) spring stiffness (N/m)
    nu: np.ndarray        # (k,) damping of the relative velocity (N s/m)
    rest: np.ndarray      # (k, 3) rest offset eps0 = x_b - x_a (lab)


class HingeJointParams(NamedTuple):
    attach_a: np.ndarray
    attach_b: np.ndarray
    k: np.ndarray
    nu: np.ndarray
    rest: np.ndarray
    kt: np.ndarray        # (k,) torque stiffness (N m)
    nut: np.ndarray       # (k,) damping of the relative angular velocity (N m s)
    normal: np.ndarray    # (k, 3) unit plane normal n_a in line a's end frame


class FixedJointParams(NamedTuple):
    attach_a: np.ndarray
    attach_b: np.ndarray
    k: np.ndarray
    nu: np.ndarray
    rest: np.ndarray
    kt: np.ndarray
    nut: np.ndarray
    rest_rotation: np.ndarray  # (k, 4) quaternion R0 = E_a^T E_b at rest


@njit(**CACHED_INLINE)
def end_motion(model, state, a):
    """Return position and velocity (lab) of line end a: r + D xi and its rate (1.1)."""
    nd = model.attach_node[a]
    q, o, w = state.node_q[nd], model.attach_offset[a], state.node_w[nd]
    rx, ry, rz = quat_rotate(q[0], q[1], q[2], q[3], o[0], o[1], o[2])
    cx, cy, cz = cross(w[0], w[1], w[2], o[0], o[1], o[2])
    ux, uy, uz = quat_rotate(q[0], q[1], q[2], q[3], cx, cy, cz)
    x, v = state.node_x[nd], state.node_v[nd]
    return x[0] + rx, x[1] + ry, x[2] + rz, v[0] + ux, v[1] + uy, v[2] + uz


@njit(**CACHED_INLINE)
def end_spin(model, state, a):
    """Return the lab angular velocity of line end a (that of its node)."""
    nd = model.attach_node[a]
    q, w = state.node_q[nd], state.node_w[nd]
    return quat_rotate(q[0], q[1], q[2], q[3], w[0], w[1], w[2])


@njit(**CACHED_INLINE)
def spring_stretch(p, j, model, state):
    """Return eps - eps0 (lab) of joint j."""
    xa = end_motion(model, state, p.attach_a[j])
    xb = end_motion(model, state, p.attach_b[j])
    return (xb[0] - xa[0] - p.rest[j, 0], xb[1] - xa[1] - p.rest[j, 1], xb[2] - xa[2] - p.rest[j, 2])


@njit(**CACHED_INLINE)
def add_spring_force(p, j, model, state, loads):
    """Update loads.f at the two end vertices of joint j: f = k (eps - eps0) + nu (v_b - v_a)
    on end a, -f on end b (spherical joint of the seed page, with the damper of its contact)."""
    a, b = p.attach_a[j], p.attach_b[j]
    ma = end_motion(model, state, a)
    mb = end_motion(model, state, b)
    va, vb = model.attach_vertex[a], model.attach_vertex[b]
    for i in range(3):
        f = p.k[j] * (mb[i] - ma[i] - p.rest[j, i]) + p.nu[j] * (mb[3 + i] - ma[3 + i])
        loads.f[va, i] += f
        loads.f[vb, i] -= f


@njit(**CACHED_INLINE)
def add_couple(p, j, model, state, loads, tx, ty, tz):
    """Update loads.node_tau: lab torque t minus nut (w_b - w_a) on end b of joint j, its
    opposite on end a."""
    a, b = p.attach_a[j], p.attach_b[j]
    wa = end_spin(model, state, a)
    wb = end_spin(model, state, b)
    t = (tx, ty, tz)
    na, nb = model.attach_node[a], model.attach_node[b]
    for i in range(3):
        ti = t[i] - p.nut[j] * (wb[i] - wa[i])
        loads.node_tau[nb, i] += ti
        loads.node_tau[na, i] -= ti


@njit(**CACHED_INLINE)
def hinge_offplane(p, j, model, state):
    """Return (s, t_b, n): the out-of-plane tangent component s = t_b . n of joint j."""
    ea = end_frame(model, state, p.attach_a[j])
    eb = end_frame(model, state, p.attach_b[j])
    n = p.normal[j]
    nx, ny, nz = quat_rotate(ea[0], ea[1], ea[2], ea[3], n[0], n[1], n[2])
    tx, ty, tz = quat_rotate(eb[0], eb[1], eb[2], eb[3], 0.0, 0.0, 1.0)
    return tx * nx + ty * ny + tz * nz, tx, ty, tz, nx, ny, nz


@njit(**CACHED_INLINE)
def fixed_deviation(p, j, model, state):
    """Return (theta, E_b): rotation vector (line-b end frame) of R0^T E_a^T E_b, and E_b."""
    ea = end_frame(model, state, p.attach_a[j])
    eb = end_frame(model, state, p.attach_b[j])
    r = p.rest_rotation[j]
    aw, ax, ay, az = quat_mul(ea[0], ea[1], ea[2], ea[3], r[0], r[1], r[2], r[3])
    th = relative_rotation(aw, ax, ay, az, eb[0], eb[1], eb[2], eb[3])
    return th[0], th[1], th[2], eb


@load_kernel(SphericalJointParams)
@njit(**CACHED)
def add_spherical_joints(p, model, state, loads):
    """Update loads.f at the joined end vertices given the end positions and velocities:
    f = k (eps - eps0) + nu (v_b - v_a) (spherical joint, seed page 004)."""
    for j in range(p.k.shape[0]):
        add_spring_force(p, j, model, state, loads)


@load_kernel(HingeJointParams)
@njit(**CACHED)
def add_hinge_joints(p, model, state, loads):
    """Update loads.f at the joined end vertices and loads.node_tau at their nodes given the
    end positions, frames and velocities: the spherical force plus tau = -kt s (t_b x n) on
    end b, -tau on end a (hinge joint, seed page 004, as the gradient of kt s^2 / 2)."""
    for j in range(p.k.shape[0]):
        add_spring_force(p, j, model, state, loads)
        s, tx, ty, tz, nx, ny, nz = hinge_offplane(p, j, model, state)
        cx, cy, cz = cross(tx, ty, tz, nx, ny, nz)
        c = -p.kt[j] * s
        add_couple(p, j, model, state, loads, c * cx, c * cy, c * cz)


@load_kernel(FixedJointParams)
@njit(**CACHED)
def add_fixed_joints(p, model, state, loads):
    """Update loads.f at the joined end vertices and loads.node_tau at their nodes given the
    end positions, frames and velocities: the spherical force plus tau = -kt E_b theta on end
    b, -tau on end a (fixed joint, seed page 004 in PyElastica's rotation-vector form)."""
    for j in range(p.k.shape[0]):
        add_spring_force(p, j, model, state, loads)
        thx, thy, thz, eb = fixed_deviation(p, j, model, state)
        tx, ty, tz = quat_rotate(eb[0], eb[1], eb[2], eb[3], thx, thy, thz)
        c = -p.kt[j]
        add_couple(p, j, model, state, loads, c * tx, c * ty, c * tz)


@njit(**CACHED_INLINE)
def spring_energy(p, j, model, state):
    e = spring_stretch(p, j, model, state)
    return 0.5 * p.k[j] * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2])


@njit(**ENTRY)
def spherical_energy(p, model, state):
    """Return sum k |eps - eps0|^2 / 2 over the joints."""
    total = 0.0
    for j in range(p.k.shape[0]):
        total += spring_energy(p, j, model, state)
    return total


@njit(**ENTRY)
def hinge_energy(p, model, state):
    """Return sum k |eps - eps0|^2 / 2 + kt (t_b . n)^2 / 2 over the joints."""
    total = 0.0
    for j in range(p.k.shape[0]):
        s = hinge_offplane(p, j, model, state)[0]
        total += spring_energy(p, j, model, state) + 0.5 * p.kt[j] * s * s
    return total


@njit(**ENTRY)
def fixed_energy(p, model, state):
    """Return sum k |eps - eps0|^2 / 2 + kt |theta|^2 / 2 over the joints."""
    total = 0.0
    for j in range(p.k.shape[0]):
        thx, thy, thz, _ = fixed_deviation(p, j, model, state)
        total += spring_energy(p, j, model, state) + 0.5 * p.kt[j] * (thx * thx + thy * thy + thz * thz)
    return total
