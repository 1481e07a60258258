"""Free flights and kicks: the two halves of every splitting step.

Drifts are exact (or symplectic) flows of the kinetic energy: vertices and centres of mass
move on straight lines; elements and nodes rotate as free rigid bodies. Kicks are exact flows
of the loads: velocities change by the impulse, angular momenta (body frame) by the torque
impulse. Both keep the junction conditions (1.1)/(1.3) exact: a line end is always placed at
r(nu) + D(nu) xi(nu, lambda) with frame D(nu) X(nu, lambda).
"""

import math

import numpy as np
from numba import njit, prange

from .backend import ENTRY, PASS, STEP, dispatch, each_node, inline_twin
from .layout import columns, quat_columns
from .compiler import INLINE, INNER, stable_cache_key
from .rotations import cross, quat_exp, quat_mul, quat_normalize, quat_rotate, quat_rotate_inv

# rows per task of the threaded element loops (each block runs the vectorised serial loop)
BLOCK = 4096


@njit(**INLINE)
def block_rows(b, n):
    """Return (start, stop) of block b of BLOCK rows out of n (empty past the end)."""
    return min(b * BLOCK, n), min((b + 1) * BLOCK, n)


def each_row_block(block):
    """Return (serial, parallel) kernels f(model, state, c, d) running
    block(model, state, c, d, vs, ve, es, ee) over every vertex and element: the serial one
    in one call, the parallel one a block of BLOCK vertices and elements per task."""
    whole = inline_twin(block)   # the serial one is all block: compiled inside it, not called

    # (the first rows as int64, not the literal 0: numba compiled block once for a literal
    # first row and again for the parallel tasks' computed ones)
    @stable_cache_key
    @njit(**STEP)
    def serial(model, state, c, d):
        whole(model, state, c, d, np.int64(0), state.x.shape[0], np.int64(0), state.q.shape[0])

    @stable_cache_key
    @njit(**INNER, parallel=True)
    def parallel(model, state, c, d):
        nv, ne = state.x.shape[0], state.q.shape[0]
        if max(nv, ne) <= BLOCK:  # one task: run it here (backend.SOLO)
            block(model, state, c, d, np.int64(0), nv, np.int64(0), ne)
            return
        for b in prange((max(nv, ne) + BLOCK - 1) // BLOCK):
            vs, ve = block_rows(b, nv)
            es, ee = block_rows(b, ne)
            block(model, state, c, d, vs, ve, es, ee)
    return serial, parallel

# Yoshida's triple jump lifts a symmetric second-order flow to fourth order
YOSHIDA_1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
YOSHIDA_0 = 1.0 - 2.0 * YOSHIDA_1

# Sequences of flows about body axes, (axis, fraction of the step). Numba compiles a function
# called with a literal int once per value; an axis read in a loop over such a tuple is a
# plain int64, so one compiled spin_about_axis serves every axis.
STRANG_123 = ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5))
STRANG_23 = ((1, 0.5), (2, 1.0), (1, 0.5))
AXIS_3 = ((2, 1.0),)


