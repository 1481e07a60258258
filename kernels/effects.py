"""Kernels of the built-in effects: gravity, node loads, line loads, damping.

Each effect is a NamedTuple of its parameters plus one registered kernel. The arrays a kernel
reads and writes are stated in its docstring; nothing else is touched.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import STEP
from .compose import account_kernel, flow_kernel, load_kernel
from .compiler import CACHED
from .rotations import cross, quat_rotate, quat_rotate_inv


class GravityParams(NamedTuple):
    g: np.ndarray  # (3,) acceleration, lab frame


class NodeLoadParams(NamedTuple):
    """Node loads, a row each (one declared NodeLoad, or several joined: cosnet.effects.loads.join_loads)."""
    nodes: np.ndarray    # (k,) int64
    force: np.ndarray    # (k, 3) lab force at the node's reference point
    torque: np.ndarray   # (k, 3) lab torque
    times: np.ndarray    # (m,) the rows' amplitude tables, one after another (abscissae)
    values: np.ndarray   # (m,) their values
    table: np.ndarray    # (k + 1,) int64: row j's table is times[table[j]:table[j + 1]] (empty:
                         # constant amplitude 1)
    omega: np.ndarray    # (k,) harmonic factor sin(omega t + phase) where omega != 0
    phase: np.ndarray    # (k,)
    work: np.ndarray     # (k,) work each row's load has done on the net so far (J)


class LineLoadParams(NamedTuple):
    """Distributed loads, a row each (as NodeLoadParams)."""
    lines: np.ndarray    # (k,) int64
    force: np.ndarray    # (k, 3) force per unit length f, lab frame (1.4)
    torque: np.ndarray   # (k, 3) torque per unit length l, lab frame (1.4)
    times: np.ndarray
    values: np.ndarray
    table: np.ndarray
    omega: np.ndarray
    phase: np.ndarray
    work: np.ndarray


class DampingParams(NamedTuple):
    translational: float  # decay rate nu (1/s): v <- v exp(-nu h)
    rotational: float     # decay rate of angular velocities
    dissipated: np.ndarray       # (1,) kinetic energy taken so far
    node_dissipated: np.ndarray  # (nn, 10) of it at each node: translational sum 1/2 m (1 - c^2) v v^T
                                 # (row-major 3 x 3, a drive holding some components pays those),
                                 # then rotational


@njit(**CACHED, inline="always")
def table_interval(t, times):
    """Return lo with times[lo] <= t < times[lo + 1], given times[0] < t < times[-1]
    (increasing times; bisection)."""
    lo, hi = 0, times.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@njit(**CACHED, inline="always")
def interp_table(t, times, values):
    """Return the piecewise-linear interpolation of (times, values) at t, held constant
    outside the table (as np.interp, which needs an allocation numba's step kernels avoid)."""
    n = times.shape[0]
    if t <= times[0]:
        return values[0]
    if t >= times[n - 1]:
        return values[n - 1]
    lo = table_interval(t, times)
    hi = lo + 1
    w = (t - times[lo]) / (times[hi] - times[lo])
    return values[lo] + w * (values[hi] - values[lo])


@njit(**CACHED, inline="always")
def row_amplitude(p, j, t):
    """Return the time factor of row j of a load record: its table interpolated at t, times
    sin(omega t + phase)."""
    a = 1.0
    lo, hi = p.table[j], p.table[j + 1]
    if hi > lo:
        a = interp_table(t, p.times[lo:hi], p.values[lo:hi])
    if p.omega[j] != 0.0:
        a *= math.sin(p.omega[j] * t + p.phase[j])
    return a


@load_kernel(GravityParams)
@njit(**STEP)
def add_gravity(p, model, state, loads):
    """Update loads.f (nv,3), loads.node_f, loads.node_tau given vertex and node masses:
    f = mu g along the lines and F = M g on the nodes (1.4)-(1.5)."""
    g = p.g
    for i in range(loads.f.shape[0]):
        m = model.vertex_mass[i]
        loads.f[i, 0] += m * g[0]
        loads.f[i, 1] += m * g[1]
        loads.f[i, 2] += m * g[2]
    for nd in range(model.node_mass.shape[0]):
        m = model.node_own_mass[nd]
        if m == 0.0:
            continue
        add_node_force(model, state, loads, nd, m * g[0], m * g[1], m * g[2])


@njit(**CACHED, inline="always")
def add_wrench(loads, nd, rx, ry, rz, fx, fy, fz):
    """Update loads.node_f, loads.node_tau of node nd with force f acting at the lab arm r from
    its centre of mass (torque r x f, (4.5))."""
    tx, ty, tz = cross(rx, ry, rz, fx, fy, fz)
    loads.node_f[nd, 0] += fx
    loads.node_f[nd, 1] += fy
    loads.node_f[nd, 2] += fz
    loads.node_tau[nd, 0] += tx
    loads.node_tau[nd, 1] += ty
    loads.node_tau[nd, 2] += tz


@njit(**CACHED, inline="always")
def add_node_force(model, state, loads, nd, fx, fy, fz):
    """Update loads.node_f, loads.node_tau with a force applied at node nd's reference point
    (its torque about the composite centre of mass included, (4.5))."""
    q = state.node_q[nd]
    c = model.node_com_offset[nd]
    rx, ry, rz = quat_rotate(q[0], q[1], q[2], q[3], -c[0], -c[1], -c[2])
    add_wrench(loads, nd, rx, ry, rz, fx, fy, fz)


@load_kernel(NodeLoadParams)
@njit(**STEP)
def add_node_loads(p, model, state, loads):
    """Update loads.node_f, loads.node_tau given the node loads F(t, nu), L(t, nu) (1.5)/(1.7),
    row by row."""
    t = state.clock[0]
    for j in range(p.nodes.shape[0]):
        a = row_amplitude(p, j, t)
        nd = p.nodes[j]
        add_node_force(model, state, loads, nd, a * p.force[j, 0], a * p.force[j, 1], a * p.force[j, 2])
        for k in range(3):
            loads.node_tau[nd, k] += a * p.torque[j, k]


@load_kernel(LineLoadParams)
@njit(**STEP)
def add_line_loads(p, model, state, loads):
    """Update loads.f (nv,3), loads.tau (ne,3) given distributed loads f, l per unit length
    on the listed lines (1.4): vertices take f times their Voronoi length, elements l times
    their length (in their body frame)."""
    t = state.clock[0]
    for j in range(p.lines.shape[0]):
        a = row_amplitude(p, j, t)
        l = p.lines[j]
        for vt in range(model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]):
            s = a * model.voronoi_rest_length[vt]
            for k in range(3):
                loads.f[vt, k] += s * p.force[j, k]
        for e in range(model.line_element_offsets[l], model.line_element_offsets[l + 1]):
            s = a * model.element_rest_length[e]
            q = state.q[e]
            bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], s * p.torque[j, 0],
                                         s * p.torque[j, 1], s * p.torque[j, 2])
            loads.tau[e, 0] += bx
            loads.tau[e, 1] += by
            loads.tau[e, 2] += bz


