"""Sheaves (§8): a line that slides over a wheel's rim, turning sharply about it.

A sheave j is a circle of radius R about a centre c (its node's centre of mass plus a fixed
offset: the node does not turn) in the plane normal to a unit axis a. A vertex's relative
position d = x - c splits into z = d.a along the axis and rho = d - z a in the plane; the
rim's point is c + R rho / |rho|. The line's vertices near it (a window lo..hi of its
vertices, followed as the line slides) may lie on the rim but not inside it: a vertex that a
drift brings inside, within the rim's half-width of the plane, engages (one farther off passes
beside the wheel); an engaged vertex is held on the rim to round-off, free to slide along and
across it, and leaves it past its edge. The constraint is kept as RATTLE keeps one
(kernels/sliding.py does it for rings), by impulses equal and opposite on the vertex and on
the sheave's node, each moving by its inverse mass (a fixed or driven node not at all):
- after every drift of h, each vertex inside the rim or engaged is put back on it (a few
  passes when the node moves too) and the velocities take the impulse that displacement means
  over h; those impulses and displacements are summed (push, moved);
- after every kick, an engaged vertex's relative velocity into or out of the rim (radial) is
  removed, unless the radial impulse of the step (the drifts' and this one) would pull it onto
  the rim: then it lets go, the step's drift impulses and displacements undone, as a rope
  leaves a wheel where its tension no longer presses it there.
Without friction the line slides freely along the rim: a wheel on perfect bearings. With
friction (a drum that does not turn), after every kick an engaged vertex's velocity along the
rim's surface is stopped while the impulse that takes stays within mu_s times the step's normal
impulse on it, else it slides against mu_k times it (a damper beside): vertex by vertex the
capstan law. Friction's work over the kick is taken on the mean of the vertex's velocity
before the kick's loads and after the friction (a vertex that stays stuck does none). A vertex
lands on the rim as a plastic impact: the kinetic energy of its approach (its relative
velocity into the rim before the drift that brought it there) is counted as dissipated (and no
longer if the next kick lets the vertex go, undoing the landing with the rest); for a line that
runs onto the wheel it goes to zero with the turn of one element over the rim. The impulses
keep a free net's momentum.

Where a fluid adds mass to the line or the node (kernels/sliding.py says how rings take it),
the impulses move a wet vertex and the node by the inverse mass tensors the kick divides by,
read from the fluid's own arrays: K = W_v + W_node. The rim holds the vertex along the radial
n alone, whose effective inverse mass is n.K n; the radial impulse then moves the vertex
along the rim a little too, and friction along the slip s, the radial motion held, meets
s.K s - (n.K s)^2 / n.K n and comes with the radial impulse that holds it. With K a multiple of
1 these are the scalar formulas above (the variant without CARRIED compiles those alone).
"""

import math
import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from .compiler import CACHED, INLINE, INNER
from .compose import constraint_kernels
from .sliding import PASSES, TOLERANCE, carries, friction_impulse, inverse_mass, move_node, move_vertex, \
    node_tensor, times, vertex_tensor
from .specialise import Variants

REACH = 1.5    # the window: the run of the line's vertices within REACH * R of the centre

# Compile-time option (kernels/specialise.py): the line or node carries a fluid's added mass
# (the variant with it moves them by tensors). This module's own functions have it.
CARRIED = True
OPTIONS = ("CARRIED",)


