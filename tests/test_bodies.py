"""Bodies that collide (cosnet.Body): a ball bouncing on a plane conserves energy to second
order and loses the dashpot's analytic restitution, a sliding ball rolls off at 5/7 of its
speed after decelerating at mu_k g, momentum is exchanged exactly with a line and between
balls, a line sticking on a driven plate is carried along (its driver carrying its weight),
and bad input is refused in one line."""

import math
import re

import numpy as np
import pytest

import cosnet
from cosnet.scene.loader import build_scene, load_scene
from test_cases import CASES, free_weight, support_force

G = 9.81
MASS, RADIUS = 1.0, 0.1
INERTIA = 0.4 * MASS * RADIUS ** 2      # a solid sphere
ROPE = cosnet.Material(E=1e8, G=4e7, density=1000.0, name="rope")


def ball_on_floor(g=G, k=1e5, gamma=0.0, mu=None, height=0.3, **kw):
    """A solid ball (mass 1 kg, radius 0.1 m) whose centre is `height` above the floor z = 0."""
    net = cosnet.Net()
    ball = net.add_node((0.0, 0.0, height), mass=MASS, inertia=(INERTIA,) * 3, name="ball")
    floor = cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=1.0, name="floor")
    body = cosnet.Body(ball, "sphere", radius=RADIUS, k=k, gamma=gamma, mu_s=mu, mu_k=mu, obstacles=["floor"])
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, -g)), floor, body], **kw)
    return sim, ball, body


def test_a_dropped_ball_bounces_with_energy_conserved_to_second_order():
    errors = []
    for dt in (2e-4, 1e-4):
        sim, ball, body = ball_on_floor(dt=dt)
        e0 = sim.energy()
        worst, top = 0.0, 0.0
        for _ in range(60):          # a drop of 0.2 m, the bounce and the flight back up
            sim.run(until=sim.time + 0.01)
            worst = max(worst, abs(sim.energy() - e0))
            top = max(top, sim.node_position(ball)[2]) if sim.time > 0.3 else top
        assert body.deepest(sim) > 0.05        # it did touch, about v sqrt(m / k) / r deep
        assert top == pytest.approx(0.3, abs=2e-3)
        errors.append(worst / abs(e0))
    assert errors[0] < 2e-3
    assert 3.0 < errors[0] / errors[1] < 5.0


def test_restitution_is_the_dashpots_analytic_value():
    """Without gravity a ball hits the floor at v0: a linear spring-dashpot whose force is
    cut at zero (no pull) lets go when k x + gamma x' = 0, at w_d t* = pi - atan(2 z sqrt(1 -
    z^2) / (1 - 2 z^2)), and e = exp(-z w t*) |cos w_d t* - z / sqrt(1 - z^2) sin w_d t*|."""
    k, v0 = 1e5, 1.0
    for zeta in (0.05, 0.2):
        gamma = 2.0 * zeta * math.sqrt(k * MASS)
        sim, ball, body = ball_on_floor(g=0.0, k=k, gamma=gamma, height=RADIUS + 0.01, dt=2e-5)
        sim.node_velocity(ball)[:] = (0.0, 0.0, -v0)
        sim.run(until=0.04)
        s = math.sqrt(1.0 - zeta ** 2)
        wt = math.pi - math.atan2(2.0 * zeta * s, 1.0 - 2.0 * zeta ** 2)
        e = math.exp(-zeta * wt / s) * abs(math.cos(wt) - zeta / s * math.sin(wt))
        assert sim.node_velocity(ball)[2] / v0 == pytest.approx(e, rel=0.01)
        assert body.active_contacts(sim) == 0


def test_a_sliding_ball_decelerates_at_mu_k_g_then_rolls_at_five_sevenths():
    mu, v0 = 0.3, 2.0
    sim, ball, body = ball_on_floor(k=1e5, gamma=2.0 * math.sqrt(1e5 * MASS), mu=mu,
                                    height=RADIUS - MASS * G / 1e5, dt=2e-4)
    sim.node_velocity(ball)[:] = (v0, 0.0, 0.0)
    t_roll = 2.0 * v0 / (7.0 * mu * G)          # sliding ends when v = r w
    sim.run(until=0.5 * t_roll)
    v = sim.node_velocity(ball)[0]
    assert (v0 - v) / sim.time == pytest.approx(mu * G, rel=0.01)
    assert body.sliding(sim) == 1
    sim.run(until=1.5 * t_roll)
    v = sim.node_velocity(ball)[0]
    spin = sim.node_angular_velocity(ball)[1]        # the principal frame is the lab's here
    assert v == pytest.approx(5.0 / 7.0 * v0, rel=0.01)
    assert spin * RADIUS == pytest.approx(v, rel=0.01)
    assert body.sliding(sim) == 0