@njit(**CACHED, inline="always")
def offset_velocity(state, nd, ox, oy, oz):
    """Return (v, w): the lab velocity of node nd's material point at body offset o from its
    centre of mass, v_com + w x R o, and the node's lab angular velocity w (1.1)."""
    q = state.node_q[nd]
    wx, wy, wz = quat_rotate(q[0], q[1], q[2], q[3], state.node_w[nd, 0], state.node_w[nd, 1], state.node_w[nd, 2])
    rx, ry, rz = quat_rotate(q[0], q[1], q[2], q[3], ox, oy, oz)
    ux, uy, uz = cross(wx, wy, wz, rx, ry, rz)
    v = state.node_v[nd]
    return (v[0] + ux, v[1] + uy, v[2] + uz), (wx, wy, wz)


@account_kernel(NodeLoadParams)
@njit(**STEP)
def account_node_load_work(p, model, state, hh):
    """Update p.work by hh times each row's power at the current velocities: F . v at the
    node's reference point (v_com + w x r, r = ref - com) plus L . w (lab): taken on both
    sides of a kick of 2 hh, the work the kick's share of the load gives the kinetic energy."""
    t = state.clock[0]
    nn = model.node_mass.shape[0]
    for j in range(p.nodes.shape[0]):
        nd = p.nodes[j]
        if nd < 0 or nd >= nn:
            continue
        a = row_amplitude(p, j, t)
        c = model.node_com_offset[nd]
        v, w = offset_velocity(state, nd, -c[0], -c[1], -c[2])
        f, m = p.force[j], p.torque[j]
        power = (f[0] * v[0] + f[1] * v[1] + f[2] * v[2] + m[0] * w[0] + m[1] * w[1] + m[2] * w[2])
        p.work[j] += hh * a * power