@njit(**INNER)
def spin_about_axis(qw, qx, qy, qz, p0, p1, p2, inv_j, axis, h, cayley):
    """Return (q, p) advanced by the flow of inv_j p_i^2 / 2 for time h about body axis i:
    q <- q exp(phi e_i), p <- exp(-phi e_i) p with phi = h inv_j p_i (exact). With cayley,
    the angle is 2 atan(phi/2): the exact flow of another function of p_i alone, so still
    symplectic with |p| and the lab angular momentum exact, O(phi^3) apart, free of trig,
    and q is turned by the factor (1, t e_i), t = phi/2, unnormalised: its norm, sqrt(1 +
    t^2), only scales q, which every caller normalises once at the end (a square root and a
    division a factor less, the costliest operations of a body's turn)."""
    p = (p0, p1, p2)
    phi = h * inv_j * p[axis]
    if cayley:
        t = 0.5 * phi
        n = 1.0 / (1.0 + t * t)
        c, s = 1.0, t
        cp, sp = (1.0 - t * t) * n, 2.0 * t * n   # the cosine and sine of 2 atan(t)
    else:
        c, s = math.cos(0.5 * phi), math.sin(0.5 * phi)
        cp, sp = c * c - s * s, 2.0 * s * c
    if axis == 0:
        qw, qx, qy, qz = quat_mul(qw, qx, qy, qz, c, s, 0.0, 0.0)
        return qw, qx, qy, qz, p0, cp * p1 + sp * p2, -sp * p1 + cp * p2
    if axis == 1:
        qw, qx, qy, qz = quat_mul(qw, qx, qy, qz, c, 0.0, s, 0.0)
        return qw, qx, qy, qz, -sp * p2 + cp * p0, p1, cp * p2 + sp * p0
    qw, qx, qy, qz = quat_mul(qw, qx, qy, qz, c, 0.0, 0.0, s)
    return qw, qx, qy, qz, cp * p0 + sp * p1, -sp * p0 + cp * p1, p2


@njit(**INNER)
def spin_strang(qw, qx, qy, qz, p0, p1, p2, i0, i1, i2, h, cayley):
    """Return (q, p) after the symmetric splitting 1(h/2) 2(h/2) 3(h) 2(h/2) 1(h/2) of the
    free rigid body (Dullweber, Leimkuhler & McLachlan): symplectic, |p| and the lab angular
    momentum exact (with Cayley angles: see spin_about_axis)."""
    r = (qw, qx, qy, qz, p0, p1, p2)
    inv_j = (i0, i1, i2)
    for axis, frac in STRANG_123:
        r = spin_about_axis(r[0], r[1], r[2], r[3], r[4], r[5], r[6], inv_j[axis], axis, frac * h, cayley)
    return r


@njit(**INLINE)
def spin_two_flows(qw, qx, qy, qz, p0, p1, p2, common, odd, axis, h, cayley):
    """Return (q, p), q not normalised, after the free rotation for time h of a body whose
    inverse inertias are ``common`` about two axes and common + odd about ``axis``: the
    Casimir flow exp(h common p) (p unchanged), then the flow of odd p_axis^2/2 about that
    axis (spin_about_axis). The two flows commute, so this is the body's whole flow: exact,
    or by Cayley angles where ``cayley`` (the exact flow of a kinetic energy differing by
    O(h^2), no trig; each factor (1, phi/2) unnormalised, as spin_about_axis's)."""
    s = h * common
    if cayley:
        ew, ex, ey, ez = 1.0, 0.5 * s * p0, 0.5 * s * p1, 0.5 * s * p2
    else:
        ew, ex, ey, ez = quat_exp(s * p0, s * p1, s * p2)
    qw, qx, qy, qz = quat_mul(qw, qx, qy, qz, ew, ex, ey, ez)
    return spin_about_axis(qw, qx, qy, qz, p0, p1, p2, odd, axis, h, cayley)


@njit(**INNER)
def spin_free_body(q, p, inv_j, h, order):
    """Update quaternion q (4,) and body momentum p (3,) by the free rigid-body flow for time
    h to the given order; a body of three different inertias by a splitting (2: Strang with
    Cayley angles, as the elements turn; 4: Yoshida's triple jump of the exact Strang
    splitting). A body with two equal inertias (a knot or a
    point mass with its line ends: symmetric about one axis) needs no splitting: it turns by
    its two commuting flows (spin_two_flows), with Cayley angles at order 2, exactly at order
    4, as a round element does (spin_element)."""
    i0, i1, i2 = inv_j[0], inv_j[1], inv_j[2]
    if i0 == i1 or i1 == i2 or i0 == i2:
        axis, common = (2, i0) if i0 == i1 else ((0, i1) if i1 == i2 else (1, i0))
        r = spin_two_flows(q[0], q[1], q[2], q[3], p[0], p[1], p[2], common, inv_j[axis] - common, axis, h,
                           order != 4)
        q[0], q[1], q[2], q[3] = quat_normalize(r[0], r[1], r[2], r[3])
        p[0], p[1], p[2] = r[4], r[5], r[6]
        return
    r = (q[0], q[1], q[2], q[3], p[0], p[1], p[2])
    if order == 4:
        for c in (YOSHIDA_1, YOSHIDA_0, YOSHIDA_1):
            r = spin_strang(r[0], r[1], r[2], r[3], r[4], r[5], r[6], inv_j[0], inv_j[1], inv_j[2], c * h, False)
    else:
        r = spin_strang(r[0], r[1], r[2], r[3], r[4], r[5], r[6], inv_j[0], inv_j[1], inv_j[2], h, True)
    q[0], q[1], q[2], q[3] = quat_normalize(r[0], r[1], r[2], r[3])
    p[0], p[1], p[2] = r[4], r[5], r[6]


