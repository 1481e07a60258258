"""Internal (strain-rate) damping of the lines' stretching (kernels/strain_damping.py): two
masses on one element ring as the damped oscillator mu x'' + (c/l0) x' + (EA/l0) x = 0, at
order 2 in dt; it is stable and dissipative however stiff the dashpot is against the step;
momentum and angular momentum are kept to round-off, a body's offset included; the energy it
takes is the energy the net loses; bad input is refused in one line."""

import math

import numpy as np
import pytest

import cosnet
from cosnet import load_scene
from nets import resumed

STEEL = cosnet.Material(E=2e11, G=8e10, density=7850.0)


def two_masses(ratio, mass=10.0, length=1.0, radius=0.01):
    """(sim-builder, mu, k, zeta): two point masses on one element, stretching apart at 1 mm/s
    each (no gravity)."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), mass=mass)
    b = net.add_node((length, 0.0, 0.0), mass=mass)
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(radius), elements=1)

    def build(dt):
        sim = cosnet.Simulation(net, [cosnet.InternalDamping(ratio=ratio)], dt=dt)
        for nd, u in ((0, -1e-3), (1, 1e-3)):
            sim.state.node_v[nd] = (u, 0.0, 0.0)
        cosnet.kernels.motion.place_line_ends(sim.model, sim.state)
        return sim
    m = build(1e-9).model
    mu = m.node_mass[0] * m.node_mass[1] / (m.node_mass[0] + m.node_mass[1])
    return build, mu, m.element_stiffness[0, 2] / m.element_rest_length[0]


def stretch_history(sim, dt, periods, every):
    out = []
    for _ in range(int(round(periods / every))):
        sim.run(steps=every)
        out.append(sim.state.node_x[1, 0] - sim.state.node_x[0, 0] - 1.0)
    return np.array(out)


def test_two_masses_ring_as_the_damped_oscillator_at_order_2():
    zeta = 0.1
    build, mu, k = two_masses(zeta)
    w0 = math.sqrt(k / mu)
    wd = w0 * math.sqrt(1 - zeta * zeta)
    period = 2 * math.pi / w0
    errors = []
    for n in (1000, 2000):   # steps a period (the element's turning modes bound dt, not this)
        dt = period / n
        sim = build(dt)
        got = stretch_history(sim, dt, 3 * n, n // 20)
        t = dt * (n // 20) * np.arange(1, got.size + 1)
        want = 2e-3 / wd * np.exp(-zeta * w0 * t) * np.sin(wd * t)
        errors.append(np.max(np.abs(got - want)) / (2e-3 / w0))
    assert errors[0] < 1e-4
    assert math.log2(errors[0] / errors[1]) > 1.8


def test_a_dashpot_far_stiffer_than_the_step_stays_stable_and_only_dissipates():
    """Ratio 1e5: the dashpot's rate c w / l0 = 2 zeta w0 is over a thousand times 1/dt at the
    stable step; an explicit dashpot would blow up at once, the exact flow stops the relative
    motion and the energy falls at every step."""
    zeta = 1e5
    build, mu, k = two_masses(zeta)
    sim = build(None)
    assert 2 * zeta * math.sqrt(k / mu) * sim.dt > 1000
    energies = [sim.energy()]
    for _ in range(200):
        sim.run(steps=1)
        energies.append(sim.energy())
    e = np.array(energies)
    # falling, to the round-off of a strain energy made of a nanometre's stretch on a metre's
    # positions (1e-16 m / 1e-9 m of itself)
    assert np.all(np.isfinite(e)) and np.all(np.diff(e) <= 1e-6 * e[1:])
    # the relative motion stopped in the first flow: what is left is the strain of the stretch
    # the first half drift made before it, (w0 dt)^2 of the energy
    assert e[-1] < 2 * (k / mu) * sim.dt ** 2 * e[0]
    # all of it counted, to the scheme's energy error at this step, (w0 dt)^2 of the energy
    assert abs(sim.energy() + sim.dissipated() - e[0]) < (k / mu) * sim.dt ** 2 * e[0]


def free_net_with_a_body():
    """A free body with two lines hung at offsets from its centre, a third line between their far
    ends: everything moving at random, no gravity."""
    net = cosnet.Net()
    body = net.add_node((0.0, 0.0, 0.0), mass=5.0, inertia=(0.2, 0.3, 0.4))
    p = net.add_node((1.0, 0.5, 0.0))
    q = net.add_node((1.0, -0.5, 0.2))
    section = cosnet.Circle(0.005)
    net.add_line(body, p, material=STEEL, section=section, elements=6, start_offset=(0.1, 0.05, 0.0))
    net.add_line(body, q, material=STEEL, section=section, elements=6, start_offset=(0.1, -0.05, 0.02))
    net.add_line(p, q, material=STEEL, section=section, elements=5)
    return net


def test_momentum_and_angular_momentum_are_kept_and_energy_balances():
    net = free_net_with_a_body()
    rng = np.random.default_rng(3)
    sim = cosnet.Simulation(net, [cosnet.InternalDamping(ratio=0.8)])
    sim.state.v[:] = rng.normal(0.0, 0.05, sim.state.v.shape)
    sim.state.w[:] = rng.normal(0.0, 0.5, sim.state.w.shape)
    sim.state.node_v[:] = rng.normal(0.0, 0.05, sim.state.node_v.shape)
    sim.state.node_w[:] = rng.normal(0.0, 0.5, sim.state.node_w.shape)
    cosnet.kernels.motion.place_line_ends(sim.model, sim.state)
    p0, l0, e0 = sim.momentum(), sim.angular_momentum(), sim.energy()
    sim.run(steps=2000)
    scale_p = np.sum(sim.model.vertex_mass) * 0.05 + np.sum(sim.model.node_mass) * 0.05
    assert np.max(np.abs(sim.momentum() - p0)) < 1e-12 * scale_p
    assert np.max(np.abs(sim.angular_momentum() - l0)) < 1e-11 * np.max(np.abs(l0))
    assert sim.dissipated() > 0.05 * e0   # the dashpots did take energy...
    assert sim.energy() + sim.dissipated() == pytest.approx(e0, rel=1e-4)   # ...and no more than was lost


def test_a_line_shaken_at_a_driven_end_balances_its_energy_at_order_two():
    """A wire from a fixed node to a node driven to and fro along it (0.5 mm at 200 Hz, so
    that its axial waves ring): energy + what the dashpots and the damping took - the driver's
    work is kept at the scheme's order. Within a kick a driven node moves on with its loads
    until its drive restores its velocity; a dashpot reading that velocity damped a motion
    that never was and made energy (hundreds of joules on a still mooring line): it reads the
    velocity the drive gives back."""
    def build(dt_factor):
        net = cosnet.Net()
        a = net.add_node((0.0, 0.0, 0.0), fixed=True)
        b = net.add_node((2.0, 0.0, 0.0), mass=1.0, inertia=(0.1, 0.1, 0.1))
        net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.005), elements=20)
        effects = [cosnet.Drive(b, position={"amplitude": [5e-4, 0.0, 0.0], "omega": 2 * math.pi * 200}),
                   cosnet.InternalDamping(ratio=0.5)]
        dt = dt_factor * cosnet.Simulation(net, effects).dt
        return cosnet.Simulation(net, effects, dt=dt)
    drifts = []
    for factor in (0.5, 0.25):
        sim = build(factor)
        start, worst = sim.balance(), 0.0
        while sim.time < 0.01:
            sim.run(until=sim.time + 2.5e-4)
            worst = max(worst, abs(sim.balance() - start))
        drifts.append(worst)
        assert sim.dissipated() > 0.1 * abs(sim.driver_work())   # the dashpots took a share of the work
    assert math.log2(drifts[0] / drifts[1]) > 1.8


def test_a_checkpoint_carries_the_dashpots_turn_and_account(tmp_path):
    """The dashpots run before a kick on one step and after it on the next: a run resumed from
    a checkpoint taken after an odd number of steps goes on as the unbroken run, bit for bit."""
    def build():
        net = free_net_with_a_body()
        sim = cosnet.Simulation(net, [cosnet.Gravity(), cosnet.InternalDamping(ratio=0.5)])
        sim.state.v[:] = np.random.default_rng(5).normal(0.0, 0.05, sim.state.v.shape)
        return sim
    a, b = resumed(build, tmp_path / "c.npz", 301, 300)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    assert a.dissipated() == b.dissipated() > 0.0


def test_the_scene_key_and_bad_input(tmp_path):
    build = """
