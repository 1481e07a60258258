"""Bodies that collide: a collision shape carried by a node, meeting lines, static obstacles
and other bodies with the obstacles' contact and friction laws (kernel and model:
cosnet.kernels.bodies). A driven node's shape is a moving obstacle."""

from __future__ import annotations

import itertools

import numpy as np

from .friction import Frictional, friction_keys
from .contact import chosen_lines, smallest_mass
from ..core import samples
from ..engine.bounds import index_error
from ..core.net import Node
from .obstacles import Obstacle, meets_elements
from ..engine.registry import Binding, Key
from ..core.rotations import matrix_from_quat
from ..core.units import LENGTH, choice, frame, positive, string_list, vec3
from ..kernels import bodies as _body_kernels  # noqa: F401  (registers the body kernel)
from ..kernels.bodies import BodyParams, BodyShape, body_energy
from ..kernels.obstacles import BOX, CAPSULE, SHAPES, SLIDE, SPHERE
from ..kernels.layout import typed_call

BODY_SHAPES = ("sphere", "capsule", "box")
TARGET_SHAPES = ("plane", "sphere", "capsule", "box")


def _shape(code, origin, axis, size, rot) -> BodyShape:
    return BodyShape(int(code), np.array(origin, float), np.array(axis, float), np.array(size, float),
                     np.ascontiguousarray(rot, dtype=float), np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros(3),
                     1.0, np.zeros(3, np.int64), np.zeros(1, np.int64), np.zeros(0, np.int64))


