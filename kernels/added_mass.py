"""Kernels of the fluid a line carries with it (its added mass), as the kick sees it.

A wet vertex i carries the entrained fluid's kinetic energy T_i = 1/2 u^T M_i u, u = v - U,
M_i = w_i l_i (a_n 1 + (a_t - a_n) t t^T) (w_i its wetness, l_i its Voronoi length, t the
unit chord c / |c| between its neighbours, the end element's at a line end). Lagrange's
equations for the line and this fluid,

    d/dt ((m + M) u) - dT/dx = f,   so   (m + M) v' = f - M' u + sum_k dT_k/dx,

hold two forces beside the kick's f / (m + M) (``kick_fluid``) that Morison's equation
leaves out (``add_turning_forces``):
- -M' u, the entrained momentum turning with the line, M' = w l (a_t - a_n) (t' t^T + t t'^T),
  t' = (1 - t t^T)(v_b - v_a) / |c| (a, b the vertices of the chord);
- dT_k/dx through the tangent of vertex k: q_k = w l (a_t - a_n) (t.u) (u - (t.u) t) / |c| on
  vertex b, -q_k on vertex a. On a straight line moving obliquely (the chord couples add up
  to (a_t - a_n) L (u.t) |u x t|) it is Munk's moment, which turns a slender body broadside.
Both vanish where the added mass is the same across and along the line. Their sum over a line
is -sum M' u, the rate of the entrained momentum at fixed velocities, so line and fluid
together keep their momentum; their power is -1/2 u^T M' u, what the resampled added mass
gives the entrained energy at the next kick, so line and fluid together keep their energy.
They are quadratic in the velocities and evaluated at the kick's midpoint velocities,
predicted by half a kick with the last kick's forces (second order, as the step: they are
state, p.turning, and a checkpoint keeps them). A free node takes the forces on its line
ends (force and moment about its centre of mass); a fixed or driven one leaves them.
"""

import numpy as np
from numba import njit

from .backend import PASS, STEP
from .compiler import CACHED, INNER
from .compose import inertia_kernel
from .fluid import (CARRIES, FluidParams, calm_medium, end_arm, has_added_mass, kick_drag_vertices, node_free,
                    sample_rows, split, still_medium, turns)
from .fluid_step import add_node_upthrust, arm_spin, held_mass, kick_drag_nodes, lifts_nodes
from .layout import columns, uint
from .rotations import cross, solve_sym3

TURNING_ROWS = 12  # rows of p.turning: the forces G (3, the last kick's until the next), the velocities V they
                   # are taken at (3), q (3), the last kick's whole change of the velocity at the interior vertices
                   # (3: add_line_forces, or with the drag's flow fluid.kick_drag_vertices)


@njit(**CACHED, inline="always")
def turning_span(p, model, j):
    """Return (l, lo, hi): row j's line and its vertices lo..hi-1 when its fluid turns, else
    hi = 0."""
    l = p.lines[j]
    if l < 0 or l >= model.line_vertex_offsets.shape[0] - 1 or not turns(p, j):
        return l, 0, 0
    return l, model.line_vertex_offsets[l], model.line_vertex_offsets[l + 1]


@njit(**CACHED, inline="always")
def turning_rows(p):
    """The rows of p.turning as four column tuples: G, V, Q, D."""
    T = p.turning
    return (T[0], T[1], T[2]), (T[3], T[4], T[5]), (T[6], T[7], T[8]), (T[9], T[10], T[11])


@njit(**INNER)
def end_spin(model, state, a):
    """Return the velocity of line end a relative to its node's centre of mass, w x r (lab)."""
    r = end_arm(model, state, a)
    if r[0] == 0.0 and r[1] == 0.0 and r[2] == 0.0:
        return 0.0, 0.0, 0.0
    return arm_spin(state, model.attach_node[a], r)


