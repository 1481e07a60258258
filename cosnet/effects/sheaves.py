"""The sheaves of a net in motion: the effect a Simulation adds when a net has eyelets with a
radius (cosnet.core.sliding); its kernels hold the line's vertices on each rim
(kernels/sheaves.py)."""

from __future__ import annotations

import math

import numpy as np

from .drives import driven_nodes
from .loads import Gravity
from ..engine.bounds import index_error
from .carried import carried_rows, table_error as carried_error
from ..kernels.sheaves import SheaveParams, sheave_record
from ..engine.registry import Binding, Effect


class Sheaves(Effect):
    """The sheaves of a net (cosnet.core.sliding.Sheave each)."""

    record = SheaveParams
    reads_added_mass = True    # its impulses move wet lines by the fluid's sampled masses

    @property
    def internal(self) -> bool:
        return True

    @classmethod
    def implied(cls, net, grids):
        return Sheaves(net.sheaves) if net.sheaves else None

    @classmethod
    def example(cls):
        net, _ = over_a_sheave(radius=0.05, drop=0.15, masses=(0.03, 0.02))
        return net, [Gravity()]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        k, nv, nn = p.node.shape[0], model.vertex_mass.shape[0], model.node_mass.shape[0]
        if any(a.shape[0] != k for a in (p.line, p.offset, p.axis, p.radius, p.groove, p.mu_s, p.mu_k, p.damping,
                                          p.near, p.lo, p.hi)):
            return "sheaves: every table needs one row per sheave"
        if (any(a.shape != (nv,) for a in (p.engaged, p.sliding, p.landing))
                or p.push.shape != (nv, 3) or p.moved.shape != (nv, 3) or p.node_weight.shape != (nn,)):
            return ("sheaves: engaged, sliding, landing, push and moved need one row per vertex, node_weight one "
                    "per node")
        problem = (index_error("sheaves.node", p.node, nn)
                   or index_error("sheaves.line", p.line, model.line_vertex_offsets.shape[0] - 1))
        if problem:
            return problem
        vo = model.line_vertex_offsets
        first, last = vo[p.line], vo[p.line + 1] - 1
        for name in ("near", "lo", "hi"):
            a = getattr(p, name)
            bad = (a < first) | (a > last)
            if np.any(bad):
                return f"sheaves.{name} holds {a[bad][0]}, outside the vertices of its line"
        if np.any(p.lo > p.hi):
            return "sheaves.lo must not exceed sheaves.hi"
        return carried_error(p, model, "sheaves")

    def __init__(self, sheaves):
        self.sheaves = list(sheaves)

    def bind(self, on: Binding):
        m = on.model
        k, nv = len(self.sheaves), m.vertex_mass.shape[0]
        weight = np.where(driven_nodes(on.effects, m.node_inv_mass.shape[0]), 0.0, m.node_inv_mass)
        x = on.state.x
        near = np.zeros(k, dtype=np.int64)
        vo = m.line_vertex_offsets
        for j, sh in enumerate(self.sheaves):
            l = sh.line.index
            near[j] = vo[l] + int(np.argmin(np.linalg.norm(x[vo[l]:vo[l + 1]] - sh.centre, axis=1)))
        return sheave_record(SheaveParams(
            node=np.array([sh.node.index for sh in self.sheaves], dtype=np.int64),
            line=np.array([sh.line.index for sh in self.sheaves], dtype=np.int64),
            offset=np.array([sh.centre - on.state.node_x[sh.node.index] for sh in self.sheaves]).reshape(k, 3),
            axis=np.array([sh.axis for sh in self.sheaves]).reshape(k, 3),
            radius=np.array([sh.radius for sh in self.sheaves], dtype=float),
            groove=np.array([sh.line.section_at(sh.s / sh.line.length).radius for sh in self.sheaves], dtype=float),
            mu_s=np.array([sh.mu for sh in self.sheaves], dtype=float),
            mu_k=np.array([sh.mu for sh in self.sheaves], dtype=float),
            damping=np.array([sh.damping for sh in self.sheaves], dtype=float), node_weight=weight,
            near=near, lo=near.copy(), hi=near.copy(), engaged=np.zeros(nv), push=np.zeros((nv, 3)),
            moved=np.zeros((nv, 3)), sliding=np.zeros(nv), landing=np.zeros(nv),
            dissipated=np.zeros(1),
            **carried_rows(on, "sheaves", [sh.line for sh in self.sheaves], [sh.node for sh in self.sheaves], weight)))

    def dissipated(self, sim) -> float:
        """Kinetic energy the line's landings on the rims have taken so far (J)."""
        return float(self.params(sim).dissipated[0])

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"near": p.near, "lo": p.lo, "hi": p.hi, "engaged": p.engaged, "push": p.push, "moved": p.moved,
                "sliding": p.sliding, "landing": p.landing, "dissipated": p.dissipated}

    def drawn_shapes(self) -> list:
        """Each sheave as a thin disc (a capsule as long as a tenth of its radius) about its
        centre, moving with its node."""
        out = []
        for sh in self.sheaves:
            c, half = sh.centre - sh.node.position, 0.05 * sh.radius * sh.axis
            out.append({"shape": "capsule", "node": sh.node.index, "origin": (c - half).tolist(),
                        "axis": (c + half).tolist(), "size": [0.9 * sh.radius, 0.0, 0.0], "rot": np.eye(3).tolist(),
                        "points": [], "triangles": []})
        return out

    def describe(self) -> str:
        return f"Sheaves({len(self.sheaves)})"


