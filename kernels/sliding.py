"""Mobile nodes (§8): a node held on a line's centreline at a material coordinate that moves.

A slider j keeps its node's centre of mass P on the centreline of a path of lines (one line,
or a chain whose lines meet end to start at nodes): P = (1 - t) x_i + t x_{i+1} on the element
of vertices i, i+1, at the material coordinate s = S_i + t (S_{i+1} - S_i) (S: unstretched arc
length from the path's start), which the constraint leaves free. A ring is
a node of its own mass sliding on the line; an eyelet is a node (fixed, driven or free) through
which the line slides. Both are the same constraint.

The constraint is kept as RATTLE keeps one, by impulses equal and opposite on P and on the two
vertices (weights 1 - t and t), each moving by its inverse mass (an end vertex by its node's):
- after every drift of h, P is brought onto the segment (its distance to it removed along the
  normal, a few passes to round-off) and the velocities take the impulse that displacement
  means over h; the slider passes from element to element as t leaves [0, 1], from line to line
  of its path through their junctions, and stops at the path's ends (the projection then takes
  the tangential part too);
- after every kick, the relative velocity of P across the line is removed; along the line, a
  damper c and Coulomb friction act on it: the slider sticks while the tangential impulse that
  would stop it stays within mu_s times the normal impulse of the step (the kick's and the
  drifts'), else slides against mu_k times it. The kinetic energy of the relative motion they
  take is counted as dissipated.
Where a drift takes the slider onto another element, the line turns under it by the angle
between the two: the relative velocity across the new element's chord, which it no longer
allows, is taken (by that drift's projection and the next kick) as in a plastic impact, and
its kinetic energy, |u_n|^2 / 2w as the drift brought it there, is counted as dissipated.
It is counted once the slider has settled, SETTLED of an element from the vertex, on either
side (p.corner, p.pending): a slider resting on the vertex of a kink (outside the corner of
its two elements, nearest_on_path) crosses back and forth between them at every step, and
counts only the first crossing of that stay. Elsewhere the constraint's work is the
scheme's own, second-order error, and left to it.
The impulses are equal and opposite, so they keep the momentum of a free net exactly.

Where a fluid adds mass to the line (kernels/fluid.py, added_mass.py), the kick moves a wet
vertex by its inverse mass tensor W = w_n (1 - t t^T) + w_t t t^T (t its sampled tangent) and
a free node at a wet line's end by the inverse of its mass matrix; the impulses move them by
the same, read from the fluid's own arrays (p.carried, p.carried_node_mass: the arrays the
fluid samples into, shared), so that they are the impulses that mass takes and the energy of
line and entrained fluid is kept as in air. The slider's relative displacement and velocity
then answer an impulse J by K J, K = W_P + (1 - t)^2 W_i + t^2 W_i+1, no longer along J: the
impulse across the element is found in the plane across it (K restricted to that plane), the
friction along it meets the effective inverse mass of the motion along the element with the
motion across it held (the Schur complement w* = d.K d - (K d)_n . K_n^-1 (K d)_n), and a stop
or a kink's vertex, which hold every direction, take J = -K^-1 u. With K a multiple of 1 these
are the scalar formulas above (the variant without CARRIED compiles those alone).
"""

import math
import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from .compiler import CACHED, INLINE, INNER
from .compose import constraint_kernels
from .fluid import INVERSE_ROW, TANGENT_ROW
from .motion import place_line_end
from .rotations import inverse_sym3, solve_sym3
from .specialise import Variants

PASSES = 8          # projections after a drift, at most (each leaves the square of the last misfit)
TOLERANCE = 1e-14   # misfit relative to the element's length that ends them
SETTLED = 1e-3      # fraction of an element past a vertex where a passage over it is settled

# Compile-time option (kernels/specialise.py): some vertex or node of a slider's path carries a
# fluid's added mass, and the impulses move it by a tensor. The record is of the variant its
# data needs (VARIANTS); this module's own functions are the variant with it.
CARRIED = True
OPTIONS = ("CARRIED",)