class SheaveParams(NamedTuple):
    """k sheaves: their nodes, geometry and the state of the vertices near them."""

    node: np.ndarray        # (k,) int64 node the sheave moves with (its rotation locked)
    line: np.ndarray        # (k,) int64 line that runs over it
    offset: np.ndarray      # (k, 3) centre minus the node's centre of mass (lab frame)
    axis: np.ndarray        # (k, 3) unit normal of the sheave's plane
    radius: np.ndarray      # (k,) radius of the rim the line's centreline wraps (m)
    groove: np.ndarray      # (k,) half-width of the rim: a vertex farther off the plane passes beside
    mu_s: np.ndarray        # (k,) static friction coefficient of the rim
    mu_k: np.ndarray        # (k,) kinetic friction coefficient
    damping: np.ndarray     # (k,) damper on an engaged vertex's sliding velocity (N s/m)
    node_weight: np.ndarray  # (nn,) inverse mass that moves each node here (0: fixed or driven)
    near: np.ndarray        # (k,) int64 vertex (global) nearest the centre at the last drift
    lo: np.ndarray          # (k,) int64 first vertex of the window
    hi: np.ndarray          # (k,) int64 last vertex of the window
    engaged: np.ndarray     # (nv,) 1.0 while the vertex is held on a rim
    push: np.ndarray        # (nv, 3) impulse on the vertex from the drifts since the last kick
    moved: np.ndarray       # (nv, 3) the displacement it meant (the impulses times their drifts' h)
    sliding: np.ndarray     # (nv,) 1.0 while the engaged vertex slides against friction
    landing: np.ndarray     # (nv,) kinetic energy of a landing in this step's drifts (counted as it
                            # lands; a vertex the kick lets go undoes it)
    dissipated: np.ndarray  # (1,) energy the landings, friction and dampers took (J)
    carried_vertex: np.ndarray  # (nv,) 1 where the kick moves an interior vertex by the carried inverse masses
    carried_node: np.ndarray    # (nn,) 1 where it moves a node by the carried mass matrix
    carried: np.ndarray         # (SAMPLE_ROWS, nv) the fluid's sample (kernels/fluid.py), shared; (0, 0): none
    carried_node_mass: np.ndarray  # (nn, 6) the fluid's node_mass, shared; (0, 6): none


@njit(**INLINE)
def rim_frame(p, j, state, v):
    """Return (rx, ry, rz, rho, z): vertex v's in-plane offset from sheave j's centre, its
    length and the offset along the axis."""
    nd, a = p.node[j], p.axis[j]
    dx = state.x[v, 0] - state.node_x[nd, 0] - p.offset[j, 0]
    dy = state.x[v, 1] - state.node_x[nd, 1] - p.offset[j, 1]
    dz = state.x[v, 2] - state.node_x[nd, 2] - p.offset[j, 2]
    z = dx * a[0] + dy * a[1] + dz * a[2]
    rx, ry, rz = dx - z * a[0], dy - z * a[1], dz - z * a[2]
    return rx, ry, rz, math.sqrt(rx * rx + ry * ry + rz * rz), z


@njit(**INNER)
def centre_distance2(p, j, state, v):
    nd = p.node[j]
    return ((state.x[v, 0] - state.node_x[nd, 0] - p.offset[j, 0]) ** 2
            + (state.x[v, 1] - state.node_x[nd, 1] - p.offset[j, 1]) ** 2
            + (state.x[v, 2] - state.node_x[nd, 2] - p.offset[j, 2]) ** 2)


@njit(**INLINE)
def own_end(p, j, model, v):
    """True if vertex v is an end of sheave j's line held by the sheave's own node (which the
    rim cannot push)."""
    l, off = p.line[j], model.line_vertex_offsets
    return ((v == off[l] and model.attach_node[2 * l] == p.node[j])
            or (v == off[l + 1] - 1 and model.attach_node[2 * l + 1] == p.node[j]))


