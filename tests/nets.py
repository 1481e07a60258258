"""Small nets shared by the tests (kept tiny so the suite stays fast)."""

import numpy as np

import cosnet

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")


# A soft rod clamped at one end with a small mass at its tip, as a scene file; fill in the
# title, stiffness, element count and the tables after the line (effects, initial, run).
ROD_SCENE = """
title = "{title}"
[materials.soft]
E = {E}
G = {G}
density = 1000.0
[sections.rod]
kind = "circle"
radius = 0.01
[nodes.root]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.tip]
position = [0.5, 0.0, 0.0]
mass = 0.05
inertia = [1e-6, 1e-6, 1e-6]
[lines.rod]
start = "root"
end = "tip"
material = "soft"
section = "rod"
elements = {elements}
{rest}"""


def cantilever(n=20, length=1.0, radius=0.01, material=STEEL, axis=(1.0, 0.0, 0.0), tip_mass=0.0):
    """A rod clamped at the origin along ``axis``; returns (net, line, root, tip)."""
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    tip = net.add_node(length * np.asarray(axis, dtype=float), mass=tip_mass, name="tip")
    line = net.add_line(root, tip, material=material, section=cosnet.Circle(radius), elements=n, name="rod")
    return net, line, root, tip


def free_net(n=4):
    """Three lines and an extended rigid body with offsets, nothing fixed."""
    mat = cosnet.Material(E=5e6, G=2e6, density=1000.0, name="rubber")
    net = cosnet.Net()
    body = net.add_node((0.0, 0.0, 0.0), mass=0.5, inertia=np.diag([2e-3, 3e-3, 4e-3]), name="body")
    a = net.add_node((1.0, 0.0, 0.0), name="a")
    b = net.add_node((0.0, 1.0, 0.2), mass=0.05, inertia=np.diag([1e-5, 1e-5, 1e-5]), name="b")
    net.add_line(body, a, material=mat, section=cosnet.Circle(0.02), elements=n,
                 start_offset=(0.1, 0.0, 0.0), name="l1")
    net.add_line(a, b, material=mat, section=cosnet.Rectangle(0.03, 0.02), elements=n, name="l2")
    net.add_line(b, body, material=mat, section=cosnet.Circle(0.015), elements=n,
                 end_offset=(0.0, 0.1, 0.05), name="l3")
    return net


def perturb(sim, rng, scale_v=0.3, scale_w=3.0):
    """Give every vertex, element and node a random velocity/angular velocity."""
    s = sim.state
    s.v[:] = scale_v * rng.standard_normal(s.v.shape)
    s.w[:] = scale_w * rng.standard_normal(s.w.shape)
    s.node_v[:] = scale_v * rng.standard_normal(s.node_v.shape)
    s.node_w[:] = scale_w * rng.standard_normal(s.node_w.shape) * (sim.model.node_locked == 0)


def smooth_motion(sim, amplitude=0.2, spin=2.0):
    """Smooth, consistent initial motion: a half-sine lateral velocity along every line (its
    elements turning with the tangent), and a spin of every node."""
    from cosnet.core.rotations import matrix_from_quat
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


# A tiny cantilever for sweeps: its stiffness E, perturbation velocity V and end time T vary
SWEEP_SCENE = """title = "tiny cantilever"
[materials.steel]
E = {E}
G = 8.1e10
density = 7850.0
[sections.rod]
kind = "circle"
radius = 0.01
[nodes.root]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.tip]
position = [0.5, 0.0, 0.0]
[lines.rod]
start = "root"
end = "tip"
material = "steel"
section = "rod"
elements = 4
[[effects]]
kind = "gravity"
g = [0.0, 0.0, -9.81]
[initial.perturbation]
velocity = {V}
seed = 7
[run]
until = {T}
output_interval = 0.004
probes = ["tip", "rod@0.5"]
"""


def write_sweep_scene(path, E="2.1e11", V="0.0", T="0.012"):
    """The tiny cantilever of the sweep tests (4 elements, a few hundred steps) at ``path``."""
    path.write_text(SWEEP_SCENE.format(E=E, V=V, T=T))
    return path
