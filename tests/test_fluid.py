"""The fluid medium (cosnet.Fluid): drag, added mass, buoyancy, currents and waves, each
held to its analytic value. Every simulation here declares (Gravity, Fluid), so the suite
compiles one step for all of them."""

import gc
import math
import weakref
from pathlib import Path

import numba
import numpy as np
import pytest

import cosnet
from nets import resumed

RHO = 1000.0   # water
G = 9.81


def rod(points, density, radius=0.01, elements=8, pin=False):
    """A straight line through ``points`` (its two ends) between two point junctions; with
    ``pin`` the first is held in place and free to turn. Returns (net, start, end)."""
    mat = cosnet.Material(E=1e9, G=4e8, density=density)
    net = cosnet.Net()
    a = net.add_node(points[0], mass=np.inf, inertia=(0.0, 0.0, 0.0)) if pin else net.add_node(points[0])
    b = net.add_node(points[1])
    net.add_line(a, b, material=mat, section=cosnet.Circle(radius), elements=elements)
    return net, a, b


@pytest.mark.parametrize("axis, along", [((1.0, 0.0, 0.0), False), ((0.0, 0.0, 1.0), True)],
                         ids=["across", "along"])
def test_a_sinking_cylinder_reaches_the_terminal_velocity_of_its_drag(axis, along):
    # weight - upthrust = drag: (rho_s - rho) g A = 1/2 rho C_d d v^2 across the axis, on the
    # surface pi d along it; the added mass slows the approach, not the end
    r, rho_s, cd = 0.01, 2000.0, (1.2, 0.3)
    net, _, _ = rod(((0.0, 0.0, 0.0), axis), rho_s, r, elements=6)
    fluid = cosnet.Fluid(RHO, drag=cd, added_mass=(1.0, 0.0), buoyancy=True, surface=100.0)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    sim.run(until=4.0)
    per_length = 0.5 * RHO * (cd[1] * math.pi if along else cd[0]) * 2 * r
    v = math.sqrt((rho_s - RHO) * G * math.pi * r * r / per_length)
    assert np.allclose(sim.state.v[:, 2], -v, rtol=1e-3)
    assert np.allclose(sim.state.node_v[:, 2], -v, rtol=1e-3)


def test_a_pinned_heavy_rod_hangs_where_drag_and_weight_balance():
    # the moments about the pin of the normal drag k (U cos th)^2 and of the submerged
    # weight w sin th, both uniform along the rod, balance at sin th = (k U^2 / w) cos^2 th
    r, rho_s, U, cd = 0.01, 3000.0, 0.5, 1.2
    net, _, tip = rod(((0.0, 0.0, 0.0), (0.0, 0.0, -1.0)), rho_s, r, pin=True)
    fluid = cosnet.Fluid(RHO, velocity=(U, 0.0, 0.0), drag=(cd, 0.0), buoyancy=True, surface=10.0)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    sim.run(until=10.0)
    c = 0.5 * RHO * cd * 2 * r * U * U / ((rho_s - RHO) * G * math.pi * r * r)
    expected = math.asin((math.sqrt(1 + 4 * c * c) - 1) / (2 * c))
    x = sim.node_position(tip)
    assert math.atan2(x[0], -x[2]) == pytest.approx(expected, rel=5e-3)
    assert sim.supplied() > 0   # the current did work on the rod as it swung out


def test_a_neutrally_buoyant_line_is_taken_up_by_the_current_as_quadratic_drag_says():
    # across and along the line the relative velocity u keeps its direction and obeys
    # m u' = -k |u| u (m with the added mass): u = u0 / (1 + k u0 t / m), u0 = -U. The added
    # mass is the same both ways: with less along the line, the oblique flow's Munk moment
    # would turn it (test_fluid_turning.py)
    r, U = 0.01, np.array([0.6, 0.2, 0.0])
    net, _, _ = rod(((0.0, 0.0, -2.0), (1.0, 0.0, -2.0)), RHO, r, elements=4)
    fluid = cosnet.Fluid(RHO, velocity=U, drag=(1.2, 0.3), added_mass=(1.0, 1.0), buoyancy=True, surface=0.0)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    sim.run(until=3.0)
    mass = RHO * math.pi * r * r
    expected = []
    for u0, k, m in ((U[0], 0.5 * RHO * 0.3 * math.pi * 2 * r, 2 * mass), (U[1], 0.5 * RHO * 1.2 * 2 * r, 2 * mass)):
        expected.append(u0 - u0 / (1 + k * u0 * sim.time / m))
    assert np.allclose(sim.state.v[:, :2], expected, rtol=1e-4)
    assert np.allclose(sim.state.node_v[:, :2], expected, rtol=1e-3)
    assert np.max(np.abs(sim.state.v[:, 2])) < 1e-9   # neutral: no sinking


def test_added_mass_lowers_a_submerged_cantilevers_frequency_by_the_mass_ratio():
    # every translational mass of the beam grows from m to m (1 + C_a rho / rho_s) across
    # the line; the rotary inertia (slender: negligible) does not
    rho_s = 1500.0

    def period(fluid):
        mat = cosnet.Material(E=2e9, G=8e8, density=rho_s)
        net = cosnet.Net()
        root, tip = net.add_node((0.0, 0.0, 0.0), fixed=True), net.add_node((1.0, 0.0, 0.0))
        net.add_line(root, tip, material=mat, section=cosnet.Circle(0.01), elements=10)
        sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0)), fluid])
        s = np.linspace(0.0, 1.0, 11)
        sim.state.v[:, 1] = 0.005 * s * s * (3 - s)   # near the first mode's shape
        sim.state.node_v[1, 1] = sim.state.v[-1, 1]
        ts, ys = [], []
        while sim.time < 2.0:
            sim.run(steps=25)
            ts.append(sim.time)
            ys.append(sim.node_position(tip)[1])
        t, y = np.array(ts), np.array(ys)
        i = np.flatnonzero((y[:-1] < 0) & (y[1:] >= 0))
        up = t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])
        return (up[-1] - up[0]) / (len(up) - 1)

    dry = period(cosnet.Fluid(RHO, lines=[]))
    wet = period(cosnet.Fluid(RHO, added_mass=(1.0, 0.0)))
    assert dry / wet == pytest.approx(math.sqrt(rho_s / (rho_s + RHO)), rel=5e-3)


