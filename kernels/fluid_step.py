"""Kernels of the fluid's step: what the medium does to the free nodes and buoys, and the kick's sequence.

kernels/fluid.py holds the fluid's record, the medium and the passes over the lines' vertices;
here: the free nodes at the lines' ends and the buoys (their added mass, the forces of position
and time, drag by one linearly implicit step), the entrained fluid's kinetic energy, and
flow_fluid, which runs the nodes' drag and the moving medium's impulses in halves on both sides of every kick
(the lines' interior vertices take their drag inside the kick: fluid.kick_drag_vertices)."""

import math

import numpy as np
from numba import njit, prange

from .backend import ENTRY, NODE_BLOCK, STEP
from .compiler import CACHED, INNER
from .compose import flow_kernel
from .fluid import (ARMS, CARRIES, LINE_BLOCK, MOVING, NODES, THREADS, FluidParams, add_split, buoy_of, calm_now,
                    carrying_span, end_arm, ends_entrained, entrained_line, has_added_mass, linear_law, node_free,
                    push_vertices, sample_buoys, sample_lines, sample_medium, sample_rows, sampled, set_wave_phases,
                    split, still_medium, vertex_force, vertex_upthrust)
from .layout import columns, uint
from .rotations import cross, quat_rotate, quat_rotate_inv, solve_sym3


@njit(**INNER)
def node_end(p, model, state, a):
    """Return (row, wet, r, tan, lv, U, A) of line end a of a node the medium moves
    (node_free): the row of its line (-1: not in the medium), whether it is wet, its lab offset
    r from the node's centre of mass, its tangent, Voronoi length, and the medium's velocity
    and acceleration there."""
    l = a // 2
    j = p.line_row[l] if l < p.line_row.shape[0] else -1
    vt = model.attach_vertex[a]
    r = end_arm(model, state, a) if ARMS else (0.0, 0.0, 0.0)   # (ARMS: some free node's ends have them)
    wet, um, acc, tan = sampled(p, vt)
    return j, wet and j >= 0, r, tan, model.voronoi_rest_length[vt], um, acc


@njit(**INNER)
def node_mass_matrix(p, model, state, nd):
    """Return the symmetric node mass matrix (a00, a01, a02, a11, a12, a22): its composite
    mass plus the added mass of its wet line ends."""
    m = model.node_mass[nd]
    a = (m, 0.0, 0.0, m, 0.0, m)
    for s in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        j, wet, _, tan, lv, _, _ = node_end(p, model, state, model.node_attach_list[s])
        if wet:
            a = add_split(a, lv * p.added_n[j], lv * (p.added_t[j] - p.added_n[j]), tan)
    b = buoy_of(p, nd) if CARRIES else -1
    if CARRIES and b >= 0:   # the buoy's own added mass, the same in every direction
        a = add_split(a, p.buoy_added[b] * p.buoy_sample[b, 0], 0.0, (0.0, 0.0, 1.0))
    return a


@njit(**INNER)
def sample_node_masses(p, model, state, n0, n1):
    """Update p.node_mass at the free nodes among n0..n1-1 given the sample: each node's mass
    matrix with the added mass (node_mass_matrix), once a kick for the flows and the kick that
    divide by it (a loop over its line ends each: a node's share of the step where lines are
    short)."""
    for nd in range(n0, n1):
        if node_free(p, model, nd):
            a = node_mass_matrix(p, model, state, nd)
            for k in range(6):
                p.node_mass[nd, k] = a[k]


@njit(**INNER)
def held_mass(p, model, nd, added):
    """Return free node nd's mass matrix as the kick holds it: p.node_mass's where the medium
    adds mass (``added``), else its own mass."""
    if added:
        a = p.node_mass[nd]
        return a[0], a[1], a[2], a[3], a[4], a[5]
    m = model.node_mass[nd]
    return m, 0.0, 0.0, m, 0.0, m


@njit(**INNER)
def lifts_nodes(p):
    """Whether the upthrust reaches the nodes: on a line's ends or on a buoy."""
    if p.buoy_node.shape[0] > 0:
        return True
    for j in range(p.buoyancy.shape[0]):
        if p.buoyancy[j] != 0.0:
            return True
    return False


