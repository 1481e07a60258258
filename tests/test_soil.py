"""A soft soil (a plane obstacle whose stiffness and damping are per unit of contact area, as
MoorDyn's seabed): a line lying on it sinks by its weight per length over 2 r k_soil at every
vertex, however its elements are spaced; it heaves on the soil as the damped oscillator of
stiffness 2 r k_soil and damping 2 r gamma_soil per length, energy conserved at order 2
without the damping; on a slope it holds below mu_s on springs that give the same at every
vertex and slides at g (sin - mu_k cos) above; each vertex's force is MoorDyn's
(kbot pen - cbot v) d l; the stable step counts it; bad input is refused in one line."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.scene.loader import build_scene

STEEL = cosnet.Material(E=2e11, G=8e10, density=7850.0)
R, G = 0.01, 9.81
PER_LENGTH = STEEL.density * math.pi * R * R     # kg/m
K_SOIL, GAMMA_SOIL = 3e6, 3e3                    # N/m^3, N s/m^3
SINK = PER_LENGTH * G / (2 * R * K_SOIL)         # m: the weight per length over the soil's stiffness per length
CRITICAL = 2 * math.sqrt(2 * R * K_SOIL * PER_LENGTH) / (2 * R)   # N s/m^3: the heave's critical damping
# uneven elements: each vertex's mass and contact area differ, their ratio does not
XS = np.cumsum([0.0, 0.05, 0.2, 0.1, 0.3, 0.05, 0.15, 0.25, 0.1])


def soil(**kw):
    kw.setdefault("k_soil", K_SOIL)
    return cosnet.Obstacle("plane", point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), **kw)


def lying(obstacle, height, dt=None, g=(0.0, 0.0, -G)):
    """A straight steel line of uneven elements along x, its axis at ``height`` over the
    soil's surface, free at both ends, under gravity g (on ``obstacle``, unless None)."""
    net = cosnet.Net()
    pts = np.column_stack([XS, np.zeros_like(XS), np.full_like(XS, height)])
    a, b = net.add_node(pts[0]), net.add_node(pts[-1])
    line = net.add_line(a, b, material=STEEL, section=cosnet.Circle(R), elements=len(XS) - 1, points=pts)
    effects = [cosnet.Gravity(g)] + ([obstacle] if obstacle is not None else [])
    return cosnet.Simulation(net, effects=effects, dt=dt), line, (a, b)


def test_a_line_on_a_soft_soil_sinks_by_its_weight_per_length_at_every_vertex():
    sim, line, _ = lying(soil(gamma_soil=CRITICAL), R)
    sim.run(until=0.3)
    sink = R - sim.line_positions(line)[:, 2]
    assert np.abs(sink / SINK - 1).max() < 1e-9
    # a stiffness per vertex (the same soil at the mean element's area) does not
    per_vertex, line2, _ = lying(cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1),
                                                 k=K_SOIL * 2 * R * XS[-1] / (len(XS) - 1), gamma=1e3), R)
    per_vertex.run(until=0.3)
    uneven = R - per_vertex.line_positions(line2)[:, 2]
    assert np.abs(uneven / SINK - 1).max() > 0.1


def heave(gamma_soil, until, dt=None, samples=400):
    """The line released at its resting depth moving down at 0.3 of the depth's heave speed;
    return (times, its mean depth below the rest, the analytic one, the energies, the energy
    of the heave)."""
    omega0 = math.sqrt(2 * R * K_SOIL / PER_LENGTH)
    decay = 2 * R * gamma_soil / (2 * PER_LENGTH)
    omega = math.sqrt(omega0 * omega0 - decay * decay)
    v0 = 0.3 * SINK * omega0
    sim, line, nodes = lying(soil(gamma_soil=gamma_soil), R - SINK, dt)
    sim.line_velocities(line)[:, 2] = -v0
    for nd in nodes:
        sim.node_velocity(nd)[2] = -v0
    times, depth, energy = [], [], []
    for t in np.linspace(0.0, until, samples + 1)[1:]:
        sim.run(until=t)
        times.append(sim.time)
        depth.append(float(np.mean(R - SINK - sim.line_positions(line)[:, 2])))
        energy.append(sim.energy())
    times = np.array(times)
    exact = v0 / omega * np.exp(-decay * times) * np.sin(omega * times)
    return times, np.array(depth), exact, np.array(energy), 0.5 * PER_LENGTH * XS[-1] * v0 * v0


