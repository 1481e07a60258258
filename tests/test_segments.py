"""Line elements against obstacles, and the dashpots' work: a stiff line whose elements are
much longer than the obstacles rests on two thin rods, two small spheres, two box edges or
two mesh edges without passing through, the contacts carrying exactly its weight; a line
thrown onto a thin rod bounces with energy conserved at second order; with dashpots, energy
plus dissipated is conserved at second order too; the element springs travel in checkpoints."""

import math

import meshio
import numpy as np
import pytest

import cosnet
from cosnet.kernels.segments import segment_triangle

STIFF = cosnet.Material(E=1e9, G=4e8, density=1000.0, name="stiff")
G = 9.81
R = 0.005             # section radius
LENGTH = 0.3          # three elements of 0.1 m, the supports under the middle of the outer two
SUPPORTS = (-0.1, 0.1)


def line(effects, height=R, elements=3, **kw):
    net = cosnet.Net()
    a, b = net.add_node((-LENGTH / 2, 0.0, height)), net.add_node((LENGTH / 2, 0.0, height))
    rope = net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=elements, name="rope")
    return cosnet.Simulation(net, effects=effects, **kw), rope, (a, b)


def cube_mesh(path, centre, half):
    """A cube turned 45 degrees about y (an edge along y on top at centre + (0, 0, half sqrt 2))."""
    pts = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], dtype=float) * half
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    pts = pts @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) + np.array(centre)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = np.array([t for a, b, c_, d in quads for t in ((a, b, c_), (a, c_, d))])
    meshio.write(path, meshio.Mesh(pts, [("triangle", tris)]))
    return path


def supports(shape, tmp_path, k=1e4, gamma=0.0, **kw):
    """Two obstacles of the shape, tops at z = 0 under x = -0.1 and 0.1, each much smaller
    than an element (0.1 m)."""
    out = []
    for x in SUPPORTS:
        if shape == "capsule":
            ob = cosnet.Obstacle("capsule", start=(x, -0.05, -0.002), end=(x, 0.05, -0.002), radius=0.002, k=k,
                                 gamma=gamma, **kw)
        elif shape == "sphere":
            ob = cosnet.Obstacle("sphere", center=(x, 0.0, -0.003), radius=0.003, k=k, gamma=gamma, **kw)
        elif shape == "box":   # turned 45 degrees about y: an edge along y on top
            c = math.cos(math.pi / 4)
            ob = cosnet.Obstacle("box", center=(x, 0.0, -0.01 * math.sqrt(2)), half_size=(0.01, 0.05, 0.01),
                                 axes=[[c, 0, c], [0, 1, 0], [-c, 0, c]], k=k, gamma=gamma, **kw)
        else:
            f = cube_mesh(str(tmp_path / f"cube{x}.stl"), (x, 0.0, -0.01 * math.sqrt(2)), 0.01)
            ob = cosnet.Obstacle("mesh", file=f, k=k, gamma=gamma, **kw)
        out.append(ob)
    return out


def contact_force(sim, obstacles, nodes, h=1e-9):
    """The obstacles' total vertical force on the line: minus the slope of their potential
    as the whole line is lifted (each vertex and its end nodes by the same dz)."""
    ends = [nd.index for nd in nodes]

    def potential(dz):
        sim.state.x[:, 2] += dz
        sim.state.node_x[ends, 2] += dz
        e = sum(ob.potential_energy(sim) for ob in obstacles)
        sim.state.x[:, 2] -= dz
        sim.state.node_x[ends, 2] -= dz
        return e
    return -(potential(h) - potential(-h)) / (2 * h)


