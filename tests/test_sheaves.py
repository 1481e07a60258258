"""Sheaves (§8, an eyelet with a radius): a rope that turns sharply over a wheel's rim.

An Atwood machine, two masses m1 > m2 on a rope over a sheave on free bearings, accelerates
as a rigid rope would: with the rope's mass lambda per length, the heavier side lengthening
by x, M x'' = g (m1 - m2 + lambda (L1 - L2) + 2 lambda x) (M all the moving mass: the
masses and the whole rope; the part on the rim keeps its height), so
x(t) = (alpha / beta) (cosh(sqrt(beta) t) - 1), alpha = g (m1 - m2 + lambda (L1 - L2)) / M,
beta = 2 lambda g / M. The rope's engaged vertices lie on the rim to round-off; energy +
what the landings took is conserved at the scheme's order; bad input gets one line."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.effects.sheaves import Sheaves, over_a_sheave

G = 9.81
R = 0.05
M1, M2 = 0.3, 0.2


def atwood(drop=0.5, dt_factor=None):
    net, sheave = over_a_sheave(radius=R, drop=drop, masses=(M1, M2))
    effects = [cosnet.Gravity()]
    dt = None if dt_factor is None else dt_factor * cosnet.Simulation(net, effects).dt
    return cosnet.Simulation(net, effects, dt=dt), net, sheave


def rigid_rope_drop(net, t):
    rope = net.lines[0]
    lam = rope.material.density * rope.section.A
    mass = M1 + M2 + lam * rope.length
    alpha, beta = G * (M1 - M2) / mass, 2.0 * lam * G / mass   # both strands hang equally as built
    return alpha / beta * (np.cosh(np.sqrt(beta) * t) - 1.0)


def test_an_atwood_machine_over_a_sheave_accelerates_as_a_rigid_rope_would():
    sim, net, sheave = atwood()
    heavy = net.node("left")
    z0 = sim.node_position(heavy)[2]
    sim.run(until=0.3)
    went = z0 - sim.node_position(heavy)[2]
    assert abs(went / rigid_rope_drop(net, sim.time) - 1.0) < 5e-3   # measured 3e-4
    state = cosnet.slider_state(sim, sheave)
    assert abs(state["wrap"] - math.pi) < 0.1       # half a turn, to an element's turn
    # the rope has run 8.6 cm over the rim, and its engaged vertices lie on it to round-off
    assert state["s"] > net.lines[0].length / 2 + 0.08
    p = next(e for e in sim.effects if isinstance(e, Sheaves)).params(sim)
    on = np.flatnonzero(p.engaged)
    assert len(on) >= 25
    rho = np.linalg.norm(sim.state.x[on][:, [0, 2]] - sim.node_position(sheave)[[0, 2]], axis=1)
    assert np.abs(rho / R - 1.0).max() < 1e-12 and np.abs(sim.state.x[on][:, 1]).max() < 1e-12


def test_energy_and_what_the_landings_took_is_conserved_at_order_two():
    errors = []
    for factor in (0.9, 0.45):
        sim, _, _ = atwood(dt_factor=factor)
        e0, worst = sim.energy(), 0.0
        while sim.time < 0.1:
            sim.run(steps=int(180 / factor))
            worst = max(worst, abs(sim.energy() + sim.dissipated() - e0))
        errors.append(worst)
        speed = np.linalg.norm(sim.state.node_v[0])
        assert 0.0 < sim.dissipated() < 1e-3 * 0.5 * (M1 + M2) * speed**2   # measured 1e-4 of it
    assert errors[0] / errors[1] > 3.5       # measured 4.8 (order 2: 4)
    assert errors[0] < 1e-7                  # against a kinetic energy of 0.01 J


def test_checkpoint_carries_the_sheaves(tmp_path):
    a, _, sheave_a = atwood()
    a.run(steps=3000)
    a.save_checkpoint(tmp_path / "c.npz")
    a.run(steps=2000)
    b, _, sheave_b = atwood()
    b.load_checkpoint(tmp_path / "c.npz")
    b.run(steps=2000)
    assert cosnet.slider_state(a, sheave_a) == cosnet.slider_state(b, sheave_b)
    assert np.array_equal(a.state.x, b.state.x) and a.dissipated() == b.dissipated()


TOP = 0.2 + R * math.sqrt(2.0)    # the rope's vertex on top of the rim


def rope_over(net=None):
    net = net or cosnet.Net()
    pts = np.array([(-R, 0.0, -0.2), (-R, 0.0, 0.0), (0.0, 0.0, R), (R, 0.0, 0.0), (R, 0.0, -0.2)])
    a = net.add_node(pts[0], mass=0.1)
    b = net.add_node(pts[-1], mass=0.1)
    rope = net.add_line(a, b, material=cosnet.Material(E=2e9, G=8e8, density=1000.0), section=cosnet.Circle(0.002),
                        elements=4, points=pts)
    return net, rope


@pytest.mark.parametrize("make, message", [
    (lambda net, l: net.add_eyelet(l, s=TOP, at=(0.0, 0.0, 0.0), radius=-0.1), "radius must be a finite number >= 0"),
    (lambda net, l: net.add_eyelet(l, s=TOP, radius=R), "give at, the sheave's centre"),
    (lambda net, l: net.add_eyelet(l, s=TOP, at=(0.0, 0.0, 0.0), radius=2 * R),
     "the line does not pass over the sheave"),
    (lambda net, l: net.add_eyelet(l, s=0.1, at=(-R, 0.0, -0.1 - 2 * R), radius=2 * R), "does not run along the rim"),
    (lambda net, l: net.add_eyelet(l, s=TOP, at=(0.0, 0.0, 0.0), radius=R, mu=0.2), "a sheave turns freely"),
    (lambda net, l: net.add_eyelet([l, l], s=TOP, at=(0.0, 0.0, 0.0), radius=R), "a path's line must end"),
    (lambda net, l: net.add_eyelet(l, s=TOP, at=net.add_node((0.0, 0.0, 0.0), mass=1.0, inertia=(1.0, 1.0, 1.0)),
                                   radius=R), "may turn; a sheave moves with a node whose rotation is locked"),
])
def test_bad_sheaves_are_refused_in_one_line(make, message):
    net, rope = rope_over()
    with pytest.raises(ValueError) as err:
        make(net, rope)
    assert message in str(err.value) and "\n" not in str(err.value)
    assert not net.sheaves    # nothing half made


SCENE = """
[materials.rope]
E = 2e9
G = 8e8
density = 1000.0
[sections.rope]
kind = "circle"
radius = 0.002
[nodes.left]
position = [-0.05, 0.0, -0.2]
mass = 0.3
[nodes.right]
position = [0.05, 0.0, -0.2]
mass = 0.2
[lines.rope]
start = "left"
end = "right"
material = "rope"
section = "rope"
elements = 4
points = [[-0.05, 0.0, -0.2], [-0.05, 0.0, 0.0], [0.0, 0.0, 0.05], [0.05, 0.0, 0.0], [0.05, 0.0, -0.2]]
[eyelets.wheel]
line = "rope"
s = %s
at = [0.0, 0.0, 0.0]
radius = 0.05
[[effects]]
kind = "gravity"
[run]
until = 0.001
"""


def test_a_scene_declares_a_sheave_as_an_eyelet_with_a_radius(tmp_path):
    path = tmp_path / "atwood.toml"
    path.write_text(SCENE % TOP)
    scene = cosnet.load_scene(path)
    (sheave,) = scene.net.sheaves
    assert sheave.radius == 0.05 and np.allclose(np.abs(sheave.axis), (0.0, 1.0, 0.0)) and not scene.net.sliders
    path.write_text(SCENE % "0.1")
    with pytest.raises(ValueError) as err:
        cosnet.load_scene(path)
    assert "eyelets.wheel" in str(err.value) and "does not pass over the sheave" in str(err.value)
    assert "\n" not in str(err.value)


def test_modes_refuse_a_net_with_a_sheave_in_one_line():
    net, _ = over_a_sheave(radius=R, drop=0.1, masses=(M1, M2))
    with pytest.raises(ValueError) as err:
        cosnet.modes(net)
    assert "a net with sheaves has no linear modes" in str(err.value) and "\n" not in str(err.value)