@njit(**INNER)
def turn_node(model, state, nd, tx, ty, tz):
    """Update node nd's body angular velocity by the lab angular impulse (tx, ty, tz) on its
    free axes; return the rotational kinetic energy it added."""
    if tx == 0.0 and ty == 0.0 and tz == 0.0:   # (a point junction's line ends: no arm, no moment)
        return 0.0
    q = state.node_q[nd]
    b = quat_rotate_inv(q[0], q[1], q[2], q[3], tx, ty, tz)
    de = 0.0
    for k in range(3):
        if model.node_locked[nd, k] == 0.0:
            w0 = state.node_w[nd, k]
            state.node_w[nd, k] = w0 + model.node_inv_inertia[nd, k] * b[k]
            de += 0.5 * model.node_inertia[nd, k] * (state.node_w[nd, k] ** 2 - w0 * w0)
    return de


@njit(**CACHED, inline="always")
def node_spin(state, nd):
    """Return node nd's angular velocity in the lab frame."""
    q, w = state.node_q[nd], state.node_w[nd]
    return quat_rotate(q[0], q[1], q[2], q[3], w[0], w[1], w[2])


@njit(**INNER)
def arm_spin(state, nd, r):
    """Return w x r: the velocity, relative to node nd's centre of mass, of the point at the lab
    arm r (w the node's angular velocity)."""
    w = node_spin(state, nd)
    return cross(w[0], w[1], w[2], r[0], r[1], r[2])


@njit(**INNER)
def node_forces(p, model, state, nd):
    """Return (force, the medium's inertia force's share of it, torque about the centre of
    mass), each lab, of the forces of position and time on free node nd: the upthrust and the
    inertia force on its wet line ends, and its buoy's at its centre of mass."""
    fx = fy = fz = ix = iy = iz = tx = ty = tz = 0.0
    for s in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        a = model.node_attach_list[s]
        j, wet, r, tan, _, _, acc = node_end(p, model, state, a)
        if j < 0:
            continue
        l = a // 2
        lo, hi = model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]
        fb, fi = vertex_force(p, model, state, j, l, model.attach_vertex[a], lo, hi, tan, wet, acc)
        gx, gy, gz = fb[0] + fi[0], fb[1] + fi[1], fb[2] + fi[2]
        fx, fy, fz = fx + gx, fy + gy, fz + gz
        ix, iy, iz = ix + fi[0], iy + fi[1], iz + fi[2]
        c = cross(r[0], r[1], r[2], gx, gy, gz)
        tx, ty, tz = tx + c[0], ty + c[1], tz + c[2]
    b = buoy_of(p, nd) if CARRIES else -1
    if CARRIES and b >= 0:   # at the centre of mass: its upthrust, the medium's inertia force rho V f (1 + C_a) A
        f = p.buoy_sample[b, 0]
        mi = f * (p.medium[0] * p.buoy_volume[b] + p.buoy_added[b])
        ix, iy, iz = ix + mi * p.buoy_sample[b, 4], iy + mi * p.buoy_sample[b, 5], iz + mi * p.buoy_sample[b, 6]
        fx, fy = fx + mi * p.buoy_sample[b, 4], fy + mi * p.buoy_sample[b, 5]
        fz += mi * p.buoy_sample[b, 6] + f * p.medium[0] * p.medium[1] * p.buoy_volume[b]
    return (fx, fy, fz), (ix, iy, iz), (tx, ty, tz)


@njit(**INNER)
def push_nodes(p, model, state, h):
    """Update the free nodes' velocities and angular velocities by the impulse h of the forces
    of position and time on them in a moving medium (node_forces; through the added mass; the
    torque about the centre of mass); p.supplied by the inertia force's work."""
    added = has_added_mass(p)
    supplied = 0.0
    for nd in range(model.node_mass.shape[0]):
        if not node_free(p, model, nd):
            continue
        (fx, fy, fz), (ix, iy, iz), (tx, ty, tz) = node_forces(p, model, state, nd)
        if fx == 0.0 and fy == 0.0 and fz == 0.0 and tx == 0.0 and ty == 0.0 and tz == 0.0:
            continue
        a00, a01, a02, a11, a12, a22 = held_mass(p, model, nd, added)
        dv = solve_sym3(a00, a01, a02, a11, a12, a22, h * fx, h * fy, h * fz)
        vn = state.node_v[nd]
        supplied += h * (ix * (vn[0] + 0.5 * dv[0]) + iy * (vn[1] + 0.5 * dv[1]) + iz * (vn[2] + 0.5 * dv[2]))
        for k in range(3):
            vn[k] += dv[k]
        turn_node(model, state, nd, h * tx, h * ty, h * tz)
    p.supplied[0] += supplied