class SlidingParams(NamedTuple):
    """k sliders: their nodes, lines and state."""

    node: np.ndarray        # (k,) int64 node held on the line
    path_offsets: np.ndarray  # (k+1,) int64 CSR offsets of each slider's path into path_lines
    path_lines: np.ndarray  # (m,) int64 the lines of each path, in order (each ends where the next starts)
    path_arc: np.ndarray    # (m,) unstretched arc length of the path before each of its lines
    link: np.ndarray        # (k,) int64 the slider's line now: an index into path_lines
    node_weight: np.ndarray  # (nn,) inverse mass that moves each node here (0: fixed or driven)
    arc: np.ndarray         # (nv,) unstretched arc length of each vertex from its line's start
    mu_s: np.ndarray        # (k,) static friction coefficient
    mu_k: np.ndarray        # (k,) kinetic friction coefficient
    damping: np.ndarray     # (k,) damper on the sliding velocity (N s/m)
    at: np.ndarray          # (k,) int64 first vertex (global) of the element the node is on
    s: np.ndarray           # (k,) material coordinate (m of unstretched length)
    push: np.ndarray        # (k, 3) impulse on the node from the drifts since the last kick
    sliding: np.ndarray     # (k,) 1.0 while sliding against friction
    corner: np.ndarray      # (k,) int64 the element (first vertex) a passage not yet settled came from; -1: none
    pending: np.ndarray     # (k,) the energy that passage takes, counted once it is settled (J)
    dissipated: np.ndarray  # (1,) energy friction, dampers and passages took (J)
    carried_vertex: np.ndarray  # (nv,) 1 where the kick moves an interior vertex by the carried inverse masses
    carried_node: np.ndarray    # (nn,) 1 where it moves a node by the carried mass matrix
    carried: np.ndarray         # (SAMPLE_ROWS, nv) the fluid's sample (kernels/fluid.py), shared; (0, 0): none
    carried_node_mass: np.ndarray  # (nn, 6) the fluid's node_mass, shared; (0, 6): none


@njit(**INLINE)
def inverse_mass(p, model, l, v):
    """Return the inverse mass that moves vertex v of line l (an end vertex: its node's)."""
    off = model.line_vertex_offsets
    if v == off[l]:
        return p.node_weight[model.attach_node[2 * l]]
    if v == off[l + 1] - 1:
        return p.node_weight[model.attach_node[2 * l + 1]]
    return model.vertex_inv_mass[v]


@njit(**INNER)
def node_tensor(p, nd):
    """Return the inverse mass tensor (w00, w01, w02, w11, w12, w22) that moves node nd here:
    the inverse of the carried mass matrix where the fluid adds to it, else its weight times 1."""
    w = p.node_weight[nd]
    if CARRIED and w > 0.0 and p.carried_node[nd] != 0:
        a = p.carried_node_mass[nd]
        return inverse_sym3(a[0], a[1], a[2], a[3], a[4], a[5])
    return w, 0.0, 0.0, w, 0.0, w


@njit(**INNER)
def vertex_tensor(p, model, l, v):
    """Return the inverse mass tensor that moves vertex v of line l as the kick moves it (an
    end vertex: its node's; a wet one: w_n (1 - t t^T) + w_t t t^T as the fluid sampled it)."""
    off = model.line_vertex_offsets
    if v == off[l]:
        return node_tensor(p, model.attach_node[2 * l])
    if v == off[l + 1] - 1:
        return node_tensor(p, model.attach_node[2 * l + 1])
    if CARRIED and p.carried_vertex[v] != 0:
        S = p.carried
        wn, d = S[INVERSE_ROW, v], S[INVERSE_ROW + 1, v] - S[INVERSE_ROW, v]
        tx, ty, tz = S[TANGENT_ROW, v], S[TANGENT_ROW + 1, v], S[TANGENT_ROW + 2, v]
        return wn + d * tx * tx, d * tx * ty, d * tx * tz, wn + d * ty * ty, d * ty * tz, wn + d * tz * tz
    w = model.vertex_inv_mass[v]
    return w, 0.0, 0.0, w, 0.0, w


@njit(**INNER)
def times(a, x, y, z):
    """Return A v for the symmetric A = (a00, a01, a02, a11, a12, a22)."""
    return (a[0] * x + a[1] * y + a[2] * z, a[1] * x + a[3] * y + a[4] * z, a[2] * x + a[4] * y + a[5] * z)