@njit(**INNER)
def spin_exact(qw, qx, qy, qz, p0, p1, p2, i1, d1, d2, h, order):
    """Return (q, p) after the exact Casimir flow exp(h i1 p) and the flow of the rest
    d1 p2^2/2 + d2 p3^2/2: exact for d1 = 0, else split symmetrically (Yoshida for order 4)."""
    ew, ex, ey, ez = quat_exp(h * i1 * p0, h * i1 * p1, h * i1 * p2)
    r = quat_mul(qw, qx, qy, qz, ew, ex, ey, ez) + (p0, p1, p2)
    inv_d = (0.0, d1, d2)
    if d1 == 0.0:
        for axis, frac in AXIS_3:
            r = spin_about_axis(r[0], r[1], r[2], r[3], r[4], r[5], r[6], inv_d[axis], axis, frac * h, False)
        return r
    for c in ((YOSHIDA_1, YOSHIDA_0, YOSHIDA_1) if order == 4 else (1.0, 0.0, 0.0)):
        if c != 0.0:
            for axis, frac in STRANG_23:
                r = spin_about_axis(r[0], r[1], r[2], r[3], r[4], r[5], r[6], inv_d[axis], axis,
                                    frac * c * h, False)
    return r


@njit(**INLINE)
def spin_round(qw, qx, qy, qz, p0, p1, p2, i1, d2, h):
    """Return (q, p) after the order-2 free-rotation flow of a round section (J1 = J2): the
    Casimir flow by the Cayley angle of h p / J1 (p unchanged), then the flow of d2 p3^2/2
    about e3 by its Cayley angle (spin_two_flows; no branch, no trig), q normalised."""
    r = (qw, qx, qy, qz, p0, p1, p2)
    for axis, _ in AXIS_3:   # (a plain int: see STRANG_123)
        r = spin_two_flows(qw, qx, qy, qz, p0, p1, p2, i1, d2, axis, h, True)
    qw, qx, qy, qz = quat_normalize(r[0], r[1], r[2], r[3])
    return qw, qx, qy, qz, r[4], r[5], r[6]


@njit(**INLINE)
def spin_element(q, w, J, inv_j, h, order):
    """Update element quaternion q (4,) and body angular velocity w (3,) by the free-rotation
    flow for time h. The kinetic energy |p|^2/(2 J1) + (1/J2 - 1/J1) p2^2/2 + (1/J3 - 1/J1) p3^2/2
    splits into a Casimir flow (rotation about p) that commutes with the rest, so a round
    section (J1 = J2) needs no splitting; otherwise the last two terms are split symmetrically.
    Order 2 turns by Cayley angles 2 atan(phi/2) instead of phi: the exact flow of a kinetic
    energy differing by O(h^2), hence still symplectic with exact momenta, and free of trig."""
    p0, p1, p2 = J[0] * w[0], J[1] * w[1], J[2] * w[2]
    i1 = inv_j[0]
    d1, d2 = inv_j[1] - i1, inv_j[2] - i1
    if order == 2 and d1 == 0.0:
        r = spin_round(q[0], q[1], q[2], q[3], p0, p1, p2, i1, d2, h)
    else:
        r = spin_exact(q[0], q[1], q[2], q[3], p0, p1, p2, i1, d1, d2, h, order)
        r = quat_normalize(r[0], r[1], r[2], r[3]) + (r[4], r[5], r[6])
    q[0], q[1], q[2], q[3] = r[0], r[1], r[2], r[3]
    w[0], w[1], w[2] = r[4] * inv_j[0], r[5] * inv_j[1], r[6] * inv_j[2]


