"""One pass from a validated Net to contiguous arrays (see cosnet.kernels.layout).

Builds, per line, the staggered grid (vertices, elements, Voronoi points) in the principal
axes of its cross-section, and per node the composite rigid body: the node's own mass and
inertia plus the lumped masses of its line ends (at their offsets xi) and a quarter of the
rotary inertia of each end element (the dual cell [0, l/4] of the node's rotation), all about
the composite centre of mass, in principal axes.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..core.fast_modes import apply_factors, line_factors
from ..core.grid import NODE_ROTARY_SHARE, LineGrid, build_line_grid
from ..core.rotations import inertia_shift, quat_from_matrix
from ..kernels.layout import Model, State, column_major

if TYPE_CHECKING:
    from ..core.net import Net


def _composite_body(node, ends):
    """Return (mass, com_offset_user, inertia_user (3,3), locked (3,)) of node + line ends.
    ends: list of (offset xi (user body frame), end mass, rotary inertia share (3,3) user frame)."""
    locked = node.locked_axes.copy()
    m_end = sum(m for _, m, _ in ends)
    if math.isinf(node.mass):
        mass, com = math.inf, np.zeros(3)
    else:
        mass = node.mass + m_end
        com = sum((m * xi for xi, m, _ in ends), np.zeros(3)) / mass
    I = np.where(np.isinf(node.inertia), 0.0, node.inertia)

    if not math.isinf(node.mass):
        I = I + node.mass * inertia_shift(-com)
    for xi, m, j in ends:
        I = I + m * inertia_shift(xi - com) + j
    # a locked axis is infinitely stiff: its couplings to the free axes vanish in the limit
    I[locked, :] = 0.0
    I[:, locked] = 0.0
    return mass, com, I, locked


def _eigh_deterministic(I):
    """Return eigh(I) with axes that do not depend on the LAPACK build: within a repeated
    eigenvalue (a round body, a sphere) the user's body axes projected on the eigenspace,
    and every axis signed so that its largest component is positive."""
    vals, vecs = np.linalg.eigh(I)
    scale = max(float(np.abs(vals).max(initial=0.0)), 1e-300)
    i = 0
    while i < len(vals):
        j = i + 1
        while j < len(vals) and vals[j] - vals[i] <= 1e-9 * scale:
            j += 1
        if j - i > 1:
            space = vecs[:, i:j]
            proj = space @ space.T            # projector on the eigenspace
            cols = proj[:, np.argsort(-np.linalg.norm(proj, axis=0), kind="stable")[:j - i]]
            vecs[:, i:j] = np.linalg.qr(cols)[0]
        i = j
    sign = np.sign(vecs[np.argmax(np.abs(vecs), axis=0), np.arange(vecs.shape[1])])
    return vals, vecs * sign


def _principal_frame(I, locked):
    """Return (P, diag): rotation P (user body -> principal, columns principal axes) and the
    principal inertia with inf on locked axes."""
    free = np.flatnonzero(~locked)
    P = np.eye(3)
    diag = np.full(3, math.inf)
    if free.size:
        vals, vecs = _eigh_deterministic(I[np.ix_(free, free)])
        block = np.eye(3)
        block[np.ix_(free, free)] = vecs
        if np.linalg.det(block) < 0:
            block[:, free[0]] *= -1.0
        P = block
        diag[free] = vals
    return P, diag


def flatten(net: Net, fast_modes: str = "resolve", load: float = 0.0,
            rest_strain: bool = False) -> tuple[Model, State, list[LineGrid]]:
    """Return the static Model, the initial State (at rest) and each line's grid, each line
    treated by its fast-modes setting (else ``fast_modes``) given the net's load scale (N);
    see cosnet.core.fast_modes. ``rest_strain``: give the model a rest strain v0 = d3 per element,
    for an active line to change (else it has none, and the step no rest-strain pass)."""
    net.validate()
    grids = [build_line_grid(l) for l in net.lines]
    for line, g in zip(net.lines, grids):
        g.factors = line_factors(line, g, fast_modes, load)
        apply_factors(g, g.factors)
        # a jointed end's boundary point bends between the joint's frame and the end element:
        # the model holds no stiffness there, the joints' effect holds it (cosnet.effects.articulations)
        g.held_bend = g.bend[[0, -1]].copy()
        for k, joint in ((0, line.start_joint), (-1, line.end_joint)):
            if joint is not None:
                g.bend[k] = 0.0
    nl, nn = len(net.lines), len(net.nodes)
    nverts = np.array([g.x.shape[0] for g in grids], dtype=np.int64)
    vo = np.concatenate([[0], np.cumsum(nverts)]).astype(np.int64)
    eo = np.concatenate([[0], np.cumsum(nverts - 1)]).astype(np.int64)
    cat = (lambda key, shape: np.concatenate([getattr(g, key) for g in grids]) if grids
           else np.zeros(shape))
    x = cat("x", (0, 3))
    vmass = cat("mass", (0,))
    frames = cat("frames", (0, 3, 3))
    rest_length = cat("rest_length", (0,))
    inertia = cat("inertia", (0, 3))
    inv_mass = np.where(vmass > 0, 1.0 / np.where(vmass > 0, vmass, 1.0), 0.0)
    inv_mass[vo[:-1]] = 0.0
    inv_mass[vo[1:] - 1] = 0.0

    # attachments: 2 l start, 2 l + 1 end
    na = 2 * nl
    attach_node = np.zeros(na, dtype=np.int64)
    attach_vertex = np.zeros(na, dtype=np.int64)
    attach_element = np.zeros(na, dtype=np.int64)
    ends_of: dict[int, list] = {n.index: [] for n in net.nodes}
    for l, (line, g) in enumerate(zip(net.lines, grids)):
        for side, node, xi in ((0, line.start, line.start_offset), (1, line.end, line.end_offset)):
            a = 2 * l + side
            attach_node[a] = node.index
            attach_vertex[a] = vo[l] if side == 0 else vo[l + 1] - 1
            attach_element[a] = eo[l] if side == 0 else eo[l + 1] - 1
            end_frame = g.end_frames[side]
            e_local = 0 if side == 0 else line.elements - 1
            Xfull = node.frame.T @ end_frame          # X in the node's user frame (principal section axes)
            whole = g.inertia[e_local] / (1.0 - NODE_ROTARY_SHARE * (2 if line.elements == 1 else 1))
            end_rot = NODE_ROTARY_SHARE * Xfull @ np.diag(whole) @ Xfull.T
            ends_of[node.index].append((a, xi, g.mass[0 if side == 0 else -1], end_rot, Xfull))

    node_mass = np.zeros(nn)
    node_own = np.zeros(nn)
    node_J = np.zeros((nn, 3))
    node_locked = np.zeros((nn, 3))
    node_com = np.zeros((nn, 3))
    node_P: np.ndarray = np.zeros((nn, 3, 3))          # rotation matrices, turned to quaternions at once below
    node_x = np.zeros((nn, 3))
    node_q: np.ndarray = np.zeros((nn, 3, 3))
    attach_offset = np.zeros((na, 3))
    attach_frame: np.ndarray = np.zeros((na, 3, 3))
    for node in net.nodes:
        i = node.index
        ends = ends_of[i]
        mass, com, I, locked = _composite_body(node, [(xi, m, j) for _, xi, m, j, _ in ends])
        P, diag = _principal_frame(I, locked)
        node_mass[i] = mass
        node_own[i] = node.mass if math.isfinite(node.mass) else 0.0
        node_J[i] = diag
        node_locked[i] = locked.astype(float)
        node_com[i] = P.T @ com
        node_P[i] = P
        node_x[i] = node.position + node.frame @ com
        node_q[i] = node.frame @ P
        for a, xi, _, _, Xfull in ends:
            attach_offset[a] = P.T @ (xi - com)
            attach_frame[a] = P.T @ Xfull
    quats = lambda m: quat_from_matrix(m) if len(m) else np.zeros((0, 4))
    node_P, node_q, attach_frame = quats(node_P), quats(node_q), quats(attach_frame)
    order = np.argsort(attach_node, kind="stable")
    counts = np.bincount(attach_node, minlength=nn) if na else np.zeros(nn, dtype=np.int64)
    node_attach_offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

    with np.errstate(divide="ignore"):
        inv = lambda a: np.where(np.isinf(a), 0.0, 1.0 / a)
        model = Model(
            line_vertex_offsets=vo, line_element_offsets=eo,
            vertex_mass=vmass, vertex_inv_mass=inv_mass,
            vertex_inv_mass3=np.repeat(inv_mass[:, None], 3, axis=1),
            element_rest_length=rest_length, element_inv_rest_length=1.0 / rest_length,
            element_stiffness=cat("stiffness", (0, 3)),
            element_rest_strain=np.tile([0.0, 0.0, 1.0], (rest_length.shape[0] if rest_strain else 0, 1)),
            element_inertia=inertia, element_inv_inertia=1.0 / inertia if inertia.size else inertia,
            voronoi_rest_length=cat("vor_length", (0,)),
            voronoi_inv_rest_length=1.0 / cat("vor_length", (0,)), voronoi_stiffness=cat("bend", (0, 3)),
            voronoi_rest_curvature=cat("curvature", (0, 3)),
            attach_node=attach_node, attach_vertex=attach_vertex, attach_element=attach_element,
            attach_offset=attach_offset, attach_frame=attach_frame,
            node_attach_offsets=node_attach_offsets, node_attach_list=order.astype(np.int64),
            node_mass=node_mass, node_inv_mass=inv(node_mass), node_own_mass=node_own,
            node_inertia=node_J, node_inv_inertia=inv(node_J), node_locked=node_locked,
            node_com_offset=node_com, node_principal=node_P,
        )
    state = State(
        x=x, v=np.zeros_like(x), q=quat_from_matrix(frames) if frames.size else np.zeros((0, 4)),
        w=np.zeros((rest_length.shape[0], 3)), node_x=node_x, node_v=np.zeros((nn, 3)),
        node_q=node_q, node_w=np.zeros((nn, 3)), node_hold=np.zeros((nn, 3)), clock=np.zeros(1),
    )
    model, state = column_major(model), column_major(state)
    _check_finite(model, state)
    return model, state, grids


def _check_finite(model: Model, state: State):
    for name, arr in list(model._asdict().items()) + list(state._asdict().items()):
        a = np.asarray(arr, dtype=float)
        bad = np.isnan(a) if name in ("node_mass", "node_inertia") else ~np.isfinite(a)
        if np.any(bad):
            raise ValueError(f"net: non-finite values in {name} after flattening")
