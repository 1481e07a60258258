"""Coulomb friction between lines (Contact with mu_s, mu_k): a short line resting across two
clamped rails on an incline holds below mu_s and slides at g (sin - mu_k cos) above it,
momentum is conserved exactly between two free lines, energy plus friction's dissipation is
conserved to an error that falls with the step (at first order: the switch from stick to slip
is resolved to a step), a checkpoint carries the pair springs, a full pair table stops the run
with an error, and bad coefficients are refused in one line."""

import math

import numpy as np
import pytest

import cosnet

STIFF = cosnet.Material(E=1e9, G=4e8, density=1000.0, name="stiff")
G = 9.81
R = 0.01          # section radius
LENGTH = 0.1      # the slider
RAIL = 0.06       # the rails' length
WEIGHT = STIFF.density * math.pi * R * R * LENGTH * G
K = 1e4


def rails(g, mu_s, mu_k, gamma=30.0, height=None, dt_factor=1.0):
    """A two-element slider along x lying across two rails along y (clamped at both ends,
    three elements each, so that each rail touches the slider at the middle of an element,
    and each slider element a rail), under gravity g; the slider sunk by its weight's share
    per rail so that the contacts are loaded from the start. gamma = 30 N s/m damps the
    contacts a little beyond critical: the dashpot's force counts against the Coulomb limit,
    and the overshoot of a less damped spring under the sudden downhill pull would exceed
    mu_s (a step load on a critically damped spring peaks at 1.14 times the load)."""
    net = cosnet.Net()
    for i, x in enumerate((-LENGTH / 4, LENGTH / 4)):
        a = net.add_node((x, -RAIL / 2, 0.0), fixed=True)
        b = net.add_node((x, RAIL / 2, 0.0), fixed=True)
        net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=3, name=f"rail{i}")
    if height is None:
        height = 2 * R - WEIGHT * abs(g[2]) / G / 2 / K
    a, b = net.add_node((-LENGTH / 2, 0.0, height)), net.add_node((LENGTH / 2, 0.0, height))
    line = net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=2, name="slider")
    contact = cosnet.Contact(k=K, gamma=gamma, mu_s=mu_s, mu_k=mu_k)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(g), contact])
    if dt_factor != 1.0:
        sim = cosnet.Simulation(net, effects=[cosnet.Gravity(g), contact], dt=sim.dt * dt_factor)
    return sim, line, contact


def push(sim, line, v):
    sim.line_velocities(line)[:] = v
    for nd in (line.start, line.end):
        sim.node_velocity(nd)[:] = v


def centre(sim, line):
    return sim.line_positions(line).mean(axis=0)


def incline(theta, mu_s, mu_k):
    return rails((G * math.sin(theta), 0.0, -G * math.cos(theta)), mu_s, mu_k)


def test_line_across_rails_holds_below_mu_s():
    theta = math.atan(0.4)
    sim, line, contact = incline(theta, mu_s=0.5, mu_k=0.3)
    x0 = centre(sim, line)[0]
    drift = []
    for i in range(10):
        sim.run(until=0.1 * (i + 1))
        drift.append(abs(centre(sim, line)[0] - x0))
    # each pair's spring holds half the downhill weight within W sin / 2 / k_t (~5e-6 m)
    hold = WEIGHT / 2 * math.sin(theta) / contact.k_t
    assert max(drift) < 3.0 * hold
    assert abs(drift[-1] - drift[4]) < 0.05 * hold   # no creep over the second half second
    assert contact.active_contacts(sim) == 2 and contact.sliding(sim) == 0


def test_line_across_rails_slides_at_g_sin_minus_mu_k_cos():
    theta = math.atan(0.7)
    mu_k = 0.3
    sim, line, contact = incline(theta, mu_s=0.5, mu_k=mu_k)
    xs = []
    for t in (0.02, 0.06, 0.1):   # 16 mm of travel: each pair stays on its slider element
        sim.run(until=t)
        xs.append(centre(sim, line)[0])
    a = (xs[2] - 2 * xs[1] + xs[0]) / 0.04**2
    assert a == pytest.approx(G * (math.sin(theta) - mu_k * math.cos(theta)), rel=0.01)
    assert contact.active_contacts(sim) == contact.sliding(sim) == 2


def crossing_free_lines(v=(0.6, 0.4, -0.3)):
    """Two free lines crossing, one pressed onto the other and sliding across it, no gravity."""
    net = cosnet.Net()
    a = net.add_line(net.add_node((-0.1, 0.0, 0.0)), net.add_node((0.1, 0.0, 0.0)), material=STIFF,
                     section=cosnet.Circle(R), elements=6, name="a")
    b = net.add_line(net.add_node((0.0, -0.1, 1.9 * R)), net.add_node((0.0, 0.1, 1.9 * R)),
                     material=STIFF, section=cosnet.Circle(R), elements=6, name="b")
    contact = cosnet.Contact(k=K, mu_s=0.6, mu_k=0.5)
    sim = cosnet.Simulation(net, effects=[contact])
    push(sim, b, v)
    return sim, contact, a, b