@njit(**INNER)
def slider_tensor(p, j, model, i, t):
    """Return K = W_P + (1 - t)^2 W_i + t^2 W_i+1: the relative displacement of slider j's node
    from its line's point at t on element i (first vertex) per unit impulse on them."""
    l = p.path_lines[p.link[j]]
    a, b, c = node_tensor(p, p.node[j]), vertex_tensor(p, model, l, i), vertex_tensor(p, model, l, i + 1)
    u, v = (1.0 - t) ** 2, t * t
    return (a[0] + u * b[0] + v * c[0], a[1] + u * b[1] + v * c[1], a[2] + u * b[2] + v * c[2],
            a[3] + u * b[3] + v * c[3], a[4] + u * b[4] + v * c[4], a[5] + u * b[5] + v * c[5])


@njit(**INNER)
def across(k, dx, dy, dz):
    """Return P K P + tr(K) d d^T (P = 1 - d d^T, d a unit vector): K restricted to the plane
    across d, made invertible along d without coupling to it, so that solving with it for a
    right-hand side across d gives the impulse across d whose displacement across d is that."""
    kx, ky, kz = times(k, dx, dy, dz)
    dk = dx * kx + dy * ky + dz * kz
    c = k[0] + k[3] + k[5] + dk
    return (k[0] - 2.0 * dx * kx + c * dx * dx, k[1] - dx * ky - dy * kx + c * dx * dy,
            k[2] - dx * kz - dz * kx + c * dx * dz, k[3] - 2.0 * dy * ky + c * dy * dy,
            k[4] - dy * kz - dz * ky + c * dy * dz, k[5] - 2.0 * dz * kz + c * dz * dz)


@njit(**INNER)
def solve(a, x, y, z):
    """Return A^-1 v for the symmetric positive definite A (6-tuple)."""
    return solve_sym3(a[0], a[1], a[2], a[3], a[4], a[5], x, y, z)


@njit(**INNER)
def move_node(model, state, nd, dx, dv):
    """Update node nd by dx (3-tuple, position) and dv (velocity); its line ends follow (1.1)."""
    for k in range(3):
        state.node_x[nd, k] += dx[k]
        state.node_v[nd, k] += dv[k]
    for a in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        place_line_end(model.node_attach_list[a], model, state)


@njit(**INNER)
def move_vertex(model, state, l, v, dx, dv):
    """Update vertex v of line l by dx (3-tuple, position) and dv (velocity); an end vertex
    moves its node, whose line ends then follow (1.1)."""
    off = model.line_vertex_offsets
    end = 0 if v == off[l] else 1 if v == off[l + 1] - 1 else -1
    if end < 0:
        for k in range(3):
            state.x[v, k] += dx[k]
            state.v[v, k] += dv[k]
        return
    move_node(model, state, model.attach_node[2 * l + end], dx, dv)


@njit(**INNER)
def apply_impulse(p, j, model, state, i, t, jx, jy, jz, h):
    """Update the node of slider j and vertices i, i+1 by the impulse J on the node and -(1-t) J,
    -t J on the vertices: velocities by J times inverse masses, positions by h times that
    (h = 0: velocities only)."""
    l, nd = p.path_lines[p.link[j]], p.node[j]
    if CARRIED:   # each moved by its inverse mass tensor (module docstring)
        d = times(node_tensor(p, nd), jx, jy, jz)
        move_node(model, state, nd, (h * d[0], h * d[1], h * d[2]), d)
        for v, share in ((i, 1.0 - t), (i + 1, t)):
            d = times(vertex_tensor(p, model, l, v), -share * jx, -share * jy, -share * jz)
            move_vertex(model, state, l, v, (h * d[0], h * d[1], h * d[2]), d)
        return
    wp = p.node_weight[nd]
    move_node(model, state, nd, (h * wp * jx, h * wp * jy, h * wp * jz), (wp * jx, wp * jy, wp * jz))
    for v, share in ((i, 1.0 - t), (i + 1, t)):
        w = -share * inverse_mass(p, model, l, v)
        move_vertex(model, state, l, v, (h * w * jx, h * w * jy, h * w * jz), (w * jx, w * jy, w * jz))


