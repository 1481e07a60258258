"""Obstacles and Coulomb friction: a line held on an incline below mu_s and sliding above it
at g (sin - mu_k cos), kinetic deceleration mu_k g along and across the line, energy plus
friction's dissipation conserved, no pass-through at a plane, a sphere and a mesh (wound
either way), and bad input refused in one line."""

import math

import meshio
import numpy as np
import pytest

import cosnet
from cosnet.kernels.obstacles import obstacle_distance
from cosnet.scene.loader import build_scene

STIFF = cosnet.Material(E=1e9, G=4e8, density=1000.0, name="stiff")
G = 9.81
R = 0.01      # section radius
LENGTH = 0.1
WEIGHT = STIFF.density * math.pi * R * R * LENGTH * G


def rod(obstacle, g=(0.0, 0.0, -G), height=R, along=(1.0, 0.0, 0.0), n=4):
    """A short stiff line along `along` whose axis is `height` above z = 0, with gravity g."""
    net = cosnet.Net()
    u = np.array(along, dtype=float)
    p0 = np.array([0.0, 0.0, height])
    a, b = net.add_node(p0), net.add_node(p0 + LENGTH * u)
    line = net.add_line(a, b, material=STIFF, section=cosnet.Circle(R), elements=n, name="rod")
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(g), obstacle])
    return sim, line, (a, b)


def push(sim, line, nodes, v):
    sim.line_velocities(line)[:] = v
    for nd in nodes:
        sim.node_velocity(nd)[:] = v


def centre(sim, line):
    return sim.line_positions(line).mean(axis=0)


def velocity(sim, line):
    return sim.line_velocities(line).mean(axis=0)


def plane(**kw):
    kw.setdefault("k", 1e4)
    kw.setdefault("gamma", 15.0)   # near critical for a vertex on k_t = k
    return cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), **kw)


def incline(theta, mu_s, mu_k):
    """The rod resting on z = 0 under gravity tilted by theta towards +x (the rod's forward),
    sunk by its weight's share per vertex so that its contacts are loaded from the start (a
    contact touching with no normal force slides at once, and a block sliding on an incline
    steeper than mu_k rightly never stops)."""
    ob = plane(mu_s=mu_s, mu_k=mu_k)
    sink = WEIGHT * math.cos(theta) / 5 / ob.k
    sim, line, _ = rod(ob, g=(G * math.sin(theta), 0.0, -G * math.cos(theta)), height=R - sink)
    return sim, line, ob


def test_line_sticks_on_incline_below_mu_s():
    theta = math.atan(0.4)
    sim, line, ob = incline(theta, mu_s=0.5, mu_k=0.3)
    x0 = centre(sim, line)
    drift = []
    for i in range(10):
        sim.run(until=0.1 * (i + 1))
        drift.append(abs(centre(sim, line)[0] - x0[0]))
    # the stick springs hold each vertex within its weight's share / k_t of the anchor:
    # m_v g sin(theta) / k_t ~ 3e-6 m here; no creep over the second
    hold = WEIGHT / 4 * math.sin(theta) / ob.k_t
    assert max(drift) < 3.0 * hold
    assert abs(drift[-1] - drift[4]) < 0.5 * hold  # no creep: the second half adds nothing
    assert ob.sliding(sim) == 0 and ob.active_contacts(sim) == 5


def second_difference(sim, line, times, axis, of=centre):
    xs = []
    for t in times:
        sim.run(until=t)
        xs.append(of(sim, line)[axis])
    dt = times[1] - times[0]
    return (xs[2] - 2 * xs[1] + xs[0]) / dt**2


def test_line_slides_on_incline_above_mu_s():
    theta = math.atan(0.7)
    mu_k = 0.3
    sim, line, ob = incline(theta, mu_s=0.5, mu_k=mu_k)
    a = second_difference(sim, line, (0.1, 0.3, 0.5), 0)
    assert a == pytest.approx(G * (math.sin(theta) - mu_k * math.cos(theta)), rel=0.01)
    assert ob.sliding(sim) == ob.active_contacts(sim) == 5


