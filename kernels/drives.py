"""Kernels of driven nodes: a node whose position, rotation or both follow a prescription.

A prescription is a path f(t) (k components): rate * t + amplitude sin(omega t + phase) plus a
clamped cubic spline through a table (piecewise polynomials, zero slope at both ends, held
beyond them), minus its value at the start so that the motion starts where the node was built.
Position paths have k = 3 (a displacement, lab frame); rotation paths k = 1 (an angle about a
fixed lab axis), or k = 3 for an orientation (a rotation vector r(t), lab frame: the node turns
by exp(r(t)) exp(r(t0))^-1, smooth on SO(3) wherever r is, its angular velocity and
acceleration analytic, rotations.exp_rates).

The node is kinematic: after every drift its prescribed components are set from the path at
the stage's end time (exact, not integrated), after every kick their velocities are restored.
What the kick would have done tells the reaction: the force and torque the driver supplies so
that the node follows its path given the loads on it, R = m a - F, T = dL/dt - L.
"""

import math
import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY, STEP
from .compose import constraint_kernels
from .effects import table_interval
from .motion import place_line_end
from .compiler import CACHED, CACHED_INNER
from .rotations import cross, exp_rates, quat_exp, quat_mul, quat_rotate, quat_rotate_inv
from .specialise import Variants

# what a drive holds of a node's position and rotation (ORIENTED: a rotation on SO(3))
FREE, PRESCRIBED, ACROSS_AXIS, ORIENTED = 0, 1, 2, 3

# A compile-time option (kernels/specialise.py): a drive's record is of the variant its data
# needs (VARIANTS), whose kernels leave out the turning where its rotation is free. This
# module's own functions, and its record DriveParams, are the variant that turns.
TURNS = True    # the rotation is prescribed: an angle about an axis or a rotation vector
OPTIONS = ("TURNS",)


class DriveParams(NamedTuple):
    node: int
    position: int          # FREE, PRESCRIBED, or ACROSS_AXIS (sliding along the axis is free)
    rotation: int          # FREE, PRESCRIBED (an angle about the axis) or ORIENTED (a rotation vector)
    axis: np.ndarray       # (3,) unit lab axis
    ref0: np.ndarray       # (3,) centre of mass as built (lab)
    rho0: np.ndarray       # (3,) centre of mass minus the reference point as built, lab (0 unless turned)
    q0: np.ndarray         # (4,) node frame quaternion as built
    pos_rate: np.ndarray   # (3,) displacement path: velocity term
    pos_amp: np.ndarray    # (3,) harmonic amplitude
    pos_wave: np.ndarray   # (2,) omega, phase
    pos_times: np.ndarray  # (m,) spline knots (m = 0: no table)
    pos_coef: np.ndarray   # (max(m-1, 0), 4, 3) spline coefficients of (t - t_i)^(3 - j)
    pos_start: np.ndarray  # (3,) path value at the start time (subtracted)
    ang_rate: np.ndarray   # (1,) angle path, same layout with k = 1
    ang_amp: np.ndarray
    ang_wave: np.ndarray
    ang_times: np.ndarray
    ang_coef: np.ndarray
    ang_start: np.ndarray
    rv_rate: np.ndarray    # (3,) orientation path (a lab rotation vector), same layout with k = 3
    rv_amp: np.ndarray
    rv_wave: np.ndarray
    rv_times: np.ndarray
    rv_coef: np.ndarray
    rv_zero: np.ndarray    # (3,) zeros: nothing is subtracted from r(t), rv_back takes its place
    rv_back: np.ndarray    # (4,) exp(r(t0))^-1: the orientation starts where the node was built
    kin: np.ndarray        # (24,) scratch: x, v, a of the centre of mass, lab angular velocity
                           # and acceleration, then the rotation path's value and derivatives
    reaction: np.ndarray   # (6,) force, torque (about the centre of mass, lab) at the last kick
    work: np.ndarray       # (1,) work done by the driver so far


@njit(**CACHED)
def eval_path(t, rate, amp, wave, times, coef, start, out, o):
    """Update out[o:o+k], out[o+k:o+2k], out[o+2k:o+3k] with the path's value (minus start),
    first and second derivatives at time t (k = rate.shape[0]). o: an np.int64 (a literal
    offset would compile this once more for each value)."""
    k = rate.shape[0]
    omega, phase = wave[0], wave[1]
    s, c = math.sin(omega * t + phase), math.cos(omega * t + phase)
    m = times.shape[0]
    i, u = -1, 0.0
    if m > 1:
        if t <= times[0]:
            i, u = 0, 0.0
        elif t >= times[m - 1]:
            i, u = m - 2, times[m - 1] - times[m - 2]
        else:
            i = table_interval(t, times)
            u = t - times[i]
    inside = m > 1 and times[0] < t < times[m - 1]
    for j in range(k):
        f = rate[j] * t + amp[j] * s - start[j]
        df = rate[j] + amp[j] * omega * c
        ddf = -amp[j] * omega * omega * s
        if i >= 0:
            a, b, cc, d = coef[i, 0, j], coef[i, 1, j], coef[i, 2, j], coef[i, 3, j]
            f += ((a * u + b) * u + cc) * u + d
            if inside:  # beyond the table the clamped ends are held at rest
                df += (3.0 * a * u + 2.0 * b) * u + cc
                ddf += 6.0 * a * u + 2.0 * b
        out[o + j] = f
        out[o + k + j] = df
        out[o + 2 * k + j] = ddf


