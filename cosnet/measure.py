"""Diagnostics of a flattened net in numpy: energy, momenta, per-vertex fields, worst strain
and the stable-step bound.

They run between steps (at output frames, health checks and set-up), never inside one, and
are vectorised over all elements and Voronoi points at once; written in numpy they cost no
compilation at start-up. The strain energy here is the one whose exact gradient the kernels
integrate (kernels/elastic.py): the conservation tests hold the two together.

Lines are taken as a contiguous block [l0, l1) (one line, or all of them): its elements
e0 .. e1-1 and vertices (= Voronoi points) v0 .. v1-1, with v0 = e0 + l0 (n + 1 vertices per
line of n elements).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .kernels.layout import Model, State


# ----------------------------------------------------------------- quaternion stacks (n, 4)
def qmul(a, b):
    """(n, 4) Hamilton products a b of quaternion stacks (w, x, y, z)."""
    aw, ax, ay, az = a.T
    bw, bx, by, bz = b.T
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], axis=1)


def qrot(q, v, inverse=False):
    """(n, 3) R(q) v (body -> lab), or R(q)^T v with inverse=True."""
    w = -q[:, :1] if inverse else q[:, :1]
    u = q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def qlog(q):
    """(n, 3) rotation vectors, |theta| <= pi, of unit quaternions q (n, 4)."""
    q = np.where(q[:, :1] < 0.0, -q, q)
    w, u = q[:, 0], q[:, 1:]
    s = np.sqrt(np.sum(u * u, axis=1))
    small = s < 1e-4 * w
    r = np.where(small, (s / np.where(small, w, 1.0)) ** 2, 0.0)
    f = np.where(small, (2.0 / np.where(small, w, 1.0)) * (1.0 - r / 3.0 + r * r / 5.0),
                 2.0 * np.arctan2(s, w) / np.where(small, 1.0, s))
    return f[:, None] * u


def qexp(theta):
    """(n, 4) unit quaternions exp(theta) of rotation vectors theta (n, 3)."""
    a = np.sqrt(np.sum(theta * theta, axis=1))
    small = a < 1e-6
    s = np.where(small, 0.5 - a * a / 48.0, np.sin(0.5 * a) / np.where(small, 1.0, a))
    return np.concatenate([np.cos(0.5 * a)[:, None], s[:, None] * theta], axis=1)


def conj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


# ----------------------------------------------------------------- strains of a block of lines
class Strains(NamedTuple):
    """Strains of the lines l0 .. l1-1 (element arrays (ne_b, ...), Voronoi arrays (nv_b, ...))."""

    elements: slice       # global element range
    vertices: slice       # global vertex (Voronoi point) range
    stretch: np.ndarray   # (ne_b, 3) v - d3 per element, principal frame (3.22)
    theta: np.ndarray     # (nv_b, 3) rotation vector between the frames on either side (3.24)
    left: np.ndarray      # (nv_b, 4) frame on the left of each Voronoi point
    curvature: np.ndarray  # (nv_b, 3) u - u0 = theta / L - u0 (3.22)


def end_frames(model: Model, state: State, ends) -> np.ndarray:
    """(len(ends), 4) director frames D(nu) X(nu, lambda) of line ends ``ends`` (1.3)."""
    return qmul(state.node_q[model.attach_node[ends]], model.attach_frame[ends])


def line_strains(model: Model, state: State, l0: int = 0, l1: int | None = None) -> Strains:
    """Strains of lines l0 .. l1-1 (all lines by default) given state.x, q and node_q."""
    eoff = model.line_element_offsets
    l1 = eoff.shape[0] - 1 if l1 is None else l1
    lines = np.arange(l0, l1)
    e0, e1 = int(eoff[l0]), int(eoff[l1])
    v0, v1 = e0 + l0, e1 + l1
    counts = np.diff(eoff[l0:l1 + 1])
    line_of_e = np.repeat(lines, counts)                  # (ne_b,)
    left_vertex = np.arange(e0, e1) + line_of_e           # (ne_b,) global
    q = state.q[e0:e1]
    s = qrot(q, state.x[left_vertex + 1] - state.x[left_vertex], inverse=True)
    stretch = s * model.element_inv_rest_length[e0:e1, None]
    stretch[:, 2] -= 1.0
    # the frames of each line in order: start frame, its elements, end frame; Voronoi point
    # (local vertex) k of line l lies between frames k + (l - l0) and k + (l - l0) + 1
    chain = np.empty((v1 - v0 + l1 - l0, 4))
    chain[np.arange(e0, e1) - e0 + 2 * (line_of_e - l0) + 1] = q
    starts = eoff[l0:l1] - e0 + 2 * (lines - l0)
    chain[starts] = end_frames(model, state, 2 * lines)
    chain[starts + counts + 1] = end_frames(model, state, 2 * lines + 1)
    line_of_v = np.repeat(lines, counts + 1)
    k = np.arange(v1 - v0) + (line_of_v - l0)
    left, right = chain[k], chain[k + 1]
    theta = qlog(qmul(conj(left), right))
    curvature = theta * model.voronoi_inv_rest_length[v0:v1, None] - model.voronoi_rest_curvature[v0:v1]
    return Strains(slice(e0, e1), slice(v0, v1), stretch, theta, left, curvature)


def strain_energy(model: Model, st: Strains) -> float:
    """Strain energy (3.25) of the lines of st."""
    e, v = st.elements, st.vertices
    u = 0.5 * np.sum(model.element_rest_length[e, None] * model.element_stiffness[e] * st.stretch ** 2)
    u += 0.5 * np.sum(model.voronoi_rest_length[v, None] * model.voronoi_stiffness[v] * st.curvature ** 2)
    return float(u)


def vertex_fields(model: Model, state: State, l0: int, l1: int) -> dict:
    """Per-vertex fields of lines l0 .. l1-1, each (nv_b, ...): director frames (quaternions;
    the mid-rotation between neighbouring frames, the line-end frame at the ends), force n and
    torque m in the lab (3.22), strain v - d3 and curvature u - u0 in the director frame."""
    st = line_strains(model, state, l0, l1)
    e = st.elements
    eoff = model.line_element_offsets[l0:l1 + 1]
    n_lab = qrot(state.q[e], model.element_stiffness[e] * st.stretch)
    # vertex values: the mean of the two neighbouring elements, an end element's own at the ends
    line_of_e = np.repeat(np.arange(l0, l1), np.diff(eoff))
    lv = np.arange(e.start, e.stop) + line_of_e - st.vertices.start   # local left vertex
    nvb = st.vertices.stop - st.vertices.start
    ends_lo = eoff[:-1] + np.arange(l0, l1) - st.vertices.start
    ends_hi = eoff[1:] + np.arange(l0, l1) - st.vertices.start
    weight = np.full(nvb, 0.5)
    weight[ends_lo] = weight[ends_hi] = 1.0

    def at_vertices(a):
        out = np.zeros((nvb, 3))
        out[lv] += a          # each element is the left neighbour of one vertex
        out[lv + 1] += a      # and the right neighbour of the next
        return out * weight[:, None]

    frames = qmul(st.left, qexp(0.5 * st.theta))
    frames[ends_lo] = end_frames(model, state, 2 * np.arange(l0, l1))
    frames[ends_hi] = end_frames(model, state, 2 * np.arange(l0, l1) + 1)
    moment = model.voronoi_stiffness[st.vertices] * st.curvature
    return {"frames": frames, "force": at_vertices(n_lab), "torque": qrot(frames, moment),
            "strain": at_vertices(st.stretch), "curvature": st.curvature}


def worst_strain(model: Model, state: State) -> tuple[float, int]:
    """(max |v - d3|_1 over elements, its element): stretch and shear (3.22); a NaN counts as
    the worst."""
    if model.element_rest_length.shape[0] == 0:
        return 0.0, 0
    s = np.sum(np.abs(line_strains(model, state).stretch), axis=1)
    bad = np.flatnonzero(~np.isfinite(s))
    e = int(bad[0]) if bad.size else int(np.argmax(s))
    return float(s[e]), e


# ----------------------------------------------------------------- energy and momenta
def energies(model: Model, state: State) -> tuple[float, float, float]:
    """(translational kinetic, rotational kinetic, strain) energy of lines and nodes: the
    kinetic terms of (3.7)/(4.6) and the potential (3.25)."""
    moving = model.vertex_inv_mass > 0.0
    kt = 0.5 * np.sum(model.vertex_mass[moving, None] * state.v[moving] ** 2)
    kr = 0.5 * np.sum(model.element_inertia * state.w ** 2)
    nodes = model.node_inv_mass > 0.0
    kt += 0.5 * np.sum(model.node_mass[nodes, None] * state.node_v[nodes] ** 2)
    free = model.node_locked == 0.0
    kr += 0.5 * np.sum(np.where(free, model.node_inertia, 0.0) * np.where(free, state.node_w, 0.0) ** 2)
    u = strain_energy(model, line_strains(model, state)) if model.element_rest_length.shape[0] else 0.0
    return float(kt), float(kr), u


def momenta(model: Model, state: State) -> np.ndarray:
    """(2, 3): linear momentum and angular momentum about the origin of everything moving
    (vertices, elements, nodes of finite mass/inertia)."""
    out = np.zeros((2, 3))
    for mass, inv, x, v in ((model.vertex_mass, model.vertex_inv_mass, state.x, state.v),
                            (model.node_mass, model.node_inv_mass, state.node_x, state.node_v)):
        moving = inv > 0.0
        p = mass[moving, None] * v[moving]
        out[0] += p.sum(axis=0)
        out[1] += np.cross(x[moving], p).sum(axis=0)
    out[1] += qrot(state.q, model.element_inertia * state.w).sum(axis=0)
    spin = np.where(model.node_locked == 0.0, model.node_inertia, 0.0) * state.node_w
    out[1] += qrot(state.node_q, spin).sum(axis=0)
    return out


# ----------------------------------------------------------------- stable-step bound
def bound_max_omega2(model: Model) -> tuple[float, int, int]:
    """(omega2, kind, index): the largest Gershgorin row bound of omega^2 of the net
    linearised about its rest state, M^-1/2 K M^-1/2, and where it sits (kind 0 vertex,
    1 element, 2 node; index global).

    K is the stiffness of the strain energy (3.25): per element, stretch/shear springs K/l
    between its vertices, the shear coupling k G A between vertex motion and element rotation
    (the r' x n term of (3.3)) and k G A l on the rotation itself; per Voronoi point,
    bend/twist springs B/L between neighbouring frames (element or node). Each row sum bounds
    omega^2 of the modes living on that degree of freedom; the largest bounds them all."""
    K, J, m = model.element_stiffness, model.element_inertia, model.vertex_mass
    B, lv = model.voronoi_stiffness, model.voronoi_rest_length
    eoff = model.line_element_offsets
    nl, ne = eoff.shape[0] - 1, K.shape[0]
    counts = np.diff(eoff)
    line_of_e = np.repeat(np.arange(nl), counts)
    vl = np.arange(ne) + line_of_e             # left vertex of each element; right = vl + 1
    vr = vl + 1
    kl = np.maximum(K[:, 0], K[:, 2]) / model.element_rest_length
    ks = np.maximum(K[:, 0], K[:, 1])
    jb = np.minimum(J[:, 0], J[:, 1])
    # vertices: the elements on either side (only interior vertices move on their own)
    rows = np.zeros(m.shape[0])
    for own, other in ((vl, vr), (vr, vl)):
        rows += np.bincount(own, kl / m[own] + kl / np.sqrt(m[own] * m[other]) + ks / np.sqrt(m[own] * jb),
                            minlength=m.shape[0])
    line_end = np.zeros(m.shape[0], dtype=bool)
    line_end[model.attach_vertex] = True
    rows[line_end] = 0.0
    # elements: shear on the rotation, the coupling to its vertices, bend/twist to its neighbours
    r = ks * model.element_rest_length / jb + ks / np.sqrt(jb * m[vl]) + ks / np.sqrt(jb * m[vr])
    rt = np.zeros(ne)
    jn = node_min_inertia(model)
    first = np.zeros(ne, dtype=bool)
    first[eoff[:-1][counts > 0]] = True
    last = np.zeros(ne, dtype=bool)
    last[eoff[1:][counts > 0] - 1] = True
    for k, at_end, side, step in ((vl, first, 0, -1), (vr, last, 1, 1)):
        other = np.clip(np.arange(ne) + step, 0, max(ne - 1, 0))
        j_node = jn[model.attach_node[2 * line_of_e + side]]
        finite = j_node != np.inf
        with np.errstate(divide="ignore"):
            cb_node = np.where(finite, 1.0 / np.sqrt(jb * np.where(finite, j_node, 1.0)), 0.0)
            ct_node = np.where(finite, 1.0 / np.sqrt(J[:, 2] * np.where(finite, j_node, 1.0)), 0.0)
        cb = np.where(at_end, cb_node, 1.0 / np.sqrt(jb * np.minimum(J[other, 0], J[other, 1])))
        ct = np.where(at_end, ct_node, 1.0 / np.sqrt(J[:, 2] * J[other, 2]))
        r += np.maximum(B[k, 0], B[k, 1]) / lv[k] * (1.0 / jb + cb)
        rt += B[k, 2] / lv[k] * (1.0 / J[:, 2] + ct)
    r = np.maximum(r, rt)
    nodes = node_row_bounds(model, jn)
    best = (0.0, 0, 0)
    for kind, a in enumerate((rows, r, nodes)):
        if a.size and a.max() > best[0]:
            best = (float(a.max()), kind, int(np.argmax(a)))
    return best


def node_min_inertia(model: Model) -> np.ndarray:
    """(nn,) the smallest finite principal inertia of each node (inf if all axes are locked)."""
    return np.min(np.where(model.node_locked == 0.0, model.node_inertia, np.inf), axis=1)


def node_row_bounds(model: Model, jn: np.ndarray) -> np.ndarray:
    """(nn,) Gershgorin bounds of omega^2 for each node's translation and rotation rows,
    summed over the line ends attached to it."""
    K, J, m = model.element_stiffness, model.element_inertia, model.vertex_mass
    a = np.arange(model.attach_node.shape[0])
    nd = model.attach_node
    e, vt = model.attach_element, model.attach_vertex
    other = np.where(a % 2 == 0, vt + 1, vt - 1)
    kl = np.maximum(K[e, 0], K[e, 2]) / model.element_rest_length[e]
    ks = np.maximum(K[e, 0], K[e, 1])
    jb = np.minimum(J[e, 0], J[e, 1])
    M = model.node_mass[nd]
    has_m = M != np.inf
    Mf = np.where(has_m, M, 1.0)
    rt = np.where(has_m, kl / Mf + kl / np.sqrt(Mf * m[other]) + ks / np.sqrt(Mf * jb), 0.0)
    j = jn[nd]
    has_j = j != np.inf
    jf = np.where(has_j, j, 1.0)
    rho = np.sqrt(np.sum(model.attach_offset ** 2, axis=1))
    bmax = np.max(model.voronoi_stiffness[vt], axis=1) / model.voronoi_rest_length[vt]
    rr = bmax * (1.0 / jf + 1.0 / np.sqrt(jf * np.minimum(jb, J[e, 2])))
    rr += kl * rho * (rho / jf + 1.0 / np.sqrt(jf * m[other]))
    rr += ks * rho / np.sqrt(jf * jb)
    rr += np.where(has_m, kl * rho / np.sqrt(jf * Mf), 0.0)
    rr = np.where(has_j, rr, 0.0)
    nn = model.node_mass.shape[0]
    return np.maximum(np.bincount(nd, rt, minlength=nn), np.bincount(nd, rr, minlength=nn))