@njit(**INNER)
def passage(p, j, model, state, i, t, came):
    """Return the energy of slider j's passage settled by this drift, which took it onto
    element i (first vertex, on its line p.link[j]) at t from element ``came`` (module
    docstring); p.corner and p.pending follow."""
    if p.corner[j] < 0 and i != came:   # a crossing: what it takes, as the drift brought it there
        p.corner[j], p.pending[j] = came, passage_loss(p, j, model, state, i, t)
    if p.corner[j] < 0 or not SETTLED < t < 1.0 - SETTLED:
        return 0.0
    taken = p.pending[j]
    p.corner[j], p.pending[j] = -1, 0.0
    return taken


@njit(**INLINE)
def relative_velocity(p, j, state, i, t):
    """Return slider j's node velocity less the line's at t on element i (first vertex)."""
    v, vp = state.v, state.node_v[p.node[j]]
    return (vp[0] - ((1.0 - t) * v[i, 0] + t * v[i + 1, 0]), vp[1] - ((1.0 - t) * v[i, 1] + t * v[i + 1, 1]),
            vp[2] - ((1.0 - t) * v[i, 2] + t * v[i + 1, 2]))


@njit(**INNER)
def passage_loss(p, j, model, state, i, t):
    """Return |u_n|^2 / 2w: the kinetic energy of slider j's velocity across element i (first
    vertex, on its line p.link[j]) relative to the line there, w their effective inverse mass:
    what a plastic impact taking it leaves out (module docstring)."""
    x = state.x
    ux, uy, uz = relative_velocity(p, j, state, i, t)
    dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
    size2 = dx * dx + dy * dy + dz * dz
    along = (ux * dx + uy * dy + uz * dz) / size2 if size2 > 0.0 else 0.0
    nx, ny, nz = ux - along * dx, uy - along * dy, uz - along * dz
    if CARRIED:   # 1/2 u_n . K_n^-1 u_n
        k = slider_tensor(p, j, model, i, t)
        if not (k[0] + k[3] + k[5] > 0.0 and size2 > 0.0):
            return 0.0
        size = math.sqrt(size2)
        jn = solve(across(k, dx / size, dy / size, dz / size), nx, ny, nz)
        return 0.5 * (nx * jn[0] + ny * jn[1] + nz * jn[2])
    w = effective_inverse_mass(p, j, model, i, t)
    return 0.5 * (nx * nx + ny * ny + nz * nz) / w if w > 0.0 else 0.0


@njit(**INLINE)
def line_span(model, l):
    """Return the first and last element's first vertex of line l."""
    return model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1] - 2


@njit(**INNER)
def nearest_on_path(p, j, model, state):
    """Return (link, i, t): the line of slider j's path (index into p.path_lines), the element
    (first vertex i) and the fraction t in [0, 1] of the point of the path nearest to the
    node, found by walking from p.link[j], p.at[j]; t stays in [0, 1] at the path's ends (the
    stops). The walk goes one way only: a node beyond the end of one element and before the
    start of the next lies outside the corner between them, and their shared vertex is the
    nearest point (walking on would swing between the two for ever)."""
    c0, c1 = p.path_offsets[j], p.path_offsets[j + 1]
    link = p.link[j]
    first, last = line_span(model, p.path_lines[link])
    i = min(max(p.at[j], first), last)
    x, xp = state.x, state.node_x[p.node[j]]
    t, way = 0.0, 0
    for _ in range(x.shape[0] + c1 - c0):
        dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
        t = ((xp[0] - x[i, 0]) * dx + (xp[1] - x[i, 1]) * dy + (xp[2] - x[i, 2]) * dz) / (dx * dx + dy * dy + dz * dz)
        if (t < 0.0 and way > 0) or (t > 1.0 and way < 0):
            break
        if t < 0.0 and i > first:
            i, way = i - 1, -1
        elif t < 0.0 and link > c0:   # on into the line before, through their junction
            link, way = link - 1, -1
            first, last = line_span(model, p.path_lines[link])
            i = last
        elif t > 1.0 and i < last:
            i, way = i + 1, 1
        elif t > 1.0 and link < c1 - 1:
            link, way = link + 1, 1
            first, last = line_span(model, p.path_lines[link])
            i = first
        else:
            break
    return link, i, min(max(t, 0.0), 1.0)


