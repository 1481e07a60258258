"""Internal damping on lines in water (kernels/strain_damping.py, its CARRIED variant): the
dashpots move a wet line by the masses the kick divides by, the water it carries included.

Two masses on one element in water ring as the damped oscillator whose reduced mass holds the
water the element carries along itself, C_at rho A l / 2 at each end; a free line thrown about
in still water by the fluid's full Lagrangian added mass (unequal across and along, so its
turning forces act), with dashpots declared before the fluid, keeps energy + dissipated at the
scheme's order 2. (Moved by their dry masses instead, the record's carried flags cleared, the
oscillator decays as the dry one, and the line's balance misses a quarter of its energy.)"""

import math

import numpy as np
import pytest

import cosnet
from nets import balance_drift, resumed

RHO = 1025.0
WIRE = cosnet.Material(E=2e11, G=8e10, density=1500.0)   # light: the water it carries outweighs it
ADDED = (1.0, 3.0)   # across and along: unequal, so the water turns with the line


def water():
    return cosnet.Fluid(RHO, drag=(0.0, 0.0), added_mass=ADDED)


def wet_masses(zeta, dt, mass=0.5, length=1.0, radius=0.02):
    """(sim, mu, k): two point masses on one element in still water, stretching apart at 1 mm/s
    each, with a dashpot of damping ratio zeta for the reduced mass mu of the wet ends."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), mass=mass)
    b = net.add_node((length, 0.0, 0.0), mass=mass)
    line = net.add_line(a, b, material=WIRE, section=cosnet.Circle(radius), elements=1)
    m = cosnet.Simulation(net, [], dt=1e-9).model
    each = m.node_mass[0] + ADDED[1] * RHO * line.section.A * length / 2   # the water along the line, half an end
    mu, k = each / 2, m.element_stiffness[0, 2] / length
    damping = cosnet.InternalDamping(axial=2 * zeta * length * math.sqrt(k * mu))
    sim = cosnet.Simulation(net, [damping, water()], dt=dt)
    for nd, u in ((0, -1e-3), (1, 1e-3)):
        sim.state.node_v[nd] = (u, 0.0, 0.0)
    cosnet.kernels.motion.place_line_ends(sim.model, sim.state)
    return sim, mu, k


def stretch_error(zeta, n, dry=False):
    """The largest gap between the stretch of wet_masses over three periods at n steps a period
    and the damped oscillator's, over the amplitude; ``dry``: the dashpot's node flags cleared
    (it moves the ends by their dry masses)."""
    _, mu, k = wet_masses(zeta, 1e-9)
    w0 = math.sqrt(k / mu)
    wd = w0 * math.sqrt(1 - zeta * zeta)
    sim, _, _ = wet_masses(zeta, 2 * math.pi / w0 / n)
    if dry:
        sim.records[1].carried_node[:] = 0
    got, every = [], n // 20
    for _ in range(60):
        sim.run(steps=every)
        got.append(sim.state.node_x[1, 0] - sim.state.node_x[0, 0] - 1.0)
    t = sim.dt * every * np.arange(1, 61)
    want = 2e-3 / wd * np.exp(-zeta * w0 * t) * np.sin(wd * t)
    return np.max(np.abs(np.array(got) - want)) / (2e-3 / w0)


def test_two_wet_masses_ring_as_the_damped_oscillator_of_the_water_they_carry():
    errors = [stretch_error(0.1, n) for n in (1000, 2000)]
    assert errors[0] < 1e-4                          # measured 7e-6
    assert math.log2(errors[0] / errors[1]) > 1.8
    assert stretch_error(0.1, 1000, dry=True) > 0.1   # measured 0.3


def thrown_line(factor=None, dashpot_first=True):
    """A free wet line of 12 elements between two small masses, each vertex and node thrown in
    its own direction; a dashpot of ratio 0.5 declared before the fluid (or after it)."""
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0), mass=0.05), net.add_node((1.0, 0.2, -0.1), mass=0.05)
    net.add_line(a, b, material=cosnet.Material(E=2e8, G=8e7, density=1500.0), section=cosnet.Circle(0.005),
                 elements=12)
    effects = lambda: ([cosnet.InternalDamping(ratio=0.5), water()] if dashpot_first   # noqa: E731
                       else [water(), cosnet.InternalDamping(ratio=0.5)])
    dt = None if factor is None else factor * cosnet.Simulation(net, effects()).dt
    sim = cosnet.Simulation(net, effects(), dt=dt)
    k = np.arange(sim.state.v.shape[0])
    sim.state.v[:] = np.column_stack([0.3 * np.cos(k), 0.5 * np.sin(2 * k), 0.4 * np.cos(3 * k + 1)])
    sim.state.node_v[:] = ((0.2, -0.3, 0.1), (-0.1, 0.4, 0.3))
    cosnet.kernels.motion.place_line_ends(sim.model, sim.state)
    return sim


def test_a_wet_line_with_dashpots_keeps_energy_at_order_two():
    errors = []
    for factor in (0.8, 0.4):
        sim = thrown_line(factor)
        assert [e.kind for e in sim.effects] == ["fluid", "internal_damping"]   # runs after the fluid
        errors.append(balance_drift(sim, 0.05, int(10 / factor)))
        energy = sim.energy()
        assert sim.effects[1].dissipated(sim) > 0.2 * energy   # the dashpots took a share (measured 0.4)
    assert errors[0] / errors[1] > 3.5     # measured 3.75 (order 2: 4)
    assert errors[0] < 1e-3 * energy       # measured 5e-4; moved by their dry masses 0.25, whatever the step


def test_checkpoint_carries_the_wet_dashpots(tmp_path):
    a, b = resumed(thrown_line, tmp_path / "c.npz", 301, 300)
    assert np.array_equal(a.state.x, b.state.x) and a.dissipated() == b.dissipated() > 0.0


def test_two_fluids_adding_mass_to_a_damped_line_are_refused_in_one_line():
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0)), net.add_node((1.0, 0.0, 0.0))
    net.add_line(a, b, material=WIRE, section=cosnet.Circle(0.01), elements=4)
    with pytest.raises(ValueError, match="InternalDamping: fluid and fluid both give their lines or nodes an "
                                         "added mass; give it in one effect"):
        cosnet.Simulation(net, [cosnet.InternalDamping(ratio=0.5), water(), water()])