def far_floor():
    """A plane nothing reaches (the simulations here declare the same kinds of effect, so
    the step compiles once for them)."""
    return cosnet.Obstacle("plane", point=(0, 0, -10), normal=(0, 0, 1), k=1.0, lines=[], name="floor")


def test_friction_dissipates_what_rolling_leaves_and_energy_balances_to_first_order():
    """Sliding into rolling loses m v0^2 / 7 (a solid sphere keeps (m + I / r^2) (5 v0 / 7)^2 / 2);
    energy plus dissipation is conserved to the first order of the step (the spring's
    displacement is carried by the velocities of the drift before each kick)."""
    v0, misses = 2.0, []
    for dt in (2e-4, 1e-4):
        sim, ball, body = ball_on_floor(k=1e5, mu=0.3, height=RADIUS - MASS * G / 1e5, dt=dt)
        sim.node_velocity(ball)[:] = (v0, 0.0, 0.0)
        e0, worst = sim.energy(), 0.0
        for i in range(30):
            sim.run(until=(i + 1) * 0.01)
            worst = max(worst, abs(sim.energy() + body.dissipated(sim) - e0))
        assert body.sliding(sim) == 0
        assert body.dissipated(sim) == pytest.approx(MASS * v0 ** 2 / 7.0, rel=3e-3)
        misses.append(worst / body.dissipated(sim))
    assert misses[0] < 2e-3 and 1.7 < misses[0] / misses[1] < 2.3


def test_a_checkpoint_carries_the_contacts(tmp_path):
    """Resumed from a checkpoint taken while the ball slides, a run ends bit-identical to the
    uninterrupted one (spring displacements, modes, the last evaluation's time and the
    dissipation travel with the state)."""
    from cosnet.engine import checkpoint

    def start():
        sim, ball, body = ball_on_floor(k=1e5, gamma=100.0, mu=0.3, height=RADIUS - MASS * G / 1e5, dt=2e-4)
        sim.node_velocity(ball)[:] = (2.0, 0.0, 0.0)
        return sim, ball, body
    whole, ball, body = start()
    whole.run(until=0.1)
    checkpoint.save(whole, tmp_path / "c.npz")
    whole.run(until=0.3)
    resumed, _, again = start()
    checkpoint.load(resumed, tmp_path / "c.npz")
    resumed.run(until=0.3)
    np.testing.assert_array_equal(resumed.state.node_x, whole.state.node_x)
    np.testing.assert_array_equal(resumed.state.node_w, whole.state.node_w)
    np.testing.assert_array_equal(again.params(resumed).delta, body.params(whole).delta)
    assert again.dissipated(resumed) == body.dissipated(whole) > 0


def resting(shape, frame, height, **geometry):
    """A 1 kg body of the given shape set down on the floor (its centre of mass at height,
    touching) under gravity, its contact dashpot near critical; (sim, node, body) after 0.3 s."""
    net = cosnet.Net()
    node = net.add_node((0.0, 0.0, height), frame=frame, mass=MASS, inertia=(0.01, 0.02, 0.03), name="block")
    floor = cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=1.0, name="floor")
    body = cosnet.Body(node, shape, k=1e5, gamma=300.0, obstacles=["floor"], **geometry)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, -G)), floor, body], dt=1e-4)
    sim.run(until=0.3)
    return sim, node, body


