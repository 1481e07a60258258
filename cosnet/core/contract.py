"""Rigid contraction of a net (Gratus & Tucker §7, Theorem 7.1).

As E, G -> infinity a line becomes rigid (7.4); the line and its two end nodes nu_a, nu_b then
move as one extended rigid body nu_c of the contracted net:

* mass (7.9): M_c = M_a + M_b + int rho A ds;
* reference point = centroid (7.8) of the node masses and the line's mass distribution;
* inertia (7.21) about that centroid in nu_c's body frame: the line's rotary inertia
  int rho I ds plus int rho A M(R) ds (each straight element exactly: its mass at the element's
  centre plus m l^2 / 12 about the transverse axes), plus I_a, I_b with the parallel-axis terms
  M_a M(R_a), M_b M(R_b), where M(x) = |x|^2 1 - x x^T (the transcription's ``||x|| 1`` lacks the
  square);
* body frame D_c = D_a (the paper's choice);
* offsets (7.17) of every other line end formerly at nu_a or nu_b: xi_c = D_c^T (end point - centroid),
  so every end stays where it was;
* junction frames (7.7): X_c = D_c^T D_a X_a or D_c^T D_b X_b, i.e. (7.7) evaluated in the
  stress-free rest state, so every other line keeps its end directors and its stress-free state.

Fixed nodes stay fixed: if nu_a or nu_b has infinite mass, the body's position is fixed and its
reference point is that fixed point (it turns about it, with the inertia taken about it); locked
inertia axes of either node, and two fixed points (which leave only the turn about the line
through them), lock the corresponding axes of nu_c, whose body frame is then aligned with them.

The contracted net is built through the public ``Net`` API, so it is validated like any other.
"""

from __future__ import annotations

import math

import numpy as np

from .grid import build_line_grid, element_frames
from .rotations import inertia_shift, rotvec_from_matrix
from .net import Line, Net, Node, node_groups


def _check_rigidifiable(line: Line):
    """A contracted line must be stress free as built: its rest shape is the rigid body's shape."""
    g = build_line_grid(line)
    for side, k in ((0, 0), (1, -1)):
        if np.abs(g.end_frames[side] - g.frames[k]).max() > 1e-8:
            raise ValueError(f"line {line.name!r}: its {('start', 'end')[side]}_frame X does not match "
                             f"its built end directors (a pre-stressed junction); a rigid "
                             f"contraction needs the line stress free as built (§7, (7.4))")
    if line.rest_curvature is not None:
        geo = np.zeros_like(g.curvature)
        for k in range(1, line.elements):
            geo[k] = rotvec_from_matrix(g.frames[k - 1].T @ g.frames[k]) / g.vor_length[k]
        scale = 1.0 / line.length + np.abs(geo).max()
        if np.abs(geo[1:-1] - g.curvature[1:-1]).max() > 1e-6 * scale:
            raise ValueError(f"line {line.name!r}: its rest curvature differs from its built shape "
                             f"(pre-stressed); a rigid contraction needs it stress free as built")


def _line_mass_elements(line: Line):
    """Per element: (mass kg, centre (3,) lab, inertia about the centre (3, 3) lab)."""
    pts = line.points
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    mids = (np.cumsum(seg) - 0.5 * seg) / seg.sum()     # as Net.total_mass
    frames = element_frames(line, 0.0)
    rho = line.material.density
    out = []
    for k, (s, l) in enumerate(zip(mids, seg)):
        sec = line.section_at(float(s))
        m = rho * sec.A * l
        t = (pts[k + 1] - pts[k]) / l
        rot = rho * l * np.array([[sec.I11, sec.I12, 0.0], [sec.I12, sec.I22, 0.0],
                                  [0.0, 0.0, sec.I11 + sec.I22]])
        I = frames[k] @ rot @ frames[k].T + m * l * l / 12.0 * (np.eye(3) - np.outer(t, t))
        out.append((m, 0.5 * (pts[k] + pts[k + 1]), I))
    return out


def _null_space(rows: list, tol=1e-9) -> np.ndarray:
    if not rows:
        return np.eye(3)
    a = np.vstack(rows)
    _, s, vt = np.linalg.svd(a)
    rank = int(np.sum(s > tol * max(1.0, s.max())))
    return vt[rank:].T