@njit(**INNER)
def node_lift(p, model, state, nd):
    """Return (upward force, torque about the centre of mass: its x and y), lab, of the forces
    on free node nd in a still medium: the upthrust on its line ends and its buoy (node_forces'
    where the medium's acceleration, and with it the inertia force, is nil)."""
    fz = tx = ty = 0.0
    x = state.x
    for s in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        a = model.node_attach_list[s]
        l = a // 2
        j = p.line_row[l] if l < p.line_row.shape[0] else -1
        if j < 0:
            continue
        up = vertex_upthrust(p, model, x, j, l, model.attach_vertex[a], model.line_vertex_offsets[l],
                             model.line_vertex_offsets[l + 1])
        fz += up
        if ARMS:   # r x (0, 0, up)
            r = end_arm(model, state, a)
            tx, ty = tx + r[1] * up, ty - r[0] * up
    b = buoy_of(p, nd) if CARRIES else -1
    if CARRIES and b >= 0:
        fz += p.buoy_sample[b, 0] * p.medium[0] * p.medium[1] * p.buoy_volume[b]
    return fz, tx, ty


@njit(**INNER)
def add_node_upthrust(p, model, state, loads, n0, n1):
    """Update loads.node_f and loads.node_tau (lab) at the free nodes among n0..n1-1 by the
    forces on them in a still medium: the upthrust on their wet line ends and buoys
    (node_lift), a load of the kick as the lines' own upthrust is (kernels/added_mass.py),
    divided by the node's mass with the rest."""
    for nd in range(n0, n1):
        if node_free(p, model, nd):
            fz, tx, ty = node_lift(p, model, state, nd)
            loads.node_f[nd, 2] += fz
            loads.node_tau[nd, 0] += tx
            loads.node_tau[nd, 1] += ty


@njit(**CACHED, inline="always")
def end_drag(p, j, tan, lv, ux, uy, uz):
    """Return the drag matrix (c_n, c_t - c_n): drag = -(c_n (1 - t t^T) + c_t t t^T) u on a
    line end of row j with relative velocity u, tangent t and Voronoi length lv."""
    cn, ct = lv * p.drag_n[j], lv * p.drag_t[j]
    if not linear_law(p):   # (a variant of one law folds the test)
        ut = ux * tan[0] + uy * tan[1] + uz * tan[2]
        nx, ny, nz = ux - ut * tan[0], uy - ut * tan[1], uz - ut * tan[2]
        cn *= math.sqrt(nx * nx + ny * ny + nz * nz)
        ct *= abs(ut)
    return cn, ct - cn


@njit(**CACHED, inline="always")
def buoy_drag(p, nd, v):
    """Return the drag coefficient c of node nd's buoy, drag = -c (v - U): 1/2 rho C_d A f |v - U|
    at the velocity v (0 without a buoy, or above the water)."""
    b = buoy_of(p, nd)
    if b < 0 or p.buoy_drag[b] == 0.0:
        return 0.0
    s = p.buoy_sample[b]
    return p.buoy_drag[b] * s[0] * math.sqrt((v[0] - s[1]) ** 2 + (v[1] - s[2]) ** 2 + (v[2] - s[3]) ** 2)