def test_a_box_and_a_capsule_rest_on_their_corners_and_ends():
    """A box turned by its node's frame (its 5 cm half side vertical) and set off the node's
    reference point rests on its four lower corners, tilted; a capsule on its two end spheres.

    The box's corners stand at x_i = 0.02 -/+ 0.1 from the centre of mass (the node). Tilted by
    phi about y, corner i is pressed delta_i = delta0 + phi x_i into the floor (delta0 the node's
    sink); its spring pushes k delta_i. Force balance sum k delta_i = W and moment balance
    sum k delta_i x_i = 0 give phi = -delta0 S1 / S2 and delta0 = W / (k (4 - S1^2 / S2)) with
    S1 = sum x_i, S2 = sum x_i^2: the nearer corners carry more, the box leans towards them.
    Left out: second order in phi (phi ~ 5e-5: 1e-9 relative) and the dashpot's transient
    (near-critical, 0.3 s = 30 periods of the 100 Hz bounce)."""
    turn = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])   # node y -> lab z
    sim, node, body = resting("box", turn, 0.05, half_size=(0.1, 0.05, 0.02), center=(0.02, 0.0, 0.0))
    assert body.active_contacts(sim) == 4
    x = np.array([-0.08, -0.08, 0.12, 0.12])
    s1, s2, k, w = x.sum(), (x ** 2).sum(), 1e5, MASS * G
    delta0 = w / (k * (4 - s1 ** 2 / s2))
    phi = -delta0 * s1 / s2
    assert 0.05 - sim.node_position(node)[2] == pytest.approx(delta0, rel=1e-4)
    tilt = sim.node_rotation(node) @ turn.T          # the turn since the box was set down
    assert tilt[0, 2] == pytest.approx(phi, rel=1e-3)
    np.testing.assert_allclose(tilt[[1, 1, 0, 2], [0, 2, 1, 1]], 0.0, atol=1e-3 * abs(phi))
    sim, node, body = resting("capsule", np.eye(3), 0.03, start=(-0.1, 0.0, 0.0), end=(0.1, 0.0, 0.0), radius=0.03)
    assert body.active_contacts(sim) == 2
    assert sim.node_position(node)[2] == pytest.approx(0.03 - MASS * G / (2 * 1e5), abs=1e-7)


def rope_and_ball(v, obstacles=()):
    """A free rope (no gravity) of 1 m along x and a ball 0.2 m above its middle moving at v."""
    net = cosnet.Net()
    a, b = net.add_node((-0.5, 0.0, 0.0), name="a"), net.add_node((0.5, 0.0, 0.0), name="b")
    rope = net.add_line(a, b, material=ROPE, section=cosnet.Circle(0.005), elements=20, name="rope")
    ball = net.add_node((0.05, 0.0, 0.2), mass=0.2, inertia=(1e-3,) * 3, name="ball")
    body = cosnet.Body(ball, "sphere", radius=0.05, k=1e4, mu_s=0.5, mu_k=0.4, obstacles=obstacles)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, 0.0)), far_floor(), body])
    sim.node_velocity(ball)[:] = v
    return sim, ball, rope, body


def test_momentum_is_exchanged_exactly_between_a_line_and_a_body():
    v = np.array([0.5, 0.0, -3.0])
    sim, ball, rope, body = rope_and_ball(v)
    p0, l0 = sim.momentum(), sim.angular_momentum()
    touched = 0
    for _ in range(40):
        sim.run(until=sim.time + 0.0025)
        touched += body.active_contacts(sim)
        scale = np.linalg.norm(p0)
        np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(sim.angular_momentum(), l0, rtol=0, atol=1e-12 * scale)
    assert touched > 0 and body.deepest(sim) < 0.5


STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0)