def deceleration(mu_s, mu_k, along, v):
    ob = plane(mu_s=mu_s, mu_k=mu_k)
    sim, line, nodes = rod(ob, along=along)
    push(sim, line, nodes, v)
    v1 = velocity(sim, line).copy()
    sim.run(until=0.1)
    v2 = velocity(sim, line)
    return -(v2 - v1) @ np.array(v) / np.linalg.norm(v) / 0.1, sim, ob


@pytest.mark.parametrize("along, v, mu", [
    ((1, 0, 0), (0.8, 0, 0), 0.2),    # forward along the line
    ((1, 0, 0), (-0.8, 0, 0), 0.4),   # backward
    ((1, 0, 0), (0, 0.8, 0), 0.6),    # lateral
    ((0, 1, 0), (0, 0.8, 0), 0.2),    # forward again, the line turned
])
def test_sliding_decelerates_at_mu_k_g_in_each_direction(along, v, mu):
    a, _, _ = deceleration((0.3, 0.5, 0.7), (0.2, 0.4, 0.6), along, v)
    assert a == pytest.approx(mu * G, rel=0.01)


def test_oblique_slide_is_resisted_component_by_component():
    """Sliding obliquely (unit slip u at 53 degrees to the line), the friction resists each
    component with its own kinetic coefficient, a = -g (mu_forward u_along, mu_lateral u_lat)
    (Hu et al.'s anisotropic law): here (0.12, 0.48) g, where a force opposite the slip on the
    same ellipse would give (0.18, 0.24) g. Fast, over a short window, so u barely turns."""
    ob = plane(mu_s=(0.3, 0.5, 0.7), mu_k=(0.2, 0.4, 0.6))
    sim, line, nodes = rod(ob, along=(1, 0, 0))
    push(sim, line, nodes, (3.0, 4.0, 0.0))
    sim.run(until=0.01)            # past the stick springs' start
    v1 = velocity(sim, line).copy()
    sim.run(until=0.03)
    v2 = velocity(sim, line)
    a = (v2 - v1) / 0.02
    u = (v1 + v2) / np.linalg.norm(v1 + v2)
    assert ob.sliding(sim) == ob.active_contacts(sim) > 0
    assert a[0] == pytest.approx(-G * 0.2 * u[0], rel=0.01)
    assert a[1] == pytest.approx(-G * 0.6 * u[1], rel=0.01)


def energy_balance_error(dt_factor):
    """A rod thrown along the plane (elastic normal law) until friction stops it: the largest
    departure of energy + dissipated from its start, over the initial kinetic energy, and
    the share of that energy friction took."""
    ob = plane(gamma=0.0, mu_s=0.4, mu_k=0.3)
    sim, _, _ = rod(ob)
    sim = cosnet.Simulation(sim.net, effects=[cosnet.Gravity(), ob], dt=sim.dt * dt_factor)
    line = sim.net.line("rod")
    push(sim, line, (line.start, line.end), (1.0, 0.3, 0.0))
    e0, kinetic = sim.energy(), sim.energy_parts()["kinetic"]
    err = 0.0
    for i in range(8):
        sim.run(until=0.05 * (i + 1))
        err = max(err, abs(sim.energy() + ob.dissipated(sim) - e0))
    return err / kinetic, ob.dissipated(sim) / kinetic


def test_energy_plus_dissipation_is_conserved_to_second_order():
    err, took = energy_balance_error(1.0)
    err_half, _ = energy_balance_error(0.5)
    assert took > 0.9   # friction stopped the rod
    assert err < 3e-3 and err / err_half > 3.5   # Verlet's error: a quarter at half the step


def throw(obstacle, speed=5.0, height=0.05):
    """The rod thrown down at speed onto the obstacle below it, without gravity; return the
    deepest overlap as a fraction of R, the rod's final vertical velocity, the simulation and
    its energy when thrown."""
    sim, line, nodes = rod(obstacle, g=(0.0, 0.0, 0.0), height=height)
    push(sim, line, nodes, (0.0, 0.0, -speed))
    e0 = sim.energy()
    sim.run(until=height / speed + 0.01)
    return obstacle.deepest(sim), velocity(sim, line)[2], sim, e0


def cube_mesh(path, inward=False, flip_some=False):
    pts = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    pts = (pts - 0.5) * 0.2 + np.array([0.05, 0.0, -0.1])   # top face at z = 0
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    if inward:
        tris = tris[:, ::-1]
    if flip_some:
        tris[::3] = tris[::3, ::-1]
    meshio.write(path, meshio.Mesh(pts, [("triangle", tris)]))
    return path


