"""Internal loads of the lines: Kirchhoff constitutive law (3.22)-(3.25) on a staggered grid.

The discrete strain energy of a line is
    U = sum_e  l_e/2 (s_e/l_e - e3)^T K_e (s_e/l_e - e3)          s_e = D_e^T (x_{e+1} - x_e)
      + sum_k  L_k/2 (theta_k/L_k - u0_k)^T B_k (theta_k/L_k - u0_k)  theta_k = log(D_a^T D_b)
where D_a, D_b are the frames on either side of Voronoi point k (at the line ends, the node's
frame D(nu) X(nu, lambda) (1.3)). The forces and torques below are its exact gradient, so the
discrete internal force across a section is n = D K (v - d3) and the internal torque
m = D B (u - u0) (3.22) (the paper's "contact force" and "contact torque"; here contact is
the rod-rod Contact effect),
and the time stepper is variational: energy has no secular drift.

An active line changes the rest strain v0 from d3 (model.element_rest_strain, empty in a model
without one): its elements then carry the extra force n = -D K (v0 - d3), the gradient of the
energy's change to l/2 (v - v0)^T K (v - v0), added by a pass of its own (prestress_span) after
the stretch pass, so a net without one steps exactly as before.
"""

import numpy as np
from numba import njit, prange

from .backend import PASS, STEP, dispatch, inline_twin
from .layout import columns, quat_columns, uint
from .compiler import INLINE, INNER, stable_cache_key
from .rotations import (cross, quat_mul, quat_rotate, quat_rotate_inv, relative_quat, relative_rotation,
                        small_rotation)

# elements per block of whole lines (the unit of the threaded internal loads; a block's
# scratch stays in cache)
LINE_BLOCK = 2048


@njit(**INLINE)
def voronoi_columns(model):
    """Return (B, u0, 1/L) of every Voronoi point as columns (see layout.columns)."""
    return (columns(model.voronoi_stiffness), columns(model.voronoi_rest_curvature),
            model.voronoi_inv_rest_length)


@njit(**INLINE)
def moment_at(vor, k, theta_x, theta_y, theta_z):
    """Return m = B (theta/L - u0) at Voronoi point k (principal frame) given vor, the
    voronoi_columns (3.22)."""
    b, u0, inv_l = vor
    il = inv_l[k]
    return (b[0][k] * (theta_x * il - u0[0][k]),
            b[1][k] * (theta_y * il - u0[1][k]),
            b[2][k] * (theta_z * il - u0[2][k]))


@njit(**INLINE)
def bend_torques(tx, ty, tz, c, mx, my, mz):
    """Return the body torques on the left frame (+J_r^-1 m) and right frame (-J_l^-1 m) of a
    Voronoi point with relative rotation theta and bending moment m."""
    ax, ay, az = cross(tx, ty, tz, mx, my, mz)
    bx, by, bz = cross(tx, ty, tz, ax, ay, az)
    sx, sy, sz = mx + c * bx, my + c * by, mz + c * bz
    return (sx + 0.5 * ax, sy + 0.5 * ay, sz + 0.5 * az,
            -(sx - 0.5 * ax), -(sy - 0.5 * ay), -(sz - 0.5 * az))


@njit(**INLINE)
def store_bend(vor, k, tx, ty, tz, c, left, right):
    """Update left, right (column triples) at Voronoi point k of a line with the torques on
    its two frames given its rotation vector theta and c(theta); vor = (B, u0, 1/L) columns
    of the line's Voronoi points (3.22), (3.24)."""
    mx, my, mz = moment_at(vor, k, tx, ty, tz)
    lx, ly, lz, rx, ry, rz = bend_torques(tx, ty, tz, c, mx, my, mz)
    left[0][k], left[1][k], left[2][k] = lx, ly, lz
    right[0][k], right[1][k], right[2][k] = rx, ry, rz


@njit(**INLINE)
def end_frame(model, state, a):
    """Return the quaternion of line end a's director frame D(nu) X(nu, lambda) (1.3)."""
    nq = state.node_q[model.attach_node[a]]
    xq = model.attach_frame[a]
    return quat_mul(nq[0], nq[1], nq[2], nq[3], xq[0], xq[1], xq[2], xq[3])