def test_a_ball_bounces_off_a_free_stiff_rod_by_the_rigid_bar_law():
    """A light ball (20 g, radius 2 cm) falls at V onto a free steel rod (0.4 m, r = 5 mm, eight elements)
    d = 0.115 m from its middle, 3/10 along an element: the element's contact alone carries the blow
    (at the depth it reaches, 2.7 mm, the ball meets no vertex), so the force is normal to the rod
    and shared (0.7, 0.3) between the element's ends. The contact spring's frequency w_c = sqrt(k /
    mu) (mu the reduced mass) is a fifth of the rod's first free-free bending frequency w_1 =
    4.730^2 sqrt(EI / rho A L^4), so the rod takes the blow as a rigid bar: an elastic impact on a
    point of effective mass m_e = 1 / (1/m + d^2/I) sends the ball back at (m_b - m_e) / (m_b + m_e)
    V and gives the rod the impulse J = 2 mu V at d (its moment J d). What flexibility leaves in the
    rod's vibration is the half-sine pulse's spectrum at w_1, of order (w_c / w_1)^4 of the
    exchange; the rod's turn during contact tilts the normal by a few 1e-3 rad, a change of its
    square. m and I are the discrete rod's own (its vertex masses and the sections' rotary inertia
    about y)."""
    net = cosnet.Net()
    length, r, radius, mb, d, k, v = 0.4, 0.005, 0.02, 0.02, 0.115, 2e3, 1.0
    a, b = net.add_node((-length / 2, 0.0, 0.0), name="a"), net.add_node((length / 2, 0.0, 0.0), name="b")
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(r), elements=8, name="rod")
    ball = net.add_node((d, 0.0, r + radius + 0.002), mass=mb, inertia=(0.4 * mb * radius ** 2,) * 3, name="ball")
    body = cosnet.Body(ball, "sphere", radius=radius, k=k, mu_s=0.5, mu_k=0.4)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, 0.0)), far_floor(), body])
    sim.node_velocity(ball)[:] = (0.0, 0.0, -v)
    m = sim.model
    x = sim.state.x.copy()
    mass = m.vertex_mass.sum()
    inertia = (m.vertex_mass * x[:, 0] ** 2).sum() + m.element_inertia[:, 1].sum()
    me = 1 / (1 / mass + d ** 2 / inertia)
    mu = mb * me / (mb + me)
    ei, rho_a = STEEL.E * math.pi * r ** 4 / 4, STEEL.density * math.pi * r ** 2
    ratio = math.sqrt(k / mu) / (4.730 ** 2 * math.sqrt(ei / (rho_a * length ** 4)))
    assert ratio < 0.2
    depth = v * math.sqrt(mu / k)              # the elastic contact's deepest compression
    gap = np.abs(x[:, 0] - d).min()            # to the nearest vertex
    assert gap > math.sqrt(2 * (radius + r) * depth)
    touched = 0
    while not touched or body.active_contacts(sim):
        sim.run(until=sim.time + 1e-3)
        touched += body.active_contacts(sim)
        assert sim.time < 0.05
    tol = ratio ** 4 * v
    assert sim.node_velocity(ball)[2] == pytest.approx((mb - me) / (mb + me) * -v, abs=tol)
    p = (m.vertex_mass[:, None] * sim.state.v).sum(axis=0)
    assert p[2] == pytest.approx(-2 * mu * v, abs=tol * mu)
    xb, vb = sim.node_position(ball), sim.node_velocity(ball)
    spin = sim.angular_momentum()[1] - mb * (xb[2] * vb[0] - xb[0] * vb[2])     # the rod's, about the origin
    spin -= 0.4 * mb * radius ** 2 * sim.node_angular_velocity(ball)[1]
    assert spin == pytest.approx(2 * mu * v * d, abs=tol * mu * d)


def test_two_balls_exchange_their_velocities_head_on():
    """Equal balls, a linear contact spring: the exchange is exact but for the step's error,
    below a tenth of (w dt)^2 with w = sqrt(2 k / m) (the onset of contact between two steps
    makes it jump about with dt rather than fall smoothly)."""
    for dt in (4e-4, 1e-4):
        net = cosnet.Net()
        one = net.add_node((0.0, 0.0, 0.0), mass=MASS, inertia=(INERTIA,) * 3, name="one")
        two = net.add_node((0.3, 0.0, 0.0), mass=MASS, inertia=(INERTIA,) * 3, name="two")
        b1 = cosnet.Body(one, "sphere", radius=RADIUS, k=1e5, bodies=["two"])
        b2 = cosnet.Body(two, "sphere", radius=RADIUS, k=1e5)
        sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, 0.0)), far_floor(), b1, b2], dt=dt)
        sim.node_velocity(one)[:] = (1.0, 0.0, 0.0)
        p0 = sim.momentum()
        sim.run(until=0.2)
        np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=1e-14)
        bound = 0.1 * (math.sqrt(2e5 / MASS) * dt) ** 2
        np.testing.assert_allclose(sim.node_velocity(one), 0.0, rtol=0, atol=bound)
        np.testing.assert_allclose(sim.node_velocity(two), (1.0, 0.0, 0.0), rtol=0, atol=bound)
        np.testing.assert_allclose(sim.node_angular_velocity(one), 0.0, rtol=0, atol=1e-14)