@njit(**CACHED, inline="always")
def own_terms(G, Q, V, S, ci, vlen, i, a, b, da, calm):
    """Update G at vertex i by -M'u and Q at i by q (module docstring), its chord from vertex a
    to b, at the velocity columns V (ci: 1 / the chord's length as the sample found it, the
    positions it was taken at being the kick's; da = a_t - a_n per length; ``calm``: the
    medium at rest, its velocity rows not read)."""
    tx, ty, tz = S[7][i], S[8][i], S[9][i]
    inv = ci[i]
    c = da * S[0][i] * vlen[i]
    Ux, Uy, Uz = (0.0, 0.0, 0.0) if calm else (S[1][i], S[2][i], S[3][i])
    ux, uy, uz = V[0][i] - Ux, V[1][i] - Uy, V[2][i] - Uz
    ut = ux * tx + uy * ty + uz * tz
    dx, dy, dz = (V[0][b] - V[0][a]) * inv, (V[1][b] - V[1][a]) * inv, (V[2][b] - V[2][a]) * inv
    dt = dx * tx + dy * ty + dz * tz
    rx, ry, rz = dx - dt * tx, dy - dt * ty, dz - dt * tz            # t'
    ru = rx * ux + ry * uy + rz * uz
    G[0][i] = -c * (ut * rx + ru * tx)
    G[1][i] = -c * (ut * ry + ru * ty)
    G[2][i] = -c * (ut * rz + ru * tz)
    g = c * ut * inv
    Q[0][i], Q[1][i], Q[2][i] = g * (ux - ut * tx), g * (uy - ut * ty), g * (uz - ut * tz)


@njit(**PASS)
def interior_terms(G, Q, V, S, ci, vlen, first, n, da, calm):
    """Update G and Q at the n interior vertices first.. (own_terms; chords between neighbours;
    a loop for a calm medium of its own)."""
    if calm:
        for k in range(n):
            i = first + uint(k)
            own_terms(G, Q, V, S, ci, vlen, i, i - uint(1), i + uint(1), da, True)
    else:
        for k in range(n):
            i = first + uint(k)
            own_terms(G, Q, V, S, ci, vlen, i, i - uint(1), i + uint(1), da, False)


@njit(**PASS)
def line_turning(G, Q, V, S, ci, vlen, lo, hi, da, calm):
    """Update the force columns G at the vertices lo..hi-1 of one line by the turning fluid's
    forces at the velocity columns V (Q: scratch for q; own_terms, the ends on their end
    element's chord), but for q's share at the interior vertices, which add_line_forces
    spreads as it adds G to the loads."""
    own_terms(G, Q, V, S, ci, vlen, lo, lo, lo + 1, da, False)
    own_terms(G, Q, V, S, ci, vlen, hi - 1, hi - 2, hi - 1, da, False)
    interior_terms(G, Q, V, S, ci, vlen, uint(lo + 1), hi - lo - 2, da, calm)
    for k in range(3):
        G[k][lo] -= Q[k][lo] + Q[k][lo + 1]
        G[k][hi - 1] += Q[k][hi - 1] + Q[k][hi - 2]


@njit(**INNER)
def end_sums(p, model, state, G, nd):
    """Return (force, moment about the centre of mass) of the forces G on node nd's line ends
    whose fluid turns."""
    fx = fy = fz = mx = my = mz = 0.0
    for s in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        a = model.node_attach_list[s]
        l = a // 2
        j = p.line_row[l] if l < p.line_row.shape[0] else -1
        if j < 0 or not turns(p, j):
            continue
        i = model.attach_vertex[a]
        gx, gy, gz = G[0][i], G[1][i], G[2][i]
        r = end_arm(model, state, a)
        c = cross(r[0], r[1], r[2], gx, gy, gz)
        fx, fy, fz, mx, my, mz = fx + gx, fy + gy, fz + gz, mx + c[0], my + c[1], mz + c[2]
    return (fx, fy, fz), (mx, my, mz)


@njit(**PASS)
def predict_line(V, v, D, first, n):
    """Update the velocity columns V at the n vertices first.. to v and half the last kick's
    whole change of the velocity D: the kick's midpoint (the drag's flow runs there, between
    the kick's halves: fluid.kick_drag_vertices), to O(h^2), the change of a kick differing
    from the last one's by O(h^2)."""
    for k in range(n):
        i = first + uint(k)
        V[0][i] = v[0][i] + 0.5 * D[0][i]
        V[1][i] = v[1][i] + 0.5 * D[1][i]
        V[2][i] = v[2][i] + 0.5 * D[2][i]


@njit(**CACHED, inline="always")
def line_force(f, G, Q, V, S, vmass, i, up):
    """Update G at interior vertex i by q of the vertex before (whose chord ends here) less q
    of the vertex after (whose chord starts here), and the force columns f there to what the
    kick divides by the vertex mass: m M^-1 (f + G + up times the sampled upthrust), as
    divide_line; return the power of G at V and the kick's change of the velocity per its
    length, M^-1 (f + G + ...)."""
    gx = G[0][i] + Q[0][i - uint(1)] - Q[0][i + uint(1)]
    gy = G[1][i] + Q[1][i - uint(1)] - Q[1][i + uint(1)]
    gz = G[2][i] + Q[2][i - uint(1)] - Q[2][i + uint(1)]
    G[0][i], G[1][i], G[2][i] = gx, gy, gz
    a = split(S[14][i], S[15][i], f[0][i] + gx, f[1][i] + gy, f[2][i] + gz + up * S[13][i], S[7][i], S[8][i], S[9][i])
    m = vmass[i]
    f[0][i], f[1][i], f[2][i] = m * a[0], m * a[1], m * a[2]
    return gx * V[0][i] + gy * V[1][i] + gz * V[2][i], a