@njit(**INLINE)
def bend_span(v0, e0, j0, j1, vor, q, left, right):
    """Update left, right at the interior Voronoi points j0 .. j1-1 (1 <= j0, j1 <= n) of the
    line whose first vertex is v0 and first element e0, given the element quaternions q, by
    the series log map; return how many points turned by 0.2 rad or more (their values are
    then meaningless: see bend_large_span)."""
    large = 0
    for j in range(j0, j1):
        a, b, k = e0 + uint(j - 1), e0 + uint(j), v0 + uint(j)
        rw, rx, ry, rz, small = relative_quat(q[0][a], q[1][a], q[2][a], q[3][a],
                                              q[0][b], q[1][b], q[2][b], q[3][b])
        large += 0 if small else 1
        tx, ty, tz, c = small_rotation(rw, rx, ry, rz)
        store_bend(vor, k, tx, ty, tz, c, left, right)
    return large


@njit(**INLINE)
def bend_large_span(v0, e0, j0, j1, vor, q, left, right):
    """Update left, right at those interior Voronoi points j0 .. j1-1 of a line (as
    bend_span) turned by 0.2 rad or more, by the exact log map."""
    for j in range(j0, j1):
        a, b, k = e0 + uint(j - 1), e0 + uint(j), v0 + uint(j)
        aw, ax, ay, az = q[0][a], q[1][a], q[2][a], q[3][a]
        bw, bx, by, bz = q[0][b], q[1][b], q[2][b], q[3][b]
        if not relative_quat(aw, ax, ay, az, bw, bx, by, bz)[4]:
            tx, ty, tz, c = relative_rotation(aw, ax, ay, az, bw, bx, by, bz)
            store_bend(vor, k, tx, ty, tz, c, left, right)


@njit(**INLINE)
def stretch_span(v0, e0, j0, j1, x, q, stiff, inv_len, left, right, force, tau):
    """Update force, the lab internal force n = D K (D^T r'/l - e3), and tau, the body torque
    r' x n plus the bending torques of the Voronoi points on either side, of elements
    j0 .. j1-1 of a line (as bend_span) (3.2)/(3.3), (3.22)."""
    for j in range(j0, j1):
        e, v, w = e0 + uint(j), v0 + uint(j), v0 + uint(j + 1)
        qw, qx, qy, qz = q[0][e], q[1][e], q[2][e], q[3][e]
        il = inv_len[e]
        sx, sy, sz = quat_rotate_inv(qw, qx, qy, qz, x[0][w] - x[0][v], x[1][w] - x[1][v], x[2][w] - x[2][v])
        nx, ny, nz = stiff[0][e] * sx * il, stiff[1][e] * sy * il, stiff[2][e] * (sz * il - 1.0)
        fx, fy, fz = quat_rotate(qw, qx, qy, qz, nx, ny, nz)
        force[0][e], force[1][e], force[2][e] = fx, fy, fz
        cx, cy, cz = cross(sx, sy, sz, nx, ny, nz)
        tau[0][e] = cx + right[0][v] + left[0][w]
        tau[1][e] = cy + right[1][v] + left[1][w]
        tau[2][e] = cz + right[2][v] + left[2][w]


@njit(**INLINE)
def prestress_span(v0, e0, j0, j1, x, q, stiff, rest, force, tau):
    """Update force and tau of elements j0 .. j1-1 of a line (as stretch_span) with the extra
    internal force -D K (v0 - d3) of a rest strain v0 (rest: its columns) and its torque
    r' x n (3.3), (3.22)."""
    for j in range(j0, j1):
        e, v, w = e0 + uint(j), v0 + uint(j), v0 + uint(j + 1)
        qw, qx, qy, qz = q[0][e], q[1][e], q[2][e], q[3][e]
        sx, sy, sz = quat_rotate_inv(qw, qx, qy, qz, x[0][w] - x[0][v], x[1][w] - x[1][v], x[2][w] - x[2][v])
        nx, ny, nz = -stiff[0][e] * rest[0][e], -stiff[1][e] * rest[1][e], stiff[2][e] * (1.0 - rest[2][e])
        fx, fy, fz = quat_rotate(qw, qx, qy, qz, nx, ny, nz)
        force[0][e] += fx
        force[1][e] += fy
        force[2][e] += fz
        cx, cy, cz = cross(sx, sy, sz, nx, ny, nz)
        tau[0][e] += cx
        tau[1][e] += cy
        tau[2][e] += cz


@njit(**INLINE)
def vertex_span(v0, e0, j0, j1, force, f):
    """Update f at the interior vertices j0 .. j1-1 (1 <= j0, j1 <= n) of a line (as
    bend_span) with the difference of the internal forces of the elements on either side (3.2)."""
    for j in range(j0, j1):
        v, e, d = v0 + uint(j), e0 + uint(j), e0 + uint(j - 1)
        f[0][v] = force[0][e] - force[0][d]
        f[1][v] = force[1][e] - force[1][d]
        f[2][v] = force[2][e] - force[2][d]