@njit(**INNER)
def add_arm(c, cn, dc, r, t):
    """Return the 3 x 3 matrix c (a row-major 9-tuple) plus [r]x D, D = cn 1 + dc t t^T: the
    moment r x (D v) of a drag D acting at the arm r is this matrix times v."""
    rt = cross(r[0], r[1], r[2], t[0], t[1], t[2])
    return (c[0] + dc * rt[0] * t[0], c[1] + dc * rt[0] * t[1] - cn * r[2], c[2] + dc * rt[0] * t[2] + cn * r[1],
            c[3] + dc * rt[1] * t[0] + cn * r[2], c[4] + dc * rt[1] * t[1], c[5] + dc * rt[1] * t[2] - cn * r[0],
            c[6] + dc * rt[2] * t[0] - cn * r[1], c[7] + dc * rt[2] * t[1] + cn * r[0], c[8] + dc * rt[2] * t[2])


@njit(**CACHED, inline="always")
def point_junction(model, nd):
    """Whether every line end of node nd is at its centre of mass (the drag on them puts no
    moment on it)."""
    for s in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        o = model.attach_offset[model.node_attach_list[s]]
        if o[0] != 0.0 or o[1] != 0.0 or o[2] != 0.0:
            return False
    return True


@njit(**INNER)
def drag_node(p, model, state, nd, h, added, calm):
    """Update free node nd's velocity by one linearly implicit step of the drag on its wet
    line ends, (M + h D) v' = M v + h sum D_a (U_a - w x r_a) (D_a the drag matrix at the
    step's start, M the mass with the added mass (``added``); a buoy's own drag
    1/2 rho C_d A f |u| at its centre added to D), and its angular velocity by the drag's
    torque about the centre of mass at v'; return (the energy dissipated, the work the medium
    supplied). (One pass over the node's line ends: the torque and the medium's work at v'
    are linear in v', and their coefficients are summed with the drag's. ``calm``: the medium
    at rest, U = 0, its sampled velocity not read: where a variant's options tell it
    (fluid.calm_now), the terms in U fold away.)"""
    vn = state.node_v[nd]
    d = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    b0 = b1 = b2 = 0.0   # sum D_a (U_a - w x r_a)
    # the torque at v' is e - C v' (C = sum [r_a]x D_a, e = sum r_a x D_a (U_a - w x r_a)); the
    # medium's work over the flow h (s - g.v') (g = sum D_a U_a, s = sum U_a . D_a (U_a - w x r_a))
    c = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    e0 = e1 = e2 = g0 = g1 = g2 = s = 0.0
    touched = False
    for k in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        j, wet, r, tan, lv, um, _ = node_end(p, model, state, model.node_attach_list[k])
        if not wet:
            continue
        if calm:
            um = (0.0, 0.0, 0.0)
        arm = r[0] != 0.0 or r[1] != 0.0 or r[2] != 0.0   # (a point junction's ends: no arm, no moment)
        spin = arm_spin(state, nd, r) if arm else (0.0, 0.0, 0.0)
        gx, gy, gz = um[0] - spin[0], um[1] - spin[1], um[2] - spin[2]   # U - w x r
        cn, dc = end_drag(p, j, tan, lv, vn[0] - gx, vn[1] - gy, vn[2] - gz)
        if cn == 0.0 and dc == 0.0:
            continue
        touched = True
        d = add_split(d, cn, dc, tan)
        f = split(cn, cn + dc, gx, gy, gz, tan[0], tan[1], tan[2])
        b0, b1, b2 = b0 + f[0], b1 + f[1], b2 + f[2]
        du = split(cn, cn + dc, um[0], um[1], um[2], tan[0], tan[1], tan[2])
        g0, g1, g2 = g0 + du[0], g1 + du[1], g2 + du[2]
        s += um[0] * f[0] + um[1] * f[1] + um[2] * f[2]
        if arm:
            rf = cross(r[0], r[1], r[2], f[0], f[1], f[2])
            e0, e1, e2 = e0 + rf[0], e1 + rf[1], e2 + rf[2]
            c = add_arm(c, cn, dc, r, tan)
    cb = buoy_drag(p, nd, vn) if CARRIES else 0.0
    if CARRIES and cb > 0.0:    # the buoy's own drag at its centre, the same in every direction
        touched = True
        d = add_split(d, cb, 0.0, (0.0, 0.0, 1.0))
        bs = p.buoy_sample[buoy_of(p, nd)]
        b0, b1, b2 = b0 + cb * bs[1], b1 + cb * bs[2], b2 + cb * bs[3]
        g0, g1, g2 = g0 + cb * bs[1], g1 + cb * bs[2], g2 + cb * bs[3]
        s += cb * (bs[1] * bs[1] + bs[2] * bs[2] + bs[3] * bs[3])
    if not touched:
        return 0.0, 0.0
    a00, a01, a02, a11, a12, a22 = held_mass(p, model, nd, added)
    r0 = a00 * vn[0] + a01 * vn[1] + a02 * vn[2] + h * b0
    r1 = a01 * vn[0] + a11 * vn[1] + a12 * vn[2] + h * b1
    r2 = a02 * vn[0] + a12 * vn[1] + a22 * vn[2] + h * b2
    v1 = solve_sym3(a00 + h * d[0], a01 + h * d[1], a02 + h * d[2], a11 + h * d[3], a12 + h * d[4],
                    a22 + h * d[5], r0, r1, r2)
    tx = e0 - (c[0] * v1[0] + c[1] * v1[1] + c[2] * v1[2])
    ty = e1 - (c[3] * v1[0] + c[4] * v1[1] + c[5] * v1[2])
    tz = e2 - (c[6] * v1[0] + c[7] * v1[1] + c[8] * v1[2])
    given = h * (s - (g0 * v1[0] + g1 * v1[1] + g2 * v1[2]))
    dx, dy, dz = v1[0] - vn[0], v1[1] - vn[1], v1[2] - vn[2]
    mx = a00 * dx + a01 * dy + a02 * dz
    my = a01 * dx + a11 * dy + a12 * dz
    mz = a02 * dx + a12 * dy + a22 * dz
    gained = 0.5 * (mx * (v1[0] + vn[0]) + my * (v1[1] + vn[1]) + mz * (v1[2] + vn[2]))
    vn[0], vn[1], vn[2] = v1[0], v1[1], v1[2]
    gained += turn_node(model, state, nd, h * tx, h * ty, h * tz)
    return given - gained, given   # what the medium gave and the motion did not gain