def test_a_neutral_dragless_particle_follows_the_airy_orbit():
    # rho V (1 + C_a) A = (m + C_a rho V) a with m = rho V: the particle's acceleration is the
    # water's, so it moves on the linear wave's orbit, semi-axes a cosh / sinh (k (z + d)) / sinh(k d)
    amp, period, depth, z0 = 0.02, 4.0, 20.0, -2.0
    mat = cosnet.Material(E=1e5, G=4e4, density=RHO)
    net = cosnet.Net()
    p, q = net.add_node((-0.025, 0.0, z0)), net.add_node((0.025, 0.0, z0))
    net.add_line(p, q, material=mat, section=cosnet.Circle(0.005), elements=1)
    fluid = cosnet.Fluid(RHO, buoyancy=True, added_mass=(1.0, 1.0), surface=0.0, depth=depth,
                         wave_amplitudes=[amp], wave_periods=[period])
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    w = 2 * math.pi / period
    k = cosnet.wave_number(w, depth, G)
    assert w * w == pytest.approx(G * k * math.tanh(k * depth), rel=1e-12)
    ch = math.cosh(k * (z0 + depth)) / math.sinh(k * depth)
    sh = math.sinh(k * (z0 + depth)) / math.sinh(k * depth)
    sim.state.v[:, 0] = sim.state.node_v[:, 0] = amp * w * ch   # on the orbit at t = 0
    ts, xs = [], []
    while sim.time < period:
        sim.run(steps=10)
        ts.append(sim.time)
        xs.append(0.5 * (sim.node_position(p) + sim.node_position(q)))
    t, x = np.array(ts), np.array(xs)
    # the orbit's semi-axes, apart from the (second-order) Stokes drift
    fit = np.column_stack([np.ones_like(t), t, np.cos(w * t), np.sin(w * t)])
    for column, expected in ((0, amp * ch), (2, amp * sh)):
        c = np.linalg.lstsq(fit, x[:, column], rcond=None)[0]
        assert math.hypot(c[2], c[3]) == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize("axis, along", [((1.0, 0.0, 0.0), False), ((0.0, 0.0, 1.0), True)],
                         ids=["sideways", "lengthwise"])
def test_stokes_flow_resists_sideways_and_lengthwise_by_its_coefficients(axis, along):
    # resistive-force theory: a filament settling under its weight w per length moves at
    # w / c_n sideways and w / c_t lengthwise, c_n / c_t the theory's ratio (near 2)
    cn, ct = cosnet.resistive_coefficients(10.0, 0.01, 1.0)
    assert 1.5 < cn / ct < 2.0
    net, _, _ = rod(((0.0, 0.0, 0.0), axis), 1200.0, elements=6)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), cosnet.Fluid(RHO, resistance=(cn, ct))])
    sim.run(until=0.4)   # 30 relaxation times m / c
    w = 1200.0 * G * math.pi * 0.01 ** 2
    # the split step's steady state is off by (c h / m)^2 / 24 (here ~1e-5)
    assert np.allclose(sim.state.v[:, 2], -w / (ct if along else cn), rtol=1e-4)


def test_a_tilted_rod_settles_as_pyelastica_s_slender_body_theory_says():
    # local slender-body theory as PyElastica has it (Gazzola et al. 2018, eq. 4.13), the
    # resistive law with cosnet.slender_body_coefficients: a rod tilted 45 degrees settles at
    # the velocity whose force by PyElastica's own kernel balances its weight, drifting
    # sideways as it sinks (the lengthwise resistance is half the sideways one)
    interaction = pytest.importorskip("elastica.interaction", reason="PyElastica (pip install '.[peers]') "
                                      "is not installed")
    mu, radius, length, n = 10.0, 0.01, 1.0, 8
    t = np.array([1.0, 0.0, 1.0]) / math.sqrt(2.0)
    net, _, _ = rod(((0.0, 0.0, 0.0), tuple(length * t)), 1200.0, radius=radius, elements=n)
    fluid = cosnet.Fluid(RHO, resistance=cosnet.slender_body_coefficients(mu, 2 * radius, length))
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    sim.run(until=1.0)   # 35 relaxation times m / c_t
    # PyElastica's force on the same rod moving at each unit velocity: its resistance matrix
    tangents, lengths = np.repeat(t[:, None], n, axis=1), np.full(n, length / n)
    drag = np.column_stack([interaction.slender_body_forces(tangents, np.repeat(e[:, None], n + 1, axis=1), mu,
                                                            lengths, np.full(n, radius), np.ones(n + 1)).sum(axis=1)
                            for e in np.eye(3)])
    weight = np.array([0.0, 0.0, -1200.0 * G * math.pi * radius ** 2 * length])
    settled = np.linalg.solve(drag, -weight)
    assert settled[0] < -0.3 * abs(settled[2])   # a drift the isotropic law would not give (1/3 here)
    assert np.allclose(sim.state.v, settled, rtol=1e-4, atol=1e-4 * np.abs(settled).max())
    with pytest.raises(ValueError, match="slender_body_coefficients: length 0.01 must exceed the diameter 0.02"):
        cosnet.slender_body_coefficients(mu, 0.02, 0.01)


@pytest.mark.parametrize("added", [(0.0, 0.0), (1.0, 0.2)])
def test_energy_and_what_drag_dissipates_are_conserved_at_order_two(added):
    # a rod swinging through the free surface of still water: drag, buoyancy cut at the
    # surface; the balance closes at the scheme's order. With added mass, a vertex entering
    # the water (its fourth, early in the swing) sets its entrained fluid moving at once: work
    # Morison's M v' = f leaves out, counted in supplied(); without that account the drift
    # would not shrink with the step. (The fluid turning with the rod is in its forces,
    # kernels/added_mass.py, and supplies nothing: test_fluid_turning.py.)
    def balance(dt):
        net, _, _ = rod(((0.0, 0.0, 0.0), (math.sin(0.5), 0.0, -math.cos(0.5))), 3000.0, 0.02, 6, pin=True)
        fluid = cosnet.Fluid(RHO, drag=(1.2, 0.2), added_mass=added, buoyancy=True, surface=-0.45)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid], dt=dt, force_dt=True)
        e0 = sim.energy()
        sim.run(until=0.2)
        assert sim.dissipated() > 0.01 * abs(e0)
        if any(added):
            assert abs(sim.supplied()) > 1e-4 * sim.dissipated()
        else:
            assert sim.supplied() == 0.0
        return sim.energy() + sim.dissipated() - sim.supplied() - e0

    errors = [abs(balance(dt)) for dt in (4e-5, 2e-5)]
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.1)


@pytest.mark.parametrize("added, law", [((0.0, 0.0), "morison"), ((1.0, 0.2), "morison"), ((1.0, 0.2), "lagrange")])
def test_a_body_spinning_in_a_current_on_its_lines_keeps_its_balance_at_order_two(added, law):
    # three lines on arms of a buoyant body spinning in a current: the drag at their ends puts
    # a torque on the body, and the medium does work; with added mass, the fluid at the ends
    # moves with the body's centre of mass (it adds to the body's mass, not to its rotary
    # inertia), and the energy counts it so: at the ends' own speeds (the spin's w x r
    # included) the balance was off by a constant 0.76 J, the same at every step
    mat = cosnet.Material(E=1e8, G=4e7, density=3000.0)

    def balance(dt):
        net = cosnet.Net()
        body = net.add_node((0.0, 0.0, -3.0), mass=5.0, inertia=(0.3, 0.5, 0.4))
        for k, (dx, dy) in enumerate(((1.0, 0.0), (0.0, 1.0), (-1.0, 0.3))):
            far = net.add_node((1.5 * dx, 1.5 * dy, -3.5), mass=0.5, inertia=(0.01, 0.01, 0.01))
            net.add_line(body, far, material=mat, section=cosnet.Circle(0.02), elements=4,
                         start_offset=(0.2 * dx, 0.2 * dy, 0.05 * k))
        fluid = cosnet.Fluid(RHO, velocity=(0.3, -0.2, 0.1), drag=(1.2, 0.1), added_mass=added, buoyancy=True,
                             surface=0.0, buoys=[body], buoy_volumes=[0.004], buoy_drag_areas=[0.02],
                             added_mass_law=law)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid], dt=dt, force_dt=True)
        sim.state.node_w[0] = (5.0, -3.0, 8.0)
        assert options_named(fluid.params(sim), sim.model)["ARMS"]   # (fluid_step.drag_nodes)
        e0 = sim.energy()
        sim.run(until=0.2)
        assert sim.dissipated() > 0.04 * abs(e0) and sim.supplied() > 0.05 * sim.dissipated()
        return sim.energy() + sim.dissipated() - sim.supplied() - e0, sim.dissipated()

    (coarse, _), (fine, taken) = balance(2e-5), balance(1e-5)
    assert abs(fine) < 1e-6 * taken
    assert math.log2(coarse / fine) > 1.7     # order 2 (measured 1.81-1.85); a fault in the account: order 0


