"""Diagnostics of a flattened net: energy, momenta, per-vertex fields, worst strain and the
stable-step bound.

They run between steps (at output frames, health checks and set-up), never inside one. Most
are numpy, vectorised over all elements and Voronoi points at once (no compilation at
start-up); the energies and the worst strain, which the instability watch reads before every
output frame, are one compiled pass (kernels/energy.py). The strain energy is the one whose
exact gradient the kernels integrate (kernels/elastic.py): the conservation tests hold the
two together.

Lines are taken as a contiguous block [l0, l1) (one line, or all of them): its elements
e0 .. e1-1 and vertices (= Voronoi points) v0 .. v1-1, with v0 = e0 + l0 (n + 1 vertices per
line of n elements).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..kernels.energy import sum_energies
from ..kernels.layout import Model, State
from ..core.rotations import cols, conj, qexp, qlog, qmul, qrot


# ----------------------------------------------------------------- strains of a block of lines
class Strains(NamedTuple):
    """Strains of the lines l0 .. l1-1: element columns (ne_b,), Voronoi columns (nv_b,)."""

    elements: slice       # global element range
    vertices: slice       # global vertex (Voronoi point) range
    stretch: tuple        # 3 columns: v - v0 per element (v0: the rest strain), principal frame (3.22)
    theta: tuple          # 3 columns: rotation vector between the frames on either side (3.24)
    left: tuple           # 4 columns: frame on the left of each Voronoi point
    curvature: tuple      # 3 columns: u - u0 = theta / L - u0 (3.22)


class Block(NamedTuple):
    """Indices of the lines l0 .. l1-1 of a net."""

    lines: np.ndarray        # (nl_b,) global line indices
    counts: np.ndarray       # (nl_b,) elements per line
    elements: slice          # global element range
    vertices: slice          # global vertex (Voronoi point) range
    left_vertex: np.ndarray  # (ne_b,) local vertex at the start of each element
    starts: np.ndarray       # (nl_b,) local first vertex of each line (its last: starts + counts)


def block_of(model: Model, l0: int = 0, l1: int | None = None) -> Block:
    """The Block of lines l0 .. l1-1 (all lines by default)."""
    eoff = model.line_element_offsets
    l1 = eoff.shape[0] - 1 if l1 is None else l1
    lines = np.arange(l0, l1)
    counts = np.diff(eoff[l0:l1 + 1])
    e0, e1 = int(eoff[l0]), int(eoff[l1])
    starts = eoff[l0:l1] - e0 + lines - l0
    return Block(lines, counts, slice(e0, e1), slice(e0 + l0, e1 + l1),
                 np.arange(e1 - e0) + np.repeat(lines - l0, counts), starts)


def end_frames(model: Model, state: State, ends) -> tuple:
    """Director frames D(nu) X(nu, lambda) of line ends ``ends`` (1.3)."""
    return qmul(cols(state.node_q[model.attach_node[ends]]), cols(model.attach_frame[ends]))


def element_stretch(model: Model, state: State, b: Block) -> tuple:
    """Columns of v - v0 = D^T (x_{e+1} - x_e) / l - v0 of the elements of block b, v0 the
    rest strain (d3 in a model without one), principal frame (3.22)."""
    x = state.x[b.vertices]
    dx = tuple(np.diff(x[:, k])[b.left_vertex] for k in range(3))
    inv_l = model.element_inv_rest_length[b.elements]
    sx, sy, sz = qrot(cols(state.q[b.elements]), dx, inverse=True)
    if not model.element_rest_strain.shape[0]:
        return sx * inv_l, sy * inv_l, sz * inv_l - 1.0
    v0 = cols(model.element_rest_strain[b.elements])
    return sx * inv_l - v0[0], sy * inv_l - v0[1], sz * inv_l - v0[2]


def line_strains(model: Model, state: State, b: Block) -> Strains:
    """Strains of the lines of block b given state.x, q and node_q."""
    ne, nl = b.elements.stop - b.elements.start, b.lines.shape[0]
    nv = b.vertices.stop - b.vertices.start
    # Voronoi point (local vertex) k, i-th of the j-th line of the block (n elements), lies
    # between element k - j - 1 (or the line's start frame if i = 0) and element k - j (its
    # end frame if i = n); the frames are gathered from [elements, start frames, end frames]
    line_of_v = np.repeat(np.arange(nl), b.counts + 1)
    i = np.arange(nv) - b.starts[line_of_v]
    k_elem = np.arange(nv) - line_of_v
    left_idx = np.where(i > 0, k_elem - 1, ne + line_of_v)
    right_idx = np.where(i < b.counts[line_of_v], k_elem, ne + nl + line_of_v)
    frames = [np.concatenate(parts) for parts in zip(cols(state.q[b.elements]),
                                                      end_frames(model, state, 2 * b.lines),
                                                      end_frames(model, state, 2 * b.lines + 1))]
    left = tuple(f[left_idx] for f in frames)
    right = tuple(f[right_idx] for f in frames)
    theta = qlog(qmul(conj(left), right))
    inv_lv = model.voronoi_inv_rest_length[b.vertices]
    u0 = cols(model.voronoi_rest_curvature[b.vertices])
    curvature = tuple(theta[k] * inv_lv - u0[k] for k in range(3))
    return Strains(b.elements, b.vertices, element_stretch(model, state, b), theta, left, curvature)


def vertex_fields(model: Model, state: State, l0: int, l1: int) -> dict:
    """Per-vertex fields of lines l0 .. l1-1, each (nv_b, ...): director frames (quaternions;
    the mid-rotation between neighbouring frames, the line-end frame at the ends), force n and
    torque m in the lab (3.22), strain v - v0 and curvature u - u0 in the director frame."""
    b = block_of(model, l0, l1)
    st = line_strains(model, state, b)
    e, v = st.elements, st.vertices
    K = cols(model.element_stiffness[e])
    n_lab = qrot(cols(state.q[e]), tuple(K[k] * st.stretch[k] for k in range(3)))
    starts, ends = b.starts, b.starts + b.counts

    def at_vertices(a):
        """(nv_b, 3): the mean of the two neighbouring elements, an end element's own at the ends."""
        out = np.zeros((v.stop - v.start, 3))
        for k in range(3):
            out[b.left_vertex, k] += 0.5 * a[k]       # each element is the left neighbour of one vertex
            out[b.left_vertex + 1, k] += 0.5 * a[k]   # and the right neighbour of the next
        out[starts] *= 2.0
        out[ends] *= 2.0
        return out

    frames = np.column_stack(qmul(st.left, qexp(tuple(0.5 * t for t in st.theta))))
    frames[starts] = np.column_stack(end_frames(model, state, 2 * b.lines))
    frames[ends] = np.column_stack(end_frames(model, state, 2 * b.lines + 1))
    B = cols(model.voronoi_stiffness[v])
    torque = qrot(cols(frames), tuple(B[k] * st.curvature[k] for k in range(3)))
    return {"frames": frames, "force": at_vertices(n_lab), "torque": np.column_stack(torque),
            "strain": at_vertices(st.stretch), "curvature": np.column_stack(st.curvature)}


