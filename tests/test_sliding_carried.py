"""Rings and eyelets on lines in water: the impulses that hold them move the net by the masses
the kick takes, the fluid's added mass included (kernels/sliding.py).

A ring pushed across the middle of a free, straight, submerged line carries it along as one
rigid body whose mass is the ring's, the nodes', the line's and the water's the line carries
across itself, C_an rho A L; at its stop at the line's start, pulled away from the line, it
draws the line along itself with C_at rho A L instead. (Moved by their dry masses instead,
as a slider blind to the fluid would move them, the same runs measured 62 % and 17 % too fast,
and the net below missed 4 % of its energy whatever the step.) A free net of wet lines, with an eyelet at one of its
junctions and a ring, thrown about in still water by the fluid's full Lagrangian added mass
(its turning forces too), keeps energy + dissipated at the scheme's order 2, and its line
passes through the eyelet's point to round-off; a run resumed from a checkpoint goes on as the
unbroken one, bit for bit (the rings read the fluid's own sampled masses)."""

import math

import numpy as np
import pytest

import cosnet
from nets import balance_drift, resumed

RHO = 1025.0
ADDED = (1.0, 0.5)   # across and along: unequal, so the fluid turns with the lines too


def water():
    return cosnet.Fluid(RHO, drag=(0.0, 0.0), added_mass=ADDED, buoyancy=False)


def pushed_line(s, force, node_mass=0.01, ring_mass=0.05):
    """A free 1 m line in still water, a ring on it at s pushed by a node load."""
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0), mass=node_mass), net.add_node((1.0, 0.0, 0.0), mass=node_mass)
    line = net.add_line(a, b, material=cosnet.Material(E=2e9, G=8e8, density=1500.0), section=cosnet.Circle(0.01),
                        elements=20)
    ring = net.add_ring(line, s=s, mass=ring_mass)
    return cosnet.Simulation(net, [water(), cosnet.NodeLoad(ring, force=force)]), line, ring


@pytest.mark.parametrize("s, axis, which, tolerance", [
    (0.5, 1, 0, 5e-3),   # across the middle (the line bends a little under the push: measured 1e-3)
    (0.0, 0, 1, 1e-5),   # along, the ring at its stop at the line's start (measured 4e-7)
])
def test_a_ring_moves_a_wet_line_with_the_water_it_carries(s, axis, which, tolerance):
    force = np.zeros(3)
    force[axis] = 0.02 if axis else -0.02
    sim, line, ring = pushed_line(s, force)
    mass = 0.05 + 2 * 0.01 + (line.material.density + ADDED[which] * RHO) * line.section.A * line.length
    t, x = [], []
    while sim.time < 0.2:
        sim.run(steps=200)
        t.append(sim.time)
        x.append(sim.node_position(ring)[axis])
    accel = 2.0 * np.polyfit(np.array(t) ** 2, np.array(x), 1)[0]
    assert abs(accel / (force[axis] / mass) - 1.0) < tolerance
    assert cosnet.slider_state(sim, ring)["s"] == pytest.approx(s, abs=1e-9)


def thrown_net():
    """A free net of wet lines: two meeting at a node, an eyelet there through which a third
    line runs, a ring on that one; every node thrown in its own direction."""
    net = cosnet.Net()
    material, section = cosnet.Material(E=2e8, G=8e7, density=1500.0), cosnet.Circle(0.005)
    a, n, b = (net.add_node(x, mass=0.02) for x in ((-0.5, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.5, 0.0)))
    net.add_line(a, n, material=material, section=section, elements=10)
    net.add_line(n, b, material=material, section=section, elements=10)
    c0, c1 = net.add_node((0.0, -0.4, -0.3), mass=0.01), net.add_node((0.0, 0.6, 0.45), mass=0.01)
    rope = net.add_line(c0, c1, material=material, section=section, elements=20)
    net.add_eyelet(rope, s=0.5, at=n)
    ring = net.add_ring(rope, s=0.8, mass=0.03)
    return net, (a, n, b, c0, c1, ring), rope, ring


def thrown(factor=None):
    net, nodes, rope, ring = thrown_net()
    effects = lambda: [water(), cosnet.NodeLoad(ring, force=(0.0, 0.0, 0.0))]   # noqa: E731
    dt = None if factor is None else factor * cosnet.Simulation(net, effects()).dt
    sim = cosnet.Simulation(net, effects(), dt=dt)
    for k, nd in enumerate(nodes):
        sim.node_velocity(nd)[:] = (0.3 * math.cos(k), 0.5 * math.sin(2 * k), 0.4 * math.cos(3 * k + 1))
    return sim, nodes, rope


def test_a_net_in_water_with_an_eyelet_and_a_ring_keeps_energy_at_order_two():
    errors = []
    for factor in (0.8, 0.4):
        sim, nodes, rope = thrown(factor)
        sim.run(steps=0)   # the sliders catch their lines (a plastic impact, counted as dissipated)
        errors.append(balance_drift(sim, 0.3, int(20 / factor)))
        energy = sim.energy()
        eyelet = nodes[1]
        assert abs(cosnet.slider_state(sim, eyelet)["s"] - 0.5) > 0.01   # the rope ran through it
        x, at = sim.line_positions(rope), sim.node_position(eyelet)
        gaps = [np.linalg.norm(np.cross(x[k + 1] - x[k], at - x[k])) / np.linalg.norm(x[k + 1] - x[k]) ** 2
                for k in range(20)]
        assert min(gaps) < 1e-12
    assert errors[0] / errors[1] > 3.5     # measured 3.9 (order 2: 4)
    assert errors[0] < 1e-3 * energy       # measured 3e-4; moved by their dry masses 4e-2, whatever the step


def test_checkpoint_carries_the_rings_in_water(tmp_path):
    (a, nodes_a, _), (b, nodes_b, _) = resumed(thrown, tmp_path / "c.npz", 1500, 1000)
    assert np.array_equal(a.state.x, b.state.x) and a.dissipated() == b.dissipated()
    assert cosnet.slider_state(a, nodes_a[5]) == cosnet.slider_state(b, nodes_b[5])


def test_two_fluids_adding_mass_to_a_ring_s_line_are_refused_in_one_line():
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0)), net.add_node((1.0, 0.0, 0.0))
    line = net.add_line(a, b, material=cosnet.Material(E=2e9, G=8e8, density=1500.0), section=cosnet.Circle(0.01),
                        elements=4)
    net.add_ring(line, s=0.5, mass=0.05)
    with pytest.raises(ValueError, match="rings and eyelets: fluid and fluid both give their lines or nodes an "
                                         "added mass; give it in one effect"):
        cosnet.Simulation(net, [water(), water()])