def test_a_rod_swinging_in_water_converges_at_order_two_after_an_odd_number_of_steps():
    # drag runs in halves on both sides of every kick, and the medium is sampled once a kick
    # (p.turn: which side is next): the positions after an odd number of steps, 13335, and
    # 26670 and 53340 of half and a quarter the size, converge at order 2 (differences in the
    # ratio 4)
    def tip(steps):
        net, _, end = rod(((0.0, 0.0, 0.0), (math.sin(0.8), 0.0, -math.cos(0.8))), 3000.0, 0.02, 6, pin=True)
        fluid = cosnet.Fluid(RHO, velocity=(0.0, 0.2, 0.0), drag=(1.2, 0.2), added_mass=(1.0, 0.0), buoyancy=True)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid], dt=0.2 / steps, force_dt=True)
        sim.run(steps=steps)
        return sim.node_position(end)

    a, b, c = (tip(steps) for steps in (13335, 2 * 13335, 4 * 13335))
    assert np.linalg.norm(a - b) > 1e-9        # the step's error is measurable above round-off
    assert np.linalg.norm(a - b) / np.linalg.norm(b - c) == pytest.approx(4.0, rel=0.1)


def test_measuring_the_energy_mid_run_leaves_the_run_unchanged():
    # the energy and the accounts sample the medium at the present positions, in the step's own
    # record, and put back what the step holds (the added mass sampled half a step before): a
    # run measured halfway ends bit for bit where the same run unmeasured does
    net, _, _ = rod(((0.0, 0.0, -0.1), (math.sin(0.8), 0.0, -0.1 - math.cos(0.8))), 3000.0, 0.02, 6, pin=True)

    def run(measure):
        fluid = cosnet.Fluid(RHO, drag=(1.2, 0.1), added_mass=(1.0, 0.0), buoyancy=True, surface=0.0)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
        sim.run(steps=150)   # (the watch measures at the end of the first run only)
        sim.run(steps=150)
        held = sim.effect_params(fluid).sample.copy()
        if measure:
            sim.energy(), fluid.supplied(sim), sim.momentum()
            assert np.array_equal(sim.effect_params(fluid).sample, held)
        sim.run(steps=150)
        return sim, fluid

    (a, fa), (b, fb) = run(False), run(True)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    assert (fa.dissipated(a), fa.supplied(a), a.energy()) == (fb.dissipated(b), fb.supplied(b), b.energy())


@pytest.mark.parametrize("law", ["morison", "lagrange"])
def test_a_line_rising_through_the_surface_moves_as_if_sampled_whole_at_every_kick(law):
    # a line under a still surface at two samples running keeps its wetness, inverse masses
    # and upthrust from the first (kernels/fluid.sample_medium, row SOAKED_ROW): a buoyant rod
    # released under water, rising wholly submerged and then through the surface, moves bit for
    # bit as the same rod whose every sample writes every row (the row cleared before each
    # step), with the same accounts (the work supplied to round-off)
    from cosnet.kernels.fluid import SOAKED_ROW

    def run(whole):
        net = cosnet.Net()
        a, b = net.add_node((0.0, 0.0, -0.2)), net.add_node((1.0, 0.0, -0.4))
        net.add_line(a, b, material=cosnet.Material(E=1e7, G=4e6, density=600.0), section=cosnet.Circle(0.02),
                     elements=6)
        fluid = cosnet.Fluid(RHO, drag=(1.2, 0.1), added_mass=(1.0, 0.2), buoyancy=True, surface=0.0,
                             added_mass_law=law)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
        sample, soaked = sim.effect_params(fluid).sample, 0
        for _ in range(int(0.8 / sim.dt)):
            soaked += int(sample[SOAKED_ROW, 0] == 1.0)
            if whole:
                sample[SOAKED_ROW, :] = 0.0
            sim.run(steps=1)
        return sim, fluid, soaked

    (a, fa, soaked), (b, fb, _) = run(False), run(True)
    assert soaked > 100 and a.state.x[:, 2].max() > 0.0   # it rose under water, then broke the surface
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
    assert (fa.dissipated(a), a.energy()) == (fb.dissipated(b), b.energy())
    # (the entrained energy's change, summed in vector lanes by a loop of another body)
    assert fa.supplied(a) == pytest.approx(fb.supplied(b), rel=1e-13)


def test_a_discarded_simulation_is_freed_though_its_energy_was_measured():
    # the energy's kernels keep their typed entry points by their arguments' identities
    # (kernels.layout.typed_call), weakly: a sweep's discarded nets must not stay in memory
    def measured():
        net, _, _ = rod(((0.0, 0.0, -1.0), (1.0, 0.0, -1.3)), 2000.0, elements=6)
        fluid = cosnet.Fluid(RHO, drag=(1.2, 0.1), added_mass=(1.0, 0.0), buoyancy=True, surface=0.0)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
        sim.run(steps=100)
        sim.energy(), fluid.supplied(sim)
        return [weakref.ref(a) for a in (sim.state.x, sim.model.vertex_mass, sim.effect_params(fluid).sample)]

    arrays = measured()
    gc.collect()
    assert all(a() is None for a in arrays)


@pytest.mark.parametrize("added", [(0.0, 0.0), (1.0, 0.0)])
def test_checkpoint_round_trip_keeps_the_accounts(tmp_path, added):
    # with added mass less along the line than across, the oblique flow turns the rod and the
    # turning fluid's forces of the last kick (the next one's predictor) are state too
    net, _, _ = rod(((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), 2000.0, elements=4)

    def sim():
        return cosnet.Simulation(net, [cosnet.Gravity(), cosnet.Fluid(RHO, velocity=(0.3, 0.0, 0.0), drag=(1.2, 0.1),
                                                                      added_mass=added, buoyancy=True)])
    a, b = resumed(sim, tmp_path / "c.npz", 500, 500)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.node_v, b.state.node_v)
    assert (a.dissipated(), a.supplied()) == (b.dissipated(), b.supplied())