@njit(**CACHED_INNER)
def prescribe_turn(p, t):
    """Update p.kin[9:15] with the prescribed lab angular velocity and acceleration at time t
    (zero for a free rotation); return the prescribed turn from the node as built (a quaternion)."""
    kin = p.kin
    if TURNS and p.rotation == PRESCRIBED:
        eval_path(t, p.ang_rate, p.ang_amp, p.ang_wave, p.ang_times, p.ang_coef, p.ang_start, kin, np.int64(15))
        th, dth, ddth = kin[15], kin[16], kin[17]
        for k in range(3):
            kin[9 + k] = dth * p.axis[k]
            kin[12 + k] = ddth * p.axis[k]
        c, s = math.cos(0.5 * th), math.sin(0.5 * th)
        return c, s * p.axis[0], s * p.axis[1], s * p.axis[2]
    if TURNS and p.rotation == ORIENTED:
        eval_path(t, p.rv_rate, p.rv_amp, p.rv_wave, p.rv_times, p.rv_coef, p.rv_zero, kin, np.int64(15))
        w, a = exp_rates(kin[15], kin[16], kin[17], kin[18], kin[19], kin[20], kin[21], kin[22], kin[23])
        for k in range(3):
            kin[9 + k] = w[k]
            kin[12 + k] = a[k]
        ew, ex, ey, ez = quat_exp(kin[15], kin[16], kin[17])
        b = p.rv_back
        return quat_mul(ew, ex, ey, ez, b[0], b[1], b[2], b[3])
    for k in range(9, 15):
        kin[k] = 0.0
    return 1.0, 0.0, 0.0, 0.0


@njit(**CACHED_INNER)
def drive_kinematics(p, t):
    """Update p.kin given time t: the prescribed centre of mass x, v, a and the angular
    velocity and acceleration (lab); return the prescribed node quaternion."""
    kin = p.kin
    eval_path(t, p.pos_rate, p.pos_amp, p.pos_wave, p.pos_times, p.pos_coef, p.pos_start, kin, np.int64(0))
    tw, tx, ty, tz = prescribe_turn(p, t)
    q0 = p.q0
    if TURNS and p.rotation != FREE:
        rx, ry, rz = quat_rotate(tw, tx, ty, tz, p.rho0[0], p.rho0[1], p.rho0[2])
        # the centre of mass turns about the reference point: v += w x rho, a += alpha x rho + w x (w x rho)
        wx, wy, wz = kin[9], kin[10], kin[11]
        vx, vy, vz = cross(wx, wy, wz, rx, ry, rz)
        ax, ay, az = cross(kin[12], kin[13], kin[14], rx, ry, rz)
        cx, cy, cz = cross(wx, wy, wz, vx, vy, vz)
        r = (rx - p.rho0[0], ry - p.rho0[1], rz - p.rho0[2])
        v = (vx, vy, vz)
        acc = (ax + cx, ay + cy, az + cz)
        for k in range(3):
            kin[k] += r[k]
            kin[3 + k] += v[k]
            kin[6 + k] += acc[k]
    for k in range(3):
        kin[k] += p.ref0[k]
    if not TURNS:
        return q0[0], q0[1], q0[2], q0[3]
    return quat_mul(tw, tx, ty, tz, q0[0], q0[1], q0[2], q0[3])


@njit(**CACHED_INNER)
def set_drive_velocity(p, model, state):
    """Update the node's prescribed velocities (state.node_v, state.node_w) given p.kin."""
    nd, kin, a = p.node, p.kin, p.axis
    if p.position == PRESCRIBED:
        for k in range(3):
            state.node_v[nd, k] = kin[3 + k]
    elif p.position == ACROSS_AXIS:
        va = state.node_v[nd, 0] * a[0] + state.node_v[nd, 1] * a[1] + state.node_v[nd, 2] * a[2]
        pa = kin[3] * a[0] + kin[4] * a[1] + kin[5] * a[2]
        for k in range(3):
            state.node_v[nd, k] = kin[3 + k] + (va - pa) * a[k]
    if TURNS and p.rotation != FREE:
        q = state.node_q[nd]
        bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], kin[9], kin[10], kin[11])
        state.node_w[nd, 0], state.node_w[nd, 1], state.node_w[nd, 2] = bx, by, bz