class Body(Frictional):
    """A collision shape on a node that meets lines, static obstacles and other bodies.

    The shape is fixed to ``node`` (a rigid body, a point mass or a driven node), given in
    the node's frame about its reference point (``position``):

      "sphere":  radius, center (default the reference point)
      "capsule": start, end, radius
      "box":     half_size, center, axes (columns in the node's frame; default its axes)

    It meets the vertices and elements of ``lines`` (names or Line objects; default every
    line not ending at the node), the static ``obstacles`` named (their ``name``: planes, spheres, capsules,
    boxes) and the shapes of the ``bodies`` named (the names of their nodes), with the static
    obstacles' normal law (k, gamma) and isotropic Coulomb friction (mu_s, mu_k, k_t; the one
    not given equals the other, neither: none). Each force acts with its reaction on the node
    (force and torque), so momentum is exchanged exactly; a driven node's drive supplies it.
    Against obstacles and bodies the shape touches by samples: a sphere by its centre, a
    capsule by its end spheres, a box by its corners (exact against planes; a box or capsule
    against a curved target touches only there). A pair of bodies is declared once.
    """

    kind = "body"
    record = BodyParams
    keys = (Key("node", "node", required=True, doc="the node carrying the shape"),
            Key("shape", choice(*BODY_SHAPES), required=True, doc="sphere, capsule or box"),
            *friction_keys(),
            Key("radius", positive, LENGTH, doc="sphere, capsule: radius"),
            Key("center", vec3, LENGTH, doc="sphere, box: centre in the node's frame"),
            Key("start", vec3, LENGTH, doc="capsule: one end of its axis, node's frame"),
            Key("end", vec3, LENGTH, doc="capsule: the other end"),
            Key("half_size", vec3, LENGTH, doc="box: half its size along its axes"),
            Key("axes", frame, doc="box: its axes as columns in the node's frame"),
            Key("lines", "lines", doc="lines touching it (default: all not ending at the node)"),
            Key("obstacles", string_list, doc="names of the static obstacles it meets"),
            Key("bodies", string_list, doc="nodes whose body shapes it meets"))

    @property
    def conservative(self) -> bool:
        return self.gamma == 0 and self.mu_s == 0

    @property
    def internal(self) -> bool:
        return not self.obstacles

    free_integers = ("mode", "active")   # each contact's stick/slip state, compared, and a counter

    @classmethod
    def example(cls):
        net, _ = samples.rod()
        ball = net.add_node((0.5 * samples.LENGTH, 0.0, 2.4 * samples.RADIUS), mass=0.1, inertia=(1e-5, 1e-5, 1e-5))
        return net, [cls(ball, "sphere", k=1e4, radius=2 * samples.RADIUS)]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        nv, nn = model.vertex_mass.shape[0], model.node_mass.shape[0]
        nl, ns, nt, ne = p.verts.shape[0], p.samples.shape[0], p.tnode.shape[0], p.elems.shape[0]
        m = nl + ns * nt + ne
        shapes = {"vrad": (nl,), "samples": (ns, 3), "srad": (ns,), "tshape": (nt,), "torigin": (nt, 3),
                  "taxis": (nt, 3), "tsize": (nt, 3), "trot": (nt, 3, 3), "tbound": (nt,), "delta": (m, 3),
                  "mode": (m,), "last": (1,), "dissipated": (1,), "deepest": (1,), "active": (1,), "damp": (m, 6),
                  "elems": (ne, 2), "eparam": (ne, 8)}
        for name, shape in shapes.items():
            if getattr(p, name).shape != shape:
                return f"body.{name} has shape {getattr(p, name).shape}, needs {shape}"
        if not 0 <= p.node < nn:
            return f"body.node is {p.node}, outside [0, {nn})"
        bad = p.tnode[(p.tnode < -1) | (p.tnode >= nn)]
        if bad.size:
            return f"body.tnode holds {bad[0]}, outside [-1, {nn}) (-1: a static obstacle)"
        return index_error("body.verts", p.verts, nv) or index_error("body.elems", p.elems.ravel(), nl)

    def __init__(self, node: Node, shape: str, *, k: float, gamma: float = 0.0, k_t=None, mu_s=None,
                 mu_k=None, radius=None, center=None, start=None, end=None, half_size=None, axes=None,
                 lines=None, obstacles=(), bodies=()):
        if not isinstance(node, Node):
            raise ValueError(f"Body: node must be a cosnet Node, got {node!r}")
        who = f"Body on {node!r} ({shape})"
        if shape not in BODY_SHAPES:
            raise ValueError(f"Body on {node!r}: shape must be one of {list(BODY_SHAPES)}, got {shape!r}")
        if shape in ("sphere", "box") and center is None:
            center = (0.0, 0.0, 0.0)
        # the geometry and the contact laws are checked as a static obstacle's are
        stand_in = f"body on {node.name}"
        try:
            self.geometry = Obstacle(shape, k=k, gamma=gamma, k_t=k_t, mu_s=mu_s, mu_k=mu_k, radius=radius,
                                     center=center, start=start, end=end, half_size=half_size, axes=axes,
                                     name=stand_in)
        except ValueError as e:
            raise ValueError(str(e).replace(f"Obstacle {stand_in!r} ({shape})", who)) from None
        g = self.geometry
        if np.any(g.mu_s != g.mu_s[0]) or np.any(g.mu_k != g.mu_k[0]):
            raise ValueError(f"{who}: mu_s and mu_k must be numbers (a body's friction is isotropic)")
        self.node, self.shape, self.who = node, shape, who
        self.k, self.gamma, self.k_t = g.k, g.gamma, g.k_t
        self.mu_s, self.mu_k = float(g.mu_s[0]), float(g.mu_k[0])
        if lines is not None and (isinstance(lines, str) or not hasattr(lines, "__iter__")):
            raise ValueError(f"{who}: lines must be a list of lines or line names, got {lines!r}")
        self.lines = None if lines is None else list(lines)
        for name, val in (("obstacles", obstacles), ("bodies", bodies)):
            if isinstance(val, (str, Obstacle, Node)) or not hasattr(val, "__iter__"):
                raise ValueError(f"{who}: {name} must be a list, got {val!r}")
        self.obstacles, self.bodies = list(obstacles), list(bodies)

    # ------------------------------------------------------------------ binding
    def _lines(self, on):
        if self.lines is None:
            return [ln for ln in on.net.lines if self.node not in (ln.start, ln.end)]
        return chosen_lines(on, self.lines, self.who)

    def _targets(self, on: Binding) -> list:
        """The static obstacles and other bodies this body meets, refused in one line when a
        name is unknown or the target is not one it can meet."""
        statics = {e.name: e for e in on.effects if isinstance(e, Obstacle) and e.name}
        bodies = {e.node.name: e for e in on.effects if isinstance(e, Body)}
        out: list = []
        for x in self.obstacles:
            ob = x if isinstance(x, Obstacle) else statics.get(x)
            if ob is None:
                raise ValueError(f"{self.who}: no obstacle named {x!r} in this simulation; named obstacles "
                                 f"are {sorted(statics)}")
            if ob.shape not in TARGET_SHAPES:
                raise ValueError(f"{self.who}: obstacle {x!r} is a {ob.shape}; a body meets a "
                                 f"{', '.join(TARGET_SHAPES)}")
            out.append(ob)
        for x in self.bodies:
            b = x if isinstance(x, Body) else bodies.get(getattr(x, "name", x))
            if b is None:
                raise ValueError(f"{self.who}: no body on a node named {getattr(x, 'name', x)!r} in this "
                                 f"simulation; bodies are on {sorted(bodies)}")
            if b is self or b.node is self.node:
                raise ValueError(f"{self.who}: a body does not meet itself")
            out.append(b)
        return out

    def _posed(self, on: Binding):
        """(code, origin, axis, size, rot) of the shape in the node's principal frame about its
        centre of mass, as the kernel reads it."""
        m, nd, g = on.model, self.node.index, self.geometry
        P = matrix_from_quat(m.node_principal[nd])
        com = P @ m.node_com_offset[nd]       # in the node's frame, from its reference point
        to = lambda y: P.T @ (y - com)        # noqa: E731
        if self.shape == "capsule":
            return CAPSULE, to(g.origin), to(g.axis), g.size, np.eye(3)
        # g.rot holds the box axes as rows, in the node's frame
        return SHAPES[self.shape], to(g.origin), np.zeros(3), g.size, g.rot @ P

    def _samples(self, on: Binding):
        code, origin, axis, size, rot = self._posed(on)
        if code == SPHERE:
            return origin[None], np.array([size[0]])
        if code == CAPSULE:
            return np.array([origin, axis]), np.full(2, size[0])
        corners = np.array(list(itertools.product((-1.0, 1.0), repeat=3))) * size
        return origin + corners @ rot, np.zeros(8)

    def bind(self, on: Binding) -> BodyParams:
        on.check_node(self.node, "Body")
        m = on.model
        verts: list[int] = []
        vrad: list[float] = []
        elems: list[tuple[int, int]] = []
        for line in self._lines(on):
            v0, v1 = int(m.line_vertex_offsets[line.index]), int(m.line_vertex_offsets[line.index + 1])
            if meets_elements(self.shape, self.geometry.size[0], m, line.index):
                elems += [(len(verts) + j, len(verts) + j + 1) for j in range(v1 - v0 - 1)]
            for i in range(v0, v1):
                verts.append(i)
                vrad.append(line.section_at((i - v0) / (v1 - v0 - 1)).radius)
        samples, srad = self._samples(on)
        targets = self._targets(on)
        rows = []
        for t in targets:
            if isinstance(t, Body):
                posed = t._posed(on)
                their, their_rad = t._samples(on)
                rows.append((t.node.index, *posed, self._reach(their, their_rad, _shape(*posed))))
            else:
                rows.append((-1, SHAPES[t.shape], t.origin, t.axis, t.size, t.rot, 0.0))
        nt = len(rows)
        col = lambda i, shape: np.array([r[i] for r in rows], dtype=float).reshape(shape)  # noqa: E731
        own = _shape(*self._posed(on))
        count = len(verts) + len(samples) * nt + len(elems)
        return BodyParams(
            self.node.index, own, self._reach(samples, srad, own), self.k, self.gamma, self.k_t, self.mu_s,
            self.mu_k, np.array(verts, np.int64), np.array(vrad, float), np.ascontiguousarray(samples),
            srad, np.array([r[0] for r in rows], np.int64), np.array([r[1] for r in rows], np.int64),
            col(2, (nt, 3)), col(3, (nt, 3)), col(4, (nt, 3)), col(5, (nt, 3, 3)), col(6, (nt,)), np.zeros((count, 3)),
            np.zeros(count, np.int64), np.array([on.time]), np.zeros(1), np.zeros(1), np.zeros(1, np.int64),
            np.zeros((count, 6)), np.array(elems, np.int64).reshape(-1, 2), np.zeros((len(elems), 8)))

    @staticmethod
    def _reach(samples, srad, own) -> float:
        """A radius about the centre of mass enclosing the shape."""
        if own.shape == BOX:
            return float(np.max(np.linalg.norm(samples, axis=1)))
        return float(np.max(np.linalg.norm(samples, axis=1) + srad))

    # ------------------------------------------------------------------ reports
    def drawn_shapes(self) -> list:
        return [self.geometry.geometry_record(self.node.index)]

    def deepest(self, sim) -> float:
        """The largest overlap met so far, as a fraction of the touching sphere's radius."""
        return float(self.params(sim).deepest[0])

    def sliding_flags(self, p) -> tuple:
        return (p.mode == SLIDE,)

    # ------------------------------------------------------------------ effect interface
    def potential(self, p, on: Binding) -> float:
        return float(typed_call(body_energy, p, on.state))

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"delta": p.delta, "mode": p.mode, "last": p.last, "dissipated": p.dissipated,
                "deepest": p.deepest, "eparam": p.eparam}

    @staticmethod
    def _inv_mass(on: Binding, nd: int, arm: float) -> float:
        """1 / the smallest effective mass a force at distance arm from the node's centre of
        mass meets (translation plus the softest rotation)."""
        m = on.model
        return float(m.node_inv_mass[nd] + arm * arm * np.max(m.node_inv_inertia[nd]))

    def omega2(self, p, on: Binding) -> float:
        """max(k, k_t) times the largest sum of inverse effective masses of a contact's two
        sides: a line's smallest free mass, this node and every target node with their arms."""
        mine = self._inv_mass(on, p.node, p.bound)
        worst = 0.0
        if p.verts.shape[0]:
            m_min = smallest_mass(on, self._lines(on))
            worst = (1.0 / m_min if m_min else 0.0) + mine
        for nd, arm in zip(p.tnode, p.tbound):
            worst = max(worst, mine + (self._inv_mass(on, int(nd), float(arm)) if nd >= 0 else 0.0))
        return max(p.k, p.k_t) * worst

    def describe(self) -> str:
        lines = "all" if self.lines is None else [getattr(x, "name", x) for x in self.lines]
        return (f"Body({self.node.name!r}, {self.shape}, k={self.k:g} N/m, gamma={self.gamma:g} N s/m, "
                f"k_t={self.k_t:g} N/m, mu_s={self.mu_s:g}, mu_k={self.mu_k:g}, lines={lines}, "
                f"obstacles={[getattr(x, 'name', x) for x in self.obstacles]}, "
                f"bodies={[getattr(x, 'name', x) for x in self.bodies]})")