@njit(**INNER)
def drag_nodes(p, model, state, h):
    """Update the velocities of the free nodes whose line ends have arms (drag_node; the
    point junctions take theirs inside the kick: kick_drag_nodes), p.dissipated and
    p.supplied by its work."""
    added, calm = has_added_mass(p), calm_now(p)
    dissipated = supplied = 0.0
    for nd in range(model.node_mass.shape[0]):
        if node_free(p, model, nd) and not point_junction(model, nd):
            d, g = drag_node(p, model, state, nd, h, added, calm)
            dissipated += d
            supplied += g
    p.dissipated[0] += dissipated
    p.supplied[0] += supplied


@njit(**INNER)
def kick_drag_nodes(p, model, state, node_f, h, n0, n1):
    """Update the velocities of the free point junctions among n0..n1-1 by the drag's step
    (drag_node) for the kick's length h between the kick's two halves, as the lines' interior
    vertices take theirs (fluid.kick_drag_vertices: K/2 F K/2, the half kick of the loads
    node_f, which the kick then gives whole, taken back after the flow): one evaluation a
    step where half flows on both sides of the kick took two. (Where a line end has an arm,
    the drag's moment turns the node, and its half kick would need the node's rotation's:
    drag_nodes.) Return (the energy dissipated, the work supplied)."""
    added, calm = has_added_mass(p), calm_now(p)
    dissipated = supplied = 0.0
    for nd in range(n0, n1):
        if not node_free(p, model, nd) or (ARMS and not point_junction(model, nd)):
            continue
        vn, s = state.node_v[nd], 0.5 * h * model.node_inv_mass[nd]
        ax, ay, az = s * node_f[nd, 0], s * node_f[nd, 1], s * node_f[nd, 2]
        vn[0], vn[1], vn[2] = vn[0] + ax, vn[1] + ay, vn[2] + az
        d, g = drag_node(p, model, state, nd, h, added, calm)
        vn[0], vn[1], vn[2] = vn[0] - ax, vn[1] - ay, vn[2] - az
        dissipated += d
        supplied += g
    return dissipated, supplied