@njit(**CACHED_INNER)
def pose_drive(p, model, state):
    """Update the node's prescribed pose and velocities (state.node_x, node_q, node_v, node_w)
    at time state.clock[0], then place its line ends (1.1)/(1.3)."""
    nd, a = p.node, p.axis
    qw, qx, qy, qz = drive_kinematics(p, state.clock[0])
    kin = p.kin
    if p.position == PRESCRIBED:
        for k in range(3):
            state.node_x[nd, k] = kin[k]
    elif p.position == ACROSS_AXIS:
        xa = state.node_x[nd, 0] * a[0] + state.node_x[nd, 1] * a[1] + state.node_x[nd, 2] * a[2]
        pa = kin[0] * a[0] + kin[1] * a[1] + kin[2] * a[2]
        for k in range(3):
            state.node_x[nd, k] = kin[k] + (xa - pa) * a[k]
    if TURNS and p.rotation != FREE:
        state.node_q[nd, 0], state.node_q[nd, 1], state.node_q[nd, 2], state.node_q[nd, 3] = qw, qx, qy, qz
    set_drive_velocity(p, model, state)
    for j in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        place_line_end(model.node_attach_list[j], model, state)


@njit(**CACHED_INNER)
def drive_reaction(p, model, state, loads):
    """Update p.reaction given p.kin (at the state's time) and the node's loads
    loads.node_f, loads.node_tau: the force m a - F on the prescribed components and the
    torque dL/dt - L (lab, about the centre of mass) when the rotation is prescribed."""
    nd, kin, a = p.node, p.kin, p.axis
    m = model.node_mass[nd]
    f = loads.node_f[nd]
    r = p.reaction
    for k in range(3):
        r[k] = m * kin[6 + k] - f[k] if p.position != FREE else 0.0
    if p.position == ACROSS_AXIS:  # no force along the axis: the node slides freely there
        ra = r[0] * a[0] + r[1] * a[1] + r[2] * a[2]
        for k in range(3):
            r[k] -= ra * a[k]
    for k in range(3):
        r[3 + k] = 0.0
    if TURNS and p.rotation != FREE:
        q = state.node_q[nd]
        inert = model.node_inertia[nd]
        # body angular acceleration: d/dt (R^T w_lab) = R^T alpha_lab (the w x w term vanishes)
        wx, wy, wz = quat_rotate_inv(q[0], q[1], q[2], q[3], kin[9], kin[10], kin[11])
        ex, ey, ez = quat_rotate_inv(q[0], q[1], q[2], q[3], kin[12], kin[13], kin[14])
        gx, gy, gz = cross(wx, wy, wz, inert[0] * wx, inert[1] * wy, inert[2] * wz)
        lx, ly, lz = quat_rotate(q[0], q[1], q[2], q[3], inert[0] * ex + gx, inert[1] * ey + gy, inert[2] * ez + gz)
        t = loads.node_tau[nd]
        r[3], r[4], r[5] = lx - t[0], ly - t[1], lz - t[2]


@njit(**STEP)
def drive_after_drift(p, model, state, h):
    """Update the driven node's pose and velocities at the drift's end time (pose_drive)."""
    pose_drive(p, model, state)


@njit(**STEP)
def drive_after_kick(p, model, state, arg):
    """Update p.reaction and p.work (by h times the driver's power, R.v + T.w, at the kick's
    time: the kick's own quadrature) and restore the node's prescribed velocities, given
    arg = (loads, h)."""
    loads, h = arg
    drive_kinematics(p, state.clock[0])
    drive_reaction(p, model, state, loads)
    set_drive_velocity(p, model, state)
    nd, r = p.node, p.reaction
    v, w = state.node_v[nd], p.kin
    p.work[0] += h * (r[0] * v[0] + r[1] * v[1] + r[2] * v[2] + r[3] * w[9] + r[4] * w[10] + r[5] * w[11])


constraint_kernels(DriveParams, drive_after_drift, drive_after_kick)


@njit(**ENTRY)
def place_drive(p, model, state):
    """Update the driven node's pose and velocities at the state's time (from Python)."""
    pose_drive(p, model, state)


@njit(**ENTRY)
def reaction_now(p, model, state, loads):
    """Update p.reaction given the current state and its evaluated loads (from Python)."""
    drive_kinematics(p, state.clock[0])
    drive_reaction(p, model, state, loads)


def _register(cls, kernels):
    constraint_kernels(cls, kernels["drive_after_drift"], kernels["drive_after_kick"])


VARIANTS = Variants(DriveParams, lambda: (sys.modules[__name__],), OPTIONS, _register, __name__)


def drive_record(p):
    """``p`` (a DriveParams) as the record of the variant its data needs, sharing its arrays."""
    return VARIANTS.record(p, (p.rotation != FREE,))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it
