"""Stable time step: a Gershgorin bound on the largest eigenvalue of M^-1/2 K M^-1/2.

K is the stiffness of the linearised strain energy (3.25) about the rest state: per element,
stretch/shear springs K/l between its vertices, the shear coupling k G A between vertex motion
and element rotation (the r' x n term of (3.3)) and k G A l on the rotation itself; per
Voronoi point, bend/twist springs B/L between neighbouring frames (element or node). Each row
sum bounds omega^2 of the modes living on that degree of freedom; the largest bounds them all.
"""

import math

from numba import njit


@njit(cache=True)
def bound_max_omega2(model):
    """Return (omega2, kind, index): the largest Gershgorin row bound of omega^2 and where it
    sits (kind 0 vertex, 1 element, 2 node; index global)."""
    best, kind, where = 0.0, 0, 0
    m, J, K, B = model.vertex_mass, model.element_inertia, model.element_stiffness, model.voronoi_stiffness
    nl = model.line_vertex_offsets.shape[0] - 1
    for l in range(nl):
        v0 = model.line_vertex_offsets[l]
        e0 = model.line_element_offsets[l]
        n = model.line_element_offsets[l + 1] - e0
        for i in range(1, n):  # interior vertices: elements i-1 and i
            vt = v0 + i
            r = 0.0
            for side in range(2):  # the element before, then after
                e, other = e0 + i - 1 + side, vt - 1 + 2 * side
                kl = max(K[e, 0], K[e, 2]) / model.element_rest_length[e]
                r += kl / m[vt] + kl / math.sqrt(m[vt] * m[other])
                r += max(K[e, 0], K[e, 1]) / math.sqrt(m[vt] * min(J[e, 0], J[e, 1]))
            if r > best:
                best, kind, where = r, 0, vt
        for i in range(n):
            e = e0 + i
            jb = min(J[e, 0], J[e, 1])
            ks = max(K[e, 0], K[e, 1])
            r = ks * model.element_rest_length[e] / jb
            r += ks / math.sqrt(jb * m[v0 + i]) + ks / math.sqrt(jb * m[v0 + i + 1])
            rt = 0.0
            for side in range(2):  # the Voronoi point before, then after
                k = v0 + i + side
                lk = model.voronoi_rest_length[k]
                if (side == 0 and i == 0) or (side == 1 and i == n - 1):
                    nd = model.attach_node[2 * l + side]  # the neighbour is a node frame
                    jn = node_min_inertia(model, nd)
                    cb = 0.0 if jn == math.inf else 1.0 / math.sqrt(jb * jn)
                    ct = 0.0 if jn == math.inf else 1.0 / math.sqrt(J[e, 2] * jn)
                else:
                    other = e - 1 if side == 0 else e + 1
                    cb = 1.0 / math.sqrt(jb * min(J[other, 0], J[other, 1]))
                    ct = 1.0 / math.sqrt(J[e, 2] * J[other, 2])
                r += max(B[k, 0] / lk, B[k, 1] / lk) * (1.0 / jb + cb)
                rt += B[k, 2] / lk * (1.0 / J[e, 2] + ct)
            r = max(r, rt)
            if r > best:
                best, kind, where = r, 1, e
    for nd in range(model.node_mass.shape[0]):
        r = node_row_bound(model, nd)
        if r > best:
            best, kind, where = r, 2, nd
    return best, kind, where


@njit(cache=True, inline="always")
def node_min_inertia(model, nd):
    """Return the smallest finite principal inertia of node nd (inf if all axes are locked)."""
    jn = math.inf
    for k in range(3):
        if model.node_locked[nd, k] == 0.0:
            jn = min(jn, model.node_inertia[nd, k])
    return jn


@njit(cache=True, inline="always")
def node_row_bound(model, nd):
    """Return the Gershgorin bound of omega^2 for node nd's translation and rotation rows."""
    M = model.node_mass[nd]
    jn = node_min_inertia(model, nd)
    rt, rr = 0.0, 0.0
    K, J, m = model.element_stiffness, model.element_inertia, model.vertex_mass
    for j in range(model.node_attach_offsets[nd], model.node_attach_offsets[nd + 1]):
        a = model.node_attach_list[j]
        e = model.attach_element[a]
        vt = model.attach_vertex[a]
        l = model.element_rest_length[e]
        start = a % 2 == 0
        other = vt + 1 if start else vt - 1
        other_mass = m[other]  # lumped mass of the neighbouring vertex (a lower bound if it is a line end)
        kl = max(K[e, 0], K[e, 2]) / l
        ks = max(K[e, 0], K[e, 1])
        jb = min(J[e, 0], J[e, 1])
        if M != math.inf:
            rt += kl / M + kl / math.sqrt(M * other_mass) + ks / math.sqrt(M * jb)
        if jn != math.inf:
            o = model.attach_offset[a]
            rho = math.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
            B = model.voronoi_stiffness
            bmax = max(B[vt, 0], B[vt, 1], B[vt, 2]) / model.voronoi_rest_length[vt]
            rr += bmax * (1.0 / jn + 1.0 / math.sqrt(jn * min(jb, J[e, 2])))
            rr += kl * rho * (rho / jn + 1.0 / math.sqrt(jn * other_mass))
            rr += ks * rho / math.sqrt(jn * jb)
            if M != math.inf:
                rr += kl * rho / math.sqrt(jn * M)
    return max(rt, rr)