@njit(**INLINE)
def finish_line(l, voff, eoff, force, f, left, right, ends):
    """Update f at the two end vertices of line l (its end elements' forces) and ends (the
    loads' end_tau) with the torques of its boundary Voronoi points on the nodes' frames."""
    v0, vn = voff[l], voff[l + 1] - 1
    first, last = eoff[l], eoff[l + 1] - 1
    for k in range(3):
        f[k][v0] = force[k][first]
        f[k][vn] = -force[k][last]
        ends[2 * l, k] = left[k][v0]
        ends[2 * l + 1, k] = right[k][vn]


@njit(**PASS)
def bend_lines(l0, l1, voff, eoff, vor, q, left, right):
    """Update left, right at the interior Voronoi points of lines l0 .. l1-1 (bend_span;
    vectorised along each line); return how many points turned by 0.2 rad or more. voff,
    eoff: the lines' vertex and element offsets; column tuples (see layout.columns). One call
    serves a block of lines: a call passes dozens of array fields, which cost more than the
    arithmetic of a ten-element line."""
    large = 0
    for l in range(l0, l1):
        large += bend_span(uint(voff[l]), uint(eoff[l]), 1, eoff[l + 1] - eoff[l], vor, q, left, right)
    return large


@njit(**PASS)
def stretch_lines(l0, l1, voff, eoff, x, q, stiff, inv_len, left, right, force, tau):
    """Update force and tau of the elements of lines l0 .. l1-1 (stretch_span; vectorised
    along each line, as bend_lines)."""
    for l in range(l0, l1):
        stretch_span(uint(voff[l]), uint(eoff[l]), 0, eoff[l + 1] - eoff[l], x, q, stiff, inv_len,
                     left, right, force, tau)


@njit(**PASS)
def prestress_lines(l0, l1, voff, eoff, x, q, stiff, rest, force, tau):
    """Update force and tau of the elements of lines l0 .. l1-1 (prestress_span)."""
    for l in range(l0, l1):
        prestress_span(uint(voff[l]), uint(eoff[l]), 0, eoff[l + 1] - eoff[l], x, q, stiff, rest, force, tau)


@njit(**INLINE)
def has_rest_strain(model):
    """Return whether the model carries a rest strain for every element (an active line)."""
    return model.element_rest_strain.shape[0] == model.element_rest_length.shape[0] > 0


@njit(**PASS)
def vertex_lines(l0, l1, voff, eoff, force, f):
    """Update f at the interior vertices of lines l0 .. l1-1 (vertex_span; vectorised along
    each line, as bend_lines; finish_line does the end vertices)."""
    for l in range(l0, l1):
        vertex_span(uint(voff[l]), uint(eoff[l]), 1, eoff[l + 1] - eoff[l], force, f)


@njit(**INLINE)
def bend_end(vor, k, a, b, left, right):
    """Update left, right at boundary Voronoi point k, between the frames of quaternions a and
    b (3.22). A point without bending stiffness (an articulated end, whose joint carries its
    stiffness: kernels/articulation.py) passes no torque: zeros, without the rotation, which
    cost about what the joint's own settling costs."""
    B = vor[0]
    if B[0][k] == 0.0 and B[1][k] == 0.0 and B[2][k] == 0.0:
        for i in range(3):
            left[i][k] = 0.0
            right[i][k] = 0.0
        return
    tx, ty, tz, c = relative_rotation(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])
    store_bend(vor, k, tx, ty, tz, c, left, right)