@pytest.mark.parametrize("kwargs, words", [
    (dict(density=-1.0), "density"),
    (dict(density=RHO, drag=(-1.0, 0.0)), "drag"),
    (dict(density=RHO, added_mass=(1.0, -0.5)), "added_mass"),
    (dict(density=RHO, drag=(1.0, 0.0), resistance=(1.0, 0.5)), "not both"),
    (dict(density=RHO, surface=0.0, depth=1.0, wave_amplitudes=[1.5], wave_periods=[3.0]), "depth"),
    (dict(density=RHO, wave_amplitudes=[0.5], wave_periods=[3.0]), "surface"),
    (dict(density=RHO, times=[0.0, 2.0, 1.0], values=[1.0, 1.0, 1.0]), "increase"),
    (dict(density=RHO, profile_heights=[0.0, -1.0], profile_factors=[1.0, 1.0]), "increase"),
    (dict(density=RHO, buoys=["a"]), "buoy_volumes"),
    (dict(density=RHO, buoys=["a"], buoy_volumes=[0.0]), "buoy_volumes"),
    (dict(density=RHO, buoys=["a", "b"], buoy_volumes=[1.0]), "buoy_volumes"),
    (dict(density=RHO, buoys=["a"], buoy_volumes=[1.0], buoy_drag_areas=[-1.0]), "buoy_drag_areas"),
    (dict(density=RHO, buoy_volumes=[1.0]), "need buoys"),
    (dict(density=RHO, resistance=(1.0, 0.5), buoys=["a"], buoy_volumes=[1.0], buoy_drag_areas=[0.1]), "Stokes"),
    (dict(density=RHO, velocity=(1.0, 0, 0), turbulence_intensity=0.1, times=[0.0], values=[1.0]), "not both"),
    (dict(density=RHO, turbulence_intensity=0.1), "needs a velocity"),
    (dict(density=RHO, velocity=(1.0, 0, 0), turbulence_intensity=-0.1), "turbulence_intensity"),
    (dict(density=RHO, velocity=(1.0, 0, 0), turbulence_intensity=0.1, turbulence_step=0.7), "whole number"),
    (dict(density=RHO, velocity=(1.0, 0, 0), turbulence_intensity=0.1, turbulence_seed=-1), "turbulence_seed"),
])
def test_bad_values_are_refused_in_one_line(kwargs, words):
    with pytest.raises(ValueError) as e:
        cosnet.Fluid(**kwargs)
    assert words in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("spoil, message", [
    (lambda p: p.lines.__setitem__(0, 7), "fluid.lines holds 7"),
    (lambda p: p.line_row.__setitem__(0, 3), "fluid.line_row holds 3"),
])
def test_spoilt_fluid_tables_are_refused_before_a_run(spoil, message):
    net, _, _ = rod(((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), 2000.0, elements=2)
    fluid = cosnet.Fluid(RHO, drag=(1.2, 0.1))
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    spoil(fluid.params(sim))
    with pytest.raises(ValueError, match="^Simulation.run: " + message):
        sim.run(steps=1)
    assert sim.steps == 0


def test_buoyancy_needs_gravity_pointing_down():
    net, _, _ = rod(((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)), 2000.0, elements=2)
    with pytest.raises(ValueError, match="along -z"):
        cosnet.Simulation(net, [cosnet.Gravity((9.81, 0.0, 0.0)), cosnet.Fluid(RHO, buoyancy=True)])


SCENE = """
title = "a rod in a current"
[materials.m]
E = 1e9
G = 4e8
density = 2000.0
[sections.s]
kind = "circle"
radius = 0.01
[nodes.a]
position = [0.0, 0.0, 0.0]
[nodes.b]
position = [1.0, 0.0, 0.0]
[lines.rod]
start = "a"
end = "b"
material = "m"
section = "s"
elements = 4
[[effects]]
kind = "gravity"
[[effects]]
kind = "fluid"
density = {density}
velocity = [0.5, 0.0, 0.0]
drag = [1.2, 0.1]
buoyancy = true
lines = ["rod"]
buoys = ["b"]
buoy_volumes = [2e-4]
buoy_drag_areas = [0.01]
[run]
until = 0.1
"""


def test_the_scene_declares_the_fluid_and_refuses_a_bad_key_in_one_line(tmp_path):
    good = tmp_path / "good.toml"
    good.write_text(SCENE.format(density=1000.0))
    sim = cosnet.load_scene(good).simulation()
    assert any(isinstance(e, cosnet.Fluid) for e in sim.effects)
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENE.format(density=-5.0))
    with pytest.raises(ValueError) as e:
        cosnet.load_scene(bad).simulation()
    msg = str(e.value)
    assert "bad.toml" in msg and "density" in msg and "\n" not in msg
    (fluid,) = [e for e in sim.effects if isinstance(e, cosnet.Fluid)]
    assert [nd.name for nd in sim.net.nodes if sim.effect_params(fluid).buoy[nd.index] >= 0] == ["b"]
    bad.write_text(SCENE.format(density=1000.0).replace('buoys = ["b"]', 'buoys = ["c"]'))
    with pytest.raises(ValueError) as e:
        cosnet.load_scene(bad)
    msg = str(e.value)
    assert "bad.toml" in msg and "buoys" in msg and "unknown node 'c'" in msg and "\n" not in msg


# ------------------------------------------------------------------ buoys: nodes with a volume
SPHERE = 0.1                                     # m^3, radius R
R = (3.0 * SPHERE / (4.0 * math.pi)) ** (1.0 / 3.0)


def buoy(mass, depth, drag_area=0.0, added=0.5, surface=0.0):
    """A sphere buoy alone (a net of one node) with its centre ``depth`` below the surface."""
    net = cosnet.Net()
    nd = net.add_node((0.0, 0.0, surface - depth), mass=mass, inertia=(1.0, 1.0, 1.0))
    fluid = cosnet.Fluid(RHO, buoyancy=True, surface=surface, buoys=[nd], buoy_volumes=[SPHERE],
                         buoy_drag_areas=[drag_area], buoy_added_mass=[added])
    return cosnet.Simulation(net, [cosnet.Gravity(), fluid], dt=1e-3), nd


def submerged(depth):
    """The volume of the sphere below the surface, its centre ``depth`` below it (a cap)."""
    d = min(max(depth, -R), R)
    return math.pi * (R + d) ** 2 * (2.0 * R - d) / 3.0


def test_a_buoy_rises_at_the_terminal_velocity_of_its_drag():
    # (rho V - m) g = 1/2 rho C_d A v^2, deep under the surface; the added mass slows the
    # approach, not the end
    sim, nd = buoy(50.0, 50.0, drag_area=0.05)
    sim.run(until=5.0)
    v = math.sqrt(2.0 * (RHO * SPHERE - 50.0) * G / (RHO * 0.05))
    assert sim.node_velocity(nd)[2] == pytest.approx(v, rel=1e-4)


def test_a_buoy_floats_where_it_displaces_its_weight():
    # rho V_sub(d) = m: the cap's volume at the analytic draught holds the buoy still
    from scipy.optimize import brentq
    mass = 50.0
    d = brentq(lambda d: submerged(d) - mass / RHO, -R, R, xtol=1e-15)
    sim, nd = buoy(mass, d, drag_area=0.05)
    sim.run(until=2.0)
    assert abs(sim.node_position(nd)[2] + d) < 1e-12 * R
    assert np.abs(sim.node_velocity(nd)).max() < 1e-12