@pytest.mark.parametrize("gamma_soil", [0.0, GAMMA_SOIL])
def test_a_line_heaves_on_a_soft_soil_as_its_damped_oscillator(gamma_soil):
    period = 2 * math.pi / math.sqrt(2 * R * K_SOIL / PER_LENGTH)
    _, depth, exact, *_ = heave(gamma_soil, 3 * period)
    assert np.abs(depth - exact).max() < 2e-4 * np.abs(exact).max()


def test_without_damping_the_soil_conserves_energy_at_order_two():
    """Position Verlet on the heave, a harmonic oscillator of frequency w: the energy swings
    by (w h)^2 / 4 of the heave's (the line's own modes are not excited: every vertex's soil
    stiffness per mass is the same)."""
    omega = math.sqrt(2 * R * K_SOIL / PER_LENGTH)
    errors = []
    for dt in (2e-6, 1e-6):
        *_, energy, heaving = heave(0.0, 2 * math.pi / omega, dt=dt)
        errors.append(np.abs(energy - energy[0]).max() / heaving)
        assert errors[-1] == pytest.approx((omega * dt) ** 2 / 4, rel=0.1)
    assert errors[0] / errors[1] > 3.5


def on_slope(theta, mu_s, mu_k, until):
    """The line on a soil tilted by theta towards +x (gravity turned), sunk by its weight's
    normal share so that its contacts are loaded from the start; return how far its centre
    moved along x."""
    ob = soil(gamma_soil=CRITICAL, mu_s=mu_s, mu_k=mu_k)   # (the stick springs damped critically)
    sim, line, _ = lying(ob, R - SINK * math.cos(theta), g=(G * math.sin(theta), 0.0, -G * math.cos(theta)))
    x0 = sim.line_positions(line)[:, 0].mean()
    sim.run(until=until)
    return sim.line_positions(line)[:, 0].mean() - x0, ob.sliding(sim)


def test_friction_on_a_soft_soil_holds_below_mu_s_and_slides_at_mu_k():
    """The soil scales each contact's spring, dashpot and normal force alike, so stick and
    slip are decided as on a stiff plane: held at 20 degrees (tan 0.36 < mu_s 0.5), sliding
    at 30 degrees (tan 0.58) with g (sin - mu_k cos)."""
    theta = math.radians(20)
    moved, sliding = on_slope(theta, 0.5, 0.3, 0.05)
    # held by the stick springs, which give the slope's pull over k_t = k_soil 2 r l at every vertex
    assert moved == pytest.approx(SINK * math.sin(theta), rel=1e-2) and sliding == 0
    theta, until = math.radians(30), 0.05
    moved, sliding = on_slope(theta, 0.5, 0.3, until)
    assert moved == pytest.approx(0.5 * G * (math.sin(theta) - 0.3 * math.cos(theta)) * until ** 2, rel=1e-2)
    assert sliding == len(XS)


