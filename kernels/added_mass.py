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
from numba import njit, prange

from .backend import NODE_BLOCK, PASS, STEP
from .compiler import CACHED, INNER
from .compose import inertia_kernel
from .fluid import (ARMS, CALM, CARRIES, CURRENT, LINE_BLOCK, NODES, THREADS, FluidParams, calm_now, end_arm,
                    has_added_mass, kick_changes, kick_drag_vertices, node_free, sample_rows, set_decay, split,
                    still_medium, turns)
from .fluid_step import add_node_upthrust, arm_spin, held_mass, kick_drag_nodes, lifts_nodes
from .layout import columns, uint
from .rotations import cross, solve_sym3

TURNING_ROWS = 6  # rows of p.turning: the forces G at the line ends (3, the last kick's until the next; at the
                  # interior vertices, scratch), the last kick's whole change of the velocity D at the interior
                  # vertices (3: add_inner_turning, or with the drag's flow fluid.kick_drag_vertices; at a line end,
                  # its node's midpoint velocity for the pass: add_turning_forces)


def threaded_blocks(lines: int, nodes: int) -> int:
    """The rows of FluidParams.block_sums for a medium of ``lines`` lines on a net of ``nodes``
    nodes: the blocks of kick_threaded's longest loop."""
    return max((lines + LINE_BLOCK - 1) // LINE_BLOCK, (nodes + NODE_BLOCK - 1) // NODE_BLOCK, 1)


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
    """The rows of p.turning as two column tuples: G, D."""
    T = p.turning
    return (T[0], T[1], T[2]), kick_changes(p)


@njit(**INNER)
def end_spin(model, state, a):
    """Return the velocity of line end a relative to its node's centre of mass, w x r (lab)."""
    r = end_arm(model, state, a)
    if r[0] == 0.0 and r[1] == 0.0 and r[2] == 0.0:
        return 0.0, 0.0, 0.0
    return arm_spin(state, model.attach_node[a], r)


@njit(**CACHED, inline="always")
def predicted(v, D, k):
    """Return vertex k's velocity at the kick's midpoint, v + D/2 (v the velocity columns, D the
    last kick's whole change of it), to O(h^2): the change of a kick differs from the last
    one's by O(h^2) (the drag's flow runs there, between the kick's halves:
    fluid.kick_drag_vertices)."""
    return v[0][k] + 0.5 * D[0][k], v[1][k] + 0.5 * D[1][k], v[2][k] + 0.5 * D[2][k]


@njit(**CACHED, inline="always")
def vertex_q(S, ci, vlen, k, da, w, calm):
    """Return q at vertex k (module docstring) at its velocity w, its tangent and 1 / its
    chord's length (ci) as the sample found them (da = a_t - a_n per length; ``calm``: the
    medium at rest, its velocity rows not read)."""
    tx, ty, tz = S[7][k], S[8][k], S[9][k]
    ux, uy, uz = (w[0], w[1], w[2]) if calm else (w[0] - S[1][k], w[1] - S[2][k], w[2] - S[3][k])
    ut = ux * tx + uy * ty + uz * tz
    g = da * S[0][k] * vlen[k] * ut * ci[k]
    return g * (ux - ut * tx), g * (uy - ut * ty), g * (uz - ut * tz)


@njit(**CACHED, inline="always")
def vertex_turning(S, ci, vlen, i, da, w, wa, wb, calm):
    """Return -M'u at vertex i (module docstring) at its velocity w, its chord's ends moving
    at wa and wb (vertex_q's arguments)."""
    tx, ty, tz = S[7][i], S[8][i], S[9][i]
    inv = ci[i]
    c = da * S[0][i] * vlen[i]
    ux, uy, uz = (w[0], w[1], w[2]) if calm else (w[0] - S[1][i], w[1] - S[2][i], w[2] - S[3][i])
    ut = ux * tx + uy * ty + uz * tz
    dx, dy, dz = (wb[0] - wa[0]) * inv, (wb[1] - wa[1]) * inv, (wb[2] - wa[2]) * inv
    dt = dx * tx + dy * ty + dz * tz
    rx, ry, rz = dx - dt * tx, dy - dt * ty, dz - dt * tz            # t'
    ru = rx * ux + ry * uy + rz * uz
    return -c * (ut * rx + ru * tx), -c * (ut * ry + ru * ty), -c * (ut * rz + ru * tz)


@njit(**CACHED, inline="always")
def load_vertex(f, S, vmass, i, up, g, w):
    """Update the force columns f at interior vertex i to what the kick divides by the vertex
    mass, m M^-1 (f + g + up times the sampled upthrust), as divide_line; return the power of
    the turning fluid's force g at the velocity w and the kick's change of the velocity per
    its length, M^-1 (f + g + ...)."""
    a = split(S[14][i], S[15][i], f[0][i] + g[0], f[1][i] + g[1], f[2][i] + g[2] + up * S[13][i], S[7][i], S[8][i],
              S[9][i])
    m = vmass[i]
    f[0][i], f[1][i], f[2][i] = m * a[0], m * a[1], m * a[2]
    return g[0] * w[0] + g[1] * w[1] + g[2] * w[2], a


@njit(**CACHED, inline="always")
def turning_vertex(f, v, D, S, ci, vlen, vmass, i, da, up, calm):
    """Update the force columns f at interior vertex i by the turning fluid's force there, its
    -M'u and the q of the chords ending (+) and starting (-) at it (a line end's on its end
    element's chord), at the midpoint velocities (predicted), and divide them (load_vertex,
    whose values it returns). (Each neighbour's q computed again, not read: one pass over
    the line where writing the velocities, then q and -M'u, then the forces took three, and
    the arithmetic costs less than the columns it spared.)"""
    a, b = i - uint(1), i + uint(1)
    w, wa, wb = predicted(v, D, i), predicted(v, D, a), predicted(v, D, b)
    g = vertex_turning(S, ci, vlen, i, da, w, wa, wb, calm)
    qa, qb = vertex_q(S, ci, vlen, a, da, wa, calm), vertex_q(S, ci, vlen, b, da, wb, calm)
    return load_vertex(f, S, vmass, i, up, (g[0] + qa[0] - qb[0], g[1] + qa[1] - qb[1], g[2] + qa[2] - qb[2]), w)


@njit(**PASS)
def add_inner_turning(f, v, D, S, ci, vlen, vmass, E, h, first, n, da, up, calm, change):
    """Update the force columns f at a line's n interior vertices first.. (turning_vertex;
    D at its ends: their midpoint velocities, add_turning_forces) and, where ``change`` (no
    drag's flow to write it), E by the kick's change of the velocity over h (E, not D, whose
    neighbours' values the pass reads: the caller copies it); return the power of the
    turning forces."""
    power = 0.0
    if change:
        for k in range(n):
            i = first + uint(k)
            w, a = turning_vertex(f, v, D, S, ci, vlen, vmass, i, da, up, False)
            power += w
            E[0][i], E[1][i], E[2][i] = h * a[0], h * a[1], h * a[2]
    elif CALM and calm:   # (a variant's options prune the loops it cannot run: fluid.calm_now)
        for k in range(n):
            power += turning_vertex(f, v, D, S, ci, vlen, vmass, first + uint(k), da, up, True)[0]
    elif CURRENT:
        for k in range(n):
            power += turning_vertex(f, v, D, S, ci, vlen, vmass, first + uint(k), da, up, False)[0]
    return power


@njit(**CACHED, inline="always")
def end_turning(v, D, S, ci, vlen, e, i, da, sign):
    """Return the turning fluid's force on line end e at the midpoint velocities (predicted):
    its own -M'u on its end element's chord (to the interior vertex i next to it) and the q
    of the chords ending (sign = 1: the line's last vertex) or starting (sign = -1: its first)
    at it, its own and vertex i's (the neighbour's spread by add_inner_turning)."""
    w, wi = predicted(v, D, e), predicted(v, D, i)
    wa, wb = (wi, w) if sign > 0.0 else (w, wi)
    g = vertex_turning(S, ci, vlen, e, da, w, wa, wb, False)
    q, qi = vertex_q(S, ci, vlen, e, da, w, False), vertex_q(S, ci, vlen, i, da, wi, False)
    return g[0] + sign * (q[0] + qi[0]), g[1] + sign * (q[1] + qi[1]), g[2] + sign * (q[2] + qi[2])


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
        fx, fy, fz = fx + gx, fy + gy, fz + gz
        if ARMS:   # (a variant's option: some free node's ends have arms)
            r = end_arm(model, state, a)
            c = cross(r[0], r[1], r[2], gx, gy, gz)
            mx, my, mz = mx + c[0], my + c[1], mz + c[2]
    return (fx, fy, fz), (mx, my, mz)


@njit(**INNER)
def turning_rates(p, model, state, loads, n0, n1):
    """Update p.node_rate at the free nodes among n0..n1-1 by their accelerations with the kick's
    loads and the last kick's turning forces G on their line ends (add_turning_forces)."""
    G, _ = turning_rows(p)
    for nd in range(n0, n1):
        if node_free(p, model, nd):
            g, _ = end_sums(p, model, state, G, nd)
            fn = loads.node_f[nd]
            a00, a01, a02, a11, a12, a22 = held_mass(p, model, nd, np.bool_(True))
            d = solve_sym3(a00, a01, a02, a11, a12, a22, fn[0] + g[0], fn[1] + g[1], fn[2] + g[2])
            p.node_rate[nd, 0], p.node_rate[nd, 1], p.node_rate[nd, 2] = d[0], d[1], d[2]


@njit(**INNER)
def add_turning_forces(p, model, state, loads, h, j0, j1):
    """Update loads.f (nv, 3) at the interior vertices of rows j0..j1-1's lines by the turning
    fluid's forces at the kick's midpoint velocities (module docstring), and their loads with
    the upthrust to what the kick divides by their masses (add_inner_turning, end_turning;
    kick_fluid the rest), and its forces G at the lines' ends (add_end_sums gives them to the
    free nodes); return their power, whose work over the kick of h, with the resampled
    entrained energy (flow_fluid), is what the line and its fluid exchange with the medium:
    nothing in still water, to the step's order. The velocities half a kick on come from the
    loads and the last kick's forces G: an O(h) error in G is an O(h^2) one in the midpoint,
    and the step stays second order for one evaluation a kick instead of two (a line end: its
    node's motion; its translation on, a node's acceleration taken once for all its ends, in
    p.node_rate: turning_rates). (One kernel of its own: the records passed to each of several
    cost more compiling than their arithmetic.)"""
    G, D = turning_rows(p)
    S, v, f = sample_rows(p), columns(state.v), columns(loads.f)
    ci, vlen = p.chord_inverse, model.voronoi_rest_length
    calm = calm_now(p)
    work = 0.0
    for j in range(j0, j1):
        l, lo, hi = turning_span(p, model, j)
        if hi == 0:
            continue
        # a line end's midpoint velocity (no drag's flow writes D there) carried in D, so that
        # predicted() gives it, and one pass takes the interior vertices next to the ends too
        for a, i in ((2 * l, lo), (2 * l + 1, hi - 1)):
            nd = model.attach_node[a]
            c = end_spin(model, state, a)
            vn = state.node_v[nd]
            hf = 0.5 * h if node_free(p, model, nd) else 0.0
            for k in range(3):
                D[k][i] = 2.0 * (vn[k] + c[k] + hf * p.node_rate[nd, k] - v[k][i])
        da, up = p.added_t[j] - p.added_n[j], 1.0 if p.buoyancy[j] != 0.0 else 0.0
        change = p.drag_n[j] == 0.0 and p.drag_t[j] == 0.0
        for a, e, i, sign in ((2 * l, lo, lo + 1, -1.0), (2 * l + 1, hi - 1, hi - 2, 1.0)):
            G[0][e], G[1][e], G[2][e] = end_turning(v, D, S, ci, vlen, e, i, da, sign)
            if node_free(p, model, model.attach_node[a]):
                w = predicted(v, D, e)
                work += G[0][e] * w[0] + G[1][e] * w[1] + G[2][e] * w[2]
        work += add_inner_turning(f, v, D, S, ci, vlen, model.vertex_mass, G, h, uint(lo + 1), hi - lo - 2, da, up,
                                  calm, change)
        if change:
            for i in range(lo + 1, hi - 1):
                D[0][i], D[1][i], D[2][i] = G[0][i], G[1][i], G[2][i]
    return work


@njit(**INNER)
def add_end_sums(p, model, state, loads, n0, n1):
    """Update loads.node_f and loads.node_tau at the free nodes among n0..n1-1 by the turning
    fluid's forces G on their line ends (add_turning_forces) and their moments."""
    G, _ = turning_rows(p)
    for nd in range(n0, n1):
        if node_free(p, model, nd):
            g, m = end_sums(p, model, state, G, nd)
            for k in range(3):
                loads.node_f[nd, k] += g[k]
                loads.node_tau[nd, k] += m[k]


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
def divide_node_loads(p, model, loads, n0, n1):
    """Update loads.node_f at the free nodes among n0..n1-1 the medium adds mass to, m A^-1 f
    (A the node's mass matrix with its added mass: fluid_step.node_mass_matrix), so that the
    kick's f / m is A^-1 f."""
    for nd in range(n0, n1):
        if not node_free(p, model, nd):
            continue
        a00, a01, a02, a11, a12, a22 = held_mass(p, model, nd, np.bool_(True))
        m = model.node_mass[nd]
        if a00 == m and a11 == m and a22 == m and a01 == 0.0 and a02 == 0.0 and a12 == 0.0:
            continue
        fn = loads.node_f[nd]
        g = solve_sym3(a00, a01, a02, a11, a12, a22, fn[0], fn[1], fn[2])
        fn[0], fn[1], fn[2] = m * g[0], m * g[1], m * g[2]


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def kick_nodes_first(n0, n1, p, model, state, loads):
    """Update loads.node_f and loads.node_tau at the free nodes among n0..n1-1 by the upthrust in
    a still medium (add_node_upthrust), and p.node_rate by their accelerations where some
    line's fluid turns (turning_rates): what the kick's pass over the lines reads of them."""
    if still_medium(p) and lifts_nodes(p):
        add_node_upthrust(p, model, state, loads, n0, n1)
    if CARRIES and p.turning.shape[1] > 0:
        turning_rates(p, model, state, loads, n0, n1)


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def kick_lines(j0, j1, p, model, state, loads, h):
    """Update loads.f at the interior vertices of rows j0..j1-1's lines by the upthrust (as
    sample_upthrust found it) and the turning fluid's forces (add_turning_forces), turned so
    that the kick's f / m is M^-1 f, M the vertex mass with the added mass of the wet line
    parts, m + a_n (1 - t t^T) + a_t t t^T (each line's interior in one pass: the upthrust
    alone where it carries no added mass, else with the division, in add_inner_turning where
    its fluid turns); then state.v there by the drag's flow between the kick's halves, with
    these loads (fluid.kick_drag_vertices). Return (the turning forces' power, the energy the
    drag dissipated, the work it supplied)."""
    f, S = columns(loads.f), sample_rows(p)
    vmass = model.vertex_mass
    nl = model.line_vertex_offsets.shape[0] - 1
    voff = model.line_vertex_offsets
    for j in range(j0, j1):
        l = p.lines[j]
        if l >= 0 and l < nl and p.buoyancy[j] != 0.0 and p.added_n[j] == 0.0 and p.added_t[j] == 0.0:
            add_upthrust(f[2], S[13], uint(voff[l] + 1), voff[l + 1] - voff[l] - 2)
    work = 0.0
    if CARRIES:
        if p.turning.shape[1] > 0:
            work = add_turning_forces(p, model, state, loads, h, j0, j1)
        for j in range(j0, j1):
            l = p.lines[j]
            if l < 0 or l >= nl or (p.added_n[j] == 0.0 and p.added_t[j] == 0.0) or turns(p, j):
                continue
            divide_line(f, S, vmass, uint(voff[l] + 1), voff[l + 1] - voff[l] - 2,
                        1.0 if p.buoyancy[j] != 0.0 else 0.0)
    d, g = kick_drag_vertices(p, model, state, loads, h, j0, j1)
    return work, d, g


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def kick_nodes_last(n0, n1, p, model, state, loads, h):
    """Update loads.node_f and loads.node_tau at the free nodes among n0..n1-1 by the turning
    fluid's forces on their line ends (add_end_sums), node_f to what the kick divides by
    their masses (divide_node_loads), then state.node_v at the free point junctions by the
    drag's flow between the kick's halves, with these loads (fluid_step.kick_drag_nodes).
    Return (the energy dissipated, the work supplied)."""
    if CARRIES:
        if p.turning.shape[1] > 0:
            add_end_sums(p, model, state, loads, n0, n1)
        if has_added_mass(p):
            divide_node_loads(p, model, loads, n0, n1)
    return kick_drag_nodes(p, model, state, loads.node_f, h, n0, n1)


@njit(**INNER, parallel=True)
def kick_threaded(p, model, state, loads, h):
    """kick_fluid's passes in blocks of LINE_BLOCK lines and of NODE_BLOCK nodes on the step's
    threads, three threaded loops a kick (the nodes the lines read; the lines; the nodes that
    read the lines' ends), each block's sums in a row of p.block_sums (a reduction would
    allocate); a loop of a single block, or of more than p.block_sums holds, runs in the
    calling thread (backend.SOLO). Return (the turning forces' power, the energy dissipated,
    the work supplied)."""
    nn, nj, sums = model.node_mass.shape[0], p.lines.shape[0], p.block_sums
    bn, bl = (nn + NODE_BLOCK - 1) // NODE_BLOCK, (nj + LINE_BLOCK - 1) // LINE_BLOCK
    serial_nodes, serial_lines = bn <= 1 or bn > sums.shape[0], bl <= 1 or bl > sums.shape[0]
    if NODES:
        if serial_nodes:
            kick_nodes_first(np.int64(0), nn, p, model, state, loads)
        else:
            for b in prange(bn):
                kick_nodes_first(b * NODE_BLOCK, min((b + 1) * NODE_BLOCK, nn), p, model, state, loads)
    if serial_lines:
        work, dissipated, supplied = kick_lines(np.int64(0), nj, p, model, state, loads, h)
    else:
        for b in prange(bl):
            sums[b, 0], sums[b, 1], sums[b, 2] = kick_lines(b * LINE_BLOCK, min((b + 1) * LINE_BLOCK, nj), p, model,
                                                            state, loads, h)
        work = dissipated = supplied = 0.0
        for b in range(bl):
            work, dissipated, supplied = work + sums[b, 0], dissipated + sums[b, 1], supplied + sums[b, 2]
    if NODES:
        if serial_nodes:
            d, g = kick_nodes_last(np.int64(0), nn, p, model, state, loads, h)
            dissipated, supplied = dissipated + d, supplied + g
        else:
            for b in prange(bn):
                sums[b, 0], sums[b, 1] = kick_nodes_last(b * NODE_BLOCK, min((b + 1) * NODE_BLOCK, nn), p, model,
                                                         state, loads, h)
            for b in range(bn):
                dissipated, supplied = dissipated + sums[b, 0], supplied + sums[b, 1]
    return work, dissipated, supplied


@inertia_kernel(FluidParams)
@njit(**STEP)
def kick_fluid(p, model, state, arg):
    """Update loads.f (nv, 3) at the wet interior vertices and loads.node_f at the free nodes
    given arg = (loads, h), the kick's loads and length: the upthrust (in a still medium the
    nodes' too, with its torque in loads.node_tau) and the turning fluid's forces added, then
    all turned so that the kick's f / m is M^-1 f, M the mass with the added mass of the wet
    line parts (a node's: the sum over its wet ends, divide_node_loads); then state.v at the
    interior vertices and state.node_v at the free point junctions by the drag's flow between
    the kick's halves, with these loads: kick_nodes_first, kick_lines and kick_nodes_last over
    every node and line, or in blocks on the threads (THREADS: kick_threaded). p.supplied and
    p.dissipated by the work done."""
    loads, h = arg
    set_decay(p, model, h)
    if THREADS:
        work, dissipated, supplied = kick_threaded(p, model, state, loads, h)
    else:
        nn = model.node_mass.shape[0]
        if NODES:
            kick_nodes_first(np.int64(0), nn, p, model, state, loads)
        work, dissipated, supplied = kick_lines(np.int64(0), p.lines.shape[0], p, model, state, loads, h)
        if NODES:
            d, g = kick_nodes_last(np.int64(0), nn, p, model, state, loads, h)
            dissipated, supplied = dissipated + d, supplied + g
    p.supplied[0] += h * work
    p.dissipated[0] += dissipated
    p.supplied[0] += supplied