@account_kernel(LineLoadParams)
@njit(**STEP)
def account_line_load_work(p, model, state, hh):
    """Update p.work by hh times each row's power at the current velocities: f l_k . v_k over
    the line's vertices and the torque per length's l . R w over its elements (1.4), as the
    node loads' account. An end vertex moves with its node (r = com + R xi, (1.1)): its
    velocity is the node's there, which a kick changes before the end is placed again."""
    t = state.clock[0]
    nl = model.line_vertex_offsets.shape[0] - 1
    for j in range(p.lines.shape[0]):
        l = p.lines[j]
        if l < 0 or l >= nl:
            continue
        a = row_amplitude(p, j, t)
        f, m = p.force[j], p.torque[j]
        power = 0.0
        for vt in range(model.line_vertex_offsets[l] + 1, model.line_vertex_offsets[l + 1] - 1):
            v = state.v[vt]
            power += model.voronoi_rest_length[vt] * (f[0] * v[0] + f[1] * v[1] + f[2] * v[2])
        for end in range(2):
            at = 2 * l + end
            o = model.attach_offset[at]
            v, _ = offset_velocity(state, model.attach_node[at], o[0], o[1], o[2])
            power += model.voronoi_rest_length[model.attach_vertex[at]] * (f[0] * v[0] + f[1] * v[1] + f[2] * v[2])
        if m[0] != 0.0 or m[1] != 0.0 or m[2] != 0.0:    # most line loads are forces alone
            for e in range(model.line_element_offsets[l], model.line_element_offsets[l + 1]):
                q = state.q[e]
                wx, wy, wz = quat_rotate(q[0], q[1], q[2], q[3], state.w[e, 0], state.w[e, 1], state.w[e, 2])
                power += model.element_rest_length[e] * (m[0] * wx + m[1] * wy + m[2] * wz)
        p.work[j] += hh * a * power


@flow_kernel(DampingParams)
@njit(**STEP)
def damp_velocities(p, model, state, h):
    """Update state.v, state.w, state.node_v, state.node_w by the exact flow of linear,
    mass-proportional viscous damping over time h (unconditionally stable), and p.dissipated,
    p.node_dissipated by the kinetic energy it takes (of what measure.energies counts)."""
    ct = math.exp(-p.translational * h)
    cr = math.exp(-p.rotational * h)
    lt, lr = 0.5 * (1.0 - ct * ct), 0.5 * (1.0 - cr * cr)
    v, w = state.v, state.w
    taken = 0.0
    for i in range(v.shape[0]):
        if model.vertex_inv_mass[i] > 0.0:  # line ends move with their nodes, counted there
            taken += lt * model.vertex_mass[i] * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
        v[i, 0] *= ct
        v[i, 1] *= ct
        v[i, 2] *= ct
    for e in range(w.shape[0]):
        inert = model.element_inertia[e]
        taken += lr * (inert[0] * w[e, 0] * w[e, 0] + inert[1] * w[e, 1] * w[e, 1] + inert[2] * w[e, 2] * w[e, 2])
        w[e, 0] *= cr
        w[e, 1] *= cr
        w[e, 2] *= cr
    nodes = p.node_dissipated
    for nd in range(min(state.node_v.shape[0], nodes.shape[0])):
        vn = state.node_v[nd]
        if model.node_inv_mass[nd] > 0.0:  # an infinitely heavy node keeps its velocity
            f = lt * model.node_mass[nd]
            for j in range(3):
                for k in range(3):
                    nodes[nd, 3 * j + k] += f * vn[j] * vn[k]
            taken += f * (vn[0] * vn[0] + vn[1] * vn[1] + vn[2] * vn[2])
            for k in range(3):
                vn[k] *= ct
        rot = 0.0
        for k in range(3):
            if model.node_locked[nd, k] == 0.0:
                rot += lr * model.node_inertia[nd, k] * state.node_w[nd, k] * state.node_w[nd, k]
            state.node_w[nd, k] *= cr
        nodes[nd, 9] += rot
        taken += rot
    p.dissipated[0] += taken