@njit(**INLINE)
def effective_inverse_mass(p, j, model, i, t):
    l = p.path_lines[p.link[j]]
    return (p.node_weight[p.node[j]] + (1.0 - t) ** 2 * inverse_mass(p, model, l, i)
            + t * t * inverse_mass(p, model, l, i + 1))


@njit(**INNER)
def drift_impulse(p, j, model, state, i, t, rx, ry, rz, size2, h):
    """Return the impulse on slider j's node that, over h, takes away its misfit r from the
    point at t on element i (first vertex; size2 its length squared) by the inverse mass
    tensors: across the element only where t lies within it, in every direction at a stop or
    a kink's vertex (t = 0 or 1); (0, 0, 0) where nothing can move."""
    k = slider_tensor(p, j, model, i, t)
    if not k[0] + k[3] + k[5] > 0.0:
        return 0.0, 0.0, 0.0
    if 0.0 < t < 1.0:
        x = state.x
        size = math.sqrt(size2)
        k = across(k, (x[i + 1, 0] - x[i, 0]) / size, (x[i + 1, 1] - x[i, 1]) / size, (x[i + 1, 2] - x[i, 2]) / size)
    return solve(k, -rx / h, -ry / h, -rz / h)


@njit(**CACHED)
def slide_after_drift(p, model, state, h):
    """Update the positions and velocities of every slider's node and line after a drift of h:
    the node back on the line's centreline (module docstring); p.at, p.s, p.push, the passages
    (p.corner, p.pending) and p.dissipated follow."""
    x = state.x
    lost = 0.0
    for j in range(p.node.shape[0]):
        nd = p.node[j]
        i, t = p.at[j], 0.0
        came = p.at[j]
        for k in range(PASSES):
            link, i, t = nearest_on_path(p, j, model, state)
            p.link[j], p.at[j] = link, i
            if k == 0:   # where the drift took it, before the projection moves anything
                lost += passage(p, j, model, state, i, t, came)
            xp = state.node_x[nd]
            rx = xp[0] - (x[i, 0] + t * (x[i + 1, 0] - x[i, 0]))
            ry = xp[1] - (x[i, 1] + t * (x[i + 1, 1] - x[i, 1]))
            rz = xp[2] - (x[i, 2] + t * (x[i + 1, 2] - x[i, 2]))
            size2 = (x[i + 1, 0] - x[i, 0]) ** 2 + (x[i + 1, 1] - x[i, 1]) ** 2 + (x[i + 1, 2] - x[i, 2]) ** 2
            if rx * rx + ry * ry + rz * rz <= TOLERANCE * TOLERANCE * size2 or not h > 0.0:
                break
            if CARRIED:
                jx, jy, jz = drift_impulse(p, j, model, state, i, t, rx, ry, rz, size2, h)
                if jx == 0.0 and jy == 0.0 and jz == 0.0:
                    break
            else:
                w = effective_inverse_mass(p, j, model, i, t)
                if not w > 0.0:
                    break
                jx, jy, jz = -rx / (w * h), -ry / (w * h), -rz / (w * h)
            apply_impulse(p, j, model, state, i, t, jx, jy, jz, h)
            p.push[j, 0] += jx
            p.push[j, 1] += jy
            p.push[j, 2] += jz
        p.s[j] = p.path_arc[p.link[j]] + p.arc[i] + t * (p.arc[i + 1] - p.arc[i])
    p.dissipated[0] += lost


@njit(**INNER)
def friction_impulse(ut, w, normal, h, c, mu_s, mu_k, sliding):
    """Return (impulse, sliding) along a contact of relative sliding velocity ut and effective
    inverse mass w: a damper c (implicit over h) and Coulomb friction against the normal impulse
    magnitude of the step: sticks while the impulse that would stop it is within mu_s times it
    (mu_k once sliding), else slides against mu_k times it."""
    jd = -c * h * ut / (1.0 + c * h * w)
    u1 = ut + w * jd
    stop = -u1 / w
    if mu_s == 0.0 and mu_k == 0.0:
        return jd, 1.0 if u1 != 0.0 else 0.0
    limit = (mu_k if sliding != 0.0 else mu_s) * normal
    if abs(stop) <= limit:
        return jd + stop, 0.0
    return jd + math.copysign(min(mu_k * normal, abs(stop)), stop), 1.0