@njit(**INLINE)
def bend_ends(l, model, state, vor, q, left, right):
    """Update left, right at the two boundary Voronoi points of line l, which join its end
    elements to its nodes' frames D(nu) X(nu, lambda) (1.3), (3.22)."""
    v0 = uint(model.line_vertex_offsets[l])
    e0 = uint(model.line_element_offsets[l])
    n = model.line_element_offsets[l + 1] - model.line_element_offsets[l]
    last, vn = e0 + uint(n - 1), v0 + uint(n)
    bend_end(vor, v0, end_frame(model, state, 2 * l), (q[0][e0], q[1][e0], q[2][e0], q[3][e0]), left, right)
    bend_end(vor, vn, (q[0][last], q[1][last], q[2][last], q[3][last]), end_frame(model, state, 2 * l + 1), left,
             right)


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def compute_line_block(l0, l1, model, state, loads):
    """Update loads.f, loads.tau, loads.end_tau of lines l0 .. l1-1 in vectorised passes
    over their Voronoi points, elements and vertices, through the scratch loads.bend_left,
    bend_right, elem_force: the bending of every line of the block, then stretch and shear,
    then the vertex forces (each pass reads fewer arrays at once, and a block's scratch stays
    in cache) (3.2)/(3.3), (3.22)-(3.25)."""
    x, q, stiff = columns(state.x), quat_columns(state.q), columns(model.element_stiffness)
    vor, left, right = voronoi_columns(model), columns(loads.bend_left), columns(loads.bend_right)
    force, f, tau = columns(loads.elem_force), columns(loads.f), columns(loads.tau)
    voff, eoff = model.line_vertex_offsets, model.line_element_offsets
    if bend_lines(l0, l1, voff, eoff, vor, q, left, right):
        for l in range(l0, l1):
            bend_large_span(uint(voff[l]), uint(eoff[l]), 1, eoff[l + 1] - eoff[l], vor, q, left, right)
    for l in range(l0, l1):
        bend_ends(l, model, state, vor, q, left, right)
    stretch_lines(l0, l1, voff, eoff, x, q, stiff, model.element_inv_rest_length, left, right, force, tau)
    if has_rest_strain(model):
        prestress_lines(l0, l1, voff, eoff, x, q, stiff, columns(model.element_rest_strain), force, tau)
    vertex_lines(l0, l1, voff, eoff, force, f)
    for l in range(l0, l1):
        finish_line(l, voff, eoff, force, f, left, right, loads.end_tau)


# compute_line_block compiled inside its serial caller (compute_internal_loads) rather than
# called by it; the threaded loops call it, a task each
line_block = inline_twin(compute_line_block)


# elements per part of a long line (a task of the threaded passes); a line longer than
# LONG_LINE is split across the threads in such parts (as one task it would leave the other
# thread idle)
LINE_PART = 4096
LONG_LINE = 2 * LINE_PART


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def bend_part(v0, e0, j0, j1, model, state, loads):
    """Update loads.bend_left, bend_right at interior Voronoi points j0 .. j1-1 of a line
    (bend_span, then bend_large_span where needed)."""
    vor, q = voronoi_columns(model), quat_columns(state.q)
    left, right = columns(loads.bend_left), columns(loads.bend_right)
    if bend_span(v0, e0, j0, j1, vor, q, left, right):
        bend_large_span(v0, e0, j0, j1, vor, q, left, right)


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def stretch_part(v0, e0, j0, j1, model, state, loads):
    """Update loads.elem_force, tau of elements j0 .. j1-1 of a line (stretch_span)."""
    stretch_span(v0, e0, j0, j1, columns(state.x), quat_columns(state.q), columns(model.element_stiffness),
                 model.element_inv_rest_length, columns(loads.bend_left), columns(loads.bend_right),
                 columns(loads.elem_force), columns(loads.tau))


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def vertex_part(v0, e0, j0, j1, model, state, loads):
    """Update loads.f at interior vertices j0 .. j1-1 of a line (vertex_span)."""
    vertex_span(v0, e0, j0, j1, columns(loads.elem_force), columns(loads.f))


BEND, STRETCH, VERTICES = 0, 1, 2   # the passes of a long line (line_parts)