@pytest.mark.parametrize("shape", ["plane", "sphere", "box", "mesh", "mesh_inward", "mesh_mixed"])
def test_thrown_line_stops_at_the_surface(shape, tmp_path):
    k = 1e5
    if shape == "plane":
        ob = cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=k)
    elif shape == "sphere":
        ob = cosnet.Obstacle("sphere", center=(0.05, 0, -0.3), radius=0.3, k=k)
    elif shape == "box":
        ob = cosnet.Obstacle("box", center=(0.05, 0, -0.1), half_size=(0.1, 0.1, 0.1), k=k)
    else:
        f = cube_mesh(str(tmp_path / "cube.stl"), inward=shape == "mesh_inward", flip_some=shape == "mesh_mixed")
        ob = cosnet.Obstacle("mesh", file=f, k=k)
    deepest, vz, sim, e0 = throw(ob)
    # the bounce turns the rod's 5 m/s into an overlap of v sqrt(m / k) ~ 0.14 R per vertex
    assert 0.05 < deepest < 0.25
    # elastically: the energy after the bounce (kinetic, some of it the rod's ringing, and
    # strain) is the energy thrown, to position Verlet's error on the stiffest motion, a vertex
    # on the penalty spring: a relative (w h / 2)^2, w = sqrt(k / m_vertex) (measured about
    # (w h)^2 / 9 on the plane)
    w = math.sqrt(k / sim.model.vertex_mass[1])
    assert abs(sim.energy() / e0 - 1) < (w * sim.dt / 2) ** 2
    assert vz > 0.0   # it came back up
    p = ob.params(sim)
    d = [obstacle_distance(p, *x)[0] for x in sim.state.x]
    assert min(d) > R   # and left the surface


def test_mesh_normals_point_out_whatever_the_winding(tmp_path):
    for inward in (False, True):
        ob = cosnet.Obstacle("mesh", file=cube_mesh(str(tmp_path / f"c{inward}.obj"), inward=inward), k=1.0)
        t = ob.points[ob.triangles]
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        outward = np.einsum("ij,ij->i", n, t.mean(axis=1) - ob.points.mean(axis=0))
        assert np.all(outward > 0)