def plate_and_rope(mu_s, mu_k, shift=0.1, duration=0.5):
    """A 1 kg plate (a driven box, top face at z = 0, its rotation held) moved by `shift`
    along x in `duration` after 0.05 s at rest (a clamped spline: it starts and stops
    smoothly, at most about 2 m/s^2), and a short stiff rope lying on it under gravity."""
    net = cosnet.Net()
    plate = net.add_node((0.0, 0.0, -0.01), mass=1.0, inertia=(1e-2,) * 3, name="plate")
    r = 0.005
    a, b = net.add_node((-0.05, 0.0, r), name="a"), net.add_node((0.05, 0.0, r), name="b")
    stiff = cosnet.Material(E=1e9, G=4e8, density=1000.0)
    rope = net.add_line(a, b, material=stiff, section=cosnet.Circle(r), elements=4, name="rope")
    k = 1e4
    body = cosnet.Body(plate, "box", half_size=(0.2, 0.2, 0.01), k=k, gamma=2.0 * math.sqrt(k * 1e-3),
                       mu_s=mu_s, mu_k=mu_k)
    drive = cosnet.Drive(plate, position=dict(times=[0.0, 0.05, 0.05 + duration],
                                              values=[[0, 0, 0], [0, 0, 0], [shift, 0, 0]]),
                         rotation=dict(rate=0.0), axis=(0.0, 0.0, 1.0))
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(), body, drive])
    return sim, plate, rope, body


def test_a_line_sticking_on_a_moving_plate_is_carried_along():
    sim, plate, rope, body = plate_and_rope(mu_s=0.8, mu_k=0.6)
    x0 = sim.line_positions(rope)[:, 0].copy()
    sim.run(until=0.7)
    moved = sim.line_positions(rope)[:, 0] - x0
    # carried to within the stick's give: mu_s N / k_t = 0.8 x 0.8 mN / 1e4 N/m per vertex
    np.testing.assert_allclose(moved, 0.1, rtol=0, atol=1e-6)
    assert body.sliding(sim) == 0 and body.active_contacts(sim) == 5
    # at rest again, the driver carries the plate and the rope
    force, _ = sim.reaction(plate)
    assert force[2] == pytest.approx(sim.net.total_mass() * G, rel=1e-6)


def test_a_line_on_a_slippery_plate_stays_behind():
    sim, plate, rope, body = plate_and_rope(mu_s=0.0, mu_k=0.0)
    x0 = sim.line_positions(rope)[:, 0].copy()
    sim.run(until=0.7)
    x = sim.line_positions(rope)[:, 0]
    # nothing pulls it along: its centre stays, its ends come in by the sag only
    assert abs(x.mean() - x0.mean()) < 1e-15
    np.testing.assert_allclose(x, x0, rtol=0, atol=1e-9)


def test_net_catch_case_catches_the_ball_and_holds_it():
    """cases/net_catch.toml: the ball comes to rest in the web, above the plane of the pins
    less its radius (it has not gone through), and the pins carry the ball and the ropes."""
    scene = load_scene(CASES / "net_catch.toml")
    sim = scene.simulation()
    ball = scene.net.node("ball")
    body = next(e for e in scene.effects if isinstance(e, cosnet.Body))
    sim.run(until=scene.run.until)
    x, v = sim.node_position(ball), sim.node_velocity(ball)
    assert np.linalg.norm(v) < 0.01
    assert np.all(np.abs(x[:2]) < 0.24) and -0.07 < x[2] < 0.07       # in the web, held in it
    assert body.active_contacts(sim) >= 3 and body.deepest(sim) < 0.5
    assert -support_force(sim)[2] == pytest.approx(free_weight(sim), rel=0.01)


def test_the_stable_step_counts_the_body_its_spin_and_its_target():
    """omega^2 = max(k, k_t) (1/m + a^2 / I) for a ball of radius a on a static floor (a force
    at its surface turns it as well as pushing it), and a second ball's share on top."""
    from cosnet.kernels.stepping import stability_interval
    sim, ball, body = ball_on_floor(k=1e5, mu=0.5, dt=1e-4)
    w2 = 1e5 * (1.0 / MASS + RADIUS ** 2 / INERTIA)
    assert sim.stable_dt() == pytest.approx(sim.safety * stability_interval("verlet") / math.sqrt(w2), rel=1e-12)
    assert sim.stiffest().startswith("Body('ball', sphere")
    net = cosnet.Net()
    one = net.add_node((0.0, 0.0, 0.0), mass=MASS, inertia=(INERTIA,) * 3, name="one")
    two = net.add_node((0.3, 0.0, 0.0), mass=2 * MASS, inertia=(2 * INERTIA,) * 3, name="two")
    b1 = cosnet.Body(one, "sphere", radius=RADIUS, k=1e5, bodies=["two"])
    b2 = cosnet.Body(two, "sphere", radius=RADIUS, k=1e5)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, 0.0)), far_floor(), b1, b2])
    assert b1.max_omega2(sim) == pytest.approx(1e5 * 3.5 * (1.0 / MASS + 0.5 / MASS), rel=1e-12)


