"""Mobile nodes (§8): rings on lines and eyelets lines slide through.

A ring on a stiff straight wire inclined at alpha stays put when tan(alpha) < mu_s and slides
at g (sin alpha - mu_k cos alpha) otherwise, with the energy friction takes accounted for; on a
stiff circular wire in a vertical plane it swings with the pendulum's elliptic-integral period;
it stops at the line's end; a free net with a ring keeps its momentum to round-off; a line
pulled through an eyelet passes through its point to round-off; checkpoints and bad input.

The ring's weight is a node load, not gravity on the wire: a wire released under its own
weight rings, and a ring on a ringing wire is thrown about by it, as a real one would be."""

import math

import numpy as np
import pytest
from scipy.special import ellipk

import cosnet
from nets import resumed

G = 9.81
MASS = 0.1
HEAVY = cosnet.Material(E=2e11, G=8e10, density=1e6)   # a stiff wire the ring barely moves


def inclined_wire(alpha, mu_s=0.0, mu_k=0.0, length=2.0, s=1.025):
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=True)
    b = net.add_node((length * math.cos(alpha), 0.0, length * math.sin(alpha)), fixed=True)
    wire = net.add_line(a, b, material=HEAVY, section=cosnet.Circle(0.02), elements=20)
    ring = net.add_ring(wire, s=s, mass=MASS, mu_s=mu_s, mu_k=mu_k)
    return cosnet.Simulation(net, [cosnet.NodeLoad(ring, force=(0.0, 0.0, -MASS * G))]), ring


def slide(sim, ring, until, every=500):
    t, s = [sim.time], [cosnet.slider_state(sim, ring)["s"]]
    while sim.time < until:
        sim.run(steps=every)
        t.append(sim.time)
        s.append(cosnet.slider_state(sim, ring)["s"])
    return np.array(t), np.array(s)


def test_ring_sticks_below_its_static_friction():
    alpha = 0.5                      # tan = 0.546
    sim, ring = inclined_wire(alpha, mu_s=0.6, mu_k=0.5)
    t, s = slide(sim, ring, 0.1)
    assert np.abs(s - s[0]).max() < 1e-12
    assert not cosnet.slider_state(sim, ring)["sliding"]


@pytest.mark.parametrize("mu_s, mu_k", [(0.0, 0.0), (0.3, 0.3), (0.4, 0.2)])
def test_ring_slides_at_the_coulomb_acceleration(mu_s, mu_k):
    alpha = 0.5
    sim, ring = inclined_wire(alpha, mu_s, mu_k)
    e0 = sim.energy()
    t, s = slide(sim, ring, 0.2)
    expected = G * (math.sin(alpha) - mu_k * math.cos(alpha))
    a = 2.0 * np.polyfit(t ** 2, s[0] - s, 1)[0]
    assert abs(a / expected - 1.0) < 5e-3
    # the load's work on the ring = its kinetic energy + what friction took (+ the wire's strain)
    drop = (s[0] - s[-1]) * math.sin(alpha)
    work = MASS * G * drop
    assert abs(sim.energy() - e0 + sim.dissipated() - work) < 1e-2 * work
    if mu_k:
        assert abs(sim.dissipated() / (mu_k * MASS * G * math.cos(alpha) * (s[0] - s[-1])) - 1.0) < 1e-2


def test_ring_on_a_circular_wire_swings_as_a_pendulum():
    radius, n, phi0 = 0.5, 200, 0.3
    net = cosnet.Net()
    a, b = net.add_node((-radius, 0.0, 0.0), fixed=True), net.add_node((radius, 0.0, 0.0), fixed=True)
    phi = np.linspace(-math.pi / 2, math.pi / 2, n + 1)
    points = np.column_stack([radius * np.sin(phi), 0.0 * phi, -radius * np.cos(phi)])
    wire = net.add_line(a, b, material=HEAVY, section=cosnet.Circle(0.01), elements=n, points=points)
    bottom = radius * math.pi / 2
    ring = net.add_ring(wire, s=bottom + radius * phi0, mass=MASS)
    sim = cosnet.Simulation(net, [cosnet.NodeLoad(ring, force=(0.0, 0.0, -MASS * G))])
    expected = 4.0 * math.sqrt(radius / G) * ellipk(math.sin(phi0 / 2) ** 2)
    t, s = slide(sim, ring, 1.3 * expected, every=200)
    d = s - bottom
    i = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1]))
    crossings = t[i] - d[i] * (t[i + 1] - t[i]) / (d[i + 1] - d[i])
    assert abs((crossings[2] - crossings[0]) / expected - 1.0) < 5e-3
    # on the centreline to round-off: the ring is on the chord of its element
    x = sim.line_positions(wire)
    k = int(np.searchsorted(np.linspace(0, math.pi * radius, n + 1), cosnet.slider_state(sim, ring)["s"]) - 1)
    p, q, r = x[k], x[k + 1], sim.node_position(ring)
    assert np.linalg.norm(np.cross(q - p, r - p)) / np.linalg.norm(q - p) < 1e-12