def test_bad_input_is_refused_in_one_line(tmp_path):
    with pytest.raises(ValueError, match=r"mu_s must be >= 0"):
        plane(mu_s=-0.1)
    with pytest.raises(ValueError, match=r"mu_k must not exceed the static"):
        plane(mu_s=0.3, mu_k=0.5)
    with pytest.raises(ValueError, match=r"Obstacle 'floor' \(plane\): k_t"):
        cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=1.0, mu_s=0.5, k_t=0.0, name="floor")
    with pytest.raises(ValueError, match=r"\(sphere\): needs radius"):
        cosnet.Obstacle("sphere", center=(0, 0, 0), k=1.0)
    pts = np.eye(3)
    with pytest.raises(ValueError, match=r"must be closed and manifold; it is open"):
        cosnet.Obstacle("mesh", points=np.vstack([pts, [[0, 0, 0]]]), triangles=[[0, 1, 2], [0, 1, 3]], k=1.0)
    bad = tmp_path / "bad.stl"
    bad.write_text("solid nothing here\n garbage\n")
    scene = {
        "materials": {"m": {"E": 1e9, "G": 4e8, "density": 1000.0}},
        "sections": {"s": {"kind": "circle", "radius": 0.01}},
        "nodes": {"a": {"position": [0, 0, 0.01]}, "b": {"position": [0.1, 0, 0.01]}},
        "lines": {"rod": {"start": "a", "end": "b", "material": "m", "section": "s", "elements": 2}},
        "effects": [{"kind": "obstacle", "shape": "mesh", "file": "bad.stl", "k": 1e4, "lines": ["rod"]}],
    }
    with pytest.raises(ValueError) as e:
        build_scene(scene, path=tmp_path / "scene.toml")
    msg = str(e.value)
    assert "\n" not in msg and "[[effects]] #1 (obstacle) file" in msg and "bad.stl" in msg
    scene["effects"] = [{"kind": "obstacle", "shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                         "k": 1e4, "mu_s": 0.2, "mu_k": 0.4}]
    with pytest.raises(ValueError, match=r"\[\[effects\]\] #1 \(obstacle\) mu_k: .*must not exceed"):
        build_scene(scene, path=tmp_path / "scene.toml")
    scene["effects"][0].update(mu_s=[0.3, -0.1, 0.2])
    with pytest.raises(ValueError, match=r"\[\[effects\]\] #1 \(obstacle\) mu_s: must be >= 0"):
        build_scene(scene, path=tmp_path / "scene.toml")


def capstan(ratio, mu=0.3, drum=0.1, r=0.003, drop=0.2, n_arc=60, until=0.6):
    """A rope over a fixed horizontal drum (a capsule along y), half a turn of contact,
    loads m and ratio * m hanging from its ends; return (how far the heavy end went down over
    the second half of the run, sliding contacts, contacts). The rope is light (0.03 kg
    against 5 kg) and supple (its bending stiffness over the drum's radius is 1 % of the
    tension); mass-proportional damping and the normal dashpot settle the first drop."""
    rope = cosnet.Material(E=1e8, G=4e7, density=1000.0)
    rr = drum + 0.99 * r
    th = np.linspace(math.pi, 0.0, n_arc + 1)
    arc = np.column_stack([rr * np.cos(th), np.zeros_like(th), rr * np.sin(th)])
    z = np.linspace(-drop, 0.0, 12, endpoint=False)
    pts = np.vstack([np.column_stack([np.full(12, -rr), np.zeros(12), z]), arc,
                     np.column_stack([np.full(12, rr), np.zeros(12), z[::-1]])])
    net = cosnet.Net()
    light = net.add_node(pts[0], mass=5.0, inertia=(1e-2, 1e-2, 1e-2))
    heavy = net.add_node(pts[-1], mass=5.0 * ratio, inertia=(1e-2, 1e-2, 1e-2))
    net.add_line(light, heavy, material=rope, section=cosnet.Circle(r), elements=len(pts) - 1, points=pts)
    ob = cosnet.Obstacle("capsule", start=(0, -0.1, 0), end=(0, 0.1, 0), radius=drum, k=1e6, gamma=24.0,
                         mu_s=mu, mu_k=mu)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(), ob, cosnet.Damping(30.0)])
    sim.run(until=until / 2)
    z0 = sim.node_position(heavy)[2]
    sim.run(until=until)
    return z0 - sim.node_position(heavy)[2], ob.sliding(sim), ob.active_contacts(sim)


@pytest.mark.parametrize("factor", [0.98, 1.02])
def test_capstan_holds_below_and_slips_above_e_to_the_mu_theta(factor):
    limit = math.exp(0.3 * math.pi)   # T2 / T1 over half a turn
    went, sliding, contacts = capstan(factor * limit)
    assert contacts >= 55   # the rope lies on the drum's half turn (61 vertices)
    if factor < 1:
        assert sliding == 0 and abs(went) < 1e-4
    else:
        assert sliding == contacts and went > 5e-4


def octasphere(levels=2, radius=0.1):
    """A closed triangulated sphere: an octahedron's faces split in four `levels` times."""
    pts = [np.array(p, float) for p in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))]
    tris = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(levels):
        mid, out = {}, []

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = pts[a] + pts[b]
                pts.append(m / np.linalg.norm(m))
                mid[key] = len(pts) - 1
            return mid[key]
        for a, b, c in tris:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
        tris = out
    return radius * np.array(pts), np.array(tris)


def test_triangle_closest_point_matches_a_fine_scan():
    from cosnet.kernels.obstacles import triangle_closest
    rng = np.random.default_rng(3)
    u, w = np.meshgrid(np.linspace(0, 1, 401), np.linspace(0, 1, 401))
    inside = u + w <= 1
    u, w = u[inside], w[inside]
    for _ in range(30):
        a, b, c, p = rng.standard_normal((4, 3))
        q = np.array(triangle_closest(*p, a, b, c))
        scan = a + u[:, None] * (b - a) + w[:, None] * (c - a)
        d_scan = np.linalg.norm(scan - p, axis=1).min()
        assert np.linalg.norm(q - p) <= d_scan + 1e-12
        assert np.linalg.norm(q - p) >= d_scan - 5e-3 * np.linalg.norm(b - a)


