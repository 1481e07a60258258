"""Diagnostics: energy, momenta and per-vertex fields (called between steps, never inside)."""

from numba import njit

from .backend import ENTRY
from .elastic import bend_moment, end_frame, line_strain_energy
from .rotations import cross, quat_exp, quat_mul, quat_rotate, quat_rotate_inv, relative_rotation


@njit(**ENTRY)
def measure_energy(model, state):
    """Return (translational kinetic, rotational kinetic, strain) energy of lines and nodes
    (the kinetic terms of (3.7)/(4.6) and the potential (3.25))."""
    kt, kr, u = 0.0, 0.0, 0.0
    for i in range(state.x.shape[0]):
        if model.vertex_inv_mass[i] > 0.0:
            v = state.v[i]
            kt += 0.5 * model.vertex_mass[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    for e in range(state.q.shape[0]):
        for k in range(3):
            kr += 0.5 * model.element_inertia[e, k] * state.w[e, k] ** 2
    for nd in range(state.node_x.shape[0]):
        if model.node_inv_mass[nd] > 0.0:
            v = state.node_v[nd]
            kt += 0.5 * model.node_mass[nd] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        for k in range(3):
            if model.node_locked[nd, k] == 0.0:
                kr += 0.5 * model.node_inertia[nd, k] * state.node_w[nd, k] ** 2
    for l in range(model.line_vertex_offsets.shape[0] - 1):
        u += line_strain_energy(l, model, state)
    return kt, kr, u


@njit(**ENTRY)
def measure_momenta(model, state, out):
    """Update out (2, 3) with the linear momentum and the angular momentum about the origin of
    all moving masses (vertices, elements, nodes of finite mass/inertia)."""
    out[:] = 0.0
    for i in range(state.x.shape[0]):
        if model.vertex_inv_mass[i] > 0.0:
            m = model.vertex_mass[i]
            add_momentum(out, m, state.x[i], state.v[i])
    for e in range(state.q.shape[0]):
        q, J, w = state.q[e], model.element_inertia[e], state.w[e]
        lx, ly, lz = quat_rotate(q[0], q[1], q[2], q[3], J[0] * w[0], J[1] * w[1], J[2] * w[2])
        out[1, 0] += lx
        out[1, 1] += ly
        out[1, 2] += lz
    for nd in range(state.node_x.shape[0]):
        if model.node_inv_mass[nd] > 0.0:
            add_momentum(out, model.node_mass[nd], state.node_x[nd], state.node_v[nd])
        q, J, w, locked = state.node_q[nd], model.node_inertia[nd], state.node_w[nd], model.node_locked[nd]
        lx, ly, lz = quat_rotate(q[0], q[1], q[2], q[3], 0.0 if locked[0] else J[0] * w[0],
                                 0.0 if locked[1] else J[1] * w[1], 0.0 if locked[2] else J[2] * w[2])
        out[1, 0] += lx
        out[1, 1] += ly
        out[1, 2] += lz


@njit(cache=True, inline="always")
def add_momentum(out, m, x, v):
    """Update out (2, 3) with m v and x x m v."""
    cx, cy, cz = cross(x[0], x[1], x[2], m * v[0], m * v[1], m * v[2])
    out[0, 0] += m * v[0]
    out[0, 1] += m * v[1]
    out[0, 2] += m * v[2]
    out[1, 0] += cx
    out[1, 1] += cy
    out[1, 2] += cz


@njit(**ENTRY)
def line_fields(l, model, state, frames, force, torque, strain, curvature):
    """Update per-vertex fields of line l (each (n+1, ...)): frames (n+1, 4) director
    quaternions (the mid-rotation between neighbouring frames), force n and torque m in the lab
    (3.22), strain v - d3 and curvature u - u0 in the director frame."""
    x, q = state.x, state.q
    v0 = model.line_vertex_offsets[l]
    e0 = model.line_element_offsets[l]
    n = model.line_element_offsets[l + 1] - e0
    pw, px, py, pz = end_frame(model, state, 2 * l)
    force[:] = 0.0
    strain[:] = 0.0
    for i in range(n + 1):
        if i < n:
            e = e0 + i
            qw, qx, qy, qz = q[e, 0], q[e, 1], q[e, 2], q[e, 3]
            inv_l = 1.0 / model.element_rest_length[e]
            sx, sy, sz = quat_rotate_inv(qw, qx, qy, qz, x[v0 + i + 1, 0] - x[v0 + i, 0],
                                         x[v0 + i + 1, 1] - x[v0 + i, 1], x[v0 + i + 1, 2] - x[v0 + i, 2])
            k = model.element_stiffness[e]
            ex, ey, ez = sx * inv_l, sy * inv_l, sz * inv_l - 1.0
            nx, ny, nz = quat_rotate(qw, qx, qy, qz, k[0] * ex, k[1] * ey, k[2] * ez)
            for j, val in ((i, 0.5), (i + 1, 0.5)):
                force[j, 0] += val * nx
                force[j, 1] += val * ny
                force[j, 2] += val * nz
                strain[j, 0] += val * ex
                strain[j, 1] += val * ey
                strain[j, 2] += val * ez
        else:
            qw, qx, qy, qz = end_frame(model, state, 2 * l + 1)
        tx, ty, tz, c = relative_rotation(pw, px, py, pz, qw, qx, qy, qz)
        mx, my, mz = bend_moment(model, v0 + i, tx, ty, tz)
        inv_lv = 1.0 / model.voronoi_rest_length[v0 + i]
        u0 = model.voronoi_rest_curvature[v0 + i]
        curvature[i, 0] = tx * inv_lv - u0[0]
        curvature[i, 1] = ty * inv_lv - u0[1]
        curvature[i, 2] = tz * inv_lv - u0[2]
        # the frame at the vertex: the node's line-end frame D X at the ends (1.3), else the
        # mid frame A exp(theta / 2) of the Voronoi point
        if i == 0:
            fw, fx, fy, fz = pw, px, py, pz
        elif i == n:
            fw, fx, fy, fz = qw, qx, qy, qz
        else:
            hw, hx, hy, hz = quat_exp(0.5 * tx, 0.5 * ty, 0.5 * tz)
            fw, fx, fy, fz = quat_mul(pw, px, py, pz, hw, hx, hy, hz)
        frames[i, 0], frames[i, 1], frames[i, 2], frames[i, 3] = fw, fx, fy, fz
        torque[i, 0], torque[i, 1], torque[i, 2] = quat_rotate(fw, fx, fy, fz, mx, my, mz)
        pw, px, py, pz = qw, qx, qy, qz
    # the end vertices carry a whole end element's force and strain, not half of it
    for j in (0, n):
        for k in range(3):
            force[j, k] *= 2.0
            strain[j, k] *= 2.0


@njit(**ENTRY)
def measure_worst_strain(model, state):
    """Return (max |v - d3| over elements, its element index): stretch and shear (3.22)."""
    x, q = state.x, state.q
    worst, where = 0.0, 0
    for l in range(model.line_vertex_offsets.shape[0] - 1):
        v0 = model.line_vertex_offsets[l]
        e0 = model.line_element_offsets[l]
        for i in range(model.line_element_offsets[l + 1] - e0):
            e = e0 + i
            inv_l = model.element_inv_rest_length[e]
            sx, sy, sz = quat_rotate_inv(q[e, 0], q[e, 1], q[e, 2], q[e, 3], x[v0 + i + 1, 0] - x[v0 + i, 0],
                                         x[v0 + i + 1, 1] - x[v0 + i, 1], x[v0 + i + 1, 2] - x[v0 + i, 2])
            s = abs(sx * inv_l) + abs(sy * inv_l) + abs(sz * inv_l - 1.0)
            if not s <= worst:  # also catches NaN
                worst, where = s, e
    return worst, where
