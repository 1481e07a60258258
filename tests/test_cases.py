"""The example scenes in cases/: each loads, runs, and shows a physical truth about itself
(static sags against hand estimates, equilibrium of the supports, exact junctions and
offsets, conservation laws, the pre-stressed triangle of §2.3)."""

import math
from pathlib import Path

import numpy as np
import pytest

import cosnet
from cosnet.scene.loader import load_scene

CASES = Path(__file__).resolve().parents[1] / "cases"
G = 9.81
STEEL_E, STEEL_RHO = 2.1e11, 7850.0


def case(name):
    return load_scene(CASES / f"{name}.toml")


def free_weight(sim):
    """Weight (N) of everything not carried straight by a fixed node: the free vertices and
    the nodes' composite masses (line-end shares included)."""
    m = sim.model
    free = m.vertex_inv_mass > 0
    fin = np.isfinite(m.node_mass)
    return G * (m.vertex_mass[free].sum() + m.node_mass[fin].sum())


def support_force(sim):
    """Sum over the line ends at fixed nodes of the internal force the line exerts on them."""
    r = np.zeros(3)
    for line in sim.net.lines:
        f = sim.line_fields(line)["force"]
        if line.start.fixed_position:
            r += f[0]
        if line.end.fixed_position:
            r -= f[-1]
    return r


def offsets_error(sim, node):
    """Largest distance between a line end and its attachment point r + D xi on the node."""
    x, d = sim.node_position(node), sim.node_rotation(node)
    err = 0.0
    for line, omega in sim.net.lines_at(node):
        end = sim.line_positions(line)[0 if omega < 0 else -1]
        xi = line.start_offset if omega < 0 else line.end_offset
        err = max(err, float(np.linalg.norm(end - (x + d @ xi))))
    return err


