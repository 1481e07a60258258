"""The net: nodes (point junctions, point masses, extended rigid bodies) joined by lines.

Notation follows Gratus & Tucker, *The dynamics of Cosserat nets* (§1-§4): a line lambda runs
from its start node to its end node, so Omega(start, lambda) = -1 and Omega(end, lambda) = +1
(2.3). A line end sits at the offset xi (1.1)-(1.2), given in the node's body frame, and its
director frame is D_lambda = D(nu) X(nu, lambda) (1.3)/(2.24).

Everything is validated when it is added: a mistake raises ``ValueError`` naming the node or
line and what was expected, so nothing invalid ever reaches a kernel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any
from collections.abc import Callable

import numpy as np

from .articulation import joint_value
from .fast_modes import fast_modes_value
from .sliding import add_eyelet, add_ring
from .materials import Material, Section, rotary_inertia_scale_value, rotary_inertia_triple
from .rotations import frame_from_tangent as frame_from_tangent  # kept importable from cosnet.core.net


def _vector(owner: str, name: str, value, shape=(3,)) -> np.ndarray:
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: {name} must be numbers of shape {shape}, got {value!r}") from None
    if a.shape != shape:
        raise ValueError(f"{owner}: {name} must have shape {shape}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{owner}: {name} must be finite, got {a.tolist()}")
    return a


def _rotation(owner: str, name: str, value) -> np.ndarray:
    r = _vector(owner, name, value, (3, 3))
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-9) or np.linalg.det(r) < 0:
        raise ValueError(f"{owner}: {name} must be a rotation matrix (orthonormal, det +1), "
                         f"got {r.tolist()}")
    # re-orthonormalise to round-off so kernels see an exact rotation
    u, _, vt = np.linalg.svd(r)
    return u @ vt


@dataclass(eq=False)
class Node:
    """A node of the net. ``index`` is its position in ``net.nodes``."""

    index: int
    position: np.ndarray
    frame: np.ndarray
    mass: float
    inertia: np.ndarray
    name: str

    @property
    def fixed_position(self) -> bool:
        return math.isinf(self.mass)

    @property
    def locked_axes(self) -> np.ndarray:
        """Boolean (3,): body axes about which the rotation is fixed (infinite inertia)."""
        return np.isinf(np.diag(self.inertia))

    def __repr__(self):
        return f"Node({self.name!r})"


@dataclass(eq=False)
class Line:
    """A line of the net: a Kirchhoff-Cosserat rod from ``start`` to ``end``."""

    index: int
    start: Node
    end: Node
    material: Material
    section: Section | Callable[[float], Section]
    elements: int
    start_offset: np.ndarray
    end_offset: np.ndarray
    start_frame: np.ndarray | None
    end_frame: np.ndarray | None
    rest_curvature: np.ndarray | Callable[[float], np.ndarray] | None
    points: np.ndarray
    d1: np.ndarray | None
    name: str
    rotary_inertia: tuple | None = None     # per length (kg m), principal axes; None: the section's
    rotary_inertia_scale: float | str = 1.0  # >= 1 or "auto"
    fast_modes: str | None = None           # None: the simulation's setting
    start_joint: Any = None                 # a cosnet.core.articulation.Joint; None: welded to the node
    end_joint: Any = None

    def section_at(self, s: float) -> Section:
        """The cross-section at the fraction s in [0, 1] of the line's arc length."""
        return self.section(s) if callable(self.section) else self.section

    def curvature_at(self, s: float) -> np.ndarray:
        """Rest curvature u0 (director frame) at the fraction s of the arc length."""
        if self.rest_curvature is None:
            return np.zeros(3)
        if callable(self.rest_curvature):
            return _vector(f"line {self.name!r}", f"rest_curvature({s:g})", self.rest_curvature(s))
        return self.rest_curvature

    @property
    def length(self) -> float:
        return float(np.sum(np.linalg.norm(np.diff(self.points, axis=0), axis=1)))

    def __repr__(self):
        return f"Line({self.name!r}: {self.start.name!r} -> {self.end.name!r})"


