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
Elements are taken in the order even, odd, even with flow times tau = h/2, h, h/2 (a symmetric
splitting: the flow of h is exact to O(h^3) a step, as the kick it wraps).
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import STEP
from .compiler import INNER
from .compose import flow_kernel
from .motion import place_line_end
from .rotations import cross, quat_rotate, quat_rotate_inv


class InternalDampingParams(NamedTuple):
    rate: np.ndarray         # (ne,) axial damping coefficient c of each element (N s; 0: none)
    node_weight: np.ndarray  # (nn,) inverse mass that moves each node here (0: fixed or driven)
    node_turn: np.ndarray    # (nn, 3) inverse principal inertia that turns it (0: locked, driven)
    dissipated: np.ndarray   # (1,) kinetic energy taken so far (J)


@njit(**INNER)
def end_weight(p, model, state, a, tx, ty, tz):
    """Return the inverse mass that moves line end a (an attachment) along the lab direction t:
    its node's translation, and its rotation about the centre of mass at the end's offset."""
    nd = model.attach_node[a]
    q = state.node_q[nd]
    bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], tx, ty, tz)
    o = model.attach_offset[a]
    cx, cy, cz = cross(o[0], o[1], o[2], bx, by, bz)
    turn = p.node_turn[nd]
    return p.node_weight[nd] + turn[0] * cx * cx + turn[1] * cy * cy + turn[2] * cz * cz


@njit(**INNER)
def end_velocity(model, state, a):
    """Return the lab velocity of line end a from its node's (1.1): a kick leaves the end
    vertices' own rows behind until the drift places them."""
    nd = model.attach_node[a]
    q, w, o = state.node_q[nd], state.node_w[nd], model.attach_offset[a]
    cx, cy, cz = cross(w[0], w[1], w[2], o[0], o[1], o[2])
    ux, uy, uz = quat_rotate(q[0], q[1], q[2], q[3], cx, cy, cz)
    return state.node_v[nd, 0] + ux, state.node_v[nd, 1] + uy, state.node_v[nd, 2] + uz


@njit(**INNER)
def push_end(p, model, state, a, jx, jy, jz):
    """Update node attach_node[a] by the impulse J (lab) at line end a, and its line ends (1.1)."""
    nd = model.attach_node[a]
    q = state.node_q[nd]
    bx, by, bz = quat_rotate_inv(q[0], q[1], q[2], q[3], jx, jy, jz)
    o = model.attach_offset[a]
    cx, cy, cz = cross(o[0], o[1], o[2], bx, by, bz)
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
def damp_element(p, model, state, l, e, i, tau):
    """Update the velocities of element e's vertices i, i+1 (of line l; an end: its node) by the
    exact flow of its dashpot over tau (module docstring); return the kinetic energy taken."""
    x, v = state.x, state.v
    dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    size = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not size > 0.0:
        return 0.0
    tx, ty, tz = dx / size, dy / size, dz / size
    first, last = i == model.line_vertex_offsets[l], i + 2 == model.line_vertex_offsets[l + 1]
    ax, ay, az = end_velocity(model, state, 2 * l) if first else (v[i, 0], v[i, 1], v[i, 2])
    bx, by, bz = end_velocity(model, state, 2 * l + 1) if last else (v[i + 1, 0], v[i + 1, 1], v[i + 1, 2])
    u = tx * (bx - ax) + ty * (by - ay) + tz * (bz - az)
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
    return 0.5 * (u * u - after * after) / w


@flow_kernel(InternalDampingParams)
@njit(**STEP)
def damp_stretching(p, model, state, h):
    """Update state.v (and the nodes at line ends: node_v, node_w) by the flow over h of every
    element's axial dashpot, even elements for h/2, odd for h, even for h/2 (module docstring),
    and p.dissipated by the kinetic energy taken. Elements of rate 0 are left alone."""
    lost = 0.0
    vo, eo = model.line_vertex_offsets, model.line_element_offsets
    for turn in range(3):
        odd = turn & 1
        tau = h if odd else 0.5 * h
        for l in range(eo.shape[0] - 1):
            for e in range(eo[l] + odd, eo[l + 1], 2):
                if p.rate[e] > 0.0:
                    lost += damp_element(p, model, state, l, e, vo[l] + e - eo[l], tau)
    p.dissipated[0] += lost