def test_a_buoy_heaves_at_its_waterplane_period_and_keeps_its_energy():
    # small heave about the draught d: (m + C_a rho V_sub) z'' = -rho g pi (R^2 - d^2) z; without
    # drag the energy (the upthrust's potential, the entrained water's kinetic energy whose
    # mass changes with the draught, kept in supplied()) is conserved to the scheme's order
    from scipy.optimize import brentq
    mass = 50.0
    d = brentq(lambda d: submerged(d) - mass / RHO, -R, R, xtol=1e-15)
    sim, nd = buoy(mass, d - 1e-3)
    b0 = sim.balance()
    t, z = [], []
    while sim.time < 6.0:
        sim.run(steps=5)
        t.append(sim.time)
        z.append(sim.node_position(nd)[2] + d)
    t, z = np.array(t), np.array(z)
    k = np.where((z[:-1] < 0) & (z[1:] >= 0))[0]
    ups = t[k] - z[k] * (t[k + 1] - t[k]) / (z[k + 1] - z[k])     # upward crossings, interpolated
    period = (ups[-1] - ups[0]) / (len(ups) - 1)
    expected = 2 * math.pi * math.sqrt((mass + 0.5 * RHO * submerged(d)) / (RHO * G * math.pi * (R * R - d * d)))
    assert period == pytest.approx(expected, rel=1e-3)
    # Verlet's energy error ~ (omega dt)^2 / 8 of the heave's energy 1/2 rho g A_w a^2
    omega, heave = 2 * math.pi / expected, 0.5 * RHO * G * math.pi * (R * R - d * d) * 1e-6
    assert sim.supplied() != 0.0
    assert abs(sim.balance() - b0) < (omega * sim.dt) ** 2 / 8 * heave


WIRE_DEPTH, WIRE_SPAN, WIRE_LENGTH, WIRE_R, WIRE_DENSITY, WIRE_E, SEA = 20.0, 40.0, 47.0, 0.02, 7850.0, 1e11, 1025.0
WIRE_AREA = math.pi * WIRE_R ** 2
WIRE_W = (WIRE_DENSITY - SEA) * G * WIRE_AREA        # weight in water per length


def moored_wire(catenary, fairlead_x, **fairlead):
    """(net, fairlead node, line): 47 m of steel wire (r = 2 cm, a chain's bending) from an
    anchor on the seabed 20 m down to a fairlead at the surface ``fairlead_x`` away (its node
    made with ``fairlead``), laid on MoorPy's frictionless elastic catenary (24 elements)."""
    guess = catenary(fairlead_x, WIRE_DEPTH, WIRE_LENGTH, WIRE_E * WIRE_AREA, WIRE_W, CB=0.0, nNodes=25, plots=1)[4]
    net = cosnet.Net()
    anchor = net.add_node((0.0, 0.0, -WIRE_DEPTH), fixed=True)
    node = net.add_node((fairlead_x, 0.0, 0.0), **fairlead)
    line = net.add_line(anchor, node, material=cosnet.Material(E=WIRE_E, G=WIRE_E / 2.6, density=WIRE_DENSITY),
                        section=cosnet.Section(A=WIRE_AREA, I11=1e-9, I22=1e-9, J=2e-9, radius=WIRE_R),
                        elements=24, points=np.column_stack([guess["X"], np.zeros(25), guess["Z"] - WIRE_DEPTH]),
                        rest_curvature=(0.0, 0.0, 0.0))
    return net, node, line


def wire_forces(sim, line):
    """(the line's force at each element, what holds the fairlead): the fairlead carries the
    end's half element besides the line's force there."""
    n = sim.line_fields(line)["force"]
    return n, n[-1] + np.array([0.0, 0.0, WIRE_W * line.length / 48])


def test_a_mooring_line_on_the_seabed_settles_on_moorpys_catenary():
    # a wire hanging in still water from a fixed fairlead to an anchor, its lower part on a
    # frictionless seabed (MoorPy's quasi-static solution is for a fully mobilised friction,
    # which a line laid down in a dynamic run need not reach): the tensions and the length on
    # the seabed match the elastic catenary's
    catenary = pytest.importorskip("moorpy.Catenary", reason="MoorPy (pip install '.[peers]') is "
                                   "not installed").catenary
    net, _, line = moored_wire(catenary, WIRE_SPAN, fixed=True)     # starts near rest
    # a linear resistance (rate c / m = 4/s) brings the line to rest; the statics do not depend on it
    fluid = cosnet.Fluid(SEA, resistance=(40.0, 40.0), added_mass=(1.0, 0.0), buoyancy=True, surface=0.0)
    bed = cosnet.Obstacle("plane", point=(0.0, 0.0, -WIRE_DEPTH - WIRE_R), normal=(0.0, 0.0, 1.0), k=1e6)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid, bed], fast_modes="auto")
    sim.run(until=6.0)
    _, _, fh, fv, info = catenary(WIRE_SPAN, WIRE_DEPTH, line.length, WIRE_E * WIRE_AREA, WIRE_W, CB=0.0)
    n, held = wire_forces(sim, line)
    assert held[0] == pytest.approx(-fh, rel=0.01) and held[2] == pytest.approx(-fv, rel=0.01)
    assert n[0][0] == pytest.approx(info["HA"], rel=0.01)
    grounded = line.length - held[2] / WIRE_W     # the suspended part's weight is the fairlead's pull
    assert grounded == pytest.approx(info["LBot"], rel=0.01)


def test_a_mooring_line_pulled_out_over_a_seabed_with_friction_matches_moorpys_catenary():
    """MoorPy's catenary with seabed friction (CB) has the friction fully mobilised: the
    tension on the seabed falls towards the anchor by CB w per length. A line that slides on
    the bed gets there: laid at the frictionless catenary of a fairlead 1.5 m closer, then
    pulled out to the span over 20 s, its tension rises by more than CB w times the laid
    length everywhere on the bed, so every grounded vertex slides towards the fairlead and its
    friction reaches mu N (the stick spring's give mu N / k_t, 1e-6 m with k_t = 1e8 N/m, far
    below the line's elastic slide on the bed, about 1e-4 m). The fairlead's pull and the
    grounded length then match MoorPy's within 1 %. The anchor's vertex is fixed, so the
    friction of its half element goes to the anchor and not into the first element's force:
    that force is MoorPy's anchor tension plus mu w l / 2, within the touchdown's own
    element's share mu w l / 2 (where on it the line lifts off)."""
    catenary = pytest.importorskip("moorpy.Catenary", reason="MoorPy (pip install '.[peers]') is "
                                   "not installed").catenary
    pull, mu, w = 1.5, 0.5, WIRE_W
    net, fairlead, line = moored_wire(catenary, WIRE_SPAN - pull, mass=1.0, inertia=(0.1, 0.1, 0.1))
    fluid = cosnet.Fluid(SEA, resistance=(40.0, 40.0), added_mass=(1.0, 0.0), buoyancy=True, surface=0.0)
    bed = cosnet.Obstacle("plane", point=(0.0, 0.0, -WIRE_DEPTH - WIRE_R), normal=(0.0, 0.0, 1.0), k=1e6, k_t=1e8,
                          mu_s=mu, mu_k=mu)
    s = np.linspace(0.0, 1.0, 41)
    hold = np.arange(23.0, 31.0)                  # knots that keep the path's spline flat after the pull
    path = {"times": [0.0, *(2.0 + 20.0 * s), *hold],
            "values": [[0.0, 0.0, 0.0], *[[pull * x * x * (3 - 2 * x), 0.0, 0.0] for x in s], *[[pull, 0.0, 0.0]] * 8]}
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid, bed, cosnet.Drive(fairlead, position=path)],
                            fast_modes="auto")
    sim.run(until=25.0)
    assert sim.node_position(fairlead)[0] == pytest.approx(WIRE_SPAN, abs=1e-6)
    _, _, fh, fv, info = catenary(WIRE_SPAN, WIRE_DEPTH, line.length, WIRE_E * WIRE_AREA, w, CB=mu)
    n, held = wire_forces(sim, line)
    assert held[0] == pytest.approx(-fh, rel=0.01) and held[2] == pytest.approx(-fv, rel=0.01)
    assert line.length - held[2] / w == pytest.approx(info["LBot"], rel=0.01)
    half = mu * w * line.length / 48
    assert abs(n[0][0] - (info["HA"] + half)) < half
    assert n[0][0] < held[0] - 0.5 * mu * w * info["LBot"]        # the bed took a share: friction acted


