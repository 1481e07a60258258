"""The snake of cases/snake.toml (PyElastica's continuum snake): a muscle wave running from
head to tail moves it only through the ground's friction, head first when the friction
resists head-first sliding least. A 20-element snake over three periods of the wave."""

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest
from cosnet.scene.loader import build_scene

CASE = Path(__file__).resolve().parents[1] / "cases" / "snake.toml"
DATA = tomllib.loads(CASE.read_text())
PERIOD = next(e for e in DATA["effects"] if e["kind"] == "muscle_torque")["period"]
MU = next(e for e in DATA["effects"] if e["kind"] == "obstacle")["mu_k"]   # forward, backward, lateral


def crawl(mu, periods=3, elements=20, rotary=1.0):
    """Mean velocity (3,) of the centre of mass after the first period (the ramp), and the
    simulation, of the case's snake on ground with the coefficients mu (mu_s = mu_k), its
    rotary inertia scaled by ``rotary`` (the damping's rotational rate divided by it, so the
    damping torque, mass-proportional, stays the case's)."""
    data = copy.deepcopy(DATA)
    data["lines"]["snake"]["elements"] = elements
    data["lines"]["snake"]["rotary_inertia_scale"] = rotary
    next(e for e in data["effects"] if e["kind"] == "damping")["rotational"] /= rotary
    ground = next(e for e in data["effects"] if e["kind"] == "obstacle")
    ground["mu_s"] = ground["mu_k"] = mu
    sim = build_scene(data).simulation()
    w = sim.model.vertex_mass / sim.model.vertex_mass.sum()
    com = lambda: w @ sim.state.x
    sim.run(until=PERIOD)
    start = com()
    sim.run(until=periods * PERIOD)
    return (com() - start) / (sim.time - PERIOD), sim


def test_on_frictionless_ground_the_snake_writhes_in_place():
    """Gravity and the ground's normal force are vertical and the muscle moments are internal
    couples: the horizontal momentum stays zero, so the centre of mass does not move across
    the ground (to round-off) however the body writhes."""
    v, sim = crawl([0.0, 0.0, 0.0], periods=2)
    x = sim.line_positions(sim.net.lines[0])
    assert np.ptp(x[:, 0]) > 0.05          # it did bend, by centimetres
    assert abs(v[0]) < 1e-12 and abs(v[2]) < 1e-12


def test_anisotropic_ground_sets_the_crawling_direction():
    """With the case's friction (head first mu, tail first 1.5 mu, across 2 mu) the snake crawls
    head first (+z, towards the line's start), more than it drifts sideways; with the
    head-first and tail-first coefficients exchanged it goes slower head first."""
    v, _ = crawl(MU)
    assert v[2] > 0.0 and v[2] > abs(v[0])
    w, _ = crawl([MU[1], MU[0], MU[2]])
    assert w[2] < v[2]


def test_scaled_rotary_inertia_crawls_alike_on_a_three_times_longer_step():
    """The snake's stable step is set by its sections' rotation against the shear stiffness
    (omega ~ 2 sqrt(kG/rho)/r), a motion the crawl does not depend on: its rotary inertia x16
    lets the step grow 3.2 times (to the stretch waves' limit) and the mean velocity of the
    centre of mass stays within 0.5 % of the crawling speed of the resolved snake (measured:
    0.16 %)."""
    v, sim = crawl(MU)
    w, fast = crawl(MU, rotary=16.0)
    assert fast.dt > 3.0 * sim.dt
    assert np.linalg.norm(w - v) < 5e-3 * v[2]


def test_the_case_crawls_at_pyelastica_speed_for_the_same_snake():
    """PyElastica 1.0.0's continuum snake, built from the case's numbers (bench/snake.py runs it
    beside cosnet and stores its forward speed in bench/snake.json with the machine and commit
    of that run: the source of the figure), crawls at the speed of the case's snake over
    periods 3-8 within 2 %: the two codes share the rod, the muscle wave, the friction
    coefficients and the damping but not the contact law (PyElastica's plane: kinetic friction
    regularised below 1e-8 m/s; cosnet's obstacle: a penalty with a stick spring, static as
    kinetic) nor the step, and the gap those leave was 1.0 % when it was stored."""
    import json
    stored = json.loads((CASE.parents[1] / "bench" / "snake.json").read_text())
    reference = stored["pyelastica"]["forward_speed_m_per_s"]
    sim = build_scene(DATA).simulation()
    w = sim.model.vertex_mass / sim.model.vertex_mass.sum()
    sim.run(until=2 * PERIOD)
    start = w @ sim.state.x
    sim.run(until=stored["periods"] * PERIOD)
    forward = (w @ sim.state.x - start)[2] / (sim.time - 2 * PERIOD)
    assert forward == pytest.approx(reference, rel=0.02)


def test_undulator_crawls_head_first_and_its_actuation_does_work():
    """cases/undulator.toml: the travelling wave of rest curvature moves the rod towards its
    start (+z) over two periods after the ramp, more than sideways, and puts energy in."""
    sim = build_scene(tomllib.loads((CASE.parent / "undulator.toml").read_text())).simulation()
    w = sim.model.vertex_mass / sim.model.vertex_mass.sum()
    sim.run(until=1.0)
    start = w @ sim.state.x
    sim.run(until=3.0)
    d = w @ sim.state.x - start
    assert d[2] > 0.0 and d[2] > abs(d[0])
    assert sim.actuation_work() > 0.0


def test_one_muscle_over_many_lines_drives_each_as_its_own_muscle_would():
    """MuscleTorque(lines=[...]) is the sum of one MuscleTorque per line, bit for bit."""
    import cosnet
    rubber = cosnet.Material(E=1e6, G=4e5, density=1000.0)

    def two_rods(muscles):
        net = cosnet.Net()
        lines = []
        for k, n in enumerate((6, 9)):
            a, b = net.add_node((0.0, 0.3 * k, 0.0)), net.add_node((1.0, 0.3 * k, 0.0))
            lines.append(net.add_line(a, b, material=rubber, section=cosnet.Circle(0.02), elements=n))
        wave = dict(moment=[0.01, 0.03, 0.02], points=[0.0, 0.5, 1.0], period=0.5, wavelength=0.7, ramp_time=0.1)
        sim = cosnet.Simulation(net, muscles(lines, wave), dt=1e-4)
        sim.run(steps=300)
        return sim.state.x.copy(), sim.state.q.copy()

    together = two_rods(lambda lines, w: [cosnet.MuscleTorque(lines=lines, **w)])
    apart = two_rods(lambda lines, w: [cosnet.MuscleTorque(line, **w) for line in lines])
    assert np.ptp(together[0][:, 2]) > 1e-5     # they bend (about d1, the lab y: out of the x-y plane)
    np.testing.assert_array_equal(together[0], apart[0])
    np.testing.assert_array_equal(together[1], apart[1])


def test_muscle_needs_exactly_one_of_line_and_lines():
    import cosnet
    import pytest
    net = cosnet.Net()
    line = net.add_line(net.add_node((0, 0, 0)), net.add_node((1, 0, 0)), elements=2,
                        material=cosnet.Material(E=1e6, G=4e5, density=1000.0), section=cosnet.Circle(0.01))
    for kw in ({}, {"line": line, "lines": [line]}, {"lines": []}):
        with pytest.raises(ValueError, match="MuscleTorque: .*line") as e:
            cosnet.MuscleTorque(moment=1.0, **kw)
        assert "\n" not in str(e.value)