@dataclass(eq=False)
class Net:
    """A Cosserat net: build it with ``add_node`` and ``add_line``, then simulate it."""

    nodes: list[Node] = field(default_factory=list)
    lines: list[Line] = field(default_factory=list)
    sliders: list = field(default_factory=list)   # rings and eyelets (cosnet.core.sliding)
    sheaves: list = field(default_factory=list)   # eyelets with a radius (cosnet.core.sliding)
    # name -> item, rebuilt whenever it lags behind the lists (building a net of 10^5 nodes
    # by name searches would cost O(N^2))
    _by_name: dict = field(default_factory=dict, init=False, repr=False)

    def _named(self, items: list, kind: str) -> dict:
        index = self._by_name.get(kind)
        if index is None or len(index) != len(items) or (items and index.get(items[-1].name) is not items[-1]):
            index = self._by_name[kind] = {item.name: item for item in items}
        return index

    def _new_name(self, items: list, kind: str, name) -> tuple[int, str, str, dict]:
        """(index, name, owner for messages, name index) of the next item of ``kind``; refuses
        a name already taken."""
        idx = len(items)
        name = f"{kind}{idx}" if name is None else str(name)
        who = f"{kind} {name!r}"
        names = self._named(items, kind)
        if name in names:
            raise ValueError(f"{who}: a {kind} with this name already exists")
        return idx, name, who, names

    # ------------------------------------------------------------------ nodes
    def add_node(self, position, *, frame=None, mass: float = 0.0, inertia=None,
                 fixed: bool = False, name: str | None = None) -> Node:
        """Add a node.

        position: (3,) lab position of the node's reference point (the rigid body's centroid).
        frame: (3, 3) rotation D(nu), columns d1 d2 d3 in the lab (default identity).
        mass: M_nu >= 0; ``np.inf`` fixes the position. A node with no mass of its own is a
            point junction (type i); its lines' end masses still carry it.
        inertia: I_nu, (3, 3) symmetric positive semidefinite in the body frame, or (3,) for
            its diagonal; ``np.inf`` on a diagonal entry fixes the rotation about that body axis.
        fixed: shorthand for infinite mass and inertia (a clamp).
        """
        idx, name, who, names = self._new_name(self.nodes, "node", name)
        pos = _vector(who, "position", position)
        frm = np.eye(3) if frame is None else _rotation(who, "frame", frame)
        if fixed:
            m, I = math.inf, np.diag([math.inf] * 3)
        else:
            try:
                m = float(mass)
            except (TypeError, ValueError):
                raise ValueError(f"{who}: mass must be a number, got {mass!r}") from None
            if math.isnan(m) or m < 0:
                raise ValueError(f"{who}: mass must be >= 0 (np.inf fixes the node), got {mass}")
            I = self._inertia(who, inertia)
        node = Node(idx, pos, frm, m, I, name)
        self.nodes.append(node)
        names[node.name] = node
        return node

    @staticmethod
    def _inertia(who: str, inertia) -> np.ndarray:
        if inertia is None:
            return np.zeros((3, 3))
        try:
            a = np.array(inertia, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{who}: inertia must be a (3,) or (3, 3) array, got {inertia!r}") from None
        if a.shape == (3,):
            a = np.diag(a)
        if a.shape != (3, 3):
            raise ValueError(f"{who}: inertia must have shape (3,) or (3, 3), got {a.shape}")
        if np.any(np.isnan(a)):
            raise ValueError(f"{who}: inertia contains NaN")
        inf_axes = np.isinf(np.diag(a))
        off = np.where(np.eye(3, dtype=bool), 0.0, a)
        if np.any(np.isinf(off)) or np.any(np.diag(a) < 0):
            raise ValueError(f"{who}: inertia entries must be >= 0 with infinity only on the diagonal")
        for k in np.flatnonzero(inf_axes):
            if np.any(off[k] != 0) or np.any(off[:, k] != 0):
                raise ValueError(f"{who}: an infinite (locked) inertia axis {k + 1} must not be "
                                 f"coupled to the others (zero off-diagonal entries)")
        free = ~inf_axes
        sub = a[np.ix_(free, free)]
        # symmetric to round-off of its largest entry (R diag(I) R^T is not exactly symmetric)
        if sub.size and np.abs(sub - sub.T).max() > 1e-12 * np.abs(sub).max():
            raise ValueError(f"{who}: inertia must be symmetric, got {a.tolist()}")
        if sub.size and np.linalg.eigvalsh(0.5 * (sub + sub.T)).min() < -1e-12 * max(1.0, np.abs(sub).max()):
            raise ValueError(f"{who}: inertia must be positive semidefinite, got {a.tolist()}")
        a[np.ix_(free, free)] = 0.5 * (sub + sub.T)
        return a

    # ------------------------------------------------------------------ lines
    def add_line(self, start: Node, end: Node, *, material: Material, section,
                 elements: int, start_offset=(0.0, 0.0, 0.0), end_offset=(0.0, 0.0, 0.0),
                 start_frame=None, end_frame=None, rest_curvature=None, points=None,
                 d1=None, name: str | None = None, rotary_inertia=None,
                 rotary_inertia_scale=1.0, fast_modes: str | None = None, start_joint=None,
                 end_joint=None) -> Line:
        """Add a line from ``start`` to ``end`` (Omega = -1 at start, +1 at end).

        material, section: a Material and a Section (or a callable s -> Section, s in [0, 1],
            for a cross-section that varies along the line).
        elements: number of elements n >= 1 (n + 1 vertices).
        start_offset, end_offset: xi(nu, lambda), the line end's offset in the node's body
            frame (1.1)-(1.2).
        start_frame, end_frame: X(nu, lambda), the line's end director frame relative to the
            node's frame (1.3). Default: implied by the built geometry, which is then free of
            stress at the junctions (§2.3).
        rest_curvature: u0 in the director frame, a (3,) vector or callable s -> (3,); a line
            built straight with u0 != 0 starts pre-stressed.
        points: (k, 3) polyline through which the line is built (its rest shape too); its ends
            must coincide with the node end points. Resampled to ``elements`` if k != n + 1.
        d1: hint for the first director (lab frame); matters for non-circular sections.
        rotary_inertia: rotary inertia per length (kg m) about the principal axes (I1, I2,
            axis), overriding the section's (default: density times (I1, I2, I1 + I2)).
        rotary_inertia_scale: a factor >= 1 on the rotary inertia (all three axes), or "auto":
            the smallest factor that keeps the rotational modes from binding the stable step
            (see docs/fast_modes.md).
        fast_modes: this line's treatment of its fast modes, overriding the simulation's
            (one of cosnet.core.fast_modes.FAST_MODES; None: the simulation's).
        start_joint, end_joint: how the line's end turns at its node: None (welded, the
            default), or a cosnet.Hinge, Universal or Ball (cosnet.core.articulation, §8).
        """
        idx, name, who, names = self._new_name(self.lines, "line", name)
        joints = [joint_value(f"{who}: {role}_joint", j) for role, j in (("start", start_joint), ("end", end_joint))]
        for role, node in (("start", start), ("end", end)):
            if not isinstance(node, Node) or node.index >= len(self.nodes) or self.nodes[node.index] is not node:
                raise ValueError(f"{who}: unknown {role} node {node!r} (not a node of this net)")
        if start is end:
            raise ValueError(f"{who}: both ends are node {start.name!r}; a line must join two "
                             f"distinct nodes (§2.1)")
        if not isinstance(material, Material):
            raise ValueError(f"{who}: material must be a cosnet.Material, got {material!r}")
        if not (isinstance(section, Section) or callable(section)):
            raise ValueError(f"{who}: section must be a cosnet Section or a callable s -> Section")
        if isinstance(elements, bool) or not isinstance(elements, (int, np.integer)) or elements < 1:
            raise ValueError(f"{who}: elements must be a positive integer, got {elements!r}")
        elements = int(elements)
        xs = _vector(who, "start_offset", start_offset)
        xe = _vector(who, "end_offset", end_offset)
        Xs = None if start_frame is None else _rotation(who, "start_frame", start_frame)
        Xe = None if end_frame is None else _rotation(who, "end_frame", end_frame)
        d1v = None if d1 is None else _vector(who, "d1", d1)
        rot = None if rotary_inertia is None else rotary_inertia_triple(who, rotary_inertia)
        rot_scale = rotary_inertia_scale_value(who, rotary_inertia_scale)
        fast = None if fast_modes is None else fast_modes_value(who, fast_modes)
        if rest_curvature is not None and not callable(rest_curvature):
            rest_curvature = _vector(who, "rest_curvature", rest_curvature)
        p0 = start.position + start.frame @ xs
        p1 = end.position + end.frame @ xe
        if points is None:
            if np.linalg.norm(p1 - p0) <= 1e-12 * max(1.0, float(np.linalg.norm(p0))):
                raise ValueError(f"{who}: length must be positive; its ends coincide at {p0.tolist()}")
            s = np.linspace(0.0, 1.0, elements + 1)[:, None]
            pts = p0 + s * (p1 - p0)
        else:
            pts = self._polyline(who, points, p0, p1, elements)
        line = Line(idx, start, end, material, section, elements, xs, xe, Xs, Xe,
                    rest_curvature, pts, d1v, name, rot, rot_scale, fast, *joints)
        self._check_sections(line)
        for k in range(elements):
            t = pts[k + 1] - pts[k]
            if d1v is not None and np.linalg.norm(np.cross(t / np.linalg.norm(t), d1v)) < 1e-9 * np.linalg.norm(d1v):
                raise ValueError(f"{who}: d1 hint {d1v.tolist()} is parallel to element {k}'s tangent")
        self.lines.append(line)
        names[line.name] = line
        return line

    @staticmethod
    def _polyline(who, points, p0, p1, elements) -> np.ndarray:
        try:
            pts = np.array(points, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{who}: points must be a (k, 3) array") from None
        if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 2:
            raise ValueError(f"{who}: points must have shape (k >= 2, 3), got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ValueError(f"{who}: points contain NaN or infinity")
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        scale = max(1.0, float(np.abs(pts).max()))
        if np.any(seg <= 1e-12 * scale):
            k = int(np.argmin(seg))
            raise ValueError(f"{who}: points {k} and {k + 1} coincide (zero-length segment)")
        tol = 1e-6 * float(seg.sum())
        for role, want, got in (("first", p0, pts[0]), ("last", p1, pts[-1])):
            if np.linalg.norm(want - got) > tol:
                raise ValueError(f"{who}: the {role} point {got.tolist()} must coincide with the "
                                 f"node end point {want.tolist()} (node position + frame @ offset)")
        pts[0], pts[-1] = p0, p1
        if pts.shape[0] != elements + 1:
            s = np.concatenate([[0.0], np.cumsum(seg)])
            si = np.linspace(0.0, s[-1], elements + 1)
            pts = np.column_stack([np.interp(si, s, pts[:, k]) for k in range(3)])
        return pts

    @staticmethod
    def _check_sections(line: Line):
        n = line.elements
        for s in np.linspace(0.0, 1.0, 2 * n + 1):
            sec = line.section_at(float(s))
            if not isinstance(sec, Section):
                raise ValueError(f"line {line.name!r}: section({s:g}) must return a Section, got {sec!r}")
            line.curvature_at(float(s))

    # ------------------------------------------------------------------ queries
    def add_ring(self, line: Line | list[Line], *, s: float, mass: float, inertia=None, mu_s: float = 0.0,
                 mu_k: float = 0.0, damping: float = 0.0, name: str | None = None) -> Node:
        """A ring of ``mass`` on ``line`` at s (m of unstretched length from its start), sliding
        with Coulomb friction mu_s / mu_k and a damper (N s/m): its new node (cosnet.core.sliding)."""
        return add_ring(self, line, s, mass, inertia, mu_s, mu_k, damping, name)

    def add_eyelet(self, line: Line | list[Line], *, s: float, at=None, mu: float = 0.0, damping: float = 0.0,
                   radius: float = 0.0, name: str | None = None) -> Node:
        """An eyelet ``line`` slides through, at s (m of unstretched length from its start): a
        fixed node made there (at=None) or at a point, or an existing node on the line; with a
        radius, a sheave about ``at`` whose rim the line wraps; its node (cosnet.core.sliding)."""
        return add_eyelet(self, line, s, at, mu, damping, radius, name)

    def node(self, name: str) -> Node:
        try:
            return self._named(self.nodes, "node")[name]
        except KeyError:
            raise KeyError(f"no node named {name!r}") from None

    def line(self, name: str) -> Line:
        try:
            return self._named(self.lines, "line")[name]
        except KeyError:
            raise KeyError(f"no line named {name!r}") from None

    def lines_at(self, node: Node) -> list[tuple[Line, int]]:
        """Lines ending at ``node`` with their orientation Omega(node, line) (2.3)."""
        out = []
        for l in self.lines:
            if l.start is node:
                out.append((l, -1))
            if l.end is node:
                out.append((l, +1))
        return out

    @property
    def element_count(self) -> int:
        return sum(l.elements for l in self.lines)

    def total_mass(self) -> float:
        """Mass of all lines and of the nodes with finite mass."""
        m = sum(n.mass for n in self.nodes if math.isfinite(n.mass))
        for l in self.lines:
            seg = np.linalg.norm(np.diff(l.points, axis=0), axis=1)
            mids = (np.cumsum(seg) - 0.5 * seg) / seg.sum()
            m += sum(l.material.density * l.section_at(float(s)).A * d for s, d in zip(mids, seg))
        return float(m)

    def contract(self, line=None, *, stiffer_than=None, name=None) -> Net:
        """A new net with ``line`` (or every line with E >= ``stiffer_than``) and its end nodes
        replaced by one extended rigid node (§7); see cosnet.contract."""
        from .contract import contract  # cycle: contraction builds a Net; this method is its shorthand
        return contract(self, line, stiffer_than=stiffer_than, name=name)

    def validate(self):
        """Whole-net checks run before flattening."""
        if not self.nodes:
            raise ValueError("net: it has no nodes")
        attached = {n.index: 0 for n in self.nodes}
        for l in self.lines:
            attached[l.start.index] += 1
            attached[l.end.index] += 1
        for n in self.nodes:
            if attached[n.index] == 0:
                free_inertia = n.inertia[~n.locked_axes][:, ~n.locked_axes]
                if n.mass == 0 or (free_inertia.size and np.linalg.eigvalsh(free_inertia).min() <= 0):
                    raise ValueError(f"node {n.name!r}: no line ends at it, so it needs its own "
                                     f"positive mass and inertia (a free rigid body)")


def node_groups(net: Net, lines) -> Callable[[int], int]:
    """Union-find of the nodes joined by ``lines``: return root(i), the representative node
    index of node i's group."""
    parent = list(range(len(net.nodes)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for l in lines:
        ra, rb = root(l.start.index), root(l.end.index)
        if ra != rb:
            parent[rb] = ra
    return root