@njit(**INNER)
def find_window(p, j, model, state):
    """Update p.near, p.lo, p.hi of sheave j: the run of vertices within REACH * R of its
    centre, moved at its ends from the last (a rope slides a fraction of an element a step);
    when it has shrunk to one vertex, about the vertex nearest the centre, walking from the
    last. A vertex the window leaves is free."""
    l, off = p.line[j], model.line_vertex_offsets
    first, last = off[l], off[l + 1] - 1
    lo, hi = min(max(p.lo[j], first), last), min(max(p.hi[j], first), last)
    if lo >= hi:
        v = lo
        d = centre_distance2(p, j, state, v)
        for _ in range(last - first + 1):
            if v > first and centre_distance2(p, j, state, v - 1) < d:
                v -= 1
            elif v < last and centre_distance2(p, j, state, v + 1) < d:
                v += 1
            else:
                break
            d = centre_distance2(p, j, state, v)
        if v != lo:
            free_vertex(p, lo)
        p.near[j] = v
        lo, hi = v, v
    reach = (REACH * p.radius[j]) ** 2
    while lo > first and centre_distance2(p, j, state, lo - 1) < reach:
        lo -= 1
    while lo < hi and not centre_distance2(p, j, state, lo) < reach:
        free_vertex(p, lo)
        lo += 1
    while hi < last and centre_distance2(p, j, state, hi + 1) < reach:
        hi += 1
    while hi > lo and not centre_distance2(p, j, state, hi) < reach:
        free_vertex(p, hi)
        hi -= 1
    p.lo[j], p.hi[j] = lo, hi


@njit(**INLINE)
def free_vertex(p, v):
    """Update vertex v's rim state: free of the rim (the window has left it)."""
    p.engaged[v], p.sliding[v], p.landing[v] = 0.0, 0.0, 0.0
    for k in range(3):
        p.push[v, k], p.moved[v, k] = 0.0, 0.0


@njit(**INNER)   # called, not inlined: three inlined copies cost about 2 s more at a first compile
def push_pair(p, j, model, state, v, jx, jy, jz, dx, dy, dz):
    """Update vertex v and sheave j's node by the impulse J on the vertex and -J on the node and
    by the displacement D that its integral over time means: velocities by J, positions by D,
    times their inverse masses."""
    l, nd = p.line[j], p.node[j]
    if CARRIED:   # by the inverse mass tensors (module docstring)
        wv, wn = vertex_tensor(p, model, l, v), node_tensor(p, nd)
        move_vertex(model, state, l, v, times(wv, dx, dy, dz), times(wv, jx, jy, jz))
        if p.node_weight[nd] > 0.0:
            d, u = times(wn, dx, dy, dz), times(wn, jx, jy, jz)
            move_node(model, state, nd, (-d[0], -d[1], -d[2]), (-u[0], -u[1], -u[2]))
        return
    wv, wn = inverse_mass(p, model, l, v), p.node_weight[nd]
    move_vertex(model, state, l, v, (wv * dx, wv * dy, wv * dz), (wv * jx, wv * jy, wv * jz))
    if wn > 0.0:
        move_node(model, state, nd, (-wn * dx, -wn * dy, -wn * dz), (-wn * jx, -wn * jy, -wn * jz))


@njit(**INNER)
def pair_tensors(p, j, model, v):
    """Return (W_v, W_node, K = W_v + W_node): the inverse mass tensors of vertex v and sheave
    j's node, and the relative displacement of the vertex from the centre per unit impulse."""
    a, b = vertex_tensor(p, model, p.line[j], v), node_tensor(p, p.node[j])
    return a, b, (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3], a[4] + b[4], a[5] + b[5])


@njit(**INNER)
def pair_weight(p, j, model, v, nx, ny, nz):
    """Return the effective inverse mass of vertex v and sheave j's node along the unit n."""
    if CARRIED:
        kx, ky, kz = times(pair_tensors(p, j, model, v)[2], nx, ny, nz)
        return nx * kx + ny * ky + nz * kz
    return inverse_mass(p, model, p.line[j], v) + p.node_weight[p.node[j]]