def test_a_mooring_line_under_a_surging_fairlead_swings_as_moordyn_does(monkeypatch):
    """bench/moordyn_compare.py's catenary wire (47 m, 24 elements; drag, added mass, buoyancy,
    a frictionless seabed) under a 1 m, 8 s surge of its fairlead, in cosnet's default and in
    MoorDyn (24 segments, coupled every millisecond, where its swing is within about 1 % of
    its converged one): the first harmonic of the fairlead's pull (cosnet's sampled every 5 ms),
    H and V, within 5 % in amplitude and 2 % of the period in phase."""
    pytest.importorskip("moorpy.Catenary", reason="MoorPy (pip install '.[peers]') is not installed")
    pytest.importorskip("moordyn", reason="MoorDyn (pip install '.[peers]') is not installed")
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "bench"))
    import moordyn_compare as bench
    monkeypatch.setattr(bench, "SAMPLE", 5e-3)    # the bench's 1 ms gives the same harmonics to 0.1 %
    mine, theirs = bench.run_cosnet(24, timed=False), bench.run_moordyn(24, 1e-4, 1e-3)
    for k in ("H", "V"):
        assert mine[k]["amplitude"] == pytest.approx(theirs[k]["amplitude"], rel=0.05)
        assert abs(mine[k]["phase"] - theirs[k]["phase"]) < 0.02 * 2 * math.pi


def forcing(monkeypatch, *names):
    """Have every fluid's record be of the variant with the options ``names`` on (kernels/fluid.py
    OPTIONS) beside those its data has."""
    from cosnet.kernels import fluid, fluid_variants
    options_of, on = fluid_variants.options_of, {fluid.OPTIONS.index(name) for name in names}
    monkeypatch.setattr(fluid_variants, "options_of",
                        lambda p, model=None, threads=1: tuple(o or k in on
                                                                for k, o in enumerate(options_of(p, model, threads))))


def swinging_wire(law, **medium):
    """(simulation, fluid): a steel wire of 24 elements between pins, from 1 m under the surface
    to 0.6 m over it, swung sideways and run for 0.05 s in water with Morison's drag (``law``
    "drag") or Stokes's resistance ("resistance") and the fluid's keys ``medium``."""
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, -1.0), fixed=True), net.add_node((4.0, 0.0, 0.6), fixed=True)
    net.add_line(a, b, material=cosnet.Material(E=WIRE_E, G=WIRE_E / 2.6, density=WIRE_DENSITY),
                 section=cosnet.Circle(WIRE_R), elements=24)
    coefficients = {"drag": (1.2, 0.008)} if law == "drag" else {"resistance": (2.0, 1.0)}
    fluid = cosnet.Fluid(SEA, surface=0.0, **coefficients, **medium)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    sim.state.v[:, 1] = 0.5 * np.sin(np.linspace(0.0, np.pi, sim.state.v.shape[0]))
    sim.run(until=0.05)
    return sim, fluid


def passes_reached(p) -> set:
    """The names of the functions the kick's and the flow's kernels of a fluid's record ``p``
    reach (compiled or inlined)."""
    from cosnet.kernels.compiler import _reach
    from cosnet.kernels.compose import FLOW_KERNELS, INERTIAS
    return {d.py_func.__name__ for k in (INERTIAS[type(p)], FLOW_KERNELS[type(p)]) for d in _reach(k)[1]}


def options_named(p, model) -> dict:
    """The options of the variant a fluid's record ``p`` on ``model`` is of, by name."""
    from cosnet.kernels import fluid, fluid_variants
    return dict(zip(fluid.OPTIONS, fluid_variants.options_of(p, model)))


NODE_PASSES = {"drag_nodes", "kick_drag_nodes", "push_nodes", "add_node_upthrust", "divide_node_loads",
               "sample_node_masses", "nodes_entrained"}


def test_a_line_whose_ends_the_medium_does_not_move_needs_no_pass_over_the_nodes(monkeypatch):
    """A line from a fixed anchor to a driven fairlead, in a current with drag, added mass and
    buoyancy: the medium moves none of its nodes, so its record is of the variant without the
    passes over the nodes (kernels/fluid.py, NODES), which its kick and flow do not reach (as
    numba prunes them: compiler._reach). It moves as in the variant with them, where they find
    no node to act on: the same positions and accounts over a surge of the fairlead."""
    from cosnet.kernels import fluid_variants

    def run():
        net = cosnet.Net()
        anchor = net.add_node((0.0, 0.0, -8.0), fixed=True)
        fairlead = net.add_node((8.0, 0.0, 0.0), mass=10.0, inertia=(1.0, 1.0, 1.0))
        net.add_line(anchor, fairlead, material=cosnet.Material(E=WIRE_E, G=WIRE_E / 2.6, density=WIRE_DENSITY),
                     section=cosnet.Circle(WIRE_R), elements=10)
        fluid = cosnet.Fluid(SEA, velocity=(0.0, 0.4, 0.0), drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True,
                             surface=0.0)
        surge = cosnet.Drive(fairlead, position={"times": [0.0, 0.1, 0.2], "values": [[0.0] * 3, [0.3, 0.0, 0.0],
                                                                                        [0.0] * 3]})
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid, surge])
        sim.run(until=0.2)
        p = fluid.params(sim)
        reached = passes_reached(p)
        return sim, fluid, fluid_variants.options_of(p, sim.model), reached

    sim, fluid, options, reached = run()
    assert options[3] is False and not reached & NODE_PASSES, reached & NODE_PASSES
    forcing(monkeypatch, "NODES", "ARMS")   # (and some node may have an arm)
    full, full_fluid, full_options, full_reached = run()
    assert full_options[3] is True and {"drag_nodes", "kick_drag_nodes", "sample_node_masses"} <= full_reached
    assert np.abs(full.state.x - sim.state.x).max() < 1e-12 and np.abs(full.state.v - sim.state.v).max() < 1e-10
    assert full_fluid.dissipated(full) == pytest.approx(fluid.dissipated(sim), rel=1e-12, abs=1e-15)
    assert full_fluid.supplied(full) == pytest.approx(fluid.supplied(sim), rel=1e-12, abs=1e-15)