@njit(**INNER)
def entrained_energy(p, model, state):
    """Return the kinetic energy of the fluid the lines carry, 1/2 v^T M_a v summed over the
    vertices of the lines in the medium (line ends of nodes the medium moves included, at
    their placed velocities), M_a = wet l (a_n (1 - t t^T) + a_t t t^T) with the wetness and
    tangent of p.sample: the added mass the step holds now. (The interior loop is
    branch-free over contiguous columns, which LLVM vectorises.)"""
    v, S = columns(state.v), sample_rows(p)
    e = 0.0
    for j in range(p.lines.shape[0]):
        l, lo, hi = carrying_span(p, model, j)
        if hi > 0:
            e += entrained_line(v, S, model.voronoi_rest_length, uint(lo + 1), hi - lo - 2, p.added_n[j], p.added_t[j])
    if NODES:
        e += nodes_entrained(p, model, state)
    return e


@njit(**INNER)
def nodes_entrained(p, model, state):
    """Return the share of entrained_energy at the nodes the medium moves: their line ends'
    and their buoys'."""
    S = sample_rows(p)
    e = 0.0
    for j in range(p.lines.shape[0]):
        l, lo, hi = carrying_span(p, model, j)
        if hi > 0:
            e += ends_entrained(p, model, state, S, model.voronoi_rest_length, l, lo, hi, p.added_n[j], p.added_t[j])
    if CARRIES:
        e += buoys_entrained(p, model, state)
    return e


@njit(**INNER)
def buoys_entrained(p, model, state):
    """Return the share of entrained_energy at the buoys of the nodes the medium moves."""
    e = 0.0
    for b in range(p.buoy_node.shape[0]):
        nd = p.buoy_node[b]
        if node_free(p, model, nd):
            vn = state.node_v[nd]
            e += 0.5 * p.buoy_added[b] * p.buoy_sample[b, 0] * (vn[0] * vn[0] + vn[1] * vn[1] + vn[2] * vn[2])
    return e


@njit(**INNER, parallel=True)
def sample_threaded(p, model, state):
    """Update p.sample as sample_medium does and return its value, in blocks of LINE_BLOCK lines
    on the step's threads, each block's share of the value in a row of p.block_sums (a
    reduction would allocate); a single block, or more than p.block_sums holds, runs in the
    calling thread (backend.SOLO)."""
    set_wave_phases(p, state.clock[0])
    nj, sums = p.lines.shape[0], p.block_sums
    bl = (nj + LINE_BLOCK - 1) // LINE_BLOCK
    if bl <= 1 or bl > sums.shape[0]:
        return sample_lines(p, model, state, np.int64(0), nj)
    for b in prange(bl):
        sums[b, 0] = sample_lines(p, model, state, b * LINE_BLOCK, min((b + 1) * LINE_BLOCK, nj))
    de = 0.0
    for b in range(bl):
        de += sums[b, 0]
    return de


@njit(**INNER, parallel=True)
def masses_threaded(p, model, state):
    """Update p.node_mass as sample_node_masses does at every node, in blocks of NODE_BLOCK on
    the step's threads (a single block in the calling thread)."""
    nn = model.node_mass.shape[0]
    bn = (nn + NODE_BLOCK - 1) // NODE_BLOCK
    if bn <= 1:
        sample_node_masses(p, model, state, np.int64(0), nn)
        return
    for b in prange(bn):
        sample_node_masses(p, model, state, b * NODE_BLOCK, min((b + 1) * NODE_BLOCK, nn))


SAMPLE, SAMPLE_NODES, ENTRAINED = 0, 1, 2   # what fluid_entry does