@njit(**PASS)
def add_line_forces(f, G, Q, V, S, vmass, D, h, first, n, up, change):
    """Update G and the force columns f at the n interior vertices first.. (line_force: one
    pass where divide_line and a pass of its own took two) and, where ``change`` (no drag's
    flow to write it: fluid.kick_drag_vertices), D by the kick's change of the velocity over
    h; return the power of G at V."""
    power = 0.0
    if change:
        for k in range(n):
            i = first + uint(k)
            w, a = line_force(f, G, Q, V, S, vmass, i, up)
            power += w
            D[0][i], D[1][i], D[2][i] = h * a[0], h * a[1], h * a[2]
    else:
        for k in range(n):
            power += line_force(f, G, Q, V, S, vmass, first + uint(k), up)[0]
    return power


@njit(**INNER)
def add_turning_forces(p, model, state, loads, h):
    """Update loads.f (nv, 3) at the interior vertices, loads.node_f and loads.node_tau at the
    free nodes by the turning fluid's forces at the kick's midpoint velocities (module
    docstring), and the interior vertices' loads with the upthrust to what the kick divides
    by their masses (add_line_forces; kick_fluid the rest); p.supplied by their work
    over the kick of h, which with the resampled entrained energy (flow_fluid) is what the
    line and its fluid exchange with the medium: nothing in still water, to the step's
    order. (One kernel of its own: the records passed to each of several cost more
    compiling than their arithmetic.)"""
    G, V, Q, D = turning_rows(p)
    S, v, f = sample_rows(p), columns(state.v), columns(loads.f)
    calm = calm_medium(p)
    # the velocities half a kick on, with the loads and the last kick's forces G: an O(h)
    # error in G is an O(h^2) one in the midpoint, and the step stays second order for one
    # evaluation a kick instead of two (a line end: its node's motion; its translation on,
    # a node's acceleration taken once for all its ends, in p.node_rate)
    for nd in range(model.node_mass.shape[0]):
        if node_free(p, model, nd):
            g, _ = end_sums(p, model, state, G, nd)
            fn = loads.node_f[nd]
            a00, a01, a02, a11, a12, a22 = held_mass(p, model, nd, np.bool_(True))
            d = solve_sym3(a00, a01, a02, a11, a12, a22, fn[0] + g[0], fn[1] + g[1], fn[2] + g[2])
            p.node_rate[nd, 0], p.node_rate[nd, 1], p.node_rate[nd, 2] = d[0], d[1], d[2]
    for j in range(p.lines.shape[0]):
        l, lo, hi = turning_span(p, model, j)
        if hi == 0:
            continue
        predict_line(V, v, D, uint(lo + 1), hi - lo - 2)
        for a, i in ((2 * l, lo), (2 * l + 1, hi - 1)):
            nd = model.attach_node[a]
            c = end_spin(model, state, a)
            vn = state.node_v[nd]
            hf = 0.5 * h if node_free(p, model, nd) else 0.0
            for k in range(3):
                V[k][i] = vn[k] + c[k] + hf * p.node_rate[nd, k]
    work = 0.0
    for j in range(p.lines.shape[0]):
        l, lo, hi = turning_span(p, model, j)
        if hi == 0:
            continue
        line_turning(G, Q, V, S, p.chord_inverse, model.voronoi_rest_length, lo, hi, p.added_t[j] - p.added_n[j],
                     calm)
        work += add_line_forces(f, G, Q, V, S, model.vertex_mass, D, h, uint(lo + 1), hi - lo - 2,
                                1.0 if p.buoyancy[j] != 0.0 else 0.0, p.drag_n[j] == 0.0 and p.drag_t[j] == 0.0)
        for a, i in ((2 * l, lo), (2 * l + 1, hi - 1)):
            if node_free(p, model, model.attach_node[a]):
                work += G[0][i] * V[0][i] + G[1][i] * V[1][i] + G[2][i] * V[2][i]
    for nd in range(model.node_mass.shape[0]):
        if node_free(p, model, nd):
            g, m = end_sums(p, model, state, G, nd)
            for k in range(3):
                loads.node_f[nd, k] += g[k]
                loads.node_tau[nd, k] += m[k]
    p.supplied[0] += h * work