def test_knots_without_arms_need_no_pass_of_their_own(monkeypatch):
    """Two lines between pins joined at a free knot, swinging in water with added mass: every
    node the medium moves is a point junction, so its record is of the variant without the
    pass over the nodes whose line ends have arms (fluid_step.drag_nodes; the knot takes its
    drag inside the kick, kick_drag_nodes). It moves as in the variant with that pass, which
    finds no such node as it runs: the same positions, velocities and accounts."""

    def run():
        net = cosnet.Net()
        a, b = net.add_node((0.0, 0.0, -3.0), fixed=True), net.add_node((4.0, 0.0, -3.0), fixed=True)
        knot = net.add_node((2.0, 0.0, -3.5), mass=0.3, inertia=(1e-3, 1e-3, 1e-3))
        for end in (a, b):
            net.add_line(end, knot, material=cosnet.Material(E=WIRE_E, G=WIRE_E / 2.6, density=WIRE_DENSITY),
                         section=cosnet.Circle(WIRE_R), elements=8)
        fluid = cosnet.Fluid(SEA, velocity=(0.0, 0.3, 0.0), drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True,
                             surface=0.0)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
        sim.state.node_v[2] = (0.0, 0.5, 0.2)
        sim.run(until=0.05)
        p = fluid.params(sim)
        reached = passes_reached(p)
        return sim, fluid, options_named(p, sim.model), reached

    sim, fluid, options, reached = run()
    assert options["NODES"] and not options["ARMS"] and "kick_drag_nodes" in reached and "drag_nodes" not in reached
    assert fluid.dissipated(sim) > 0.0
    forcing(monkeypatch, "ARMS")
    full, full_fluid, _, full_reached = run()
    assert "drag_nodes" in full_reached
    assert np.array_equal(full.state.x, sim.state.x) and np.array_equal(full.state.v, sim.state.v)
    assert np.array_equal(full.state.node_v, sim.state.node_v)
    assert full_fluid.dissipated(full) == fluid.dissipated(sim) and full_fluid.supplied(full) == fluid.supplied(sim)


@pytest.mark.parametrize("law", ["drag", "resistance"])
def test_drag_alone_in_still_water_takes_the_wetness_and_tangent_itself(monkeypatch, law):
    """A wire between pins, half out of the water, swinging through a current with drag alone
    (Morison's or Stokes's law): no line carries added mass and the medium is still, so its
    record is of the variant whose drag takes each interior vertex's wetness and tangent from
    the positions and whose sample never reaches the interior (kernels/fluid.py,
    kick_drag_line). It moves as in the variant that samples them (forced: some line may carry
    added mass), its dry vertices included: the same positions and accounts."""
    from cosnet.kernels import fluid_variants

    def run():
        sim, fluid = swinging_wire(law, velocity=(0.0, 0.3, 0.0))
        p = fluid.params(sim)
        reached = passes_reached(p)
        return sim, fluid, fluid_variants.options_of(p, sim.model), reached

    sim, fluid, options, reached = run()
    assert options[:4] == (False, False, False, False) and "sample_still_line" not in reached
    assert fluid.dissipated(sim) > 0.0
    forcing(monkeypatch, "CARRIES")
    full, full_fluid, full_options, full_reached = run()
    assert full_options[1] is True and "sample_still_line" in full_reached
    assert np.abs(full.state.x - sim.state.x).max() < 1e-12 and np.abs(full.state.v - sim.state.v).max() < 1e-10
    assert full_fluid.dissipated(full) == pytest.approx(fluid.dissipated(sim), rel=1e-12, abs=1e-15)
    assert full_fluid.supplied(full) == pytest.approx(fluid.supplied(sim), rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("law, current, added_mass_law", [   # a case for each of kick_drag_line's loops
    ("drag", 0.0, "lagrange"), ("drag", 0.3, "lagrange"), ("resistance", 0.0, "morison"), ("drag", 0.0, "morison"),
    ("drag", 0.3, "morison")])
def test_a_variant_of_one_law_and_one_medium_moves_as_the_one_with_every_part(monkeypatch, law, current,
                                                                             added_mass_law):
    """A wire between pins, half out of the water, swinging with added mass across it (its fluid
    turning with it, Lagrange's, or not, Morison's), in water at rest or in a current, with
    either drag law: its record is of the variant with that law and that medium alone, whose
    drag and turning passes compile only their loops (kernels/fluid.py: calm_now, linear_law).
    It moves as in the variant with both of each, which tests them as it runs: the
    same positions and accounts to round-off (LLVM rounds the same loops a little differently
    beside the others), and velocities as near as positions so near make them at the wire's
    fastest axial rate, 2 c / l (c = sqrt(E / rho), l an element's length)."""

    def run():
        sim, fluid = swinging_wire(law, velocity=(0.0, current, 0.0), added_mass=(1.0, 0.0), buoyancy=True,
                                   added_mass_law=added_mass_law)
        return sim, fluid, options_named(fluid.params(sim), sim.model)

    sim, fluid, options = run()
    assert [options[k] for k in ("DRAG", "RESISTANCE", "CALM", "CURRENT", "ARMS")] == [
        law == "drag", law == "resistance", current == 0.0, current != 0.0, False]
    assert fluid.dissipated(sim) > 0.0
    forcing(monkeypatch, "DRAG", "RESISTANCE", "CALM", "CURRENT")
    full, full_fluid, _ = run()
    dx, dv = np.abs(full.state.x - sim.state.x).max(), np.abs(full.state.v - sim.state.v).max()
    assert dx < 1e-12 and dv < 2.0 * math.sqrt(WIRE_E / WIRE_DENSITY) / (math.hypot(4.0, 1.6) / 24) * 1e-12, (dx, dv)
    assert full_fluid.dissipated(full) == pytest.approx(fluid.dissipated(sim), rel=1e-12, abs=1e-15)
    assert full_fluid.supplied(full) == pytest.approx(fluid.supplied(sim), rel=1e-12, abs=1e-15)


def test_the_stable_step_counts_the_added_mass():
    # a light rod (400 kg/m^3) whose heavier rotary inertia leaves its translation setting the
    # step: in water with C_a = 1 across and along, every translational mass grows by 2.5
    def simulation(coefficients, dt=None):
        mat = cosnet.Material(E=1e8, G=4e7, density=400.0)
        net = cosnet.Net()
        a, b = net.add_node((0.0, 0.0, -1.0)), net.add_node((1.0, 0.0, -1.0))
        net.add_line(a, b, material=mat, section=cosnet.Circle(0.01), elements=10, rotary_inertia_scale=1000.0)
        sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0)), cosnet.Fluid(RHO, added_mass=coefficients)],
                                dt=dt, force_dt=dt not in (None, "tight"))
        sim.state.v[:] = 1e-3 * np.random.default_rng(1).standard_normal(sim.state.v.shape)
        return sim

    def stable(sim):
        try:
            sim.run(steps=4000)
            return True
        except cosnet.InstabilityError:
            return False

    dry, wet = simulation((0.0, 0.0)).dt, simulation((1.0, 1.0)).dt
    assert wet > 1.5 * dry
    assert stable(simulation((1.0, 1.0), wet)) and not stable(simulation((0.0, 0.0), wet))
    assert not stable(simulation((1.0, 1.0), 2 * wet))
    # the highest mode's step: the zigzag of the free rod's vertices (half masses at its ends)
    # is an exact mode, omega^2 = 4 E A / (l m) with m the vertex's mass, its own and entrained
    for coefficients, mass in (((0.0, 0.0), 400.0), ((1.0, 1.0), 400.0 + RHO)):
        sim = simulation(coefficients, "tight")
        omega = math.sqrt(4.0 * 1e8 / (0.1 * 0.1 * mass))
        assert sim.dt == pytest.approx(0.9 * 2.0 / omega, rel=2e-3)
        assert stable(sim) and not stable(simulation(coefficients, 1.2 * sim.dt))


