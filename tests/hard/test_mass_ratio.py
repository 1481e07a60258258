"""Extreme mass and inertia ratios at the automatic time step: a heavy body on a light line,
a light body on stiff lines, and a point junction with no inertia of its own joining 20 lines."""

import math

import numpy as np

import cosnet
from nets import smooth_motion
from nets_hard import heavy_body_on_light_line, light_body_on_stiff_lines, star, zero_crossing_omega


def test_heavy_body_bounces_on_a_light_line_at_the_spring_period():
    """Body mass / line mass = 1e6: the body bounces at omega = sqrt(k / (M + m/3)),
    k = E A / L, within 1e-5 (measured 3e-7), momentum flowing only through the fixed top."""
    net, p = heavy_body_on_light_line(ratio=1e6)
    sim = cosnet.Simulation(net)
    body = p["body"]
    exact = math.sqrt(p["k"] / (p["M"] + p["m"] / 3))
    amp = 1e-4
    sim.node_velocity(body)[:] = (0.0, 0.0, amp * exact)
    z0 = sim.node_position(body)[2]
    e0 = sim.energy()
    errs, drift = [], []

    def record(sim):
        errs.append(abs(sim.energy() / e0 - 1))
        drift.append(np.abs(sim.node_position(body)[:2]).max())

    omega = zero_crossing_omega(sim, lambda s: s.node_position(body)[2] - z0, 2.6, exact, record=record)
    print(f"omega {omega:.8g} exact {exact:.8g} rel {omega / exact - 1:.3g}; energy error "
          f"{max(errs):.3g}; dt {sim.dt:.3g}; {sim.steps} steps")
    assert abs(omega / exact - 1) < 1e-5, (omega, exact)
    assert max(errs) < 1e-6
    assert max(drift) < 1e-9 * amp                 # an axial motion stays axial


def test_light_body_on_stiff_lines_is_stable_and_conserves_momenta():
    """A rigid body 1e6 times lighter than each steel line it joins (free net, offsets):
    stable at the automatic step, energy error at Verlet's bounded level (< 1e-3, measured
    2e-4) with no drift, linear and angular momentum conserved to round-off."""
    net, p = light_body_on_stiff_lines(ratio=1e6)
    sim = cosnet.Simulation(net)
    smooth_motion(sim, amplitude=0.2, spin=5.0)
    e0, p0, l0 = sim.energy(), sim.momentum(), sim.angular_momentum()
    m = sim.model
    scale_p = np.abs(sim.state.v).sum(axis=1) @ m.vertex_mass + np.abs(sim.state.node_v).sum(axis=1) @ m.node_mass
    err = []
    for _ in range(50):
        sim.run(steps=1000)
        err.append(sim.energy() / e0 - 1)
    err = np.array(err)
    print(f"energy error max {np.abs(err).max():.3g}, drift {abs(err[-10:].mean() - err[:10].mean()):.3g}; "
          f"momentum {np.abs(sim.momentum() - p0).max() / scale_p:.3g}, angular "
          f"{np.abs(sim.angular_momentum() - l0).max() / np.abs(l0).max():.3g}")
    assert np.abs(err).max() < 1e-3
    assert abs(err[-10:].mean() - err[:10].mean()) < 1e-4
    assert np.abs(sim.momentum() - p0).max() < 1e-12 * scale_p
    assert np.abs(sim.angular_momentum() - l0).max() < 1e-12 * np.abs(l0).max()


def test_star_of_20_lines_on_a_point_junction_conserves_energy_and_angular_momentum():
    """A massless point junction joining 20 lines (its rotary inertia is only its share of
    the end elements): stable at the automatic step, energy error < 1e-3 (measured 1e-4),
    linear and angular momentum conserved to round-off, the junction exact."""
    net, p = star(lines=20)
    sim = cosnet.Simulation(net)
    smooth_motion(sim, amplitude=0.2, spin=3.0)
    e0, p0, l0 = sim.energy(), sim.momentum(), sim.angular_momentum()
    err, joint = [], 0.0
    hub = p["hub"]
    for _ in range(40):
        sim.run(steps=500)
        err.append(abs(sim.energy() / e0 - 1))
        r = sim.node_position(hub)
        joint = max(joint, max(np.abs(sim.line_positions(l)[0] - r).max() for l in p["lines"]))
    scale = math.sqrt(2 * e0 * net.total_mass())
    print(f"energy error {max(err):.3g}; momentum {np.abs(sim.momentum() - p0).max() / scale:.3g}; "
          f"angular {np.abs(sim.angular_momentum() - l0).max() / np.abs(l0).max():.3g}; {sim.steps} steps")
    assert max(err) < 1e-3
    assert np.abs(sim.momentum() - p0).max() < 1e-12 * scale
    assert np.abs(sim.angular_momentum() - l0).max() < 1e-12 * np.abs(l0).max()
    assert joint < 1e-13