def test_mesh_distance_is_the_nearest_triangle_with_the_side_of_the_solid():
    """Through the grid, the distance of points near a closed mesh (either winding) is the
    brute-force distance to its nearest triangle, negative exactly inside the polyhedron."""
    from cosnet.kernels.obstacles import triangle_closest
    pts, tris = octasphere()
    rng = np.random.default_rng(4)
    dirs = rng.standard_normal((300, 3))
    probes = dirs / np.linalg.norm(dirs, axis=1)[:, None] * rng.uniform(0.085, 0.112, (300, 1))
    faces = pts[tris]
    normals = np.cross(faces[:, 1] - faces[:, 0], faces[:, 2] - faces[:, 0])
    for winding in (tris, tris[:, ::-1]):
        ob = cosnet.Obstacle("mesh", points=pts, triangles=winding, k=1.0)
        sim, _, _ = rod(ob, g=(0.0, 0.0, 0.0), height=1.0)   # binds the grid for vertices of radius R
        p = ob.params(sim)
        for x in probes:
            d = obstacle_distance(p, *x)[0]
            brute = min(np.linalg.norm(np.array(triangle_closest(*x, *f)) - x) for f in faces)
            inside = np.all(np.einsum("ij,ij->i", normals, x - faces[:, 0]) < 0)
            if brute < R:   # within a vertex's reach the grid must find the nearest triangle
                assert abs(d) == pytest.approx(brute, abs=1e-15)
                assert (d < 0) == inside
            else:   # farther: no triangle is reported nearer than the nearest
                assert abs(d) >= brute - 1e-15


def test_a_checkpoint_carries_the_anchors(tmp_path):
    """Resumed from a checkpoint taken while contacts stick and slide, a run ends bit-identical
    to the uninterrupted one (the anchors, modes and dissipation travel with the state)."""
    from cosnet.engine import checkpoint

    def start():
        sim, line, nodes = rod(plane(mu_s=0.4, mu_k=0.3))
        push(sim, line, nodes, (0.5, 0.2, 0.0))
        return sim
    whole = start()
    whole.run(until=0.1)
    checkpoint.save(whole, tmp_path / "c.npz")
    whole.run(until=0.2)
    resumed = checkpoint.load(start(), tmp_path / "c.npz")
    resumed.run(until=0.2)
    np.testing.assert_array_equal(resumed.state.x, whole.state.x)
    np.testing.assert_array_equal(resumed.effects[1].params(resumed).anchor, whole.effects[1].params(whole).anchor)
    assert resumed.effects[1].dissipated(resumed) == whole.effects[1].dissipated(whole) > 0


def test_only_the_listed_lines_touch(tmp_path):
    """A scene's mesh file is read beside the scene; of two rods dropped onto it, the one not
    listed falls through, the listed one rests on it."""
    from cosnet.cli import main
    cube_mesh(str(tmp_path / "cube.obj"))
    (tmp_path / "two.toml").write_text('''
[materials.m]
E = 1e9
G = 4e8
density = 1000.0

[sections.s]
kind = "circle"
radius = 0.01

[nodes.a]
position = [0.0, 0.0, 0.01]
[nodes.b]
position = [0.1, 0.0, 0.01]
[nodes.c]
position = [0.0, 0.05, 0.01]
[nodes.d]
position = [0.1, 0.05, 0.01]

[lines.held]
start = "a"
end = "b"
material = "m"
section = "s"
elements = 4

[lines.loose]
start = "c"
end = "d"
material = "m"
section = "s"
elements = 4

[[effects]]
kind = "gravity"

[[effects]]
kind = "obstacle"
shape = "mesh"
file = "cube.obj"
k = 1e4
gamma = 15.0
mu_s = 0.5
lines = ["held"]

[run]
until = 0.1
''')
    assert main(["info", str(tmp_path / "two.toml")]) == 0
    scene = cosnet.load_scene(tmp_path / "two.toml")
    sim = scene.simulation()
    sim.run(until=0.1)
    held, loose = (sim.line_positions(scene.net.line(n))[:, 2].mean() for n in ("held", "loose"))
    assert abs(held - R) < 0.05 * R                             # resting, overlapped by its weight
    assert loose == pytest.approx(R - 0.5 * G * 0.1**2, rel=1e-3)   # in free fall
    (tmp_path / "cube.obj").write_text("v 0 0 0\nf 1 2 3\n")
    assert main(["info", str(tmp_path / "two.toml")]) == 2