def test_the_turbulent_series_has_its_intensity_and_the_kaimal_spectrum():
    """The seeded series (cosnet.core.turbulence): mean zero and r.m.s. the intensity over its
    record, exactly; each harmonic's power in proportion to the Kaimal spectrum at its
    frequency, whatever the seed; the same seed the same series."""
    from cosnet.core.turbulence import kaimal, turbulent_series
    mean, intensity, length = 12.0, 0.18, 150.0
    records = [turbulent_series(mean, intensity, length, duration=300.0, step=0.05, seed=s) for s in (4, 4, 5)]
    (t, f), (_, again), (_, other) = records
    assert t[-1] == 300.0 and f[0] == f[-1] and np.array_equal(f, again) and not np.array_equal(f, other)
    for series in (f, other):
        u = series[:-1] - 1.0
        assert abs(u.mean()) < 1e-15 and math.sqrt(np.mean(u * u)) == pytest.approx(intensity, rel=1e-12)
        power = np.abs(np.fft.rfft(u))[1:-1] ** 2
        shape = kaimal(np.arange(1, power.size + 1) / 300.0, 1.0, length, mean)
        np.testing.assert_allclose(power / shape, (power / shape)[0], rtol=1e-9)


def test_a_line_in_a_turbulent_current_moves_as_its_equation_of_motion_says():
    """A free line across a turbulent current U(t) e_y, three times as dense as the water:
    per length (rho_s + C_a rho) A v' = rho (1 + C_a) A U' e_y - 1/2 rho C_d d |w| w
    + (rho - rho_s) A g e_z with w = v - U e_y (added mass, the medium's inertia force, drag,
    weight less buoyancy), integrated here by scipy with the series' own U(t)."""
    from scipy.integrate import solve_ivp
    r, rho_s, ca, cd, speed = 0.01, 3 * RHO, 1.0, 1.2, 0.5
    net, _, _ = rod(((0.0, 0.0, -2.0), (1.0, 0.0, -2.0)), rho_s, r, elements=4)
    # (a wave of no height, which moves nothing, puts the fluid in the variant of the Airy orbit's
    # above, kernels/fluid_variants.py: one compilation for both)
    fluid = cosnet.Fluid(RHO, velocity=(0.0, speed, 0.0), drag=(cd, 0.0), added_mass=(ca, 0.0), buoyancy=True,
                         surface=0.0, turbulence_intensity=0.3, turbulence_length=20.0, turbulence_duration=20.0,
                         turbulence_step=0.05, turbulence_seed=1, wave_amplitudes=[0.0], wave_periods=[8.0])
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    times, factors = fluid.time_table
    sim.node_velocity(net.nodes[0])[:] = sim.node_velocity(net.nodes[1])[:] = (0.0, speed * factors[0], 0.0)
    sim.line_velocities(net.lines[0])[:] = (0.0, speed * factors[0], 0.0)
    area = math.pi * r * r
    slopes = np.diff(factors) / np.diff(times)

    def rate(t, v):
        k = min(int(np.searchsorted(times, t, side="right")) - 1, slopes.size - 1)
        w = v - (speed * np.interp(t, times, factors), 0.0)
        drag = -0.5 * RHO * cd * 2 * r * np.linalg.norm(w) * w
        forcing = (RHO * (1 + ca) * area * speed * slopes[k], (RHO - rho_s) * area * G)
        return (np.array(forcing) + drag) / ((rho_s + ca * RHO) * area)
    until = 4.0
    exact = solve_ivp(rate, (0.0, until), [speed * factors[0], 0.0], rtol=1e-10, atol=1e-12, max_step=0.0125).y[:, -1]
    sim.run(until=until)
    assert sim.time == pytest.approx(until, abs=sim.dt)
    # the fluctuation is 0.15 m/s r.m.s.; the step's error is about 2e-6 m/s here, where leaving
    # out the medium's inertia force (rho A U' for a turbulent U) moves the answer by 2.6e-2
    np.testing.assert_allclose(sim.state.v[:, 1:], np.broadcast_to(exact, (sim.state.v.shape[0], 2)), atol=2e-5)


def test_a_net_in_water_steps_alike_on_one_and_two_threads():
    """A chain of 301 lines of 2 elements between pins, joined at 300 free knots, sinking and
    swinging in still water with drag, added mass that turns and buoyancy: on two threads the
    kick's passes over the lines and the nodes run in blocks on both (added_mass.kick_threaded;
    more lines than a block of them, more knots than a block of nodes), and the net moves as on
    one thread, to round-off (the accounts' sums, and the elastic step's threaded loops, add
    in another order). A net of a few lines on two threads keeps the variant without threaded
    passes, whose loops would each run one block (fluid_variants.options_of). The two variants
    share the clones of every function that does not read THREADS, itself or through its
    callees (kernels/specialise.py: the threaded variant compiles its loops and its hooks
    alone), which their records' numba type, their base's, lets them call."""
    from cosnet.kernels import fluid_variants

    def run(threads, knots=300, steps=300):
        net = cosnet.Net()
        wire = cosnet.Material(E=1e9, G=1e9 / 2.6, density=WIRE_DENSITY)
        ends = [net.add_node((0.0, 0.0, -5.0), fixed=True)]
        for k in range(1, knots + 1):
            ends.append(net.add_node((0.1 * k, 0.0, -5.0), mass=0.05, inertia=(1e-4, 1e-4, 1e-4)))
        ends.append(net.add_node((0.1 * (knots + 1), 0.0, -5.0), fixed=True))
        for a, b in zip(ends, ends[1:]):
            net.add_line(a, b, material=wire, section=cosnet.Circle(0.005), elements=2)
        fluid = cosnet.Fluid(SEA, surface=0.0, drag=(1.2, 0.05), added_mass=(1.0, 0.2), buoyancy=True)
        sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid], threads=threads)
        sim.state.node_v[1:-1, 1] = 0.5 * np.sin(np.linspace(0.0, np.pi, knots))
        if steps:   # (the variant is chosen when the simulation is built)
            sim.run(steps=steps)
        return sim, fluid

    (one, f1), (two, f2) = run(1), run(2)
    small = run(2, knots=3, steps=0)
    assert [type(f.params(s)).__name__[-1] for s, f in ((one, f1), (two, f2), small)] == ["0", "1", "0"]   # THREADS
    serial, threaded = (fluid_variants.VARIANTS.of(f.params(s)) for s, f in ((one, f1), (two, f2)))
    assert serial.family["kick_lines"] is threaded.family["kick_lines"]
    assert serial.family["kick_fluid"] is not threaded.family["kick_fluid"] and "kick_threaded" in threaded.family
    assert numba.typeof(f2.params(two)) == numba.typeof(f1.params(one))
    assert numba.typeof(f2.params(two)).instance_class is fluid_variants.FluidParams
    assert f1.dissipated(one) > 1e-6 * abs(one.energy())    # the drag acts
    assert np.abs(two.state.x - one.state.x).max() < 1e-10
    assert np.abs(two.state.v - one.state.v).max() < 1e-8
    assert f2.dissipated(two) == pytest.approx(f1.dissipated(one), rel=1e-9)
    assert f2.supplied(two) == pytest.approx(f1.supplied(one), rel=1e-9, abs=1e-12)
