"""Static obstacles as declared effects: a plane, sphere, capsule, box or closed triangle mesh
that the lines' vertices (spheres of the section radius) cannot enter, with Coulomb friction
that sticks (kernel and model: cosnet.kernels.obstacles)."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .friction import Frictional, friction_keys
from ..core import samples
from ..engine.bounds import index_error, offsets_error
from ..core import checks
from .contact import chosen_lines, pushed_masses, smallest_mass
from ..core.net import Line
from ..engine.registry import Binding, Key
from ..core.units import (LENGTH, SOIL_DAMPING, SOIL_STIFFNESS, choice, coefficients, direction, frame, nonnegative,
                          positive, string, vec3)
from ..kernels.obstacles import SHAPES, SLIDE, ROWS, ObstacleParams
from ..kernels.segments import VARIANTS, obstacle_record
from ..kernels.layout import typed_call

GRID_CELLS = 4_000_000  # the mesh grid's cell size grows until it has at most this many cells


def _coefficients(who, name, value):
    a = np.array(value, dtype=float)
    if a.ndim == 0:
        a = np.full(3, float(a))
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{who}: {name} must be a number or [forward, backward, lateral], got {value!r}")
    if np.any(a < 0):
        raise ValueError(f"{who}: {name} must be >= 0, got {value!r}")
    return a


def read_mesh(file, who: str):
    """Return (points (n, 3), triangles (t, 3)) of a mesh file meshio reads (STL, OBJ, PLY, ...)."""
    import meshio
    try:
        mesh = meshio.read(file)
    except Exception as e:  # meshio raises many kinds: every one is an unreadable file here
        reason = " ".join(str(e).split()) or type(e).__name__
        raise ValueError(f"{who}: cannot read mesh file {str(file)!r}: {reason}") from None
    tris = [c.data for c in mesh.cells if c.type == "triangle"]
    if not tris:
        raise ValueError(f"{who}: mesh file {str(file)!r} has no triangles")
    return np.asarray(mesh.points, dtype=float)[:, :3], np.concatenate(tris).astype(np.int64)


def orient_outwards(points, triangles, who: str) -> np.ndarray:
    """Return the triangles of a closed mesh wound consistently, their normals pointing out of
    the enclosed volume; refuse a mesh with an open or a shared-by-three edge, or one that
    cannot be oriented."""
    tris = np.array(triangles, dtype=np.int64)
    if tris.ndim != 2 or tris.shape[1] != 3 or tris.shape[0] == 0:
        raise ValueError(f"{who}: triangles must be a non-empty (t, 3) array of point indices")
    if tris.min() < 0 or tris.max() >= len(points):
        raise ValueError(f"{who}: a triangle refers to a point the mesh does not have")
    if not np.all(np.isfinite(points)):
        raise ValueError(f"{who}: the mesh's points must be finite")
    edges: dict = {}
    for t, (a, b, c) in enumerate(tris):
        for u, w in ((a, b), (b, c), (c, a)):
            edges.setdefault((min(u, w), max(u, w)), []).append(t)
    for (u, w), ts in edges.items():
        if len(ts) != 2:
            kind = ("open (an edge of one triangle)" if len(ts) == 1
                    else f"non-manifold (an edge of {len(ts)} triangles)")
            raise ValueError(f"{who}: the mesh must be closed and manifold; it is {kind} at points {u}, {w}")

    def directed(t, u, w):  # +1 if triangle t runs u -> w
        a, b, c = tris[t]
        return 1 if (u, w) in ((a, b), (b, c), (c, a)) else -1

    flip = np.zeros(len(tris), dtype=np.int64)   # 0 unvisited, +1 kept, -1 reversed
    for seed in range(len(tris)):
        if flip[seed]:
            continue
        flip[seed] = 1
        part, todo = [seed], deque([seed])
        while todo:
            t = todo.popleft()
            a, b, c = tris[t]
            for u, w in ((a, b), (b, c), (c, a)):
                ts = edges[(min(u, w), max(u, w))]
                o = ts[0] if ts[1] == t else ts[1]
                want = -flip[t] * directed(t, u, w) * directed(o, u, w)   # opposite directions
                if flip[o] == 0:
                    flip[o] = want
                    part.append(o)
                    todo.append(o)
                elif flip[o] != want:
                    raise ValueError(f"{who}: the mesh cannot be oriented (a Moebius-like surface)")
        p = np.array(part)
        pts = points[tris[p]]
        vol = np.einsum("ij,ij->i", pts[:, 0], np.cross(pts[:, 1], pts[:, 2])) * flip[p]
        if vol.sum() < 0:   # wound inwards: turn the whole closed piece over
            flip[p] = -flip[p]
    out = tris.copy()
    out[flip < 0] = out[flip < 0][:, ::-1]
    return out


def _triangle_grid(tri, reach):
    """Uniform grid over the triangles (t, 3, 3): each cell lists every triangle whose box,
    widened by reach, meets it. Return (origin, h, dims, cell_start, cell_tri)."""
    lo, hi = tri.min(axis=(0, 1)) - reach, tri.max(axis=(0, 1)) + reach
    extent = tri.max(axis=1) - tri.min(axis=1)
    h = max(2.0 * reach, float(np.median(extent.max(axis=1))), 1e-12 * float(np.max(hi - lo)))
    while True:
        dims = np.maximum(np.ceil((hi - lo) / h).astype(np.int64), 1)
        if int(np.prod(dims)) <= GRID_CELLS:
            break
        h *= 1.5
    first = np.clip(np.floor((tri.min(axis=1) - reach - lo) / h).astype(np.int64), 0, dims - 1)
    last = np.clip(np.floor((tri.max(axis=1) + reach - lo) / h).astype(np.int64), 0, dims - 1)
    cells, owners = [], []
    for t in range(tri.shape[0]):
        ix, iy, iz = (np.arange(first[t, k], last[t, k] + 1) for k in range(3))
        c = (ix[:, None, None] + dims[0] * (iy[None, :, None] + dims[1] * iz[None, None, :])).ravel()
        cells.append(c)
        owners.append(np.full(c.shape[0], t, dtype=np.int64))
    cells, owners = np.concatenate(cells), np.concatenate(owners)
    order = np.argsort(cells, kind="stable")
    start = np.zeros(int(np.prod(dims)) + 1, dtype=np.int64)
    np.add.at(start, cells + 1, 1)
    return lo, float(h), dims, np.cumsum(start), owners[order]


def meets_elements(shape: str, radius: float, m, line: int) -> bool:
    """Whether the elements of line ``line`` meet a shape beside its vertices
    (kernels/segments.py): always a box's or a mesh's (their edges can pass between two
    vertices), never a plane (a capsule's deepest point in a half-space is an end), a sphere
    or capsule only when an element is longer than its radius. A shorter element's chord
    dips at most L^2 / (8 R) < L / 8 below its ends, which the vertex contacts hold at a
    fraction of the cost; and a rope laid with its vertices on a drum is at rest for them,
    while its chords would start that dip deep in the element contacts (docs/obstacles.md)."""
    if shape in ("box", "mesh"):
        return True
    e0, e1 = int(m.line_element_offsets[line]), int(m.line_element_offsets[line + 1])
    return shape != "plane" and e1 > e0 and float(np.max(m.element_rest_length[e0:e1])) > radius


class Obstacle(Frictional):
    """A static obstacle the vertices of the chosen lines (spheres of their section radius)
    cannot enter: penalty normal force max(0, k eps - gamma v_n) for an overlap eps, and
    Coulomb friction by a tangential spring of stiffness k_t anchored where the contact began,
    sticking up to mu_s times the normal force and sliding at mu_k times it.

    shape and its geometry (lab frame, metres):
      "plane":   point, normal (the solid is the half-space behind the normal)
      "sphere":  center, radius
      "capsule": start, end, radius (a cylinder with rounded ends)
      "box":     center, half_size (3,), axes (3x3, columns the box's axes; default the lab's)
      "mesh":    file (read with meshio: STL, OBJ, PLY, ...) or points (n, 3) and triangles
                 (t, 3); it must be closed and manifold, and is wound outwards on loading
    k: normal stiffness (N/m) > 0; gamma: normal damping (N s/m) >= 0.
    k_soil, gamma_soil: a plane only, instead of k and gamma: a soft soil (a seabed, as
    MoorDyn's), whose stiffness (N/m^3) and damping (N s/m^3) are per unit of contact area;
    each vertex's are these times its area 2 r l (r its section radius, l its Voronoi length),
    and so is its tangential stiffness, k_t = k_soil 2 r l. A line lying on it sinks by its
    weight per length over 2 r k_soil, the same all along.
    mu_s, mu_k: static and kinetic coefficients, a number or [forward, backward, lateral]
    (along the line's tangent, against it, across it); the one not given equals the other
    (neither: no friction); mu_k <= mu_s in each direction.
    k_t: tangential stiffness (N/m), default k (friction needs k_t > 0); the contact sticks
    elastically within mu_s N / k_t of its anchor (on a soft soil, k_soil's per area).
    lines: the lines touching it (Line objects or names); None: all of them.
    """

    kind = "obstacle"
    record = ObstacleParams
    keys = (Key("shape", choice(*SHAPES), required=True, doc="plane, sphere, capsule, box or mesh"),
            Key("lines", "lines", doc="names of the lines touching it (default: all)"),
            *friction_keys(coefficients, static="static coefficient, or [forward, backward, lateral]",
                           kinetic="kinetic coefficient(s), at most mu_s",
                           normal="normal penalty stiffness (or k_soil on a plane)",
                           damping="normal damping; default 0", k_required=False),
            Key("k_soil", positive, SOIL_STIFFNESS,
                doc="plane, instead of k: a soft soil's stiffness per contact area (each vertex's times 2 r l)"),
            Key("gamma_soil", nonnegative, SOIL_DAMPING, doc="with k_soil: its damping per contact area"),
            Key("point", vec3, LENGTH, doc="plane: a point of it"),
            Key("normal", direction, doc="plane: its outward normal"),
            Key("center", vec3, LENGTH, doc="sphere, box: centre"),
            Key("radius", positive, LENGTH, doc="sphere, capsule: radius"),
            Key("start", vec3, LENGTH, doc="capsule: one end of its axis"),
            Key("end", vec3, LENGTH, doc="capsule: the other end"),
            Key("half_size", vec3, LENGTH, doc="box: half its size along its axes"),
            Key("axes", frame, doc="box: its axes as columns (default: the lab's)"),
            Key("file", "path", doc="mesh: a file meshio reads (STL, OBJ, PLY, ...), relative to the scene"),
            Key("name", string, doc="a name for messages"))

    @property
    def conservative(self) -> bool:
        return self.gamma == 0 and not np.any(self.mu_s)

    # each vertex's stick/slip state, compared; a counter; the contact pass's scratch, written
    # by every call before it reads it
    free_integers = ("mode", "active", "held")

    @classmethod
    def example(cls):
        net, _ = samples.rod(start=(0.0, 0.0, 0.6 * samples.RADIUS), end=(samples.LENGTH, 0.0, 0.002))
        return net, [cls("plane", k=1e4, point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        nv, m, nt = model.vertex_mass.shape[0], p.verts.shape[0], p.tri.shape[0]
        shapes = {"origin": (3,), "axis": (3,), "size": (3,), "rot": (3, 3), "mu_s": (3,), "mu_k": (3,),
                  "vprev": (m,), "vnext": (m,), "radius": (m,), "scale": (m,), "anchor": (m, 3), "mode": (m,),
                  "dissipated": (1,), "deepest": (1,), "active": (1,), "tri": (nt, 3, 3), "tri_normal": (nt, 3),
                  "grid_origin": (3,), "grid_dims": (3,), "damp": (m, 3)}
        ne = p.elems.shape[0]
        shapes.update({"elems": (ne, 2), "edata": (ne, 7), "emode": (ne,), "edamp": (ne, 2, 3)})
        for name, shape in shapes.items():
            if getattr(p, name).shape != shape:
                return f"obstacle.{name} has shape {getattr(p, name).shape}, needs {shape}"
        dims = p.grid_dims
        if (np.any(dims < 0) or (np.any(dims == 0) and np.any(dims != 0))
                or p.cell_start.shape != (int(np.prod(dims)) + 1,)):
            return "obstacle: the triangle grid's cell_start does not have one offset per cell and one more"
        return (index_error("obstacle.verts", p.verts, nv) or index_error("obstacle.vprev", p.vprev, nv)
                or index_error("obstacle.elems", p.elems.ravel(), m)
                or index_error("obstacle.vnext", p.vnext, nv)
                or offsets_error("obstacle.cell_start", p.cell_start, p.cell_tri.shape[0])
                or index_error("obstacle.cell_tri", p.cell_tri, nt))

    def __init__(self, shape: str, *, k: float | None = None, lines=None, gamma: float | None = None, k_t=None,
                 mu_s=None, mu_k=None, point=None, normal=None, center=None, radius=None,
                 start=None, end=None, half_size=None, axes=None, file=None, points=None,
                 triangles=None, name: str | None = None, k_soil: float | None = None,
                 gamma_soil: float | None = None):
        if shape not in SHAPES:
            raise ValueError(f"Obstacle: shape must be one of {list(SHAPES)}, got {shape!r}")
        who = f"Obstacle {name!r} ({shape})" if name else f"Obstacle ({shape})"
        self.shape, self.name, self.who = shape, name, who
        self.soil = k_soil is not None
        if self.soil:
            if shape != "plane":
                raise ValueError(f"{who}: k_soil (a soft soil) is a plane's, not a {shape}'s")
            per_vertex = [key for key, val in (("k", k), ("gamma", gamma), ("k_t", k_t)) if val is not None]
            if per_vertex:
                raise ValueError(f"{who}: give k_soil and gamma_soil (per contact area), not {', '.join(per_vertex)} "
                                 "(per vertex) beside them")
            k, gamma = k_soil, gamma_soil if gamma_soil is not None else 0.0
        elif gamma_soil is not None:
            raise ValueError(f"{who}: gamma_soil needs k_soil")
        elif k is None:
            raise ValueError(f"{who}: needs k (N/m), or on a plane k_soil (N/m^3)")
        self.k = checks.positive(who, "k_soil" if self.soil else "k", k)
        self.gamma = checks.nonnegative(who, "gamma_soil" if self.soil else "gamma", 0.0 if gamma is None else gamma)
        if mu_s is None:   # only a kinetic coefficient: the contact holds up to the same
            mu_s = 0.0 if mu_k is None else mu_k
        self.mu_s = _coefficients(who, "mu_s", mu_s)
        self.mu_k = self.mu_s.copy() if mu_k is None else _coefficients(who, "mu_k", mu_k)
        if np.any(self.mu_k > self.mu_s):
            raise ValueError(f"{who}: mu_k must not exceed the static coefficient, got "
                             f"{self.mu_k.tolist()} > {self.mu_s.tolist()}")
        friction = bool(np.any(self.mu_s > 0))
        self.k_t = (self.k if friction else 0.0) if k_t is None else float(k_t)
        if not math.isfinite(self.k_t) or self.k_t < 0 or (friction and self.k_t == 0):
            raise ValueError(f"{who}: k_t must be a finite number > 0 (>= 0 without friction), got {k_t!r}")
        if lines is not None:
            if isinstance(lines, (str, Line)):
                raise ValueError(f"{who}: lines must be a list of lines or line names, got {lines!r}")
            lines = list(lines)
        self.lines = lines
        given = {key for key, val in (("point", point), ("normal", normal), ("center", center),
                                       ("radius", radius), ("start", start), ("end", end),
                                       ("half_size", half_size), ("axes", axes), ("file", file),
                                       ("points", points), ("triangles", triangles)) if val is not None}
        need, allowed = {"plane": ({"point", "normal"}, set()), "sphere": ({"center", "radius"}, set()),
                         "capsule": ({"start", "end", "radius"}, set()),
                         "box": ({"center", "half_size"}, {"axes"}),
                         "mesh": (set(), {"file", "points", "triangles"})}[shape]
        if need - given:
            raise ValueError(f"{who}: needs {', '.join(sorted(need - given))}")
        if given - need - allowed:
            raise ValueError(f"{who}: does not take {', '.join(sorted(given - need - allowed))}")
        self.origin, self.axis, self.size, self.rot = np.zeros(3), np.zeros(3), np.zeros(3), np.eye(3)
        self.points, self.triangles = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
        if shape == "plane":
            self.origin, n = checks.vec3(who, "point", point), checks.vec3(who, "normal", normal)
            if not np.linalg.norm(n) > 0:
                raise ValueError(f"{who}: normal must not be zero")
            self.axis = n / np.linalg.norm(n)
        elif shape == "sphere":
            self.origin, self.size[0] = checks.vec3(who, "center", center), checks.positive(who, "radius", radius)
        elif shape == "capsule":
            self.origin, self.axis = checks.vec3(who, "start", start), checks.vec3(who, "end", end)
            self.size[0] = checks.positive(who, "radius", radius)
        elif shape == "box":
            self.origin = checks.vec3(who, "center", center)
            half = checks.vec3(who, "half_size", half_size)
            self.size = np.array([checks.positive(who, "half_size", x) for x in half])
            if axes is not None:
                r = np.array(axes, dtype=float)
                if r.shape != (3, 3) or not np.allclose(r.T @ r, np.eye(3), atol=1e-9) or np.linalg.det(r) < 0:
                    raise ValueError(f"{who}: axes must be a rotation matrix (orthonormal columns, right-handed)")
                self.rot = r.T.copy()
        else:
            if file is not None and (points is not None or triangles is not None):
                raise ValueError(f"{who}: give file, or points and triangles, not both")
            source = who
            if file is not None:
                self.file = str(file)
                pts, tris = read_mesh(file, who)
                source = f"{who} file {self.file!r}"
            elif points is not None and triangles is not None:
                pts, tris = np.array(points, dtype=float), np.array(triangles)
                if pts.ndim != 2 or pts.shape[1] != 3:
                    raise ValueError(f"{who}: points must be an (n, 3) array")
            else:
                raise ValueError(f"{who}: needs file, or points and triangles")
            self.points, self.triangles = pts, orient_outwards(pts, tris, source)

    def drawn_shapes(self) -> list:
        return [self.geometry_record()]

    def geometry_record(self, node: int | None = None) -> dict:
        """Its geometry as plain lists (Effect.drawn_shapes), moving with ``node`` or fixed."""
        return {"shape": self.shape, "node": node, "origin": self.origin.tolist(), "axis": self.axis.tolist(),
                "size": self.size.tolist(), "rot": self.rot.tolist(), "points": self.points.tolist(),
                "triangles": self.triangles.tolist()}

    # ------------------------------------------------------------------ binding
    def _lines(self, sim):
        return chosen_lines(sim, self.lines, self.who)

    def bind(self, on: Binding) -> ObstacleParams:
        m = on.model
        verts: list[int] = []
        prev: list[int] = []
        nxt: list[int] = []
        radius: list[float] = []
        elems: list[tuple[int, int]] = []
        for line in self._lines(on):
            v0, v1 = int(m.line_vertex_offsets[line.index]), int(m.line_vertex_offsets[line.index + 1])
            n = v1 - v0 - 1
            if meets_elements(self.shape, self.size[0], m, line.index):
                elems += [(len(verts) + j, len(verts) + j + 1) for j in range(n)]
            for i in range(v0, v1):
                verts.append(i)
                prev.append(max(i - 1, v0))
                nxt.append(min(i + 1, v1 - 1))
                radius.append(line.section_at((i - v0) / n).radius)
        # a soft soil's constants are per area: each vertex's contact area, its diameter times its length
        scale = (2.0 * np.array(radius, float) * m.voronoi_rest_length[np.array(verts, np.int64)] if self.soil
                 else np.ones(len(verts)))
        count = len(verts)
        tri = self.points[self.triangles] if self.shape == "mesh" else np.zeros((0, 3, 3))
        if tri.shape[0]:
            normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            length = np.linalg.norm(normal, axis=1)
            normal = normal / np.where(length > 0, length, 1.0)[:, None]
            grid = _triangle_grid(tri, max(radius, default=0.0))
        else:
            normal = np.zeros((0, 3))
            grid = (np.zeros(3), 1.0, np.zeros(3, np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64))
        # of the variant that compiles only its own shape
        return obstacle_record(ObstacleParams(
            SHAPES[self.shape], self.origin.copy(), self.axis.copy(), self.size.copy(), self.rot.copy(),
            np.ascontiguousarray(tri), normal, *grid, self.k, self.gamma, self.k_t,
            self.mu_s.copy(), self.mu_k.copy(), np.array(verts, np.int64), np.array(prev, np.int64),
            np.array(nxt, np.int64), np.array(radius, float), scale, np.zeros((count, 3)), np.zeros(count, np.int64),
            np.zeros(1), np.zeros(1), np.zeros(1, np.int64), np.array(elems, np.int64).reshape(-1, 2),
            np.zeros((len(elems), 7)), np.zeros(len(elems), np.int64), np.zeros((len(elems), 2, 3)),
            np.zeros((count, 3)), np.zeros((ROWS, count)), np.zeros((2, count), np.int64)))

    # ------------------------------------------------------------------ reports
    def deepest(self, sim) -> float:
        """The largest overlap met so far, as a fraction of the vertex radius."""
        return float(self.params(sim).deepest[0])

    def sliding_flags(self, p) -> tuple:
        return p.mode == SLIDE, p.emode == SLIDE

    # ------------------------------------------------------------------ effect interface
    def potential(self, p, on: Binding) -> float:
        kernels = VARIANTS.of(p)
        return float(typed_call(kernels.kernel("obstacle_energy"), p, on.state)
                     + typed_call(kernels.kernel("element_energy"), p, on.state))

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"anchor": p.anchor, "mode": p.mode, "dissipated": p.dissipated, "deepest": p.deepest,
                "edata": p.edata, "emode": p.emode}

    def omega2(self, p, on: Binding) -> float:
        """max(k, k_t) / m_min: the smallest free mass on the stiffer of the normal and
        tangential springs (they act along orthogonal directions); on a soft soil, the largest
        of a vertex's area over the free mass it pushes (its own, or its line end's node's),
        times the constants per area."""
        if not self.soil:
            m_min = smallest_mass(on, self._lines(on))
            return max(p.k, p.k_t) / m_min if m_min else 0.0
        verts, masses = pushed_masses(on, self._lines(on))
        if not verts.size:
            return 0.0
        row = np.full(on.model.vertex_mass.shape[0], -1, np.int64)   # each vertex's contact row
        row[p.verts] = np.arange(p.verts.shape[0])
        return max(p.k, p.k_t) * float(np.max(p.scale[row[verts]] / masses))

    def describe(self) -> str:
        lines = "all" if self.lines is None else [getattr(x, "name", x) for x in self.lines]
        mu = lambda a: f"{a[0]:g}" if np.all(a == a[0]) else "[" + ", ".join(f"{x:g}" for x in a) + "]"  # noqa: E731
        named = f", name={self.name!r}" if self.name else ""
        law = (f"k_soil={self.k:g} N/m^3, gamma_soil={self.gamma:g} N s/m^3, k_t={self.k_t:g} N/m^3 (per contact area)"
               if self.soil else f"k={self.k:g} N/m, gamma={self.gamma:g} N s/m, k_t={self.k_t:g} N/m")
        return f"Obstacle({self.shape}{named}, {law}, mu_s={mu(self.mu_s)}, mu_k={mu(self.mu_k)}, lines={lines})"