@pytest.mark.parametrize("shape", ["capsule", "sphere", "box", "mesh"])
def test_a_line_rests_on_features_smaller_than_its_elements(shape, tmp_path):
    obstacles = supports(shape, tmp_path)
    sim, rope, nodes = line([cosnet.Gravity((0.0, 0.0, -G)), cosnet.Damping(60.0), *obstacles], height=R + 1e-3)
    sim.run(until=0.4)
    x = sim.line_positions(rope)
    weight = STIFF.density * math.pi * R * R * LENGTH * G
    # without the elements the line would have fallen between its vertices, none of which
    # is within 0.05 m of a support
    assert np.min(np.abs(x[:, 0][:, None] - np.array(SUPPORTS)[None])) > 0.04
    assert np.all(x[:, 2] > R * 0.9)
    # the deepest overlap met, a fraction of R: at least the resting one, weight / 2k (each
    # support holds half), and at most the landing's without damping: dropped from h0 = 1 mm
    # onto the two springs, 1/2 (2k) d^2 = W (h0 + d)
    k, h0 = 1e4, 1e-3
    rest = weight / (2 * k)
    landing = 0.5 * (weight / k + math.sqrt((weight / k) ** 2 + 4 * weight * h0 / k))
    deepest = max(ob.deepest(sim) for ob in obstacles)
    assert rest < deepest * R < landing, (rest, deepest * R, landing)
    assert np.max(np.abs(sim.line_velocities(rope))) < 1e-4   # at rest
    assert contact_force(sim, obstacles, nodes) == pytest.approx(weight, rel=0.01)


def body_supports(net, shape):
    """Two fixed nodes under x = -0.1 and 0.1 carrying small shapes with tops at z = 0."""
    out = []
    for x in SUPPORTS:
        nd = net.add_node((x, 0.0, -0.003), fixed=True)
        if shape == "sphere":
            out.append(cosnet.Body(nd, "sphere", radius=0.003, k=1e4))
        elif shape == "capsule":
            out.append(cosnet.Body(nd, "capsule", start=(0, -0.05, 0), end=(0, 0.05, 0), radius=0.003, k=1e4))
        else:   # turned 45 degrees about y: an edge along y on top
            c = math.cos(math.pi / 4)
            out.append(cosnet.Body(nd, "box", center=(0, 0, 0.003 - 0.002 * math.sqrt(2)),
                                   half_size=(0.002, 0.05, 0.002), axes=[[c, 0, c], [0, 1, 0], [-c, 0, c]], k=1e4))
    return out


@pytest.mark.parametrize("shape", ["sphere", "capsule", "box"])
def test_a_line_rests_on_body_shapes_smaller_than_its_elements(shape):
    net = cosnet.Net()
    a, b = net.add_node((-LENGTH / 2, 0.0, R + 1e-3)), net.add_node((LENGTH / 2, 0.0, R + 1e-3))
    rope = net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=3, name="rope")
    bodies = body_supports(net, shape)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0.0, 0.0, -G)), cosnet.Damping(60.0), *bodies])
    sim.run(until=0.4)
    x = sim.line_positions(rope)
    assert np.all(x[:, 2] > R * 0.9)
    over = R - np.interp(SUPPORTS, x[:, 0], x[:, 2])   # the overlap over each support's top
    weight = STIFF.density * math.pi * R * R * LENGTH * G
    # each support holds half the weight on its spring k = 1e4: the overlap over it is W / 2k
    # (measured 1e-4 from it: the points over the supports are elements' midpoints, where the
    # line's own sag between its vertices is not seen)
    np.testing.assert_allclose(over, weight / (2 * 1e4), rtol=1e-3)
    assert np.max(np.abs(sim.line_velocities(rope))) < 1e-4
    assert contact_force(sim, bodies, (a, b)) == pytest.approx(weight, rel=0.01)


def test_a_line_thrown_across_a_free_ball_exchanges_momentum_exactly():
    """A ball (a rigid body) hit by an element's interior takes exactly the momentum the line
    loses, and energy plus the dashpot's dissipation is conserved at second order."""
    def run(dt):
        net = cosnet.Net()
        a, b = net.add_node((-LENGTH / 2, 0.0, 0.02)), net.add_node((LENGTH / 2, 0.0, 0.02))
        rope = net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=3, name="rope")
        ball = net.add_node((0.02, 0.0, 0.0), mass=0.01, inertia=(1e-7,) * 3)
        body = cosnet.Body(ball, "sphere", radius=0.004, k=1e5, gamma=0.5)
        sim = cosnet.Simulation(net, effects=[body], dt=dt)
        sim.line_velocities(rope)[:] = (0.0, 0.0, -2.0)
        for nd in (a, b):
            sim.node_velocity(nd)[:] = (0.0, 0.0, -2.0)

        m = sim.model
        free, fin = m.vertex_inv_mass > 0, np.isfinite(m.node_mass)

        def momentum():   # the free vertices and the nodes (line ends' shares included)
            return m.vertex_mass[free] @ sim.state.v[free] + m.node_mass[fin] @ sim.state.node_v[fin]
        p0, e0, worst = momentum(), sim.energy(), 0.0
        for i in range(40):
            sim.run(until=0.0003 * (i + 1))
            worst = max(worst, abs(sim.energy() + body.dissipated(sim) - e0))
        assert sim.node_velocity(ball)[2] < -0.5 and body.dissipated(sim) > 0   # it was hit
        np.testing.assert_allclose(momentum(), p0, atol=1e-12 * np.abs(p0).max())
        return worst / e0
    err, err_half = run(2e-6), run(1e-6)
    assert err < 1e-3 and 3.5 < err / err_half < 4.5