def _rigid_body(nodes: list[Node], lines: list[Line], frame: np.ndarray, name: str) -> dict:
    """add_node keyword arguments of the rigid body made of ``nodes`` and ``lines``."""
    elems = [e for l in lines for e in _line_mass_elements(l)]
    fixed = [n for n in nodes if n.fixed_position]
    if fixed:
        c, mass = fixed[0].position.copy(), math.inf
    else:
        mass = sum(n.mass for n in nodes) + sum(m for m, _, _ in elems)
        c = (sum(n.mass * n.position for n in nodes) + sum(m * x for m, x, _ in elems)) / mass
    I = np.zeros((3, 3))
    for n in nodes:
        own = np.where(np.isinf(n.inertia), 0.0, n.inertia)
        I += n.frame @ own @ n.frame.T
        if not n.fixed_position:
            I += n.mass * inertia_shift(n.position - c)
    for m, x, Ie in elems:
        I += Ie + m * inertia_shift(x - c)
    # rotations still allowed: orthogonal to every locked axis and, with two fixed points,
    # along the line through them
    rows = [n.frame[:, k][None, :] for n in nodes for k in np.flatnonzero(n.locked_axes)]
    rows += [np.cross(np.eye(3), f.position - c) for f in fixed[1:]]
    W = _null_space(rows)
    if W.shape[1] == 0:
        return dict(position=c, frame=frame, fixed=True, name=name)
    if W.shape[1] < 3:
        # align the body frame with the free axes: prefer a member node's frame that already is
        for D in [frame] + [n.frame for n in nodes]:
            free = np.abs(D.T @ W @ W.T @ D).diagonal() > 0.5
            if np.allclose(D[:, free] @ D[:, free].T, W @ W.T, atol=1e-9):
                frame = D
                break
        else:
            comp = _null_space([W.T]) if W.shape[1] else np.eye(3)
            frame = np.column_stack([W, comp])
            if np.linalg.det(frame) < 0:
                frame[:, -1] *= -1.0
    Ib = frame.T @ I @ frame
    Ib = 0.5 * (Ib + Ib.T)
    locked = np.abs(frame.T @ W @ W.T @ frame).diagonal() < 0.5
    Ib[locked, :] = 0.0
    Ib[:, locked] = 0.0
    Ib[locked, locked] = math.inf
    return dict(position=c, frame=frame, mass=mass, inertia=Ib, name=name)


def contract(net: Net, line: Line | str | None = None, *, stiffer_than: float | None = None,
             name: str | None = None) -> Net:
    """Return a NEW net in which rigid lines and their end nodes become extended rigid nodes (§7).

    line: a Line (or its name) to contract: it and its two end nodes become one node.
    stiffer_than: instead, contract every line whose Young's modulus E >= stiffer_than (Pa);
        lines joining nodes already merged (a closed rigid loop) are absorbed into the body.
    name: name of the new node (single-line contraction); default "<start>+<end>".
    The original net is not changed. Every other node and line is copied unchanged, except
    that line ends formerly at a merged node get new offsets and junction frames so that they
    keep their place, directors and stress-free state.
    """
    if (line is None) == (stiffer_than is None):
        raise ValueError("contract: give exactly one of line or stiffer_than")
    if line is not None:
        if isinstance(line, str):
            line = net.line(line)
        if not isinstance(line, Line) or line.index >= len(net.lines) or net.lines[line.index] is not line:
            raise ValueError(f"contract: {line!r} is not a line of this net")
        chosen = [line]
    else:
        try:
            thr = float(stiffer_than)  # type: ignore[arg-type]  # not None: one of line, stiffer_than
        except (TypeError, ValueError):
            raise ValueError(f"contract: stiffer_than must be a Young's modulus in Pa, got {stiffer_than!r}") from None
        if not (thr > 0 and math.isfinite(thr)):
            raise ValueError(f"contract: stiffer_than must be a positive Young's modulus, got {stiffer_than!r}")
        chosen = [l for l in net.lines if l.material.E >= thr]
        if not chosen:
            raise ValueError(f"contract: no line has Young's modulus E >= {thr:g} Pa")
    net.validate()
    for l in chosen:
        _check_rigidifiable(l)
    root = node_groups(net, chosen)
    chosen_ids = {l.index for l in chosen}
    members: dict[int, list[Node]] = {}
    for n in net.nodes:
        members.setdefault(root(n.index), []).append(n)
    merged = {r for r in members if any(root(l.start.index) == r for l in chosen)}
    for l in net.lines:
        if l.index not in chosen_ids and root(l.start.index) == root(l.end.index) and root(l.start.index) in merged:
            raise ValueError(f"contract: line {l.name!r} would join the contracted node to itself "
                             f"(both its ends are on the merged rigid body); contract it too or "
                             f"remove it")
    out = Net()
    new_node: dict[int, Node] = {}
    for n in net.nodes:
        r = root(n.index)
        if r not in merged:
            kw: dict = dict(frame=n.frame, name=n.name)
            if n.fixed_position and n.locked_axes.all():
                kw["fixed"] = True
            else:
                kw.update(mass=n.mass, inertia=n.inertia)
            new_node[n.index] = out.add_node(n.position, **kw)
        elif n.index not in new_node:
            group_lines = [l for l in chosen if root(l.start.index) == r]
            nodes = members[r]
            if name is not None and line is not None:
                nm = name
            else:
                nm = "+".join(m.name for m in nodes)
            frame = group_lines[0].start.frame      # D(nu_c) = D(nu_a) (§7)
            kw = _rigid_body(nodes, group_lines, frame, nm)
            body = out.add_node(kw.pop("position"), **kw)
            for m in nodes:
                new_node[m.index] = body
    for l in net.lines:
        if l.index in chosen_ids:
            continue
        ends = {}
        for role, node, xi, X in (("start", l.start, l.start_offset, l.start_frame),
                                  ("end", l.end, l.end_offset, l.end_frame)):
            nn = new_node[node.index]
            if root(node.index) in merged:
                p = node.position + node.frame @ xi
                ends[role + "_offset"] = nn.frame.T @ (p - nn.position)       # (7.17)
                ends[role + "_frame"] = None if X is None else nn.frame.T @ node.frame @ X   # (7.7)
            else:
                ends[role + "_offset"], ends[role + "_frame"] = xi, X
        out.add_line(new_node[l.start.index], new_node[l.end.index], material=l.material,
                     section=l.section, elements=l.elements, rest_curvature=l.rest_curvature,
                     points=l.points.copy(), d1=l.d1, name=l.name, **ends)
    return out