@pytest.mark.parametrize("path", sorted(CASES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_case_loads_and_steps(path):
    assert path.read_text().lstrip().startswith("#"), "each case starts with a comment"
    scene = load_scene(path)
    sim = scene.simulation()
    assert sim.dt <= sim.stable_dt() and scene.run.until > 0 and scene.net.total_mass() > 0
    e0 = sim.energy()
    sim.run(steps=200)
    assert np.isfinite(sim.energy()) and np.isfinite(e0)
    assert all(np.all(np.isfinite(sim.line_positions(l))) for l in scene.net.lines)


def test_figure_1_1_case_is_the_net_of_the_paper():
    """Its boundary is exactly the set of ordered pairs (2.2) of the paper."""
    net = case("figure_1_1").net
    pairs = {(n.name, l.name) for n in net.nodes for l, _ in net.lines_at(n)}
    want = {("v1", "λ1"), ("v2", "λ1"), ("v2", "λ2"), ("v2", "λ6"), ("v3", "λ2"), ("v3", "λ3"),
            ("v3", "λ5"), ("v4", "λ3"), ("v4", "λ4"), ("v4", "λ7"), ("v5", "λ4"), ("v6", "λ5"),
            ("v6", "λ6"), ("v6", "λ7")}
    assert pairs == want and len(net.nodes) == 6 and len(net.lines) == 7
    assert {n.name for n in net.nodes if n.fixed_position} == {"v1", "v3", "v5"}
    assert net.line("λ6").material.name == "cable" and net.line("λ1").material.name == "steel"


def test_figure_1_1_bridge_sags_as_the_hand_estimate():
    """Clamped-clamped half deck (span 10 m) propped at midspan by the cable, in series with
    the tower's shortening; Euler-Bernoulli. The net's sag at v2 agrees within 5 % (cable
    sag and discretisation are the neglected few per cent)."""
    scene = case("figure_1_1")
    sim = scene.simulation()
    sim.run(until=0.4)                                   # damping 30/s: transient < 0.3 %
    deck, cable, tower = (scene.net.line(n) for n in ("λ1", "λ6", "λ5"))
    EI = STEEL_E * deck.section.I11
    span = 10.0
    w = STEEL_RHO * deck.section.A * G
    k_beam = 192 * EI / span**3
    k_cable = cable.material.E * cable.section.A / cable.length * 0.5         # sin^2(45 deg)
    k_tower = STEEL_E * tower.section.A / tower.length
    k_prop = k_cable / (1 + 2 * k_cable / k_tower)
    p_cable = STEEL_RHO * cable.section.A * cable.length * G / 2               # half a cable hangs on v2
    sag = (w * span**4 / (384 * EI) + p_cable / k_beam) * k_beam / (k_beam + k_prop)
    v2, v4, v6 = (sim.node_position(scene.net.node(n)) for n in ("v2", "v4", "v6"))
    assert -v2[2] == pytest.approx(sag, rel=0.05)
    assert -v2[2] < 0.6 * w * span**4 / (384 * EI)       # the cable really carries load
    assert abs(v2[2] - v4[2]) < 1e-9 * abs(v2[2])        # mirror symmetry
    assert abs(v6[0] - 10.0) < 1e-9 and v6[2] < 5.0      # the tower top only shortens
    for name in ("v1", "v3", "v5"):
        np.testing.assert_array_equal(sim.node_position(scene.net.node(name)), scene.net.node(name).position)


def test_bridge_is_a_whole_suspension_bridge():
    """Two towers of two legs, a two-girder deck of many elements, two main cables over the
    tower tops and a row of hangers, all joined at point junctions."""
    net = case("bridge").net
    names = [l.name for l in net.lines]
    kinds = {k: sum(n.startswith(k) for n in names) for k in ("girder", "cable", "hanger", "backstay")}
    assert kinds == {"girder": 24, "cable": 24, "hanger": 22, "backstay": 4} and len(names) >= 90
    assert sum(l.elements for l in net.lines if l.name.startswith("girder")) >= 90
    assert all(n.mass == 0 or n.fixed_position for n in net.nodes)         # point junctions
    assert {l.material.name for l in net.lines} == {"steel", "concrete", "strand", "rod"}
    for side in "ns":                      # each main cable runs over both tower tops
        at_tops = {l.name for t in ("west", "east") for l, _ in net.lines_at(net.node(f"{t}_{side}_top"))}
        assert {f"cable_{side}01", f"cable_{side}12", f"backstay_west_{side}", f"backstay_east_{side}"} <= at_tops


def _lorry_load(scene, t):
    """Total vertical node load (N) of the lorry at time t, from the declared NodeLoads."""
    total = 0.0
    for e in scene.effects:
        if isinstance(e, cosnet.NodeLoad):
            times, values = e.amp[:2]
            total += e.force[2] * np.interp(t, times, values)
    return total


def test_bridge_supports_carry_weight_and_lorry():
    """Momentum balance of the whole bridge: the force R the lines exert on the clamps
    equals gravity plus the lorry's node loads, less dP/dt and the damping force nu P, with
    P the momentum of everything free. Before the lorry the
    residual motion (dP/dt + nu P) is a small fraction of the weight; while it crosses, the
    clamps carry its 30 t as well. dP/dt by a central difference over one step."""
    scene = case("bridge")
    sim = scene.simulation()
    nu = next(e.translational for e in scene.effects if isinstance(e, cosnet.Damping))
    weight = free_weight(sim)
    lorry = []
    for t in (1.2, 2.1):                                  # settled, no lorry; lorry at x = 12 m
        sim.run(until=t)
        p0 = sim.momentum()
        sim.run(steps=1)
        p1, r, t1 = sim.momentum(), support_force(sim), sim.time
        sim.run(steps=1)
        dp = (sim.momentum() - p0) / (2 * sim.dt)
        load = np.array([0.0, 0.0, _lorry_load(scene, t1) - weight])
        np.testing.assert_allclose(r, load - dp - nu * p1, rtol=0, atol=1e-5 * weight)
        lorry.append(-_lorry_load(scene, t1))
        if t == 1.2:
            assert np.linalg.norm(dp + nu * p1) < 0.05 * weight      # nearly settled
    assert lorry[0] == 0.0 and lorry[1] == pytest.approx(30e3 * G, rel=1e-12)


def test_cantilever_tip_sags_as_euler_bernoulli():
    """Static tip deflection w L^4 / (8 E I); 10 elements leave an O(h^2) error near 1 %."""
    scene = case("cantilever")
    sim = scene.simulation()
    sim.run(until=0.4)
    rod = scene.net.line("rod")
    w = STEEL_RHO * rod.section.A * G
    want = w * rod.length**4 / (8 * STEEL_E * rod.section.I11)
    assert -sim.node_position(scene.net.node("tip"))[2] == pytest.approx(want, rel=0.02)
    assert sim.energy_parts()["kinetic"] < 1e-6 * w * want  # at rest


def test_t_junction_sag_and_exact_right_angle():
    """Junction sag P L^3/(192 E I) + w L^4/(384 E I); 12 elements per line converge to it
    at second order (about 1 % away here). The three line ends at J keep their frames: the
    stem stays exactly perpendicular to the beam at J."""
    scene = case("t_junction")
    sim = scene.simulation()
    sim.run(until=0.1)
    stem, left = scene.net.line("stem"), scene.net.line("left")
    EI = STEEL_E * left.section.I11
    rho_a = STEEL_RHO * left.section.A
    p = (scene.net.node("C").mass + rho_a * stem.length) * G
    want = p * 2.0**3 / (192 * EI) + rho_a * G * 2.0**4 / (384 * EI)
    assert -sim.node_position(scene.net.node("J"))[2] == pytest.approx(want, rel=0.03)
    d_stem = sim.line_fields(stem)["d3"][0]
    d_left = sim.line_fields(left)["d3"][-1]
    d_right = sim.line_fields(scene.net.line("right"))["d3"][0]
    assert abs(d_stem @ d_left) < 1e-12 and abs(d_stem @ d_right) < 1e-12
    assert d_left @ d_right == pytest.approx(1.0, abs=1e-12)


def test_tree_root_carries_the_weight_and_its_moment():
    """Statics of a tree: the trunk's internal force and moment at the root are the total
    weight and its moment about the root (the whole net hangs on that one clamp)."""
    scene = case("tree")
    sim = scene.simulation()
    sim.run(until=0.5)
    m, s = sim.model, sim.state
    free, fin = m.vertex_inv_mass > 0, np.isfinite(m.node_mass)
    g = np.array([0.0, 0.0, -G])
    weight = free_weight(sim) * g / G
    moment = (np.cross(s.x[free], g) * m.vertex_mass[free, None]).sum(0) \
        + (np.cross(s.node_x[fin], g) * m.node_mass[fin, None]).sum(0)
    f = sim.line_fields(scene.net.line("trunk"))
    np.testing.assert_allclose(f["force"][0], weight, rtol=0, atol=1e-4 * np.linalg.norm(weight))
    np.testing.assert_allclose(f["torque"][0], moment, rtol=0, atol=1e-4 * np.linalg.norm(moment))
    assert np.linalg.norm(moment) > 1.0                  # a lopsided tree: a real moment


def test_mast_supports_carry_the_weight_and_offsets_are_exact():
    scene = case("mast")
    sim = scene.simulation()
    sim.run(until=0.5)
    box = scene.net.node("box")
    assert offsets_error(sim, box) < 1e-12
    r = support_force(sim)
    w = free_weight(sim)
    np.testing.assert_allclose(r, [0.0, 0.0, -w], rtol=0, atol=1e-4 * w)
    assert sim.node_position(box)[2] < 6.2               # the mast shortened under the box


def test_triangle_keeps_its_corners_and_has_no_stress_free_state():
    """§2.3: right-angle junctions force the straight rods to bend. Free in space, the
    pre-stressed triangle keeps zero momentum; damped to rest, each rod becomes an arc
    turning 30 degrees (uniform curvature pi/6 per metre) and the corners between the end
    elements open to 90 + 30/n degrees (the discrete arc), the right angle held by X."""
    scene = case("triangle")
    sim = scene.simulation()
    assert sim.energy_parts()["strain"] > 1.0            # stressed from the start
    sim.run(until=0.01)
    scale = math.sqrt(2 * sim.energy() * scene.net.total_mass())
    assert np.linalg.norm(sim.momentum()) < 1e-10 * scale
    assert np.linalg.norm(sim.angular_momentum()) < 1e-10 * scale
    scene.effects.append(cosnet.Damping(400.0))
    sim = scene.simulation()
    sim.run(until=0.05)
    assert sim.energy_parts()["strain"] > 1.0            # at rest, still stressed
    n = scene.net.line("AB").elements
    for node in scene.net.nodes:
        (la, oa), (lb, ob) = scene.net.lines_at(node)
        da = sim.line_directors(la)[0 if oa < 0 else -1][:, 2]
        db = sim.line_directors(lb)[0 if ob < 0 else -1][:, 2]
        assert math.degrees(math.acos(da @ db)) == pytest.approx(90 + 30 / n, abs=0.01)
    for line in scene.net.lines:
        k = sim.line_fields(line)["curvature"][:, 0]
        np.testing.assert_allclose(k, math.pi / 6 / line.length, rtol=1e-3)


def test_chain_conserves_energy_and_keeps_its_links_on_their_rods():
    scene = case("chain")
    sim = scene.simulation()
    e0, k0 = sim.energy(), sim.energy_parts()["kinetic"]
    worst = 0.0
    for k in range(10):
        sim.run(until=0.02 * (k + 1))
        worst = max(worst, abs(sim.energy() - e0))
    assert worst < 1e-3 * k0                             # Verlet: bounded, O(dt^2) energy error
    assert max(offsets_error(sim, n) for n in scene.net.nodes if n.mass > 0) < 1e-12
    assert sim.node_position(scene.net.node("link4"))[0] > 0.005   # it swung


def test_web_energy_error_is_second_order():
    """The web (a net with a loop) conserves energy up to Verlet's bounded error, which falls
    four-fold when dt halves."""
    scene = case("web")
    base = scene.simulation().dt
    errors = []
    for f in (1.0, 0.5):
        sim = scene.simulation(dt=base * f)
        e0 = sim.energy()
        steps = int(round(0.05 / base / f))
        worst = 0.0
        for _ in range(25):
            sim.run(steps=steps // 25)
            worst = max(worst, abs(sim.energy() - e0))
        errors.append(worst)
    assert errors[0] < 2e-3 * e0
    assert 3.5 < errors[0] / errors[1] < 4.5


def test_tumbling_net_conserves_momenta_and_energy():
    scene = case("tumbling")
    sim = scene.simulation()
    mass = scene.net.total_mass()
    p0, l0, e0 = sim.momentum(), sim.angular_momentum(), sim.energy()
    np.testing.assert_allclose(p0, mass * np.array([0.2, 0.0, 0.0]), rtol=1e-12, atol=1e-14)
    assert np.linalg.norm(l0) > 0.1                       # it really spins
    sim.run(until=scene.run.until)
    np.testing.assert_allclose(sim.momentum(), p0, rtol=0, atol=1e-12 * np.linalg.norm(p0))
    np.testing.assert_allclose(sim.angular_momentum(), l0, rtol=0, atol=1e-12 * np.linalg.norm(l0))
    assert abs(sim.energy() - e0) < 1e-8 * e0
    assert sim.energy_parts()["strain"] > 1e-3 * e0       # the spin stretched it


def test_winch_reels_the_load_in_and_pulls_its_tension_times_the_capstan_factor():
    """Once the start has settled the rope slides over the drum's half turn (friction mu): the
    load rises at the reeling speed v times (1 + T1/EA) / (1 + T2/EA), rope material flowing
    at one rate from the load's side (tension T1 = m (g + nu u), weight and drag at the load's
    speed u) to the winch's (T2 = T1 e^(mu pi), the capstan relation); the driver holds T2 less
    its pin's weight. Averaged over one second, several passes of the rope's vertices over
    the drum's edges."""
    scene = case("winch")
    sim = scene.simulation()
    load, pin = (next(n for n in scene.net.nodes if n.name == name) for name in ("load", "winch"))
    drum = next(e for e in sim.effects if isinstance(e, cosnet.Obstacle))
    m, nu, mu, v = 5.0, 20.0, 0.3, 0.1
    ea = 5e7 * math.pi * 0.003 ** 2
    sim.run(until=0.6)
    z0, pulls = sim.node_position(load)[2], []
    while sim.time < scene.run.until - 1e-9:
        sim.run(until=min(scene.run.until, sim.time + 0.01))
        pulls.append(-sim.reaction(pin)[0][2])
        assert drum.sliding(sim) == drum.active_contacts(sim) > 10
    u = (sim.node_position(load)[2] - z0) / (scene.run.until - 0.6)
    t1 = m * (G + nu * u)
    t2 = t1 * math.exp(mu * math.pi)
    assert u == pytest.approx(v * (1 + t1 / ea) / (1 + t2 / ea), rel=0.01)
    assert u < 0.96 * v                     # the stretch is seen: not the reeling speed itself
    assert np.mean(pulls) == pytest.approx(t2 - 0.1 * G, rel=0.01)


def test_crane_hoists_its_hook_block_at_half_the_hauling_speed_on_half_its_weight():
    """Two parts of rope carry the hook block (frictionless sheaves): it rises half as far as
    the winch hauls in, and the rope's tension is the same on both sides of each wheel but for
    the rope's weight between heights, T(z) = C + lambda g z. So the block's sheave carries
    2 T(z_B) = M (g + nu v_B) + lambda pi R g (its weight, its drag, the rope on its lower
    half turn) and the winch's pin pulls T(z_W) less its own weight. Averaged over the second
    half second, the hauling speed steady."""
    scene = case("crane")
    sim = scene.simulation()
    block, winch, rope = scene.net.node("block"), scene.net.node("winch"), scene.net.line("rope")
    lam = rope.material.density * rope.section_at(0.5).A
    m, nu, radius = 20.0, 5.0, 0.1
    sim.run(until=0.5)
    zb0, zw0, pulls, speeds = sim.node_position(block)[2], sim.node_position(winch)[2], [], []
    while sim.time < scene.run.until - 1e-9:
        sim.run(until=min(scene.run.until, sim.time + 0.002))
        pulls.append(-sim.reaction(winch)[0][2])
        speeds.append(sim.node_velocity(block)[2])
    rise, hauled = sim.node_position(block)[2] - zb0, zw0 - sim.node_position(winch)[2]
    assert rise == pytest.approx(hauled / 2, rel=2e-3)
    tension_at_block = 0.5 * (m * (G + nu * np.mean(speeds)) + lam * math.pi * radius * G)
    zb, zw = sim.node_position(block)[2], sim.node_position(winch)[2]
    pull = tension_at_block + lam * G * (zw - zb) - 0.1 * G
    assert np.mean(pulls) == pytest.approx(pull, rel=0.01)
    for sheave in ("block", "jib_sheave"):   # each wheel wrapped half a turn, to an element's turn
        assert abs(cosnet.slider_state(sim, scene.net.node(sheave))["wrap"] - math.pi) < 0.15


def test_purse_seine_closes_with_its_rings_on_the_purse_line():
    """The purse line slides through the nine rings of the net's foot and the boat's two
    blocks (eyelets): every ring stays on its centreline to round-off; the path from block to
    block through the rings is never longer than the line between the blocks (stretched at
    most by its largest strain), which the winch shortens, so the foot's round closes; energy +
    what the water and the eyelets took (at each vertex that passes a sharp turn,
    docs/sliding.md) - the winch's work stays what it was."""
    scene = case("purse_seine")
    sim = scene.simulation()
    net, purse = scene.net, scene.net.line("purse")
    rings = [net.node(f"ring{i:02d}") for i in range(9)]
    blocks = [net.node("block_a"), net.node("block_b")]
    rest = np.linalg.norm(np.diff(np.asarray(purse.points), axis=0), axis=1)

    def path():
        p = [sim.node_position(n) for n in (blocks[0], *rings, blocks[1])]
        return np.linalg.norm(np.diff(p, axis=0), axis=1)

    start, last = path()[1:-1].sum(), sim.balance()
    first = last
    while sim.time < 2.0 - 1e-9:
        sim.run(until=sim.time + 0.1)
        x = sim.line_positions(purse)
        for ring in rings:
            p = sim.node_position(ring)
            assert min(np.linalg.norm(np.cross(x[k + 1] - x[k], p - x[k])) / np.linalg.norm(x[k + 1] - x[k])
                       for k in range(len(x) - 1)) < 1e-9
        strain = (np.linalg.norm(np.diff(x, axis=0), axis=1) / rest).max() - 1.0
        between = cosnet.slider_state(sim, blocks[1])["s"] - cosnet.slider_state(sim, blocks[0])["s"]
        assert path().sum() <= between * (1.0 + strain)
        assert abs(sim.balance() - last) < 1e-4
        last = sim.balance()
    assert path()[1:-1].sum() < 0.75 * start
    assert abs(first - last) < 1e-4 * sim.dissipated()


def test_plectoneme_coils_onto_itself_without_passing_through():
    """The twisted rod, its end pulled in, stays straight with the motor torque G J theta / L
    until it buckles, then coils onto itself: at the end its strands touch (two capsules at
    2 r), and no two segments ever came much closer (no pass-through)."""
    from cosnet.kernels.contact import closest_points
    scene = case("plectoneme")
    sim = scene.simulation()
    line, motor = scene.net.line("rod"), scene.net.node("motor")
    radius = line.section_at(0.5).radius
    r2, n = 2.0 * radius, line.elements
    apart = [(i, j) for i in range(n) for j in range(i + 4, n)]   # 4 l > pi r: beyond the bend limit
    gj = line.material.G * math.pi * radius ** 4 / 2.0

    def closest():
        x = sim.line_positions(line)
        return min(closest_points(x[i], x[i + 1], x[j], x[j + 1])[2] for i, j in apart)
    sim.run(until=2.0)               # before Greenhill's twist: straight (the seed is tiny)
    u = sim.time / 7.0
    theta = 60.0 * u * u * (3.0 - 2.0 * u)   # the two-point clamped spline of the case's drive
    d = sim.node_rotation(motor)
    assert math.atan2(d[2, 1], d[1, 1]) % (2 * math.pi) == pytest.approx(theta % (2 * math.pi), abs=1e-9)
    assert sim.reaction(motor)[1][0] == pytest.approx(gj * theta / 1.0, rel=0.01)
    nearest = np.inf
    while sim.time < scene.run.until - 1e-9:
        sim.run(until=min(sim.time + 0.25, scene.run.until))
        nearest = min(nearest, closest())
    assert closest() < 1.05 * r2                                   # the strands touch
    assert nearest > 0.8 * r2                                      # and never pass through


def test_rope_pile_settles_into_a_pile_held_by_friction():
    """The ropes dropped criss-cross come to rest stacked: the top rope lies on others (more
    than three diameters up), none sinks into the ground beyond a tenth of its radius, and at
    the end every rope-rope pair and every ground contact sticks."""
    scene = case("rope_pile")
    sim = scene.simulation()
    ground = next(e for e in scene.effects if isinstance(e, cosnet.Obstacle))
    contact = next(e for e in scene.effects if isinstance(e, cosnet.Contact))
    e0 = sim.energy()
    sim.run(until=scene.run.until)
    r = scene.net.lines[0].section.radius
    z = np.concatenate([sim.line_positions(l)[:, 2] for l in scene.net.lines])
    assert z.max() > 6 * r and z.min() > 0.9 * r
    assert sim.energy_parts()["kinetic"] < 1e-3 * (e0 - sim.energy())
    assert contact.active_contacts(sim) >= 5 and contact.sliding(sim) == 0
    assert ground.active_contacts(sim) > 0 and ground.sliding(sim) == 0
    assert contact.dissipated(sim) > 0 and ground.dissipated(sim) > 0


def test_hinged_chain_conserves_energy_and_its_hinges_turn_freely():
    """Four arms on free hinges, released from the horizontal: nothing dissipates, so the energy
    stays within Verlet's error; a free hinge passes no moment about its axis (y)."""
    scene = case("hinged_chain")
    sim = scene.simulation()
    e0 = sim.energy()
    scale = free_weight(sim) * 2.0    # the weight falling through the chain's length
    worst = 0.0
    for _ in range(10):
        sim.run(steps=5000)
        worst = max(worst, abs(sim.energy() - e0))
        for line in scene.net.lines:
            assert abs(cosnet.joint_state(sim, line)["reaction"][1]) < 1e-8 * scale
    assert worst < 1e-6 * scale
    assert sim.node_position(scene.net.node("hand"))[2] < -0.1   # it fell (in 0.18 s)


def test_zip_line_trolley_rides_the_cable_and_keeps_the_energy_account():
    """The trolley (a ring) runs down the sagging cable: on its centreline to round-off, and
    energy + what its damper and the damping took stays what it was (Verlet's error)."""
    scene = case("zip_line")
    sim = scene.simulation()
    trolley = scene.net.node("trolley")
    e0 = sim.energy()
    sim.run(until=1.0)
    s = cosnet.slider_state(sim, trolley)["s"]
    assert s > 3.0 and sim.dissipated() > 0.0
    drop = free_weight(sim) * 10.0       # the net's weight over the towers' height difference
    assert abs(sim.energy() + sim.dissipated() - e0) < 1e-4 * drop
    x, p = sim.line_positions(scene.net.line("cable")), sim.node_position(trolley)
    gaps = [np.linalg.norm(np.cross(x[k + 1] - x[k], p - x[k])) / np.linalg.norm(x[k + 1] - x[k]) for k in range(100)]
    assert min(gaps) < 1e-9