def throw_on_rod(dt, gamma=0.0, speed=2.0):
    """The line thrown down at speed onto a thin rod under its middle element's interior (no
    gravity); return (largest |energy + dissipated - start| / kinetic, deepest, the rod)."""
    rod = cosnet.Obstacle("capsule", start=(0.03, -0.05, -0.002), end=(0.03, 0.05, -0.002), radius=0.002,
                          k=1e5, gamma=gamma)
    sim, rope, nodes = line([rod], height=R + 0.01, dt=dt)
    sim.line_velocities(rope)[:] = (0.0, 0.0, -speed)
    for nd in nodes:
        sim.node_velocity(nd)[:] = (0.0, 0.0, -speed)
    e0 = sim.energy()
    kinetic = e0
    worst = 0.0
    for i in range(40):
        sim.run(until=0.00025 * (i + 1))
        worst = max(worst, abs(sim.energy() + rod.dissipated(sim) - e0))
    return worst / kinetic, rod.deepest(sim), rod.dissipated(sim) / kinetic, sim


def test_a_line_thrown_onto_a_thin_rod_bounces_with_energy_conserved_to_second_order():
    err, deepest, took, sim = throw_on_rod(2e-6)
    err_half, _, _, _ = throw_on_rod(1e-6)
    assert 0.05 < deepest < 0.6 and took == 0.0
    x = sim.line_positions(sim.net.lines[0])
    assert sim.effects[0].active_contacts(sim) == 0 and np.interp(0.03, x[:, 0], x[:, 2]) > R   # it left the rod
    assert err < 1e-3 and 3.5 < err / err_half < 4.5


def test_the_dashpots_work_is_counted_to_second_order():
    """With gamma > 0 and no friction, energy + dissipated is conserved with Verlet's error."""
    err, deepest, took, _ = throw_on_rod(2e-6, gamma=2.0)
    err_half, _, _, _ = throw_on_rod(1e-6, gamma=2.0)
    assert took > 0.05             # the dashpot took a good share of the kinetic energy
    assert err < 1e-3 and 3.5 < err / err_half < 4.5


def test_segment_triangle_matches_a_fine_scan():
    rng = np.random.default_rng(3)
    for _ in range(30):
        tri = rng.normal(size=(3, 3))
        a, b = rng.normal(size=3), rng.normal(size=3)
        t, qx, qy, qz, d2 = segment_triangle(*a, *b, tri[0], tri[1], tri[2])
        s = np.linspace(0, 1, 2001)[:, None]
        u, w = np.meshgrid(np.linspace(0, 1, 201), np.linspace(0, 1, 201))
        keep = (u + w <= 1).ravel()
        pts = tri[0] + np.outer(u.ravel()[keep], tri[1] - tri[0]) + np.outer(w.ravel()[keep], tri[2] - tri[0])
        seg = a + s * (b - a)
        brute = min(np.min(np.sum((seg[i] - pts) ** 2, axis=1)) for i in range(0, 2001, 10))
        assert d2 <= brute + 1e-12
        p = a + t * (b - a)
        assert np.sum((p - np.array([qx, qy, qz])) ** 2) == pytest.approx(d2, abs=1e-12)
        assert d2 >= brute - 5e-3 * (1 + brute)


