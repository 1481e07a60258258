"""Sheaves (§8, an eyelet with a radius): a rope that turns sharply over a wheel's rim.

An Atwood machine, two masses m1 > m2 on a rope over a sheave on free bearings, accelerates
as a rigid rope would: with the rope's mass lambda per length, the heavier side lengthening
by x, M x'' = g (m1 - m2 + lambda (L1 - L2) + 2 lambda x) (M all the moving mass: the
masses and the whole rope; the part on the rim keeps its height), so
x(t) = (alpha / beta) (cosh(sqrt(beta) t) - 1), alpha = g (m1 - m2 + lambda (L1 - L2)) / M,
beta = 2 lambda g / M. The rope's engaged vertices lie on the rim to round-off; energy +
what the landings took is conserved at the scheme's order; bad input gets one line. With
friction mu the rim does not turn (a drum): the rope holds a load up to e^(mu theta) times the
other over a wrap theta and slips beyond (the capstan), and energy + what friction took is
conserved at the scheme's order while it slips."""

import math
import subprocess
import sys

import numpy as np
import pytest

import cosnet
from cosnet.effects.sheaves import Sheaves, laid_rope, over_a_sheave
from nets import resumed

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


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_checkpoint_carries_the_sheaves(tmp_path, mu):
    """A resumed run goes on as the unbroken one, bit for bit: on a drum (mu 0.3) the rim's
    stick and slip states and the step's landings are carried too."""
    def build():
        sim, net, sheave = atwood()
        if mu:
            net.sheaves[0].mu = mu
            sim = cosnet.Simulation(net, [cosnet.Gravity()])
        return sim, sheave
    (a, sheave_a), (b, sheave_b) = resumed(build, tmp_path / "c.npz", 3001, 2000)
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
    (lambda net, l: net.add_eyelet(l, s=TOP, at=(0.0, 0.0, 0.0), radius=R, mu=-0.2), "mu_s must be"),
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


def test_an_atwood_machine_in_water_accelerates_with_the_water_its_rope_carries():
    """In still water that the rope carries along itself (C_at rho A a length; no drag, no
    upthrust), the Atwood machine falls as the rigid rope with that mass added to what moves
    (0.5 %; the water slows it 1.5 %); the rim's impulses move the rope by the masses the kick
    takes, so its engaged vertices lie on the rim to round-off and energy + what the landings
    took is conserved at order 2 (over its first 0.1 s, measured 9e-9 J at 0.9 times the stable
    step; moved by its dry masses, it missed 5e-7 J whatever the step)."""
    errors = []
    for factor, until in ((0.9, 0.3), (0.45, 0.1)):   # the balance over the first 0.1 s at both steps
        net, sheave = over_a_sheave(radius=R, drop=0.5, masses=(M1, M2))
        effects = [cosnet.Gravity(), cosnet.Fluid(1025.0, drag=(0.0, 0.0), added_mass=(1.0, 0.5), buoyancy=False)]
        sim = cosnet.Simulation(net, effects, dt=factor * cosnet.Simulation(net, effects).dt)
        heavy, rope = net.node("left"), net.lines[0]
        z0, e0, worst = sim.node_position(heavy)[2], sim.energy(), 0.0
        while sim.time < until:
            sim.run(steps=int(180 / factor))
            if sim.time < 0.1:
                worst = max(worst, abs(sim.energy() + sim.dissipated() - e0))
        errors.append(worst)
        if until == 0.3:   # (the rope's release rings for a while: its mean motion, later)
            lam, carried = rope.material.density * rope.section.A, 0.5 * 1025.0 * rope.section.A
            mass = M1 + M2 + (lam + carried) * rope.length
            alpha, beta = G * (M1 - M2) / mass, 2.0 * lam * G / mass
            expected = alpha / beta * (np.cosh(np.sqrt(beta) * sim.time) - 1.0)
            assert abs((z0 - sim.node_position(heavy)[2]) / expected - 1.0) < 5e-3   # measured 1e-4
    p = next(e for e in sim.effects if isinstance(e, Sheaves)).params(sim)
    on = np.flatnonzero(p.engaged)
    rho = np.linalg.norm(sim.state.x[on][:, [0, 2]] - sim.node_position(sheave)[[0, 2]], axis=1)
    assert len(on) >= 25 and np.abs(rho / R - 1.0).max() < 1e-12
    assert errors[0] / errors[1] > 3.5 and errors[0] < 5e-8


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
mu = 0.25
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
    assert sheave.mu == 0.25
    path.write_text(SCENE % "0.1")
    with pytest.raises(ValueError) as err:
        cosnet.load_scene(path)
    assert "eyelets.wheel" in str(err.value) and "does not pass over the sheave" in str(err.value)
    assert "\n" not in str(err.value)


