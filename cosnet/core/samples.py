"""Small nets, built in milliseconds: the rods an effect's example scene is built on
(Effect.example, on which cosnet.studies.effect_check holds each effect to its contract), and
the nets, motions and scene files the tests and benchmarks share."""

from __future__ import annotations

import numpy as np

from .materials import Circle, Material, Rectangle
from .net import Line, Net
from .rotations import matrix_from_quat

STEEL = Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")
RADIUS = 0.005   # m: every sample rod's section
LENGTH = 0.3     # m


def rod(net: Net | None = None, start=(0.0, 0.0, 0.0), end=(LENGTH, 0.0, 0.0), *, elements: int = 4,
        fixed: bool = False, **kw) -> tuple[Net, Line]:
    """(net, line): a steel rod from ``start`` to ``end`` added to ``net`` (a new one by
    default), its start node fixed when ``fixed``; ``kw`` go to Net.add_line."""
    net = Net() if net is None else net
    a = net.add_node(start, fixed=fixed)
    b = net.add_node(end)
    return net, net.add_line(a, b, material=STEEL, section=Circle(RADIUS), elements=elements, **kw)


def crossing(gap: float = 1.6 * RADIUS) -> tuple[Net, Line, Line]:
    """(net, a, b): two rods crossing at their middles, their centrelines ``gap`` apart
    (less than two radii: their capsules overlap)."""
    net, a = rod()
    h = 0.5 * LENGTH
    _, b = rod(net, (h, -h, gap), (h, h, gap))
    return net, a, b


def chain() -> tuple[Net, Line, Line]:
    """(net, a, b): two rods end to end, b's start a millimetre past a's end and turned a
    little (a joint between them holds a load)."""
    net, a = rod()
    _, b = rod(net, (LENGTH + 1e-3, 0.0, 0.0), (2 * LENGTH, 0.02, 0.01))
    return net, a, b


def free_net(n=4):
    """Three lines and an extended rigid body with offsets, nothing fixed."""
    mat = Material(E=5e6, G=2e6, density=1000.0, name="rubber")
    net = Net()
    body = net.add_node((0.0, 0.0, 0.0), mass=0.5, inertia=np.diag([2e-3, 3e-3, 4e-3]), name="body")
    a = net.add_node((1.0, 0.0, 0.0), name="a")
    b = net.add_node((0.0, 1.0, 0.2), mass=0.05, inertia=np.diag([1e-5, 1e-5, 1e-5]), name="b")
    net.add_line(body, a, material=mat, section=Circle(0.02), elements=n,
                 start_offset=(0.1, 0.0, 0.0), name="l1")
    net.add_line(a, b, material=mat, section=Rectangle(0.03, 0.02), elements=n, name="l2")
    net.add_line(b, body, material=mat, section=Circle(0.015), elements=n,
                 end_offset=(0.0, 0.1, 0.05), name="l3")
    return net


def smooth_motion(sim, amplitude=0.2, spin=2.0):
    """Smooth, consistent initial motion: a half-sine lateral velocity along every line (its
    elements turning with the tangent), and a spin of every node."""
    m, s = sim.model, sim.state
    for line in sim.net.lines:
        v0, v1 = m.line_vertex_offsets[line.index], m.line_vertex_offsets[line.index + 1]
        e0 = m.line_element_offsets[line.index]
        x = s.x[v0:v1]
        n = v1 - v0 - 1
        t = x[-1] - x[0]
        side = np.cross(t, (0.3, 0.5, 0.8))
        side *= amplitude / np.linalg.norm(side)
        vel = np.sin(np.pi * np.arange(n + 1) / n)[:, None] * side
        s.v[v0 + 1:v1 - 1] = vel[1:-1]
        for i in range(n):
            seg = x[i + 1] - x[i]
            w_lab = np.cross(seg, vel[i + 1] - vel[i]) / np.dot(seg, seg)
            s.w[e0 + i] = matrix_from_quat(s.q[e0 + i]).T @ w_lab
    s.node_w[:] = spin * (sim.model.node_locked == 0)


# a scene file of a steel rod 0.5 m long and 1 cm in radius, clamped at the origin along x
CANTILEVER = """title = "{title}"
[materials.{material}]
E = {E}
G = {G}
density = {density}
[sections.rod]
kind = "circle"
radius = 0.01
[nodes.root]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.tip]
position = [0.5, 0.0, 0.0]
{tip}[lines.rod]
start = "root"
end = "tip"
material = "{material}"
section = "rod"
elements = {elements}
{rest}"""


def cantilever_scene(title: str = "cantilever", *, E="2.1e11", G="8.1e10", density="7850.0", elements=4,
                     material: str = "steel", tip: str = "", rest: str = "") -> str:
    """The text of CANTILEVER: ``tip`` the tip node's own keys (a mass), ``rest`` the tables
    after the line (effects, initial motion, run)."""
    return CANTILEVER.format(title=title, material=material, E=E, G=G, density=density, elements=elements,
                             tip=tip, rest=rest)