def worst_strain(model: Model, state: State) -> tuple[float, int]:
    """(max |v - v0|_1 over elements, its element): stretch and shear (3.22); a NaN counts as
    the worst."""
    _, _, _, worst, e = sum_energies(model, state)
    return float(worst), int(e)


# ----------------------------------------------------------------- energy and momenta
def energies(model: Model, state: State) -> tuple[float, float, float]:
    """(translational kinetic, rotational kinetic, strain) energy of lines and nodes: the
    kinetic terms of (3.7)/(4.6) and the potential (3.25), in one compiled pass (the watch
    reads them before every output frame: in numpy they cost more than the steps of a small
    net)."""
    kt, kr, u, _, _ = sum_energies(model, state)
    return float(kt), float(kr), float(u)


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
    J, w = cols(model.element_inertia), cols(state.w)
    out[1] += [c.sum() for c in qrot(cols(state.q), tuple(J[k] * w[k] for k in range(3)))]
    spin = cols(np.where(model.node_locked == 0.0, model.node_inertia, 0.0) * state.node_w)
    out[1] += [c.sum() for c in qrot(cols(state.node_q), spin)]
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


# A node whose highest frequency (its Gershgorin bound) times the step is below this is slow
# beside the grid: a step resolves its turning against its line ends (a heavy fitting on a
# sagging wire swings against the wire in a mode of 170 steps a period, omega dt = 0.037),
# which is motion, not flutter. The flutter node_wobble looks for is at the grid scale
# (omega dt = 1.5 at the tip of docs/rolled_cantilever.md's rod).
GRID_SCALE = 0.25


def node_wobble(model: Model, state: State, dt: float | None = None) -> tuple[float, float, int]:
    """(angle, rate, line end): the largest turning rate |w_node - w_end element| (lab) of a
    rotating node against the end element of a line attached to it, and that rate divided
    by the node's highest frequency (its Gershgorin bound): the amplitude, in rad, of a
    vibration of the node against its line end at the grid scale. Resolved motion turns a
    node with its line ends (the angle stays far below 1e-3 rad); a node fluttering at the
    grid scale does not. With the step ``dt``, nodes slower than GRID_SCALE / dt are left out."""
    na = model.attach_node.shape[0]
    if na == 0:
        return 0.0, 0.0, 0
    nd, e = model.attach_node, model.attach_element
    free = model.node_locked[nd] == 0.0
    w_node = qrot(cols(state.node_q[nd]), cols(np.where(free, state.node_w[nd], 0.0)))
    w_elem = qrot(cols(state.q[e]), cols(state.w[e]))
    rate = np.sqrt(sum((w_node[k] - w_elem[k]) ** 2 for k in range(3)))
    w2 = node_row_bounds(model, node_min_inertia(model))[nd]
    rotating = np.any(free, axis=1) & (w2 > 0.0)
    if dt is not None:
        rotating &= w2 * dt * dt >= GRID_SCALE ** 2
    angle = np.where(rotating, rate / np.sqrt(np.where(rotating, w2, 1.0)), 0.0)
    a = int(np.argmax(angle))
    return float(angle[a]), float(rate[a]), a
