"""Rod-rod contact: the closest points of two segments, elastic and damped bounces, a coil
that cannot pass through itself, the broad phase doing no work for lines far apart, and
junctions that stay at rest."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.kernels.contact import add_contact, closest_points
from cosnet.kernels.layout import empty_loads
from cosnet.scene.loader import build_scene

STIFF = cosnet.Material(E=1e9, G=4e8, density=1000.0, name="stiff")
SOFT = cosnet.Material(E=1e8, G=4e7, density=1000.0, name="soft")


def brute_distance(p, q, a, b, n=20001):
    """Distance of two segments: a fine scan of s, the exact nearest t for each."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    x = p + s * (q - p)
    d = b - a
    dd = d @ d
    t = np.clip((x - a) @ d / dd, 0.0, 1.0)[:, None] if dd > 0 else np.zeros((n, 1))
    return np.linalg.norm(x - a - t * d, axis=1).min()


def segment_pairs(rng):
    for _ in range(150):  # generic
        yield rng.standard_normal((4, 3))
    for _ in range(40):  # parallel, antiparallel and collinear
        p, u, off = rng.standard_normal(3), rng.standard_normal(3), rng.standard_normal(3)
        off = off * rng.choice([0.0, 1.0])
        a = p + off + rng.uniform(-1.5, 1.5) * u
        yield np.array([p, p + u, a, a + rng.choice([-1.0, 1.0]) * rng.uniform(0.2, 2.0) * u])
    p = np.zeros(3)
    yield np.array([p, p, [1.0, 1.0, 0.0], [1.0, -1.0, 0.0]])  # a point and a segment
    yield np.array([p, [1.0, 0.0, 0.0], [0.5, 0.0, 0.0], [2.0, 0.0, 0.0]])  # collinear overlap


def test_closest_points_match_brute_force():
    rng = np.random.default_rng(1)
    for p, q, a, b in segment_pairs(rng):
        s, t, d = closest_points(p, q, a, b)
        assert 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0
        assert d == pytest.approx(np.linalg.norm(p + s * (q - p) - a - t * (b - a)), abs=1e-12)
        ref = brute_distance(p, q, a, b)
        scale = np.linalg.norm(q - p) + np.linalg.norm(b - a)
        assert d <= ref + 1e-12 and d >= ref - 1e-7 * scale
    # parallel segments side by side: the middle of their overlap
    s, t, d = closest_points(np.zeros(3), np.array([1.0, 0, 0]), np.array([0.5, 1.0, 0]), np.array([3.0, 1.0, 0]))
    assert (s, t, d) == pytest.approx((0.75, 0.1, 1.0))


def crossing_rods(gamma=0.0, k=1e3, v=0.5, gap=0.04, r=0.01, n=4, length=0.2):
    """Two free rods crossing at right angles, approaching each other along y at +-v."""
    net = cosnet.Net()
    a0, a1 = net.add_node((-length / 2, -gap / 2, 0)), net.add_node((length / 2, -gap / 2, 0))
    b0, b1 = net.add_node((0, gap / 2, -length / 2)), net.add_node((0, gap / 2, length / 2))
    la = net.add_line(a0, a1, material=STIFF, section=cosnet.Circle(r), elements=n, name="a")
    lb = net.add_line(b0, b1, material=STIFF, section=cosnet.Circle(r), elements=n, name="b")
    contact = cosnet.Contact(k=k, gamma=gamma)
    sim = cosnet.Simulation(net, effects=[contact])
    for nodes, line, vy in (((a0, a1), la, v), ((b0, b1), lb, -v)):
        for nd in nodes:
            sim.node_velocity(nd)[:] = (0.0, vy, 0.0)
        sim.line_velocities(line)[:] = (0.0, vy, 0.0)
    return sim, contact, la, lb


def centre_velocity(sim, line):
    m, i = sim.model, line.index
    sl = slice(m.line_vertex_offsets[i], m.line_vertex_offsets[i + 1])
    w = m.vertex_mass[sl]
    return w @ sim.state.v[sl] / w.sum()


def bounce(gamma):
    """Return (restitution, energies sampled through the bounce, contact record)."""
    sim, contact, la, lb = crossing_rods(gamma)
    before = (centre_velocity(sim, lb) - centre_velocity(sim, la))[1]
    energies, touched = [sim.energy()], False
    for i in range(60):
        sim.run(until=0.001 * (i + 1))
        energies.append(sim.energy())
        touched |= contact.active_contacts(sim) > 0
    assert touched and contact.active_contacts(sim) == 0  # they met, and have parted
    after = (centre_velocity(sim, lb) - centre_velocity(sim, la))[1]
    return -after / before, np.array(energies), sim