[materials.steel]
E = 2e11
G = 8e10
density = 7850.0
[sections.wire]
kind = "circle"
radius = 0.005
[nodes.a]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.b]
position = [1.0, 0.0, 0.0]
[lines.wire]
start = "a"
end = "b"
material = "steel"
section = "wire"
elements = 4
[effects.ringdown]
kind = "internal_damping"
{}
[run]
until = 0.01
"""
    path = tmp_path / "ringdown.toml"
    path.write_text(build.format('ratio = 0.5\nlines = ["wire"]'))
    scene = load_scene(path)
    (effect,) = [e for e in scene.effects if isinstance(e, cosnet.InternalDamping)]
    assert effect.ratio == 0.5 and effect.lines == ["wire"]
    with pytest.raises(ValueError, match="give axial .* or ratio, one of them"):
        cosnet.InternalDamping(1.0, ratio=0.5)
    with pytest.raises(ValueError, match="give axial"):
        cosnet.InternalDamping()
    with pytest.raises(ValueError, match="ratio"):
        cosnet.InternalDamping(ratio=-1.0)
    net = free_net_with_a_body()
    with pytest.raises(ValueError, match="unknown line 'rope'"):
        cosnet.Simulation(net, [cosnet.InternalDamping(ratio=1.0, lines=["rope"])])