def test_ring_stops_at_the_line_end():
    sim, ring = inclined_wire(0.5, s=0.05)
    t, s = slide(sim, ring, 0.3)
    assert s.min() >= 0.0 and s[-1] == 0.0
    assert np.linalg.norm(sim.node_position(ring)) < 1e-9   # on the fixed end


def test_free_net_with_a_ring_keeps_its_momentum():
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0)), net.add_node((1.0, 0.0, 0.0))
    line = net.add_line(a, b, material=cosnet.Material(E=1e7, G=4e6, density=1000.0),
                        section=cosnet.Circle(0.01), elements=10)
    ring = net.add_ring(line, s=0.43, mass=0.05, mu_s=0.3, mu_k=0.2, damping=0.01)
    sim = cosnet.Simulation(net, [cosnet.NodeLoad(ring, force=(0.0, 0.0, 0.0))])
    sim.node_velocity(ring)[:] = (0.3, 0.2, -0.1)
    sim.line_velocities(line)[3:6] = (0.0, -0.1, 0.4)
    p0 = sim.momentum()
    sim.run(steps=5000)
    assert np.abs(sim.momentum() - p0).max() < 1e-13
    assert cosnet.slider_state(sim, ring)["s"] != 0.43


def test_ring_at_rest_on_a_moving_line_is_caught_plastically():
    """A line moving across itself at V and a ring at rest on it: before the first step the
    ring and the two vertices beside it take one velocity across the line (a plastic impact,
    momentum kept); the energy taken is 1/2 V^2 / w, w = 1/m + (1 - t)^2 / m_i + t^2 / m_i+1
    the effective inverse mass, and it is counted as dissipated."""
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0), mass=0.02), net.add_node((1.0, 0.0, 0.0), mass=0.02)
    line = net.add_line(a, b, material=cosnet.Material(E=1e7, G=4e6, density=1000.0),
                        section=cosnet.Circle(0.01), elements=10)
    ring = net.add_ring(line, s=0.43, mass=0.05)
    sim = cosnet.Simulation(net, [cosnet.NodeLoad(ring, force=(0.0, 0.0, 0.0))])
    V = np.array([0.0, 0.3, -0.4])
    for nd in (a, b):
        sim.node_velocity(nd)[:] = V
    sim.line_velocities(line)[:] = V
    p0, e0 = sim.momentum(), sim.energy()
    sim.run(steps=0)
    mass = sim.model.vertex_mass[4:6]           # the vertices of the ring's element, t = 0.3
    w = 1.0 / 0.05 + 0.7 ** 2 / mass[0] + 0.3 ** 2 / mass[1]
    assert sim.dissipated() == pytest.approx(0.5 * (V @ V) / w, rel=1e-12)
    assert e0 - sim.energy() == pytest.approx(sim.dissipated(), rel=1e-12)
    assert np.abs(sim.momentum() - p0).max() < 1e-15
    v = sim.line_velocities(line)
    assert np.abs(sim.node_velocity(ring) - (0.7 * v[4] + 0.3 * v[5])).max() < 1e-15
    # from there the balance drifts at the scheme's order (tests/test_effect_contract.py)


def test_line_pulled_through_an_eyelet_passes_through_its_point():
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0), mass=0.5), net.add_node((2.0, 0.0, 0.0), mass=0.5)
    rope = net.add_line(a, b, material=cosnet.Material(E=1e8, G=4e7, density=1000.0),
                        section=cosnet.Circle(0.005), elements=20)
    eyelet = net.add_eyelet(rope, s=1.0)
    sim = cosnet.Simulation(net, [cosnet.NodeLoad(b, force=(2.0, 0.5, 0.0))])
    sim.line_velocities(rope)[1:-1, 2] = 0.2     # and shaken across
    for _ in range(10):
        sim.run(steps=2000)
        x, at = sim.line_positions(rope), sim.node_position(eyelet)
        gaps = [np.linalg.norm(np.cross(x[k + 1] - x[k], at - x[k])) / np.linalg.norm(x[k + 1] - x[k])
                for k in range(20)]
        assert min(gaps) < 1e-12
    assert cosnet.slider_state(sim, eyelet)["s"] < 0.99   # the rope has moved through it toward b