@njit(**CACHED)
def wrap_after_drift(p, model, state, h):
    """Update the positions and velocities of the vertices near every sheave and of its node
    after a drift of h: each vertex inside a rim or engaged on it back on the rim (module
    docstring); p.near, p.lo, p.hi, p.engaged, p.push, p.moved, p.landing and p.dissipated
    (landings) follow."""
    for j in range(p.node.shape[0]):
        find_window(p, j, model, state)
        R = p.radius[j]
        for _ in range(PASSES):
            worst = 0.0
            for v in range(p.lo[j], p.hi[j] + 1):
                rx, ry, rz, rho, z = rim_frame(p, j, state, v)
                inside = rho < R and abs(z) <= p.groove[j]
                if not (inside or p.engaged[v] != 0.0) or not rho > TOLERANCE * R or own_end(p, j, model, v):
                    continue
                w = pair_weight(p, j, model, v, rx / rho, ry / rho, rz / rho)
                if not (w > 0.0 and h > 0.0):
                    continue
                if p.engaged[v] == 0.0:   # a plastic landing: the approach's kinetic energy is taken
                    nd = p.node[j]
                    ur = ((state.v[v, 0] - state.node_v[nd, 0]) * rx + (state.v[v, 1] - state.node_v[nd, 1]) * ry
                          + (state.v[v, 2] - state.node_v[nd, 2]) * rz) / rho
                    landing = 0.5 * min(ur, 0.0) ** 2 / w
                    p.landing[v] += landing
                    p.dissipated[0] += landing
                    p.engaged[v] = 1.0
                out = R / rho - 1.0          # the rim's point less the vertex: out * rho
                mx, my, mz = out * rx, out * ry, out * rz
                worst = max(worst, abs(out) * rho)
                push_pair(p, j, model, state, v, mx / (w * h), my / (w * h), mz / (w * h), mx / w, my / w, mz / w)
                p.push[v, 0] += mx / (w * h)
                p.push[v, 1] += my / (w * h)
                p.push[v, 2] += mz / (w * h)
                p.moved[v, 0] += mx / w
                p.moved[v, 1] += my / w
                p.moved[v, 2] += mz / w
            # a fixed wheel: one pass is exact, unless a tensor moved the vertices along the rim too
            if worst <= TOLERANCE * R or (p.node_weight[p.node[j]] == 0.0 and not CARRIED):
                break


@njit(**INNER)
def slip_rate(loads, v, nd, a, b):
    """Return a.f_v - b.f_nd: the rate at which the kick's loads change vertex v's velocity
    relative to node nd along the unit s, given a = W_v s and b = W_node s."""
    f, fn = loads.f, loads.node_f
    return (a[0] * f[v, 0] + a[1] * f[v, 1] + a[2] * f[v, 2]) - (b[0] * fn[nd, 0] + b[1] * fn[nd, 1] + b[2] * fn[nd, 2])