@pytest.mark.parametrize("spoil, message", [
    (lambda p: p.verts.__setitem__(0, 99), "obstacle.verts holds 99"),
    (lambda p: p.vnext.__setitem__(4, -1), "obstacle.vnext holds -1"),
    (lambda p: p.cell_tri.__setitem__(0, 12), "obstacle.cell_tri holds 12"),
    (lambda p: p.cell_start.__setitem__(-1, 10**6), "obstacle.cell_start is not an offset table"),
])
def test_spoilt_obstacle_tables_are_refused_before_a_run(spoil, message, tmp_path):
    ob = cosnet.Obstacle("mesh", file=cube_mesh(str(tmp_path / "c.stl")), k=1e4)
    sim, _, _ = rod(ob)
    spoil(ob.params(sim))
    with pytest.raises(ValueError, match="^Simulation.run: " + message):
        sim.run(steps=1)
    assert sim.steps == 0


def _contacts_in_every_mode(m=203, seed=3):
    """Rows of the vertex pass (kernels/obstacles.py) for m vertices: touching or not, free,
    sticking or sliding before, moving every way, on lines at every angle to the normal (some
    along it), anchors near and far (inside and outside the friction ellipse)."""
    from cosnet.kernels.obstacles import A, C, EPS, N, ROWS, U, V
    rng = np.random.default_rng(seed)
    w = np.zeros((ROWS, m))
    w[C:C + 3] = rng.normal(size=(3, m)) * 1e-2
    w[V:V + 3] = rng.normal(size=(3, m)) * 1e-1
    w[EPS] = rng.normal(size=m) * 1e-4
    n = rng.normal(size=(3, m))
    w[N:N + 3] = n / np.linalg.norm(n, axis=0)
    w[U:U + 3] = rng.normal(size=(3, m))
    w[U:U + 3, ::17] = w[N:N + 3, ::17]   # lines along the normal: no tangent
    w[A:A + 3] = w[C:C + 3] + rng.normal(size=(3, m)) * np.array([1e-5, 1e-3])[rng.integers(0, 2, m)]
    return w, rng.integers(0, 3, m).astype(np.int64)


@pytest.mark.parametrize("mu_s, mu_k", [((0.5, 0.3, 0.8), (0.4, 0.2, 0.6)), ((0.5, 0.0, 0.8), (0.4, 0.0, 0.6)),
                                        ((0.5, 0.3, 0.0), (0.4, 0.2, 0.0))])
def test_the_contact_law_in_vector_lanes_is_the_law_one_vertex_at_a_time(mu_s, mu_k):
    """The vertex contacts' law (kernels/obstacles.contact_law) runs its loop in vector lanes,
    selects instead of branches; compiled as a plain loop one vertex at a time (without its
    rows declared apart, which LLVM leaves scalar) every force, anchor, dashpot force, dissipated energy and mode is
    the same bit for bit, over contacts in every mode and with frictionless directions."""
    from numba import njit

    from cosnet.kernels.compiler import CACHED_LANES
    from cosnet.kernels.obstacles import contact_law
    one_at_a_time = njit(**{k: v for k, v in CACHED_LANES.items() if k != "cache"})(contact_law.py_func)
    w, mode = _contacts_in_every_mode()
    args = (mode.shape[0], 1e4, 2.0, 1e3) + tuple(mu_s) + tuple(mu_k)
    lanes, scalar = (w.copy(), mode.copy()), (w.copy(), mode.copy())

    @njit
    def call(w, mode, a):
        contact_law(w, mode, *a)
    call(tuple(lanes[0]), lanes[1], args)
    one_at_a_time(tuple(scalar[0]), scalar[1], *args)
    assert np.array_equal(lanes[1], scalar[1])
    assert np.array_equal(lanes[0].view(np.int64), scalar[0].view(np.int64))
    met = set(np.unique(scalar[1]).tolist())
    # every mode met; without lateral friction nothing displaced sideways can stick
    assert {0, 2} <= met and (1 in met or mu_k[2] == 0.0)