@pytest.mark.parametrize("elsewhere", [0, 1])
def test_rope_over_an_eyelet_at_its_corner_vertex_hangs_in_balance(elsewhere):
    """A rope bent through a right angle at one of its vertices, hung over a point eyelet there
    with equal loads on its ends: the eyelet lies outside the corner between the two elements
    (beyond the end of one and before the start of the other), so the vertex itself is the
    line's point nearest it; the rope hangs in balance, its elements stretched by the load's
    tension alone, whatever else the net holds (`elsewhere`: elements of an unrelated line)."""
    n, length, mass = 10, 0.05, 0.5
    arm = length / math.sqrt(2)
    points = ([(-(n - k) * arm, 0.0, -(n - k) * arm) for k in range(n)] + [(0.0, 0.0, 0.0)]
              + [(k * arm, 0.0, -k * arm) for k in range(1, n + 1)])
    rope_material, section = cosnet.Material(E=2e9, G=8e8, density=1000.0), cosnet.Circle(0.002)
    net = cosnet.Net()
    a = net.add_node(points[0], mass=mass, inertia=[math.inf] * 3)
    b = net.add_node(points[-1], mass=mass, inertia=[math.inf] * 3)
    rope = net.add_line(a, b, material=rope_material, section=section, elements=2 * n, points=points,
                        rest_curvature=(0.0, 0.0, 0.0))
    if elsewhere:
        top = net.add_node((1.0, 1.0, 1.0), fixed=True)
        net.add_line(top, net.add_node((1.0, 1.0, 0.0), mass=0.1), material=rope_material, section=section,
                     elements=elsewhere)
    eyelet = net.add_eyelet(rope, s=n * length)
    sim = cosnet.Simulation(net, [cosnet.Gravity()])
    sim.run(steps=2000)
    strain = np.linalg.norm(np.diff(sim.line_positions(rope), axis=0), axis=1) / length - 1.0
    static = mass * G / (rope_material.E * section.A)
    assert np.abs(strain).max() < 20 * static          # ringing about the static stretch, no element lost
    assert abs(cosnet.slider_state(sim, eyelet)["s"] - n * length) < 1e-6


def test_ring_in_water_slides_down_against_the_drag_with_the_account_kept():
    """Drag on the wire alone (no added mass: tests/test_sliding_carried.py has rings on lines
    that carry one): the ring slides down the frictionless wire, the account kept to Verlet's
    error."""
    sim, ring = inclined_wire(0.3)
    sim = cosnet.Simulation(sim.net, [cosnet.Fluid(1025.0, drag=(1.2, 0.0), added_mass=(0.0, 0.0)),
                                      cosnet.NodeLoad(ring, force=(0.0, 0.0, -MASS * G))])
    b0 = sim.balance()
    sim.run(steps=4000)
    assert cosnet.slider_state(sim, ring)["s"] < 1.0
    assert abs(sim.balance() - b0) < 0.01 * sim.load_work()


def test_rope_sliding_over_a_sharp_eyelet_counts_what_each_passage_takes():
    """A rope turned through a right angle at a point eyelet, unequal loads on its ends, slides
    over it: each vertex that passes the eyelet meets the turn at once, and the velocity across
    the new element is taken as in a plastic impact. That energy is counted as dissipated, so
    energy + dissipated keeps to a few % of it (left out, the balance misses all of it, the
    same 8 mJ whatever the step)."""
    n, length = 20, 0.025
    arm = length / math.sqrt(2)
    points = ([(-(n - k) * arm, 0.0, -(n - k) * arm) for k in range(n)] + [(0.0, 0.0, 0.0)]
              + [(k * arm, 0.0, -k * arm) for k in range(1, n + 1)])
    net = cosnet.Net()
    a = net.add_node(points[0], mass=0.6, inertia=[math.inf] * 3)
    b = net.add_node(points[-1], mass=0.4, inertia=[math.inf] * 3)
    rope = net.add_line(a, b, material=cosnet.Material(E=2e9, G=8e8, density=1000.0), section=cosnet.Circle(0.002),
                        elements=2 * n, points=points, rest_curvature=(0.0, 0.0, 0.0))
    net.add_eyelet(rope, s=(n + 0.3) * length)
    stable = cosnet.Simulation(net, [cosnet.Gravity()]).dt
    misses, took = [], []
    for dt in (stable / 2, stable / 8):
        sim = cosnet.Simulation(net, [cosnet.Gravity()], dt=dt)
        start = sim.balance()
        sim.run(until=0.15)
        misses.append(abs(sim.balance() - start))
        took.append(sim.dissipated())
    assert min(took) > 0.0
    assert misses[0] < 0.05 * took[0] and misses[1] < 0.05 * took[1]