def laid_rope(radius: float):
    """A circular rope section of ``radius`` whose bending and torsion stiffness are a
    thousandth of the solid section's (a laid rope: its tension, not its stiffness, lays it on
    a rim) and whose rotary inertia is a thousand times the solid's (its rotations then do not
    bind the stable step)."""
    from ..core.materials import Section
    solid = math.pi * radius**4 / 4
    return Section(A=math.pi * radius * radius, I11=solid / 1000, I22=solid / 1000, J=solid / 500, radius=radius,
                   rotary_inertia=(1000 * solid, 1000 * solid, 2000 * solid))


def over_a_sheave(radius: float, drop: float, masses: tuple, elements_per_radius: float = 10.0,
                  material=None, section=None):
    """(net, sheave node): a rope over a fixed sheave of ``radius`` about the origin in the
    x-z plane (axis y), its two strands hanging ``drop`` below the centre with point masses
    ``masses`` at their ends; elements about radius / elements_per_radius long; the rope
    straight at rest (bent over the rim as built)."""
    from ..core.materials import Material
    from ..core.net import Net
    material = material or Material(E=2e9, G=8e8, density=1000.0)
    section = section or laid_rope(0.002)
    step = radius / elements_per_radius
    n_drop = max(2, int(round(drop / step)))
    n_arc = max(4, int(round(math.pi * elements_per_radius)))
    left = [(-radius, 0.0, -drop + drop * i / n_drop) for i in range(n_drop)]
    arc = [(-radius * math.cos(math.pi * i / n_arc), 0.0, radius * math.sin(math.pi * i / n_arc))
           for i in range(n_arc + 1)]
    right = [(radius, 0.0, -drop * i / n_drop) for i in range(1, n_drop + 1)]
    points = np.array(left + arc + right)
    net = Net()
    a = net.add_node(points[0], mass=masses[0], inertia=[math.inf] * 3, name="left")
    b = net.add_node(points[-1], mass=masses[1], inertia=[math.inf] * 3, name="right")
    rope = net.add_line(a, b, material=material, section=section, elements=len(points) - 1, points=points,
                        rest_curvature=(0.0, 0.0, 0.0), name="rope")
    sheave = net.add_eyelet(rope, s=drop + 0.5 * math.pi * radius, at=(0.0, 0.0, 0.0), radius=radius,
                            name="sheave")
    return net, sheave