def test_elastic_bounce_conserves_energy():
    e, energies, sim = bounce(0.0)
    assert e == pytest.approx(1.0, abs=5e-3)
    assert np.abs(energies - energies[0]).max() < 1e-4 * energies[0]
    assert np.abs(sim.momentum()).max() < 1e-12  # equal and opposite forces
    parts = sim.energy_parts()
    assert parts["potential"] == 0.0 and parts["kinetic"] == pytest.approx(energies[0], rel=1e-3)


def test_damped_bounce_loses_energy_monotonically_in_gamma():
    rest = [bounce(g)[0] for g in (0.0, 0.5, 2.0)]
    assert rest[0] > rest[1] > rest[2] > 0.0
    _, energies, _ = bounce(0.5)
    assert np.all(np.diff(energies) <= 1e-6 * energies[0])  # never gains (beyond Verlet error)
    assert energies[-1] < 0.8 * energies[0]


def coil(contact=True, turns=1.25, radius=0.1, pitch=0.04, r=0.005, n=48, v=1.0):
    """A one-and-a-quarter-turn coil whose top turn is thrown down onto the bottom one."""
    th = np.linspace(0.0, 2 * math.pi * turns, n + 1)
    pts = np.column_stack([radius * np.cos(th), radius * np.sin(th), pitch * th / (2 * math.pi)])
    net = cosnet.Net()
    a, b = net.add_node(pts[0]), net.add_node(pts[-1])
    line = net.add_line(a, b, material=SOFT, section=cosnet.Circle(r), elements=n, points=pts, name="coil")
    effects = [cosnet.Contact(k=2e3)] if contact else []
    sim = cosnet.Simulation(net, effects=effects)
    top = th > 2 * math.pi
    sim.line_velocities(line)[top] = (0.0, 0.0, -v)
    sim.node_velocity(b)[:] = (0.0, 0.0, -v)
    over = th < 2 * math.pi * (turns - 1)  # the stretch of the bottom turn under the top one
    return sim, line, over, top


def min_distance(x, pairs):
    return min(closest_points(x[i], x[i + 1], x[j], x[j + 1])[2] for i, j in pairs)


@pytest.mark.parametrize("contact", [True, False])
def test_coil_does_not_pass_through_itself(contact):
    sim, line, over, top = coil(contact)
    pairs = [(i, j) for i in np.flatnonzero(over[:-1]) for j in np.flatnonzero(top[1:])]
    r2 = 0.01
    closest = np.inf
    for i in range(70):
        sim.run(until=0.001 * (i + 1))
        closest = min(closest, min_distance(sim.line_positions(line), pairs))
    if contact:
        assert closest > 0.8 * r2  # 2 r less a small penalty overlap
    else:
        assert closest < 0.1 * r2  # the control: without contact the turns run into each other


def test_lines_far_apart_need_no_narrow_phase():
    net = cosnet.Net()
    for y in (0.0, 10.0):
        a, b = net.add_node((0.0, y, 0.0)), net.add_node((1.0, y, 0.0))
        net.add_line(a, b, material=SOFT, section=cosnet.Circle(0.01), elements=8)
    contact = cosnet.Contact(k=1e3)
    sim = cosnet.Simulation(net, effects=[contact])
    sim.state.v[:] = (0.0, 1.0, 0.0)
    sim.state.node_v[:] = (0.0, 1.0, 0.0)
    sim.run(steps=100)
    assert contact.narrow_tests(sim) == 0 and contact.active_contacts(sim) == 0