@njit(**PASS)
def add_upthrust(fz, up, first, n):
    """Update the vertical force column fz at the n vertices first.. by the sampled upthrust."""
    for k in range(n):
        i = first + uint(k)
        fz[i] += up[i]


@njit(**PASS)
def divide_line(f, S, vmass, first, n, up):
    """Update the force columns f at the n vertices first.. to m M^-1 f, M the vertex mass
    with the added mass of its sampled wetness and tangent (branch-free: a dry vertex keeps m),
    with up times the sampled upthrust (row 13) added first (up: 1, or 0 without buoyancy)."""
    for k in range(n):
        i = first + uint(k)
        m = vmass[i]
        f[0][i], f[1][i], f[2][i] = split(m * S[14][i], m * S[15][i], f[0][i], f[1][i], f[2][i] + up * S[13][i],
                                          S[7][i], S[8][i], S[9][i])


@njit(**INNER)
def divide_node_loads(p, model, loads):
    """Update loads.node_f at the free nodes the medium adds mass to, m A^-1 f (A the node's
    mass matrix with its added mass: fluid_step.node_mass_matrix), so that the kick's f / m is
    A^-1 f."""
    for nd in range(model.node_mass.shape[0]):
        if not node_free(p, model, nd):
            continue
        a00, a01, a02, a11, a12, a22 = held_mass(p, model, nd, np.bool_(True))
        m = model.node_mass[nd]
        if a00 == m and a11 == m and a22 == m and a01 == 0.0 and a02 == 0.0 and a12 == 0.0:
            continue
        fn = loads.node_f[nd]
        g = solve_sym3(a00, a01, a02, a11, a12, a22, fn[0], fn[1], fn[2])
        fn[0], fn[1], fn[2] = m * g[0], m * g[1], m * g[2]


@inertia_kernel(FluidParams)
@njit(**STEP)
def kick_fluid(p, model, state, arg):
    """Update loads.f (nv, 3) at the wet interior vertices and loads.node_f at the free nodes
    given arg = (loads, h), the kick's loads and length: the upthrust (as sample_upthrust
    found it; in a still medium the nodes' too, with its torque in loads.node_tau:
    add_node_upthrust) and the turning fluid's forces added (add_turning_forces), then all
    turned so that the kick's f / m is M^-1 f, M the mass with the added mass of the wet line
    parts (the vertex mass m + a_n (1 - t t^T) + a_t t t^T; a node's sum over its wet ends:
    divide_node_loads). (Each line's interior in one pass: the upthrust alone where it
    carries no added mass, else with the division, in add_line_forces where its fluid turns.)
    Then state.v at the interior vertices and state.node_v at the free point junctions by the
    drag's flow between the kick's halves, with these loads (fluid.kick_drag_vertices,
    fluid_step.kick_drag_nodes)."""
    loads, h = arg
    f, S = columns(loads.f), sample_rows(p)
    vmass = model.vertex_mass
    nl = model.line_vertex_offsets.shape[0] - 1
    if still_medium(p) and lifts_nodes(p):
        add_node_upthrust(p, model, state, loads)
    for j in range(p.lines.shape[0]):
        l = p.lines[j]
        if l >= 0 and l < nl and p.buoyancy[j] != 0.0 and p.added_n[j] == 0.0 and p.added_t[j] == 0.0:
            add_upthrust(f[2], S[13], uint(model.line_vertex_offsets[l] + 1),
                         model.line_vertex_offsets[l + 1] - model.line_vertex_offsets[l] - 2)
    if CARRIES:
        if p.turning.shape[1] > 0:
            add_turning_forces(p, model, state, loads, h)
        for j in range(p.lines.shape[0]):
            l = p.lines[j]
            if l < 0 or l >= nl or (p.added_n[j] == 0.0 and p.added_t[j] == 0.0) or turns(p, j):
                continue
            divide_line(f, S, vmass, uint(model.line_vertex_offsets[l] + 1),
                        model.line_vertex_offsets[l + 1] - model.line_vertex_offsets[l] - 2,
                        1.0 if p.buoyancy[j] != 0.0 else 0.0)
        if has_added_mass(p):
            divide_node_loads(p, model, loads)
    kick_drag_vertices(p, model, state, loads, h)
    kick_drag_nodes(p, model, state, loads.node_f, h)