def test_checkpoint_carries_the_sliders(tmp_path):
    (a, ring_a), (b, ring_b) = resumed(lambda: inclined_wire(0.5, 0.4, 0.2), tmp_path / "c.npz", 3000, 2000)
    assert cosnet.slider_state(a, ring_a) == cosnet.slider_state(b, ring_b)
    assert np.array_equal(a.state.node_x, b.state.node_x) and a.dissipated() == b.dissipated()


def bare_line():
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0), fixed=True), net.add_node((1.0, 0.0, 0.0), fixed=True)
    return net, net.add_line(a, b, material=HEAVY, section=cosnet.Circle(0.01), elements=4)


@pytest.mark.parametrize("make, message", [
    (lambda net, l: net.add_ring(l, s=1.5, mass=1.0),
     "s must be in [0, 1] m (the unstretched length of 'line0'), got 1.5"),
    (lambda net, l: net.add_ring(l, s=0.5, mass=0.0), "mass must be a finite number > 0"),
    (lambda net, l: net.add_ring(l, s=0.5, mass=1.0, mu_s=-0.1), "mu_s must be a finite number >= 0"),
    (lambda net, l: net.add_ring(l, s=0.5, mass=1.0, mu_s=0.1, mu_k=0.2), "mu_k must not exceed mu_s"),
    (lambda net, l: net.add_eyelet(l, s=0.5, at=(0.5, 0.1, 0.0)), "the line does not pass through the eyelet"),
    (lambda net, l: net.add_eyelet(l, s=0.5, at=net.nodes[1]), "the line does not pass through the eyelet"),
])
def test_bad_sliders_are_refused_in_one_line(make, message):
    net, line = bare_line()
    with pytest.raises(ValueError) as err:
        make(net, line)
    assert message in str(err.value) and "\n" not in str(err.value)
    assert len(net.nodes) == 2 and not net.sliders    # nothing half made


SCENE = """
[materials.wire]
E = 2e11
G = 8e10
density = 1e6
[sections.wire]
kind = "circle"
radius = 0.02
[nodes.a]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.b]
position = [2.0, 0.0, 0.0]
fixed = true
[lines.wire]
start = "a"
end = "b"
material = "wire"
section = "wire"
elements = 20
[rings.bead]
line = "wire"
s = %s
mass = 0.1
mu_s = 0.2
mu_k = 0.1
[eyelets.guide]
line = "wire"
s = 1.5
[[effects]]
kind = "node_load"
node = "bead"
force = [0.5, 0.0, -0.981]
[run]
until = 0.01
"""


def test_scene_declares_rings_and_eyelets(tmp_path):
    path = tmp_path / "bead.toml"
    path.write_text(SCENE % "0.5")
    scene = cosnet.load_scene(path)
    kinds = [(sl.kind, sl.node.name, sl.s) for sl in scene.net.sliders]
    assert kinds == [("ring", "bead", 0.5), ("eyelet", "guide", 1.5)]
    sim = scene.simulation()
    sim.run(steps=2000)
    # the push along the wire (0.5 N) beats static friction (0.2 x 0.981 N): it slides toward b
    assert cosnet.slider_state(sim, scene.net.node("bead"))["s"] > 0.5
    path.write_text(SCENE % "2.5")
    with pytest.raises(ValueError, match=r"\[rings.bead\] s: ring on line 'wire': s must be in \[0, 2\] m"):
        cosnet.load_scene(path)


def test_ring_passes_through_the_junction_of_a_path_of_lines():
    alpha, length = 0.5, 2.0
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=True)
    mid = net.add_node((length / 2 * math.cos(alpha), 0.0, length / 2 * math.sin(alpha)))
    b = net.add_node((length * math.cos(alpha), 0.0, length * math.sin(alpha)), fixed=True)
    lower = net.add_line(a, mid, material=HEAVY, section=cosnet.Circle(0.02), elements=10)
    upper = net.add_line(mid, b, material=HEAVY, section=cosnet.Circle(0.02), elements=10)
    ring = net.add_ring([lower, upper], s=1.1, mass=MASS)   # on the upper line, 0.1 m above the junction
    sim = cosnet.Simulation(net, [cosnet.NodeLoad(ring, force=(0.0, 0.0, -MASS * G))])
    t, s = slide(sim, ring, 0.3)
    assert s[0] > 1.0 > s[-1]                               # it has passed the junction
    a_fit = 2.0 * np.polyfit(t ** 2, s[0] - s, 1)[0]
    assert abs(a_fit / (G * math.sin(alpha)) - 1.0) < 5e-3
    with pytest.raises(ValueError, match="a path's line must end at the node where the next starts"):
        net.add_ring([upper, lower], s=0.5, mass=MASS)