def on_a_drum(mu, ratio, damping, rotational=None, dt_factor=1.0):
    """(sim, heavy node, sheaves effect): 5 kg against ratio e^(mu pi) times it over a drum of
    friction mu (a sheave that does not turn), released from rest with mass-proportional
    damping."""
    light = 5.0
    net, _ = over_a_sheave(radius=R, drop=0.1, masses=(light * ratio * math.exp(mu * math.pi), light))
    net.sheaves[0].mu = mu
    effects = [cosnet.Gravity(), cosnet.Damping(damping, rotational)]
    dt = dt_factor * cosnet.Simulation(net, effects).dt
    sim = cosnet.Simulation(net, effects, dt=dt)
    return sim, net.node("left"), next(e for e in sim.effects if isinstance(e, Sheaves))


@pytest.mark.parametrize("mu", [0.15, 0.3])
def test_a_rope_on_a_drum_holds_below_the_capstan_ratio_and_slips_above_it(mu):
    """The capstan: a rope wrapped half a turn over a drum of friction mu holds a load up to
    e^(mu pi) times the other and slips beyond (1 %). Released from rest, each settles under
    damping (300/s, which holds nothing up: it acts on velocities alone); then over 0.1 s the
    load at 0.99 of the ratio stays put (measured 1e-8 m), the one at 1.01 keeps sliding at
    the speed its excess buys against the damping (measured 2e-5 m at mu 0.15, 7e-5 m at 0.3)."""
    went = {}
    for ratio in (0.99, 1.01):
        sim, heavy, held = on_a_drum(mu, ratio, 300.0)
        sim.run(until=0.3)
        z = sim.node_position(heavy)[2]
        sim.run(until=0.4)
        went[ratio] = z - sim.node_position(heavy)[2]
        state = cosnet.slider_state(sim, held.sheaves[0].node)
        assert abs(state["wrap"] - math.pi) < 0.1      # all the rim's vertices pressed on it
    assert abs(went[0.99]) < 1e-7
    assert went[1.01] > 1e-5


def test_energy_and_what_friction_took_is_conserved_at_order_two_while_a_rope_slips():
    """A rope slipping over a drum (1.5 times the capstan ratio, mu 0.3): energy + what the
    friction, the landings and the damping took is conserved at the scheme's order. Stick and
    slip ring the rope's finest shear-and-turn waves (an element turning against its chord); the
    elements' spin is damped hard (1e5/s) so that the rim's vertices stay pressed, as the slow
    motion of so slender a rope barely turns them."""
    errors = []
    for factor in (1.0, 0.5):
        sim, heavy, held = on_a_drum(0.3, 1.5, 30.0, rotational=1e5, dt_factor=factor)
        e0, worst = sim.energy(), 0.0
        while sim.time < 0.1:
            sim.run(steps=int(2000 / factor))
            worst = max(worst, abs(sim.energy() + sim.dissipated() - e0))
        errors.append(worst)
        assert held.dissipated(sim) > 0.3     # friction took most of the fall (measured 0.51 J)
        assert cosnet.slider_state(sim, held.sheaves[0].node)["sliding"]
    assert errors[0] / errors[1] > 3.5        # measured 4.0 (order 2: 4)
    assert errors[0] < 1e-3 * held.dissipated(sim)   # measured 3e-4 of it


def test_modes_refuse_a_net_with_a_sheave_in_one_line():
    net, _ = over_a_sheave(radius=R, drop=0.1, masses=(M1, M2))
    with pytest.raises(ValueError) as err:
        cosnet.modes(net)
    assert "a net with sheaves has no linear modes" in str(err.value) and "\n" not in str(err.value)


def over_wheel(a, b, centre, radius, step):
    """The path (points, x-z plane) of a cable from a to b passing under a wheel of ``radius``
    about ``centre`` (the wheel above it): straight to its tangent point, round the wheel's
    underside, straight on; and its length."""
    def tangent(p, left):
        d = p - centre
        dist = np.hypot(d[0], d[2])
        phi, spread = math.atan2(d[2], d[0]), math.acos(radius / dist)
        # the tangent point on the wheel's side facing the support, the wheel above the cable
        angle = phi + spread if left else phi - spread
        return angle, centre + radius * np.array([math.cos(angle), 0.0, math.sin(angle)])
    t1, p1 = tangent(a, left=True)
    t2, p2 = tangent(b, left=False)
    t1 = t1 - 2 * math.pi if t1 > t2 else t1        # round the underside, counter-clockwise
    def run(p, q):
        n = max(1, int(round(np.linalg.norm(q - p) / step)))
        return [p + (q - p) * i / n for i in range(n)]
    n_arc = max(2, int(round((t2 - t1) * radius / step)))
    arc = [centre + radius * np.array([math.cos(t), 0.0, math.sin(t)]) for t in np.linspace(t1, t2, n_arc + 1)]
    points = np.array(run(a, p1) + arc[:-1] + run(p2, b) + [b])
    length = np.linalg.norm(p1 - a) + radius * (t2 - t1) + np.linalg.norm(b - p2)
    return points, length