@njit(**INLINE)
def spin_round_at(q, w, J, ij, e, h):
    """Return (q, w) of element e of the columns q (4-tuple), w (3-tuple) turned by
    spin_round, given J, 1/J (3-tuples)."""
    qw, qx, qy, qz, p0, p1, p2 = spin_round(q[0][e], q[1][e], q[2][e], q[3][e], J[0][e] * w[0][e],
                                            J[1][e] * w[1][e], J[2][e] * w[2][e], ij[0][e],
                                            ij[2][e] - ij[0][e], h)
    return qw, qx, qy, qz, p0 * ij[0][e], p1 * ij[1][e], p2 * ij[2][e]


@njit(**PASS)
def spin_round_elements(q, w, J, ij, h):
    """Update the element columns q (4-tuple), w (3-tuple) of the round-section elements by
    spin_round (other lanes keep their values) given J, 1/J (3-tuples)."""
    for e in range(q[0].shape[0]):
        rnd = ij[1][e] == ij[0][e]
        r = spin_round_at(q, w, J, ij, e, h)
        q[0][e] = r[0] if rnd else q[0][e]
        q[1][e] = r[1] if rnd else q[1][e]
        q[2][e] = r[2] if rnd else q[2][e]
        q[3][e] = r[3] if rnd else q[3][e]
        w[0][e] = r[4] if rnd else w[0][e]
        w[1][e] = r[5] if rnd else w[1][e]
        w[2][e] = r[6] if rnd else w[2][e]


@njit(**PASS)
def count_not_round(ij):
    """Return how many elements of the 1/J columns ij (3-tuple) are not round (1/J1 != 1/J2)."""
    other = 0
    for e in range(ij[0].shape[0]):
        other += 0 if ij[1][e] == ij[0][e] else 1
    return other


@njit(**PASS)
def spin_round_columns(q, w, J, ij, h):
    """Update the element columns q (4-tuple), w (3-tuple) of elements all of round section
    by spin_round, given J, 1/J (3-tuples). spin_round_elements with no lane to keep: its
    per-lane choice between the new and the old values keeps LLVM from vectorising the
    pass, which then costs several times as much (four times on 20-element snakes)."""
    for e in range(q[0].shape[0]):
        r = spin_round_at(q, w, J, ij, e, h)
        q[0][e], q[1][e], q[2][e], q[3][e] = r[0], r[1], r[2], r[3]
        w[0][e], w[1][e], w[2][e] = r[4], r[5], r[6]


@njit(**PASS)
def drift_columns(x, v, h):
    """Update positions x by h v (3-tuples of columns)."""
    for i in range(x[0].shape[0]):
        x[0][i] += h * v[0][i]
        x[1][i] += h * v[1][i]
        x[2][i] += h * v[2][i]


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def drift_block(model, state, h, order, vs, ve, es, ee):
    """Update vertices vs .. ve-1 and elements es .. ee-1 by the free flight of time h. At
    order 2 the round sections turn in one vectorised pass (without a per-lane choice when
    all are round); the others follow one by one."""
    drift_columns(columns(state.x, vs, ve), columns(state.v, vs, ve), h)
    other = ee - es
    if order == 2:
        qc, wc = quat_columns(state.q, es, ee), columns(state.w, es, ee)
        jc, ijc = columns(model.element_inertia, es, ee), columns(model.element_inv_inertia, es, ee)
        other = count_not_round(ijc)
        if other == 0:
            spin_round_columns(qc, wc, jc, ijc, h)
        else:
            spin_round_elements(qc, wc, jc, ijc, h)
    if other:
        q, w, J, ij = state.q, state.w, model.element_inertia, model.element_inv_inertia
        for e in range(es, ee):
            if order != 2 or ij[e, 1] != ij[e, 0]:
                spin_element(q[e], w[e], J[e], ij[e], h, order)


