"""Internal (strain-rate) damping of the lines' stretching: a Kelvin-Voigt dashpot beside each
element's axial spring, n_damp = c d(epsilon)/dt along the element, epsilon = |x_b - x_a| / l0 - 1
its axial strain (the third component of v - d3 in (1.2), taken on the chord).

Such damping takes the energy of the fast axial waves a stiff line rings with (after a snap,
a stick on a rim, a start from rest) and barely touches its slow swinging, which the
mass-proportional damping cannot tell apart. Explicit, a dashpot would bound the step (its
rate c / (l0 mu) can exceed the elastic frequency); integrated here as an exact flow of each
element's pair of vertices in turn, it is stable at any step:

- on its chord t (held over the flow), the two ends' relative axial velocity u = t (v_b - v_a)
  decays as exp(-c w tau / l0), with w = w_a + w_b the inverse masses that move the ends along t
  (an end vertex: its node's translation and, at an offset xi, its rotation: 1/M + sum_k
  (xi x t)_k^2 / I_k on the axes that turn);
- the change is made by the impulses +-J t, J = (u' - u) / w: momentum and angular momentum
  are kept, and the kinetic energy taken, 1/2 (u^2 - u'^2) / w, is counted as dissipated.
The dashpots run once a kick, for the kick's length: before it on one kick, taking the even
elements then the odd, and after it on the next, the odd then the even (p.turn), so that two
kicks form the symmetric sequence F_eo K D ... D K F_oe (the splitting's order 2, at half the
cost of half flows on both sides of every kick). The interior elements' decay factors are made
once for the kick's length (p.decay_h), and take no square root (the chord's length enters
only squared).
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import STEP
from .compiler import INLINE, INNER
from .compose import flow_kernel
from .motion import place_line_end
from .rotations import cross, quat_rotate, quat_rotate_inv


class InternalDampingParams(NamedTuple):
    rate: np.ndarray         # (ne,) axial damping coefficient c of each element (N s; 0: none)
    node_weight: np.ndarray  # (nn,) inverse mass that moves each node here (0: fixed or driven)
    node_turn: np.ndarray    # (nn, 3) inverse principal inertia that turns it (0: locked, driven)
    driven: np.ndarray       # (m,) int64 the nodes a drive moves
    is_driven: np.ndarray    # (nn,) 1.0 at those
    held: np.ndarray         # (nn, 6) a driven node's velocity and body angular velocity before the kick
    weight: np.ndarray       # (ne,) w = w_a + w_b of each element (read for those with no end on a node)
    gain: np.ndarray         # (ne,) (c - 1) / w of those, c = exp(-c w tau / l0) for tau = decay_h
    loss: np.ndarray         # (ne,) -(1 + c) / 2 of those
    decay_h: np.ndarray      # (1,) the flow length of gain and loss (nan: none yet)
    turn: np.ndarray         # (1,) int64: bit 0: 0 before a kick, 1 after; bit 1: the side the dashpots run on
    dissipated: np.ndarray   # (1,) kinetic energy taken so far (J)


@njit(**INNER)
def end_moment(model, state, a, x, y, z):
    """Return xi x R^T f: the moment about its node's centre of mass, in the node's body axes, of
    the lab vector f at line end a (offset xi)."""
    q, o = state.node_q[model.attach_node[a]], model.attach_offset[a]
    bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], x, y, z)
    return cross(o[0], o[1], o[2], bx, by, bz)


@njit(**INNER)
def end_weight(p, model, state, a, tx, ty, tz):
    """Return the inverse mass that moves line end a (an attachment) along the lab direction t:
    its node's translation, and its rotation about the centre of mass at the end's offset."""
    nd = model.attach_node[a]
    cx, cy, cz = end_moment(model, state, a, tx, ty, tz)
    turn = p.node_turn[nd]
    return p.node_weight[nd] + turn[0] * cx * cx + turn[1] * cy * cy + turn[2] * cz * cz


@njit(**INNER)
def end_velocity(p, model, state, a):
    """Return the lab velocity of line end a from its node's (1.1): a kick leaves the end
    vertices' own rows behind until the drift places them. A driven node's is the one it had
    before the kick, which its drive gives it back after the kick (within the kick, the node
    has moved on with its loads)."""
    nd = model.attach_node[a]
    q, o = state.node_q[nd], model.attach_offset[a]
    if p.is_driven[nd] != 0.0:
        h = p.held[nd]
        vx, vy, vz, wx, wy, wz = h[0], h[1], h[2], h[3], h[4], h[5]
    else:
        v, w = state.node_v[nd], state.node_w[nd]
        vx, vy, vz, wx, wy, wz = v[0], v[1], v[2], w[0], w[1], w[2]
    cx, cy, cz = cross(wx, wy, wz, o[0], o[1], o[2])
    ux, uy, uz = quat_rotate(q[0], q[1], q[2], q[3], cx, cy, cz)
    return vx + ux, vy + uy, vz + uz


@njit(**INNER)
def push_end(p, model, state, a, jx, jy, jz):
    """Update node attach_node[a] by the impulse J (lab) at line end a, and its line ends (1.1)."""
    nd = model.attach_node[a]
    cx, cy, cz = end_moment(model, state, a, jx, jy, jz)
    w, turn = p.node_weight[nd], p.node_turn[nd]
    state.node_v[nd, 0] += w * jx
    state.node_v[nd, 1] += w * jy
    state.node_v[nd, 2] += w * jz
    state.node_w[nd, 0] += turn[0] * cx
    state.node_w[nd, 1] += turn[1] * cy
    state.node_w[nd, 2] += turn[2] * cz
    for k in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        place_line_end(model.node_attach_list[k], model, state)


@njit(**INNER)
def damp_end_element(p, model, state, l, e, i, tau):
    """Update the velocities of element e's vertices i, i+1 (of line l; one or both an end,
    moved by its node) by the exact flow of its dashpot over tau (module docstring); return the
    kinetic energy taken."""
    x, v = state.x, state.v
    dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    size = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not size > 0.0:
        return 0.0
    tx, ty, tz = dx / size, dy / size, dz / size
    first, last = i == model.line_vertex_offsets[l], i + 2 == model.line_vertex_offsets[l + 1]
    ax, ay, az = end_velocity(p, model, state, 2 * l) if first else (v[i, 0], v[i, 1], v[i, 2])
    bx, by, bz = end_velocity(p, model, state, 2 * l + 1) if last else (v[i + 1, 0], v[i + 1, 1], v[i + 1, 2])
    ua, ub = tx * ax + ty * ay + tz * az, tx * bx + ty * by + tz * bz
    u = ub - ua
    wa = end_weight(p, model, state, 2 * l, tx, ty, tz) if first else model.vertex_inv_mass[i]
    wb = end_weight(p, model, state, 2 * l + 1, tx, ty, tz) if last else model.vertex_inv_mass[i + 1]
    w = wa + wb
    if not w > 0.0:
        return 0.0
    after = u * math.exp(-p.rate[e] * w * tau / model.element_rest_length[e])
    j = (after - u) / w
    jx, jy, jz = j * tx, j * ty, j * tz
    if first:
        push_end(p, model, state, 2 * l, -jx, -jy, -jz)
    else:
        v[i, 0] -= wa * jx
        v[i, 1] -= wa * jy
        v[i, 2] -= wa * jz
    if last:
        push_end(p, model, state, 2 * l + 1, jx, jy, jz)
    else:
        v[i + 1, 0] += wb * jx
        v[i + 1, 1] += wb * jy
        v[i + 1, 2] += wb * jz
    # the kinetic energy the impulses took from each side, P.v + w P^2 / 2; a driven node's
    # velocity is its drive's, which pays that side (not in its reaction: a flow, not a load)
    taken_a = 0.0 if first and p.is_driven[model.attach_node[2 * l]] != 0.0 else j * ua - 0.5 * wa * j * j
    taken_b = 0.0 if last and p.is_driven[model.attach_node[2 * l + 1]] != 0.0 else -j * ub - 0.5 * wb * j * j
    return taken_a + taken_b


@njit(**INLINE)   # the loop's body: a call would pass the model and state records element by element
def damp_element(p, model, state, e, i):
    """Update the velocities of interior vertices i, i+1 (element e) by the flow of its dashpot
    over p.decay_h; return the kinetic energy taken. On the chord d, u = d (v_b - v_a) / |d| and
    the impulse on b is J d / |d| = (c - 1) u d / (w |d|), c the decay: only |d|^2 enters."""
    x, v = state.x, state.v
    dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    ud = dx * (v[i + 1, 0] - v[i, 0]) + dy * (v[i + 1, 1] - v[i, 1]) + dz * (v[i + 1, 2] - v[i, 2])
    s = p.gain[e] * ud / (dx * dx + dy * dy + dz * dz)   # (c - 1) u / (w |d|)
    wa, wb = model.vertex_inv_mass[i] * s, model.vertex_inv_mass[i + 1] * s
    v[i, 0] -= wa * dx
    v[i, 1] -= wa * dy
    v[i, 2] -= wa * dz
    v[i + 1, 0] += wb * dx
    v[i + 1, 1] += wb * dy
    v[i + 1, 2] += wb * dz
    return p.loss[e] * ud * s   # 1/2 (1 - c^2) u^2 / w


@njit(**INNER)
def make_decays(p, model, tau):
    """Update p.gain, p.loss for flows of length tau (p.decay_h follows)."""
    for e in range(p.gain.shape[0]):
        w = p.weight[e]
        c = math.exp(-p.rate[e] * w * tau / model.element_rest_length[e])
        p.gain[e] = (c - 1.0) / w if w > 0.0 else 0.0
        p.loss[e] = -0.5 * (1.0 + c)
    p.decay_h[0] = tau


@flow_kernel(InternalDampingParams)
@njit(**STEP)
def damp_stretching(p, model, state, h):
    """Update state.v (and the nodes at line ends: node_v, node_w) by the flow of every
    element's axial dashpot over the kick's length 2 h, once a kick: before it (even elements,
    then odd) on one kick, after it (odd, then even) on the next (p.turn: bit 0 the half, bit 1
    the side), so that two kicks form a symmetric sequence; p.dissipated by the kinetic energy
    taken (module docstring); p.gain, p.loss follow the kick's length. Elements of rate 0 are
    left alone."""
    after = p.turn[0] & 1
    side = (p.turn[0] >> 1) & 1
    p.turn[0] = 1 | (side << 1) if after == 0 else (1 - side) << 1
    if after == 0:
        for nd in p.driven:
            for k in range(3):
                p.held[nd, k], p.held[nd, 3 + k] = state.node_v[nd, k], state.node_w[nd, k]
    if after != side:
        return
    tau = 2.0 * h
    if tau != p.decay_h[0]:
        make_decays(p, model, tau)
    lost = 0.0
    vo, eo = model.line_vertex_offsets, model.line_element_offsets
    for sweep in range(2):
        odd = after ^ sweep
        for l in range(eo.shape[0] - 1):
            e0, e1 = eo[l], eo[l + 1]
            if odd == 0 and p.rate[e0] > 0.0:
                lost += damp_end_element(p, model, state, l, e0, vo[l], tau)
            for e in range(e0 + 2 - odd, e1 - 1, 2):   # an interior element of rate 0 has gain 0
                lost += damp_element(p, model, state, e, vo[l] + e - e0)
            last = e1 - 1
            if last > e0 and (last - e0) % 2 == odd and p.rate[last] > 0.0:
                lost += damp_end_element(p, model, state, l, last, vo[l] + last - e0, tau)
    p.dissipated[0] += lost