def test_bad_input_is_refused_in_one_line():
    net = cosnet.Net()
    ball = net.add_node((0.0, 0.0, 0.3), mass=1.0, inertia=(1e-3,) * 3, name="ball")
    with pytest.raises(ValueError, match=r"shape must be one of \['sphere', 'capsule', 'box'\]"):
        cosnet.Body(ball, "plane", k=1.0)
    with pytest.raises(ValueError, match=r"^Body on Node\('ball'\) \(sphere\): needs radius$"):
        cosnet.Body(ball, "sphere", k=1.0)
    with pytest.raises(ValueError, match=r"^Body on Node\('ball'\) \(box\): does not take radius$"):
        cosnet.Body(ball, "box", half_size=(1, 1, 1), radius=0.1, k=1.0)
    with pytest.raises(ValueError, match=r"mu_k must not exceed the static"):
        cosnet.Body(ball, "sphere", radius=0.1, k=1.0, mu_s=0.2, mu_k=0.3)
    with pytest.raises(ValueError, match=r"isotropic"):
        cosnet.Body(ball, "sphere", radius=0.1, k=1.0, mu_s=[0.2, 0.3, 0.3])
    floor = cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=1.0, name="floor")
    with pytest.raises(ValueError, match=r"no obstacle named 'ground'.*\['floor'\]"):
        cosnet.Simulation(net, [floor, cosnet.Body(ball, "sphere", radius=0.1, k=1.0, obstacles=["ground"])])
    lump = cosnet.Obstacle("mesh", points=[[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
                           triangles=[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], k=1.0, name="lump")
    with pytest.raises(ValueError, match=r"obstacle 'lump' is a mesh; a body meets a plane, sphere"):
        cosnet.Simulation(net, [lump, cosnet.Body(ball, "sphere", radius=0.1, k=1.0, obstacles=["lump"])])
    with pytest.raises(ValueError, match=r"does not meet itself"):
        cosnet.Simulation(net, [cosnet.Body(ball, "sphere", radius=0.1, k=1.0, bodies=["ball"])])
    with pytest.raises(ValueError, match=r"no body on a node named 'other'"):
        cosnet.Simulation(net, [cosnet.Body(ball, "sphere", radius=0.1, k=1.0, bodies=["other"])])
    scene = {"nodes": {"ball": {"position": [0, 0, 0.3], "mass": 1.0, "inertia": [1e-3, 1e-3, 1e-3]}},
             "effects": [{"kind": "body", "node": "ball", "shape": "sphere", "radius": 0.1, "k": 1e4,
                          "obstacles": "floor"}]}
    for spoil, where in ((lambda e: None, "[[effects]] #1 (body) obstacles"),
                         (lambda e: e.update(obstacles=[], nodes="ball"), "nodes"),
                         (lambda e: e.update(nodes=None, shape="cube"), "shape"),
                         (lambda e: e.update(shape="sphere", radius=-1.0), "radius")):
        spoil(scene["effects"][0])
        scene["effects"][0] = {k: v for k, v in scene["effects"][0].items() if v is not None}
        with pytest.raises(ValueError) as e:
            build_scene(scene)
        assert "\n" not in str(e.value) and where in str(e.value), str(e.value)


@pytest.mark.parametrize("spoil, message", [
    (lambda p: p.verts.__setitem__(0, 10 ** 6), "body.verts holds 1000000, outside [0, "),
    (lambda p: p.tnode.__setitem__(0, 7), "body.tnode holds 7, outside [-1, 3)"),
])
def test_spoilt_body_tables_are_refused_before_a_run(spoil, message):
    sim, ball, rope, body = rope_and_ball(np.zeros(3), obstacles=["floor"])
    spoil(body.params(sim))
    with pytest.raises(ValueError, match=r"^Simulation.run: " + re.escape(message)):
        sim.run(steps=1)