# drift_bodies(model, state, h, order): vertex positions and element frames by the free
# flight of time h (and its threaded twin)
drift_bodies, drift_bodies_parallel = each_row_block(drift_block)
drift_bodies_on = dispatch(drift_bodies, drift_bodies_parallel)


def drift_node(nd, model, state, h, order):
    """Update node nd's centre of mass and frame by the free flight of time h (the free
    rigid body (4.3)/(4.4) without loads), then place its line ends (1.1)/(1.3)."""
    p = state.node_hold  # locked axes keep their momentum here; free axes are converted below
    for k in range(3):
        state.node_x[nd, k] += h * state.node_v[nd, k]
        if model.node_locked[nd, k] == 0.0:
            p[nd, k] = model.node_inertia[nd, k] * state.node_w[nd, k]
    spin_free_body(state.node_q[nd], p[nd], model.node_inv_inertia[nd], h, order)
    for k in range(3):
        if model.node_locked[nd, k] == 0.0:
            state.node_w[nd, k] = p[nd, k] * model.node_inv_inertia[nd, k]
            p[nd, k] = 0.0
    for j in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        place_line_end(model.node_attach_list[j], model, state)


drift_nodes_on = dispatch(*each_node(drift_node))


@njit(**STEP, inline="always")  # part of its caller, stepping.drift_positions_at
def drift_state(model, state, h, order, backend):
    """Update state (positions, quaternions, clock) by the free flight of time h, then place
    every line end on its node (1.1)/(1.3)."""
    drift_bodies_on(backend, model, state, h, order)
    drift_nodes_on(backend, state.node_x.shape[0], model, state, h, order)
    state.clock[0] += h


@njit(**INLINE)
def place_line_end(a, model, state):
    """Update state.x, state.v at line end a given its node: r_lambda = r + D xi (1.1)."""
    nd = model.attach_node[a]
    vt = model.attach_vertex[a]
    o = model.attach_offset[a]
    if o[0] == 0.0 and o[1] == 0.0 and o[2] == 0.0:   # (a point junction's end: the node's own motion)
        for k in range(3):
            state.x[vt, k] = state.node_x[nd, k]
            state.v[vt, k] = state.node_v[nd, k]
        return
    qw, qx, qy, qz = state.node_q[nd, 0], state.node_q[nd, 1], state.node_q[nd, 2], state.node_q[nd, 3]
    w = state.node_w[nd]
    rx, ry, rz = quat_rotate(qw, qx, qy, qz, o[0], o[1], o[2])
    cx, cy, cz = cross(w[0], w[1], w[2], o[0], o[1], o[2])
    ux, uy, uz = quat_rotate(qw, qx, qy, qz, cx, cy, cz)
    state.x[vt, 0] = state.node_x[nd, 0] + rx
    state.x[vt, 1] = state.node_x[nd, 1] + ry
    state.x[vt, 2] = state.node_x[nd, 2] + rz
    state.v[vt, 0] = state.node_v[nd, 0] + ux
    state.v[vt, 1] = state.node_v[nd, 1] + uy
    state.v[vt, 2] = state.node_v[nd, 2] + uz


@njit(**ENTRY)
def place_line_ends(model, state):
    """Update state.x, state.v at every line end given its node: r_lambda = r + D xi (1.1)."""
    for a in range(model.attach_node.shape[0]):
        place_line_end(a, model, state)