def test_friction_between_free_lines_conserves_momentum():
    sim, contact, a, b = crossing_free_lines()
    p0 = sim.momentum().copy()
    v_b0 = sim.line_velocities(b).mean(axis=0)[:2].copy()
    sim.run(until=0.02)
    assert contact.dissipated(sim) > 0          # friction acted
    # it slowed the sliding (tangential) motion of b, beyond what the normal push does
    assert np.linalg.norm(sim.line_velocities(b).mean(axis=0)[:2]) < 0.99 * np.linalg.norm(v_b0)
    np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=1e-14)


def energy_balance_error(dt_factor):
    """The slider thrown along the rails (elastic normal law) until friction stops it: the
    largest departure of energy + dissipated from its start over the initial kinetic energy,
    and the share of that energy friction took."""
    sim, line, contact = rails((0.0, 0.0, -G), mu_s=0.4, mu_k=0.3, gamma=0.0, dt_factor=dt_factor)
    push(sim, line, (0.5, 0.0, 0.0))
    e0, kinetic = sim.energy(), sim.energy_parts()["kinetic"]
    err = 0.0
    for i in range(8):
        sim.run(until=0.025 * (i + 1))
        err = max(err, abs(sim.energy() + contact.dissipated(sim) - e0))
    return err / kinetic, contact.dissipated(sim) / kinetic


def test_energy_plus_dissipation_is_conserved():
    """The balance holds to 4e-5 of the kinetic energy at the stable step. What remains is
    the switch of the friction law from stick to slip, resolved to a step: it shrinks with
    the step (about half at half the step), not at Verlet's second order."""
    err, took = energy_balance_error(1.0)
    err_half, _ = energy_balance_error(0.5)
    assert took > 0.9   # friction stopped the slider
    assert err < 1e-4 and err_half < 0.6 * err


def test_a_checkpoint_carries_the_pair_springs(tmp_path):
    """Resumed from a checkpoint taken while pairs slide, a run ends bit-identical to the
    uninterrupted one (the pair table and the dissipation travel with the state)."""
    from cosnet.engine import checkpoint

    def start():
        sim, line, _ = rails((0.0, 0.0, -G), mu_s=0.4, mu_k=0.3)
        push(sim, line, (0.3, 0.05, 0.0))
        return sim
    whole = start()
    whole.run(until=0.05)
    assert whole.effects[1].sliding(whole) > 0
    checkpoint.save(whole, tmp_path / "c.npz")
    whole.run(until=0.1)
    resumed = checkpoint.load(start(), tmp_path / "c.npz")
    resumed.run(until=0.1)
    np.testing.assert_array_equal(resumed.state.x, whole.state.x)
    np.testing.assert_array_equal(resumed.effects[1].params(resumed).pair_data,
                                  whole.effects[1].params(whole).pair_data)
    assert resumed.effects[1].dissipated(resumed) == whole.effects[1].dissipated(whole) > 0


def test_a_full_pair_table_stops_the_run():
    """Three parallel lines of ten elements touching each other along their length, their axes
    1.9 R and 1.86 R apart: an element meets the other line's element beside it and both its
    neighbours (they share an end at that distance, < 2 R), not the next ones (their gap of one
    element length puts them > 2.1 R apart): 10 + 2 x 9 = 28 pairs per two lines, 84 in all, more
    than one per element, so a table of one pair per element is full."""
    net = cosnet.Net()
    for i, (y, z) in enumerate(((0.0, 0.0), (1.9 * R, 0.0), (0.95 * R, 1.6 * R))):
        net.add_line(net.add_node((0.0, y, z)), net.add_node((0.1, y, z)), material=STIFF,
                     section=cosnet.Circle(R), elements=10, name=f"l{i}")
    sim = cosnet.Simulation(net, effects=[cosnet.Contact(k=K, mu_s=0.5, pairs_per_element=1)])
    with pytest.raises(RuntimeError, match="pairs_per_element"):
        sim.run(steps=1)
    roomy = cosnet.Simulation(net, effects=[cosnet.Contact(k=K, mu_s=0.5)])
    roomy.run(steps=1)
    assert roomy.effects[0].active_contacts(roomy) == 3 * (10 + 2 * 9)


@pytest.mark.parametrize("kw, message", [
    ({"mu_s": -0.1}, "mu_s"),
    ({"mu_s": 0.3, "mu_k": 0.5}, "mu_k must not exceed"),
    ({"mu_s": 0.3, "k_t": 0.0}, "k_t"),
    ({"mu_s": 0.3, "pairs_per_element": 0}, "pairs_per_element"),
])
def test_bad_friction_is_refused_in_one_line(kw, message):
    with pytest.raises(ValueError, match=message) as e:
        cosnet.Contact(k=1e3, **kw)
    assert "\n" not in str(e.value)