@njit(**CACHED)
def slide_after_kick(p, model, state, arg):
    """Update the velocities of every slider's node and line after a kick of h (arg = (loads,
    h)): the relative velocity across the line removed, the damper and friction along it
    (module docstring); p.dissipated, p.sliding follow and p.push is spent."""
    h = arg[1]
    x = state.x
    lost = 0.0
    for j in range(p.node.shape[0]):
        i = p.at[j]
        span = p.arc[i + 1] - p.arc[i]
        t = min(max((p.s[j] - p.path_arc[p.link[j]] - p.arc[i]) / span, 0.0), 1.0) if span > 0.0 else 0.0
        dx, dy, dz = x[i + 1, 0] - x[i, 0], x[i + 1, 1] - x[i, 1], x[i + 1, 2] - x[i, 2]
        size = math.sqrt(dx * dx + dy * dy + dz * dz)
        tx, ty, tz = dx / size, dy / size, dz / size
        ux, uy, uz = relative_velocity(p, j, state, i, t)
        ut = ux * tx + uy * ty + uz * tz
        if CARRIED:
            k = slider_tensor(p, j, model, i, t)
            if not k[0] + k[3] + k[5] > 0.0:
                continue
            # the impulse across that holds the motion across at rest, with the friction's
            # impulse jt along: n + jt m (module docstring)
            kn = across(k, tx, ty, tz)
            nx, ny, nz = solve(kn, -(ux - ut * tx), -(uy - ut * ty), -(uz - ut * tz))
            kx, ky, kz = times(k, tx, ty, tz)
            kt = kx * tx + ky * ty + kz * tz
            mx, my, mz = solve(kn, -(kx - kt * tx), -(ky - kt * ty), -(kz - kt * tz))
            ut = ut + kx * nx + ky * ny + kz * nz
            w = kt + kx * mx + ky * my + kz * mz
        else:
            w = effective_inverse_mass(p, j, model, i, t)
            if not w > 0.0:
                continue
            nx, ny, nz = -(ux - ut * tx) / w, -(uy - ut * ty) / w, -(uz - ut * tz) / w
            mx, my, mz = 0.0, 0.0, 0.0
        pt = p.push[j, 0] * tx + p.push[j, 1] * ty + p.push[j, 2] * tz
        px, py, pz = p.push[j, 0] - pt * tx, p.push[j, 1] - pt * ty, p.push[j, 2] - pt * tz
        normal = math.sqrt((nx + px) ** 2 + (ny + py) ** 2 + (nz + pz) ** 2)
        p.push[j, 0], p.push[j, 1], p.push[j, 2] = 0.0, 0.0, 0.0
        first = line_span(model, p.path_lines[p.path_offsets[j]])[0]
        last = line_span(model, p.path_lines[p.path_offsets[j + 1] - 1])[1]
        at_start = t == 0.0 and i == first and ut < 0.0
        at_end = t == 1.0 and i == last and ut > 0.0
        if at_start or at_end:   # a stop: the slider does not leave the line
            jt = -ut / w
        else:
            jt, p.sliding[j] = friction_impulse(ut, w, normal, h, p.damping[j], p.mu_s[j], p.mu_k[j],
                                                p.sliding[j])
            after = ut + w * jt
            lost += 0.5 * (ut * ut - after * after) / w
        apply_impulse(p, j, model, state, i, t, nx + jt * (tx + mx), ny + jt * (ty + my), nz + jt * (tz + mz), 0.0)
    p.dissipated[0] += lost


constraint_kernels(SlidingParams, slide_after_drift, slide_after_kick)


VARIANTS = Variants(SlidingParams, lambda: (sys.modules[__name__],), OPTIONS,
                    lambda cls, kernels: constraint_kernels(cls, kernels["slide_after_drift"],
                                                            kernels["slide_after_kick"]), __name__)


def carries(p) -> bool:
    """Whether record ``p`` (a slider's or a sheave's) moves some vertex or node by a carried
    mass: the CARRIED option of its variant."""
    return bool(p.carried_vertex.any() or p.carried_node.any())


def sliding_record(p):
    """``p`` (a SlidingParams) as the record of the variant its data needs, sharing its arrays."""
    return VARIANTS.record(p, (carries(p),))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it