def gather_node(nd, model, state, loads, unused):
    """Update loads.node_f[nd], loads.node_tau[nd] (lab, about the centre of mass) given the
    loads at node nd's line ends: F - sum Omega n_lambda and L - sum Omega (m_lambda + zeta x
    n_lambda) (4.3)/(4.4); the sign Omega is already in the end-vertex forces and end torques.
    (unused: the node loops take four arguments.)"""
    qw, qx, qy, qz = state.node_q[nd, 0], state.node_q[nd, 1], state.node_q[nd, 2], state.node_q[nd, 3]
    for j in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        a = model.node_attach_list[j]
        vt = model.attach_vertex[a]
        f = loads.f[vt]
        o = model.attach_offset[a]
        rx, ry, rz = quat_rotate(qw, qx, qy, qz, o[0], o[1], o[2])
        cx, cy, cz = cross(rx, ry, rz, f[0], f[1], f[2])
        xq = model.attach_frame[a]
        t = loads.end_tau[a]
        ew, ex, ey, ez = quat_mul(qw, qx, qy, qz, xq[0], xq[1], xq[2], xq[3])
        tx, ty, tz = quat_rotate(ew, ex, ey, ez, t[0], t[1], t[2])
        loads.node_f[nd, 0] += f[0]
        loads.node_f[nd, 1] += f[1]
        loads.node_f[nd, 2] += f[2]
        loads.node_tau[nd, 0] += cx + tx
        loads.node_tau[nd, 1] += cy + ty
        loads.node_tau[nd, 2] += cz + tz


gather_node_loads_on = dispatch(*each_node(gather_node))


@njit(**PASS)
def kick_columns(u, inv_m, load, h):
    """Update u by the impulse h inv_m load (componentwise; 3-tuples of columns) (3.2)/(3.3)."""
    for i in range(u[0].shape[0]):
        u[0][i] += h * inv_m[0][i] * load[0][i]
        u[1][i] += h * inv_m[1][i] * load[1][i]
        u[2][i] += h * inv_m[2][i] * load[2][i]


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def kick_block(model, state, loads, h, vs, ve, es, ee):
    """Update the velocities of vertices vs .. ve-1 and angular velocities of elements
    es .. ee-1 given the loads over time h."""
    kick_columns(columns(state.v, vs, ve), columns(model.vertex_inv_mass3, vs, ve), columns(loads.f, vs, ve), h)
    kick_columns(columns(state.w, es, ee), columns(model.element_inv_inertia, es, ee),
                 columns(loads.tau, es, ee), h)


# kick_bodies(model, state, loads, h): vertex velocities and element angular velocities
# given the loads over time h (and its threaded twin)
kick_bodies, kick_bodies_parallel = each_row_block(kick_block)
kick_bodies_on = dispatch(kick_bodies, kick_bodies_parallel)


def kick_node(nd, model, state, loads, h):
    """Update node nd's velocity and body angular velocity (or the held momentum of its
    locked axes) given its loads over time h (4.3)/(4.4)."""
    s = h * model.node_inv_mass[nd]
    for k in range(3):
        state.node_v[nd, k] += s * loads.node_f[nd, k]
    q = state.node_q[nd]
    t = loads.node_tau[nd]
    bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], t[0], t[1], t[2])
    tb = (bx, by, bz)
    for k in range(3):
        if model.node_locked[nd, k] == 0.0:
            state.node_w[nd, k] += h * model.node_inv_inertia[nd, k] * tb[k]
        else:
            state.node_hold[nd, k] += h * tb[k]


kick_nodes_on = dispatch(*each_node(kick_node))


@njit(**STEP, inline="always")  # one caller: kick_loads
def kick_state(model, state, loads, h, backend):
    """Update velocities and body angular momenta given the loads over time h:
    mu r'' = n' + f (3.2), (I w)' = m' + r' x n + l (3.3), (4.3), (4.4)."""
    kick_bodies_on(backend, model, state, loads, h)
    kick_nodes_on(backend, state.node_x.shape[0], model, state, loads, h)