@stable_cache_key
@njit(**INNER, parallel=True)
def line_parts(which, v0, e0, n, model, state, loads):
    """Update loads by pass ``which`` (BEND: bend_part over the interior Voronoi points,
    STRETCH: stretch_part over the elements, VERTICES: vertex_part over the interior vertices)
    of a line of n elements, in parts of LINE_PART, a task each. (One threaded loop for the
    three passes: numba compiles each prange loop as a kernel of its own, with a wrapper the
    thread pool calls.)"""
    j0, j1 = (0 if which == STRETCH else 1), n
    for p in prange((j1 - j0 + LINE_PART - 1) // LINE_PART):
        a = j0 + p * LINE_PART
        b = min(a + LINE_PART, j1)
        if which == BEND:
            bend_part(v0, e0, a, b, model, state, loads)
        elif which == STRETCH:
            stretch_part(v0, e0, a, b, model, state, loads)
        else:
            vertex_part(v0, e0, a, b, model, state, loads)


@njit(**STEP, inline="always")   # (see longest_lines)
def compute_long_line(l, model, state, loads):
    """Update loads.f, loads.tau, loads.end_tau of line l as compute_line_block, each pass
    split across the threads (a pass finishes before the next one reads its results)."""
    voff, eoff = model.line_vertex_offsets, model.line_element_offsets
    v0, e0, n = uint(voff[l]), uint(eoff[l]), eoff[l + 1] - eoff[l]
    line_parts(np.int64(BEND), v0, e0, n, model, state, loads)
    vor, q = voronoi_columns(model), quat_columns(state.q)
    left, right = columns(loads.bend_left), columns(loads.bend_right)
    bend_ends(l, model, state, vor, q, left, right)
    line_parts(np.int64(STRETCH), v0, e0, n, model, state, loads)
    if has_rest_strain(model):  # on one thread: a long active line is rare
        prestress_span(v0, e0, 0, n, columns(state.x), quat_columns(state.q), columns(model.element_stiffness),
                       columns(model.element_rest_strain), columns(loads.elem_force), columns(loads.tau))
    line_parts(np.int64(VERTICES), v0, e0, n, model, state, loads)
    finish_line(l, voff, eoff, columns(loads.elem_force), columns(loads.f), left, right, loads.end_tau)


@njit(**INLINE)
def lines_per_block(model):
    """Return how many lines make a block of about LINE_BLOCK elements (at least one)."""
    offsets = model.line_element_offsets
    nl = offsets.shape[0] - 1
    return max(1, (LINE_BLOCK * nl) // max(offsets[nl], 1))


@njit(**STEP)
def compute_internal_loads(model, state, loads):
    """Update loads.f (nv,3), loads.tau (ne,3), loads.end_tau (na,3) given the state: the
    internal force and torque balances (3.2)/(3.3) of every line."""
    nl = model.line_vertex_offsets.shape[0] - 1
    per = lines_per_block(model)
    for b in range((nl + per - 1) // per):
        line_block(b * per, min((b + 1) * per, nl), model, state, loads)


def over_line_blocks(block):
    """Return a threaded kernel f(model, state, loads) running block(l0, l1, model, state,
    loads) over the blocks of lines_per_block lines (a task each)."""
    @stable_cache_key
    @njit(**INNER, parallel=True)
    def run(model, state, loads):
        nl = model.line_vertex_offsets.shape[0] - 1
        per = lines_per_block(model)
        # one task: run it here (backend.SOLO); its first line an int64 as the tasks' are (numba
        # compiles a callee once more for a literal 0)
        if nl <= per:
            block(np.int64(0), nl, model, state, loads)
        else:
            for b in prange((nl + per - 1) // per):
                block(b * per, min((b + 1) * per, nl), model, state, loads)
    return run


# Update loads.f, loads.tau, loads.end_tau as compute_internal_loads, a block of lines per
# task: on a net with no line longer than LONG_LINE (backend.Parallel)
compute_internal_loads_parallel = over_line_blocks(compute_line_block)


@njit(**STEP)
def compute_internal_loads_split(model, state, loads):
    """Update loads.f, loads.tau, loads.end_tau as compute_internal_loads: a block of lines
    per task, and each line longer than LONG_LINE split across the threads (backend.ParallelSplit)."""
    short_lines_parallel(model, state, loads)
    longest_lines(model.line_vertex_offsets.shape[0] - 1, model, state, loads)


@njit(**STEP)  # not inline="always": called inside prange (see backend.py)
def compute_short_lines(l0, l1, model, state, loads):
    """compute_line_block over the runs of lines of l0 .. l1-1 between those longer than
    LONG_LINE (which longest_lines splits across the threads)."""
    eoff = model.line_element_offsets
    start = l0
    for l in range(l0, l1):
        if eoff[l + 1] - eoff[l] > LONG_LINE:
            if start < l:
                compute_line_block(start, l, model, state, loads)
            start = l + 1
    if start < l1:
        compute_line_block(start, l1, model, state, loads)


short_lines_parallel = over_line_blocks(compute_short_lines)


@njit(**STEP, inline="always")
def longest_lines(nl, model, state, loads):
    """compute_long_line for every line longer than LONG_LINE (outside the prange loop over
    blocks: each of its passes is a threaded loop of its own). Both compiled inside their one
    caller, compute_internal_loads_split, rather than called: each level of calls would
    optimise and compile the threaded passes' code once more."""
    eoff = model.line_element_offsets
    for l in range(nl):
        if eoff[l + 1] - eoff[l] > LONG_LINE:
            compute_long_line(l, model, state, loads)


internal_loads_on = dispatch(compute_internal_loads, compute_internal_loads_parallel,
                             compute_internal_loads_split)