@njit(**CACHED)
def wrap_after_kick(p, model, state, arg):
    """Update the velocities of the engaged vertices near every sheave and of its node after a
    kick of h (arg = (loads, h)): their relative velocity across the rim removed while the rim
    presses them, friction and the damper along it (module docstring); p.engaged, p.sliding
    and p.dissipated (friction, landings) follow and p.push, p.moved, p.landing are spent."""
    h = arg[1]
    lost = 0.0
    for j in range(p.node.shape[0]):
        nd = p.node[j]
        for v in range(p.lo[j], p.hi[j] + 1):
            if p.engaged[v] == 0.0:
                continue
            rx, ry, rz, rho, z = rim_frame(p, j, state, v)
            if not rho > 0.0:
                continue
            nx, ny, nz = rx / rho, ry / rho, rz / rho
            if CARRIED:   # the pair's tensors, once a vertex: K n gives the radial weight and its coupling
                wv, wn, pk = pair_tensors(p, j, model, v)
                kn = times(pk, nx, ny, nz)
                w = nx * kn[0] + ny * kn[1] + nz * kn[2]
            else:
                w = pair_weight(p, j, model, v, nx, ny, nz)
            if not w > 0.0:
                continue
            ux, uy, uz = (state.v[v, 0] - state.node_v[nd, 0], state.v[v, 1] - state.node_v[nd, 1],
                          state.v[v, 2] - state.node_v[nd, 2])
            radial = -(ux * nx + uy * ny + uz * nz) / w
            normal = p.push[v, 0] * nx + p.push[v, 1] * ny + p.push[v, 2] * nz + radial   # the step's, outward
            if not normal >= 0.0 or abs(z) > p.groove[j]:
                # the rim would have to pull (or the vertex has slid past its edge): it lets go, as
                # if the rim had not held it this step (its drifts' impulses and displacements
                # undone: kept, the pull's displacement against the line's tension would add to
                # its energy)
                lost -= p.landing[v]   # the landing is undone with the rest
                p.engaged[v], p.sliding[v], p.landing[v] = 0.0, 0.0, 0.0
                push_pair(p, j, model, state, v, -p.push[v, 0], -p.push[v, 1], -p.push[v, 2], -p.moved[v, 0],
                          -p.moved[v, 1], -p.moved[v, 2])
            else:
                # friction against the relative velocity along the rim's surface, its normal
                # impulse the step's (drifts' and this kick's); its work over the kick taken on
                # the mean of the velocities before the kick's loads and after it (a stuck
                # vertex does none)
                if CARRIED:   # the radial impulse moves the vertex along the rim too
                    ux, uy, uz = ux + radial * kn[0], uy + radial * kn[1], uz + radial * kn[2]
                    ur = ux * nx + uy * ny + uz * nz
                else:
                    ur = -radial * w
                sx, sy, sz = ux - ur * nx, uy - ur * ny, uz - ur * nz
                slip = math.sqrt(sx * sx + sy * sy + sz * sz)
                jt, mx, my, mz = 0.0, 0.0, 0.0, 0.0
                if slip > 0.0 and (p.mu_s[j] > 0.0 or p.damping[j] > 0.0):   # else a wheel on free bearings
                    sx, sy, sz = sx / slip, sy / slip, sz / slip
                    if CARRIED:   # along s with the radial motion held: the radial share m of the impulse
                        ks = times(pk, sx, sy, sz)
                        ns = nx * ks[0] + ny * ks[1] + nz * ks[2]
                        mu = -ns / w
                        mx, my, mz = mu * nx, mu * ny, mu * nz
                        ws = sx * ks[0] + sy * ks[1] + sz * ks[2] + mu * ns
                        rate = slip_rate(arg[0], v, nd, times(wv, sx, sy, sz), times(wn, sx, sy, sz))
                    else:
                        ws, a, b = w, inverse_mass(p, model, p.line[j], v), p.node_weight[nd]
                        rate = slip_rate(arg[0], v, nd, (a * sx, a * sy, a * sz), (b * sx, b * sy, b * sz))
                    jt, p.sliding[v] = friction_impulse(slip, ws, normal, h, p.damping[j], p.mu_s[j], p.mu_k[j],
                                                        p.sliding[v])
                    before = slip - h * rate
                    lost -= jt * 0.5 * (before + slip + ws * jt)
                push_pair(p, j, model, state, v, radial * nx + jt * (sx + mx), radial * ny + jt * (sy + my),
                          radial * nz + jt * (sz + mz), 0.0, 0.0, 0.0)
                p.landing[v] = 0.0
            for k in range(3):
                p.push[v, k], p.moved[v, k] = 0.0, 0.0
    p.dissipated[0] += lost


constraint_kernels(SheaveParams, wrap_after_drift, wrap_after_kick)


VARIANTS = Variants(SheaveParams, lambda: (sys.modules[__name__],), OPTIONS,
                    lambda cls, kernels: constraint_kernels(cls, kernels["wrap_after_drift"],
                                                            kernels["wrap_after_kick"]), __name__)


def sheave_record(p):
    """``p`` (a SheaveParams) as the record of the variant its data needs, sharing its arrays."""
    return VARIANTS.record(p, (carries(p),))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it