def test_junctions_feel_no_contact_at_rest():
    """Thick lines with short elements meeting at nodes (straight through, at 90 and 30
    degrees, a closed ring): the capsules overlap near the nodes, yet no force arises."""
    net = cosnet.Net()
    r = 0.02
    hub = net.add_node((0.0, 0.0, 0.0), mass=0.1, name="hub")
    ends = [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (math.cos(0.52), math.sin(0.52), 0.0)]
    for i, p in enumerate(ends):
        net.add_line(hub, net.add_node(0.5 * np.array(p)), material=SOFT, section=cosnet.Circle(r),
                     elements=16, name=f"spoke{i}")
    ring = [net.add_node((1.0, 0.0, 1.0)), net.add_node((-1.0, 0.0, 1.0))]
    for i in range(2):  # a closed ring of two half circles
        th = np.linspace(i * math.pi, (i + 1) * math.pi, 21)
        pts = np.column_stack([np.cos(th), np.sin(th), np.ones_like(th)])
        net.add_line(ring[i], ring[1 - i], material=SOFT, section=cosnet.Circle(r), elements=20,
                     points=pts, name=f"ring{i}")
    contact = cosnet.Contact(k=1e4)
    sim = cosnet.Simulation(net, effects=[contact])
    loads = empty_loads(sim.model)
    add_contact(contact.params(sim), sim.model, sim.state, loads)
    assert contact.active_contacts(sim) == 0 and np.all(loads.f == 0.0)
    x0 = sim.state.x.copy()
    sim.run(steps=50)
    assert np.abs(sim.state.x - x0).max() < 1e-12 and sim.energy_parts()["potential"] == 0.0


def test_validation_and_scene_kind():
    for bad in (dict(k=0.0), dict(k=math.inf), dict(k=1.0, gamma=-1.0), dict(k=1.0, self_gap=-1)):
        with pytest.raises(ValueError, match="Contact"):
            cosnet.Contact(**bad)
    net = cosnet.Net()
    a, b = net.add_node((0, 0, 0)), net.add_node((1, 0, 0))
    net.add_line(a, b, material=SOFT, section=cosnet.Circle(0.01), elements=4, name="rod")
    with pytest.raises(ValueError, match="unknown line 'nope'"):
        cosnet.Simulation(net, effects=[cosnet.Contact(k=1.0, lines=["nope"])])
    sim = cosnet.Simulation(net, effects=[cosnet.Contact(k=1e9, lines=["rod"])])
    assert sim.stable_dt() < cosnet.Simulation(net).stable_dt()  # the penalty stiffness counts
    data = {"materials": {"m": {"E": 1e8, "G": 4e7, "density": 1000.0}},
            "sections": {"s": {"kind": "circle", "radius": 0.01}},
            "nodes": {"a": {"position": [0, 0, 0]}, "b": {"position": [1, 0, 0]}},
            "lines": {"rod": {"start": "a", "end": "b", "material": "m", "section": "s", "elements": 4}},
            "effects": [{"kind": "contact", "k": 100.0, "gamma": 0.5, "lines": ["rod"],
                         "self_contact": False}], "run": {"until": 0.01}}
    (c,) = build_scene(data).simulation().effects
    assert isinstance(c, cosnet.Contact) and (c.k, c.gamma, c.self_contact, c.lines) == (100.0, 0.5, False, ["rod"])


@pytest.mark.parametrize("far", [0.0, 1e3])
def test_broad_phase_finds_every_overlap(far):
    """A heap of short rods: the grid finds exactly the overlaps of an all-pairs search, in
    the dense grid and in the hashed one (a rod far away makes the bounding box huge)."""
    rng = np.random.default_rng(7)
    net, r, k = cosnet.Net(), 0.02, 1e3
    for _ in range(30):
        c, u = rng.uniform(0.0, 0.3, 3), rng.standard_normal(3)
        u *= 0.05 / np.linalg.norm(u)
        net.add_line(net.add_node(c - u), net.add_node(c + u), material=SOFT, section=cosnet.Circle(r),
                     elements=2)
    if far:
        net.add_line(net.add_node((far, 0, 0)), net.add_node((far + 0.1, 0, 0)), material=SOFT,
                     section=cosnet.Circle(r), elements=2)
    contact = cosnet.Contact(k=k)
    sim = cosnet.Simulation(net, effects=[contact])
    x, ends = sim.state.x, sim.model.line_element_offsets
    segs = [(l, e) for l in range(len(net.lines)) for e in range(ends[l], ends[l + 1])]
    brute = 0.0
    for n, (l1, e1) in enumerate(segs):
        for l2, e2 in segs[n + 1:]:
            if l1 != l2:
                v1, v2 = e1 + l1, e2 + l2  # first vertex of each element
                eps = 2 * r - closest_points(x[v1], x[v1 + 1], x[v2], x[v2 + 1])[2]
                brute += 0.5 * k * eps**2 if eps > 0 else 0.0
    assert brute > 0 and contact.potential_energy(sim) == pytest.approx(brute, rel=1e-12)
    loads = empty_loads(sim.model)
    add_contact(contact.params(sim), sim.model, sim.state, loads)
    assert np.abs(loads.f.sum(axis=0)).max() < 1e-9  # equal and opposite