def wheel_path_length(a, b, centre, radius):
    return over_wheel(a, b, centre, radius, step=1.0)[1]


def test_a_trolley_on_a_slack_cable_keeps_to_its_static_path():
    """A trolley (a 5 kg node on a sheave of 5 cm) on a light, slack rope between two
    pins 0.5 m apart, released beside the middle: it swings along the curve where the rope's
    length over the wheel (two straight runs and the wrap) is the rope's length as stretched,
    the static equilibrium's path at each position (the ellipse of a ring on a rope, offset by
    the wheel); energy + what the landings took is conserved."""
    a, b, length, radius, mass = np.array([0.0, 0.0, 0.0]), np.array([0.5, 0.0, 0.0]), 0.6, 0.05, 5.0
    x0 = 0.1
    lo, hi = -length, -radius   # the centre's height where the rope over the wheel is as long as the rope
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if wheel_path_length(a, b, np.array([x0, 0.0, mid]), radius) > length:
            lo = mid
        else:
            hi = mid
    centre = np.array([x0, 0.0, 0.5 * (lo + hi)])
    points, _ = over_wheel(a, b, centre, radius, step=radius / 10)
    net = cosnet.Net()
    pa, pb = net.add_node(a, fixed=True), net.add_node(b, fixed=True)
    rope = cosnet.Material(E=2e10, G=8e9, density=7850.0)      # a tenth of steel's stiffness
    line = net.add_line(pa, pb, material=rope, section=laid_rope(0.001), elements=len(points) - 1, points=points,
                        rest_curvature=(0.0, 0.0, 0.0))
    trolley = net.add_node(centre, mass=mass, inertia=[math.inf] * 3)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    below = int(np.argmin(np.linalg.norm(points - (centre - [0.0, 0.0, radius]), axis=1)))
    net.add_eyelet(line, s=float(arc[below]), at=trolley, radius=radius)
    sim = cosnet.Simulation(net, [cosnet.Gravity()])
    e0, worst, drift, xs = sim.energy(), 0.0, 0.0, []
    while sim.time < 0.45:
        sim.run(until=sim.time + 0.01)
        c = sim.node_position(trolley)
        xs.append(c[0])
        x = sim.line_positions(line)
        now = np.linalg.norm(np.diff(x, axis=0), axis=1).sum()      # the rope's length, stretched
        worst = max(worst, abs(wheel_path_length(a, b, c, radius) / now - 1.0))
        drift = max(drift, abs(sim.energy() + sim.dissipated() - e0))
    fall = mass * G * (centre[2] - min(sim.node_position(trolley)[2], centre[2]))
    assert max(xs) > 0.25 > x0          # it swung past the middle
    assert worst < 2e-4                 # measured 5e-5 (the rope's stretch is 7e-4)
    assert drift < 1e-6 * fall          # measured 3e-8


SPOIL = """
import sys
import numpy as np
import cosnet
from cosnet.effects.sheaves import Sheaves, over_a_sheave
net, _ = over_a_sheave(radius=0.05, drop=0.2, masses=(0.3, 0.2))
sim = cosnet.Simulation(net, [cosnet.Gravity()])
sim.run(steps=50)
p = next(e for e in sim.effects if isinstance(e, Sheaves)).params(sim)
on = np.flatnonzero(p.engaged)
sim.state.x[on[len(on) // 2]] = float(sys.argv[1])       # a vertex on the rim
sim.state.x[p.lo[0]] = float(sys.argv[1])                 # the window's end
for _ in range(3):
    try:
        sim.run(steps=1)
        print("ran")
    except cosnet.InstabilityError as e:
        print(str(e).splitlines()[0][:40])
"""


@pytest.mark.parametrize("value", ["nan", "inf", "1e300"])
def test_a_spoilt_vertex_on_the_rim_ends_in_a_clear_error_not_a_crash(value):
    """A NaN, infinite or huge coordinate on the rim and at the window's end: the sheave's
    kernels keep to the line's vertices (the window clamped to them, no landing or release on
    a coordinate that is not a number), and the watch stops the run in one line."""
    r = subprocess.run([sys.executable, "-c", SPOIL, value], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.splitlines()[0].startswith("unstable at t = "), r.stdout