def test_a_checkpoint_carries_the_element_springs(tmp_path):
    """Resumed while the line slides and sticks on two thin rods, a run ends bit-identical."""
    from cosnet.engine import checkpoint

    def start():
        obstacles = supports("capsule", tmp_path, k=1e4, gamma=5.0, mu_s=0.4, mu_k=0.3)
        sim, rope, nodes = line([cosnet.Gravity((0.0, 0.0, -G)), *obstacles], height=R - 1e-5)
        sim.line_velocities(rope)[:] = (0.2, 0.0, 0.0)
        for nd in nodes:
            sim.node_velocity(nd)[:] = (0.2, 0.0, 0.0)
        return sim
    whole = start()
    whole.run(until=0.05)
    checkpoint.save(whole, tmp_path / "c.npz")
    whole.run(until=0.1)
    resumed = checkpoint.load(start(), tmp_path / "c.npz")
    resumed.run(until=0.1)
    np.testing.assert_array_equal(resumed.state.x, whole.state.x)
    for a, b in zip(resumed.effects[1:], whole.effects[1:]):
        np.testing.assert_array_equal(a.params(resumed).edata, b.params(whole).edata)
    assert whole.effects[1].params(whole).emode.max() > 0   # the element contacts had springs
    assert sum(e.dissipated(resumed) for e in resumed.effects[1:]) == sum(e.dissipated(whole)
                                                                         for e in whole.effects[1:]) > 0


def test_the_line_line_dashpots_work_is_counted_to_second_order():
    """Two crossing lines, one thrown onto the other, with a damped contact and no friction:
    energy + dissipated is conserved with Verlet's error, the dashpot's share included."""
    def run(dt):
        net = cosnet.Net()
        a, b = net.add_node((-LENGTH / 2, 0.0, 0.0)), net.add_node((LENGTH / 2, 0.0, 0.0))
        c, d = net.add_node((0.03, -LENGTH / 2, 2 * R + 0.005)), net.add_node((0.03, LENGTH / 2, 2 * R + 0.005))
        net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=3, name="low")
        top = net.add_line(c, d, material=STIFF, section=cosnet.Circle(R), elements=3, name="top")
        contact = cosnet.Contact(k=1e5, gamma=2.0)
        sim = cosnet.Simulation(net, effects=[contact], dt=dt)
        sim.line_velocities(top)[:] = (0.0, 0.0, -2.0)
        for nd in (c, d):
            sim.node_velocity(nd)[:] = (0.0, 0.0, -2.0)
        e0, worst = sim.energy(), 0.0
        for i in range(40):
            sim.run(until=0.0002 * (i + 1))
            worst = max(worst, abs(sim.energy() + contact.dissipated(sim) - e0))
        assert contact.dissipated(sim) > 0.02 * e0   # the dashpot took its share
        return worst / e0
    err, err_half = run(2e-6), run(1e-6)
    assert err < 1e-3 and 3.5 < err / err_half < 4.5


def test_elements_meet_only_curved_shapes_smaller_than_them():
    """A sphere or capsule larger than a line's elements meets its vertices alone (an element's
    chord dips at most L^2 / 8R below its ends; a rope wrapped on such a drum holds on its
    vertices at 0.95 of the capstan limit, cosseratbench's capstan); one smaller than them, a
    box and a mesh meet its elements too; a plane never needs them."""
    drum = cosnet.Obstacle("capsule", start=(0.0, -0.1, -0.2), end=(0.0, 0.1, -0.2), radius=0.15, k=1e4)
    rod = cosnet.Obstacle("capsule", start=(0.0, -0.1, -0.2), end=(0.0, 0.1, -0.2), radius=0.05, k=1e4)
    ball = cosnet.Obstacle("sphere", center=(0.0, 0.0, -1.0), radius=0.5, k=1e4)
    box = cosnet.Obstacle("box", center=(0.0, 0.0, -1.0), half_size=(1.0, 1.0, 0.5), k=1e4)
    ground = cosnet.Obstacle("plane", point=(0.0, 0.0, -1.0), normal=(0.0, 0.0, 1.0), k=1e4)
    sim, _, _ = line([drum, rod, ball, box, ground])
    counts = [len(ob.params(sim).elems) for ob in (drum, rod, ball, box, ground)]
    assert counts == [0, 3, 0, 3, 0]
