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
On a line that carries a fluid's added mass (kernels/fluid.py), the kick moves a vertex by the
inverse mass tensor W = w_n (1 - s s^T) + w_t s s^T (s its sampled tangent, w_n and w_t its
inverse masses across and along the line, the water's share included) and a node by the
inverse of its mass matrix: the impulse J t then moves the vertex by W t J, and w is t^T W t
summed over the two ends. The same flow, with those w, is exact for those masses and takes
the kinetic energy of the line and the water it carries (the record shares the fluid's
sampled arrays, cosnet/effects/carried.py; the variant without CARRIED compiles the scalar
formulas alone).
The dashpots run as half flows on both sides of every kick, mirrored: before it the even
elements then the odd, after it the odd then the even (p.turn), so that every step is the
symmetric sequence F_eo K F_oe D (order 2). Run once a kick for the kick's length, alternately
before and after it, a dashpot stiff against the step (its rate times the step of order one)
made the pair of steps unstable near the step's own limit (a split of an exact flow so placed
is not bounded by the kick and drift's stability); mirrored halves are. The interior elements'
decay factors are made once for the half kick's length (p.decay_h), and take no square root
(the chord's length enters only squared).
"""

import math
import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import STEP
from .compiler import INLINE, INNER
from .compose import flow_kernel
from .fluid import INVERSE_ROW, TANGENT_ROW, split
from .motion import place_line_end
from .rotations import cross, quat_rotate, quat_rotate_inv
from .sliding import carries, node_tensor, times
from .specialise import Variants

# Compile-time option (kernels/specialise.py): some damped line or node carries a fluid's added
# mass; the dry variant compiles the scalar inverse masses alone.
CARRIED = True
OPTIONS = ("CARRIED",)


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
    turn: np.ndarray         # (1,) int64: 0 before a kick, 1 after
    dissipated: np.ndarray   # (1,) kinetic energy taken so far (J)
    carried_vertex: np.ndarray  # (nv,) 1 at the vertices of damped lines a fluid adds mass to
    carried_node: np.ndarray    # (nn,) 1 where the kick moves a node by the fluid's mass matrix
    carried: np.ndarray         # (SAMPLE_ROWS, nv) the fluid's sample (kernels/fluid.py), shared; (0, 0): none
    carried_node_mass: np.ndarray  # (nn, 6) the fluid's node_mass, shared; (0, 6): none
    carried_decay: np.ndarray   # (ne,) scratch: each element's decay c on a carried line as the flow before the
                                # kick made it, which the flow after it takes again (the same positions and
                                # masses: one exponential a kick); (0,) where no line is carried


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
    w = p.node_weight[nd]
    if CARRIED and p.carried_node[nd] != 0:   # t^T W t, W the inverse of its mass matrix
        g = times(node_tensor(p, nd), tx, ty, tz)
        w = g[0] * tx + g[1] * ty + g[2] * tz
    return w + turn[0] * cx * cx + turn[1] * cy * cy + turn[2] * cz * cz


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
    gx, gy, gz = w * jx, w * jy, w * jz
    if CARRIED and p.carried_node[nd] != 0:
        gx, gy, gz = times(node_tensor(p, nd), jx, jy, jz)
    state.node_v[nd, 0] += gx
    state.node_v[nd, 1] += gy
    state.node_v[nd, 2] += gz
    state.node_w[nd, 0] += turn[0] * cx
    state.node_w[nd, 1] += turn[1] * cy
    state.node_w[nd, 2] += turn[2] * cz
    for k in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        place_line_end(model.node_attach_list[k], model, state)


@njit(**INNER)
def vertex_push(p, model, i, tx, ty, tz):
    """Return (W t, t^T W t): the velocity a unit impulse along the unit t gives interior vertex
    i and its part along t (W: its inverse mass tensor as the kick holds it, module docstring)."""
    if CARRIED and p.carried_vertex[i] != 0:
        g = carried_push(p.carried, i, tx, ty, tz)
        return g[0], g[1], g[2], g[0] * tx + g[1] * ty + g[2] * tz
    w = model.vertex_inv_mass[i]
    return w * tx, w * ty, w * tz, w


@njit(**INLINE)
def carried_push(S, i, dx, dy, dz):
    """Return W d at interior vertex i of a line that carries added mass, W = w_n (1 - s s^T) +
    w_t s s^T with s, w_n, w_t the fluid's sample rows (S: p.carried)."""
    return split(S[INVERSE_ROW, i], S[INVERSE_ROW + 1, i], dx, dy, dz, S[TANGENT_ROW, i], S[TANGENT_ROW + 1, i],
                 S[TANGENT_ROW + 2, i])


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
    # each end's W t and t^T W t (an end on a node: its node moves, push_end)
    if first:
        ga = (0.0, 0.0, 0.0, end_weight(p, model, state, 2 * l, tx, ty, tz))
    else:
        ga = vertex_push(p, model, i, tx, ty, tz)
    if last:
        gb = (0.0, 0.0, 0.0, end_weight(p, model, state, 2 * l + 1, tx, ty, tz))
    else:
        gb = vertex_push(p, model, i + 1, tx, ty, tz)
    wa, wb = ga[3], gb[3]
    w = wa + wb
    if not w > 0.0:
        return 0.0
    after = u * math.exp(-p.rate[e] * w * tau / model.element_rest_length[e])
    j = (after - u) / w
    if first:
        push_end(p, model, state, 2 * l, -j * tx, -j * ty, -j * tz)
    else:
        v[i, 0] -= j * ga[0]
        v[i, 1] -= j * ga[1]
        v[i, 2] -= j * ga[2]
    if last:
        push_end(p, model, state, 2 * l + 1, j * tx, j * ty, j * tz)
    else:
        v[i + 1, 0] += j * gb[0]
        v[i + 1, 1] += j * gb[1]
        v[i + 1, 2] += j * gb[2]
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


@njit(**INLINE)   # as damp_element
def damp_carried_element(p, model, state, e, i, tau, after):
    """Update the velocities of interior vertices i, i+1 (element e) of a line that carries added
    mass by the flow of its dashpot over tau; return the kinetic energy taken (of the line and
    its water). On the chord d, with g = W d at each end: u = d (v_b - v_a) / |d|, w = d (g_a +
    g_b) / |d|^2, and the impulse J d / |d| moves b by (c - 1) (d (v_b - v_a)) g_b / (d (g_a + g_b)):
    only |d|^2 enters, but the decay c = exp(-c w tau / l0) is made here (w changes as the line
    turns; after the kick, the one before it, p.carried_decay)."""
    x, v = state.x, state.v
    dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    ga, gb = carried_push(p.carried, i, dx, dy, dz), carried_push(p.carried, i + 1, dx, dy, dz)
    wd = dx * (ga[0] + gb[0]) + dy * (ga[1] + gb[1]) + dz * (ga[2] + gb[2])   # w |d|^2
    dd = dx * dx + dy * dy + dz * dz
    if not (wd > 0.0 and dd > 0.0):
        return 0.0
    ud = dx * (v[i + 1, 0] - v[i, 0]) + dy * (v[i + 1, 1] - v[i, 1]) + dz * (v[i + 1, 2] - v[i, 2])
    if after == 0:
        c = math.exp(-p.rate[e] * tau * wd / (dd * model.element_rest_length[e]))
        p.carried_decay[e] = c
    else:
        c = p.carried_decay[e]
    s = (c - 1.0) * ud / wd
    v[i, 0] -= s * ga[0]
    v[i, 1] -= s * ga[1]
    v[i, 2] -= s * ga[2]
    v[i + 1, 0] += s * gb[0]
    v[i + 1, 1] += s * gb[1]
    v[i + 1, 2] += s * gb[2]
    return 0.5 * (1.0 - c * c) * ud * ud / wd   # 1/2 (1 - c^2) u^2 / w


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
    element's axial dashpot over half a kick, h, on both sides of every kick: before it even
    elements then odd, after it odd then even (p.turn: the side), so that every step is a
    symmetric sequence; p.dissipated by the kinetic energy taken (module docstring); p.gain,
    p.loss follow h. Elements of rate 0 are left alone."""
    after = p.turn[0] & 1
    p.turn[0] = 1 - after
    if after == 0:
        for nd in p.driven:
            for k in range(3):
                p.held[nd, k], p.held[nd, 3 + k] = state.node_v[nd, k], state.node_w[nd, k]
    tau = h
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
            if CARRIED and p.carried_vertex[vo[l]] != 0:
                for e in range(e0 + 2 - odd, e1 - 1, 2):
                    lost += damp_carried_element(p, model, state, e, vo[l] + e - e0, tau, after)
            else:
                for e in range(e0 + 2 - odd, e1 - 1, 2):   # an interior element of rate 0 has gain 0
                    lost += damp_element(p, model, state, e, vo[l] + e - e0)
            last = e1 - 1
            if last > e0 and (last - e0) % 2 == odd and p.rate[last] > 0.0:
                lost += damp_end_element(p, model, state, l, last, vo[l] + last - e0, tau)
    p.dissipated[0] += lost


def _register(cls, kernels):
    flow_kernel(cls)(kernels["damp_stretching"])


VARIANTS = Variants(InternalDampingParams, lambda: (sys.modules[__name__],), OPTIONS, _register, __name__)


def damping_record(p):
    """``p`` (an InternalDampingParams) as the record of the variant its data needs, sharing its
    arrays: CARRIED where some damped vertex or node carries a fluid's added mass."""
    return VARIANTS.record(p, (carries(p),))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it