@njit(**ENTRY)
def fluid_entry(p, model, state, task):
    """Do ``task`` and return its value (0.0 for an update), callable from Python:
    - SAMPLE: update p.sample given the positions and the clock, as a kick's first half flow
      does (the added mass a simulation holds before its first step);
    - SAMPLE_NODES: update p.node_mass given the sample, as a kick's first half flow does: the
      nodes' mass matrices that rings, eyelets and sheaves move them by before the first step
      (cosnet/effects/carried.py);
    - ENTRAINED: return entrained_energy(p, model, state) (Fluid.potential).
    (One entry for the three: each entry's Python wrapper unboxes the three records, which
    cost more compiling than the calls behind it; a variant without added mass or buoys
    compiles neither the nodes' masses nor the entrained energy.)"""
    if task == ENTRAINED:
        if CARRIES:
            return entrained_energy(p, model, state)
        return 0.0
    if task == SAMPLE_NODES:
        if CARRIES and NODES:
            sample_node_masses(p, model, state, np.int64(0), model.node_mass.shape[0])
        return 0.0
    sample_medium(p, model, state)
    if CARRIES:
        sample_buoys(p, state, state.clock[0])
    return 0.0


@njit(**CACHED, inline="always")
def push_medium(p, model, state, h, still):
    """Update the velocities by the impulse h of the forces of position and time the kick does
    not carry, in a moving medium: its inertia force at the lines' vertices, and the forces on
    the nodes (in a still medium, the upthrust on the nodes is a load of the kick:
    add_node_upthrust)."""
    if MOVING and not still:
        push_vertices(p, model, state, h)
        if NODES:
            push_nodes(p, model, state, h)


@flow_kernel(FluidParams)
@njit(**STEP)
def flow_fluid(p, model, state, h):
    """Update state.v, state.node_v, state.node_w by what the medium does over half a kick, h,
    beside the kick's loads: the drag on the free nodes whose line ends have arms (drag_nodes;
    a point junction's is inside the kick) and, in a moving medium, the forces of
    position and time the kick does not carry (its inertia force at the lines' vertices, the
    forces on the nodes: push_medium), on both sides of every kick, mirrored (before it drag
    then the forces, after it the forces then drag; p.turn: the side), so that every step is
    a symmetric sequence (second order). (The lines' interior vertices and the point
    junctions take their drag inside the kick, between its halves: fluid.kick_drag_vertices,
    kick_drag_nodes. Run once a kick for the kick's length, alternately before and after
    it, a stiff drag, a dashpot whose rate times the step is of order one, near the step's
    own limit, made the pair of steps unstable, as a split of any exact flow does so
    placed.) p.dissipated and p.supplied follow their work
    (the medium's own kinetic energy through the added mass counted as the line's). Before
    the kick, the medium is sampled: a new sample changes the added mass (the lines turned,
    entered or left the water since the last kick) at the velocities of the drift between:
    the entrained fluid's kinetic energy then changes by work Morison's M v' = f leaves out
    of its forces, counted in p.supplied, so the energy balance still closes."""
    after = p.turn[0] & 1
    still = still_medium(p)   # (then the medium's inertia force is nil at the lines' vertices)
    if after == 0:
        before = 0.0
        if CARRIES and has_added_mass(p):   # (the test, not a variable holding it: numba prunes on the option)
            # (in a still medium, the lines' share of the change is the sample's own; where the
            # medium moves no node, there are no buoys either and nothing at the nodes to sample)
            before = entrained_energy(p, model, state) if not still else 0.0
            if still and NODES:
                before = buoys_entrained(p, model, state)
        de = sample_threaded(p, model, state) if THREADS else sample_medium(p, model, state)
        if CARRIES and has_added_mass(p):
            if NODES:
                if p.buoy_node.shape[0] > 0:   # (a call passing the records costs more than a short line's sample)
                    sample_buoys(p, state, state.clock[0])
                if THREADS:
                    masses_threaded(p, model, state)
                else:
                    sample_node_masses(p, model, state, np.int64(0), model.node_mass.shape[0])
            after_sample = entrained_energy(p, model, state) if not still else de
            if still and NODES:
                after_sample += buoys_entrained(p, model, state)
            p.supplied[0] += after_sample - before
        elif CARRIES and NODES and p.buoy_node.shape[0] > 0:
            sample_buoys(p, state, state.clock[0])
    if after == 1:
        push_medium(p, model, state, h, still)
    if NODES and ARMS:
        drag_nodes(p, model, state, h)
    if after == 0:
        push_medium(p, model, state, h, still)
    p.turn[0] = 1 - after
