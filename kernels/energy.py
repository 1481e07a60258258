"""The energies of a net in one pass over its flat arrays: what the instability watch reads
before every output frame, and Simulation.energy.

The strain energy is (3.25) as kernels/elastic.py states it, with the same relative rotations
(relative_rotation) and line-end frames (end_frame), so the loads stay its exact gradient;
the kinetic energy is that of (3.7)/(4.6). The largest strain |v - v0|_1 (v0 the rest strain,
d3 unless an active line changes it) comes from the same pass over the elements (the watch's
strain test).
"""

import math

from numba import njit

from .elastic import end_frame
from .compiler import CACHED
from .rotations import quat_rotate_inv, relative_rotation

# not the kernels' fastmath: under it LLVM may take the test for a non-finite strain for
# always true, and a NaN must be found here
EXACT = dict(CACHED, fastmath=False)


@njit(**EXACT)
def sum_energies(model, state):
    """Return (translational kinetic, rotational kinetic, strain energy, largest |v - v0|_1
    over the elements, that element) given the state, lines and nodes; a non-finite strain
    counts as the largest (the first element holding one), and a net without elements has
    largest strain 0 at element 0."""
    x, v, q, w = state.x, state.v, state.q, state.w
    kt = 0.0
    for i in range(v.shape[0]):
        if model.vertex_inv_mass[i] > 0.0:   # line-end vertices move with their node
            kt += model.vertex_mass[i] * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
    kr = 0.0
    J = model.element_inertia
    for e in range(w.shape[0]):
        kr += J[e, 0] * w[e, 0] * w[e, 0] + J[e, 1] * w[e, 1] * w[e, 1] + J[e, 2] * w[e, 2] * w[e, 2]
    nv, nw = state.node_v, state.node_w
    for n in range(nv.shape[0]):
        if model.node_inv_mass[n] > 0.0:
            kt += model.node_mass[n] * (nv[n, 0] * nv[n, 0] + nv[n, 1] * nv[n, 1] + nv[n, 2] * nv[n, 2])
        for k in range(3):
            if model.node_locked[n, k] == 0.0:   # a locked axis has infinite inertia and no spin
                kr += model.node_inertia[n, k] * nw[n, k] * nw[n, k]
    u = 0.0
    worst, worst_e, bad = 0.0, 0, False
    K, il, le = model.element_stiffness, model.element_inv_rest_length, model.element_rest_length
    rs = model.element_rest_strain
    strained = rs.shape[0] > 0
    B, u0 = model.voronoi_stiffness, model.voronoi_rest_curvature
    lv, ilv = model.voronoi_rest_length, model.voronoi_inv_rest_length
    voff, eoff = model.line_vertex_offsets, model.line_element_offsets
    for line in range(eoff.shape[0] - 1):
        v0, e0, n = voff[line], eoff[line], eoff[line + 1] - eoff[line]
        for j in range(n):
            e, a = e0 + j, v0 + j
            sx, sy, sz = quat_rotate_inv(q[e, 0], q[e, 1], q[e, 2], q[e, 3], x[a + 1, 0] - x[a, 0],
                                         x[a + 1, 1] - x[a, 1], x[a + 1, 2] - x[a, 2])
            if strained:   # an active line's rest strain v0 (kernels/active.py)
                sx, sy, sz = sx * il[e] - rs[e, 0], sy * il[e] - rs[e, 1], sz * il[e] - rs[e, 2]
            else:          # v0 = d3
                sx, sy, sz = sx * il[e], sy * il[e], sz * il[e] - 1.0
            u += le[e] * (K[e, 0] * sx * sx + K[e, 1] * sy * sy + K[e, 2] * sz * sz)
            s = abs(sx) + abs(sy) + abs(sz)
            if not bad and not math.isfinite(s):
                worst, worst_e, bad = s, e, True
            elif not bad and s > worst:
                worst, worst_e = s, e
        for j in range(n + 1):
            # Voronoi point j joins the frames on either side: the line-end frames at the ends
            if j == 0:
                aw, ax, ay, az = end_frame(model, state, 2 * line)
            else:
                p = e0 + j - 1
                aw, ax, ay, az = q[p, 0], q[p, 1], q[p, 2], q[p, 3]
            if j == n:
                bw, bx, by, bz = end_frame(model, state, 2 * line + 1)
            else:
                p = e0 + j
                bw, bx, by, bz = q[p, 0], q[p, 1], q[p, 2], q[p, 3]
            tx, ty, tz, _ = relative_rotation(aw, ax, ay, az, bw, bx, by, bz)
            k = v0 + j
            cx, cy, cz = tx * ilv[k] - u0[k, 0], ty * ilv[k] - u0[k, 1], tz * ilv[k] - u0[k, 2]
            u += lv[k] * (B[k, 0] * cx * cx + B[k, 1] * cy * cy + B[k, 2] * cz * cz)
    return 0.5 * kt, 0.5 * kr, 0.5 * u, worst, worst_e