def test_each_vertex_feels_moordyns_seabed_force():
    """On a seabed at depth D, MoorDyn pushes a node whose centre is pen below it by
    (kbot pen - cbot v_z) d l (d the diameter, l half its two segments); a soil plane r below
    the seabed gives each vertex that force."""
    depth, pen = 20.0, np.linspace(1e-3, 4e-3, len(XS))
    ob = cosnet.Obstacle("plane", point=(0.0, 0.0, -depth - R), normal=(0.0, 0.0, 1.0), k_soil=K_SOIL,
                         gamma_soil=GAMMA_SOIL)
    sim, line, _ = lying(ob, 0.0)
    sim.line_positions(line)[:, 2] = -depth - pen
    vz = np.linspace(-0.2, 0.05, len(XS))
    sim.line_velocities(line)[:, 2] = vz
    f = sim.effect_loads(ob).f[sim.model.line_vertex_offsets[line.index] + np.arange(len(XS))]
    seg = np.diff(XS)
    l = 0.5 * (np.r_[0.0, seg] + np.r_[seg, 0.0])
    # (positions 20 m down hold 4e-15 m: 4e-12 of the shallowest penetration)
    assert np.allclose(f[:, 2], (K_SOIL * pen - GAMMA_SOIL * vz) * 2 * R * l, rtol=1e-10, atol=0.0)
    assert np.all(f[:, :2] == 0.0)


def test_bad_soil_is_refused_in_one_line_and_a_scene_declares_it(tmp_path):
    with pytest.raises(ValueError, match=r"k_soil \(a soft soil\) is a plane's, not a sphere's"):
        cosnet.Obstacle("sphere", center=(0, 0, 0), radius=1.0, k_soil=K_SOIL)
    with pytest.raises(ValueError, match=r"give k_soil and gamma_soil .* not k, gamma \(per vertex\)"):
        soil(k=1e4, gamma=1.0)
    with pytest.raises(ValueError, match=r"gamma_soil needs k_soil"):
        cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=1e4, gamma_soil=1.0)
    with pytest.raises(ValueError, match=r"needs k \(N/m\), or on a plane k_soil"):
        cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1))
    with pytest.raises(ValueError, match=r"\(plane\): k_soil must be a finite number > 0"):
        soil(k_soil=-1.0)
    scene = {
        "materials": {"m": {"E": 2e11, "G": 8e10, "density": 7850.0}},
        "sections": {"s": {"kind": "circle", "radius": R}},
        "nodes": {"a": {"position": [0, 0, R]}, "b": {"position": [1, 0, R]}},
        "lines": {"rod": {"start": "a", "end": "b", "material": "m", "section": "s", "elements": 4}},
        "effects": [{"kind": "obstacle", "shape": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                     "k_soil": -3e6}],
        "run": {"until": 0.01},
    }
    with pytest.raises(ValueError) as e:
        build_scene(scene, path=tmp_path / "scene.toml")
    assert "\n" not in str(e.value) and "[[effects]] #1 (obstacle) k_soil: must be positive" in str(e.value)
    scene["effects"][0].update(k_soil=3e6, gamma_soil=3e5)
    sim = build_scene(scene, path=tmp_path / "scene.toml").simulation()
    ob = next(e for e in sim.effects if isinstance(e, cosnet.Obstacle))
    p = ob.params(sim)
    assert ob.soil and (p.k, p.gamma, p.k_t) == (3e6, 3e5, 0.0)   # per area; no friction, no stick spring
    assert np.allclose(p.scale, 2 * R * sim.model.voronoi_rest_length[p.verts], rtol=1e-15, atol=0.0)


def test_the_stable_step_counts_the_soil_at_its_stiffest_vertex():
    """The soil adds max(k, k_t) times the largest of a vertex's area over the mass it pushes
    to the bound on the highest frequency squared: 2 r k_soil / (rho A) on a line of one
    section, whatever its elements' lengths (each vertex's area and mass both scale with its
    Voronoi length, an end's too). (A soil stiff enough to weigh against the line's own
    frequencies, so that the difference of the two bounds keeps its digits.)"""
    from cosnet.kernels.stepping import stability_interval
    stiff = 1e6 * K_SOIL
    bare, _, _ = lying(None, R)
    on_soil, _, _ = lying(soil(k_soil=stiff), R)
    scale = on_soil.safety * stability_interval(on_soil.stepper)
    added = scale ** 2 * (1 / on_soil.stable_dt() ** 2 - 1 / bare.stable_dt() ** 2)
    assert added == pytest.approx(2 * R * stiff / PER_LENGTH, rel=1e-9)
