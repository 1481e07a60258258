"""Fast rigid rotation of a free net, and the free rigid body near its intermediate axis."""

import math

import numpy as np

import cosnet
from nets_hard import STEEL, lone_body, rigid_body_flip_period, rigid_motion, spinning_hub


def test_rotor_spinning_at_100_rad_s_keeps_its_shape_and_its_invariants():
    """A free steel rotor (hub body, three radial arms with tip masses) set spinning rigidly
    at 100 rad/s, three revolutions at the automatic step: quaternions stay unit (1e-12),
    energy (1e-6) and angular momentum (1e-12) conserved, and the arms only stretch as the
    centrifugal load dictates: a suddenly applied load, so the hub-tip distance oscillates
    between 0 and twice the static stretch u = int N / (E A) (N = rho A W^2 (R^2 - x^2) / 2
    + M_tip W^2 R) with mean u."""
    net, p = spinning_hub()
    sim = cosnet.Simulation(net)
    W = 100.0
    rigid_motion(sim, np.zeros(3), (0.0, 0.0, W))
    e0, p0, l0 = sim.energy(), sim.momentum(), sim.angular_momentum()
    A, a = p["section"].A, p["hub_radius"]
    R = a + p["length"]
    u = (STEEL.density * A * W**2 / 2 * (R**2 * (R - a) - (R**3 - a**3) / 3)
         + p["tip_mass"] * W**2 * R * (R - a)) / (STEEL.E * A)

    def distances():
        hub = sim.node_position(p["hub"])
        return np.array([np.linalg.norm(sim.node_position(t) - hub) for t in p["tips"]])

    d0 = distances()
    stretch, energy, unit, lateral = [], [], 0.0, 0.0
    steps = int(3 * 2 * math.pi / W / sim.dt / 300) + 1
    for _ in range(300):
        sim.run(steps=steps)
        stretch.append(distances() - d0)
        energy.append(abs(sim.energy() / e0 - 1))
        unit = max(unit, np.abs(np.linalg.norm(sim.state.q, axis=1) - 1).max(),
                   np.abs(np.linalg.norm(sim.state.node_q, axis=1) - 1).max())
        # the tips stay in the spin plane through the hub
        lateral = max(lateral, max(abs(sim.node_position(t)[2] - sim.node_position(p["hub"])[2]) for t in p["tips"]))
    stretch = np.array(stretch)
    scale_p = net.total_mass() * W * R
    print(f"{sim.time * W / (2 * math.pi):.2f} revolutions, {sim.steps} steps; stretch max/u "
          f"{stretch.max() / u:.4f} mean/u {stretch.mean() / u:.4f} (u = {u:.3g} m); energy "
          f"{max(energy):.3g}; |L| {np.abs(sim.angular_momentum() - l0).max() / np.abs(l0).max():.3g}; "
          f"|q|-1 {unit:.3g}")
    assert sim.time * W > 3 * 2 * math.pi
    assert unit < 1e-12
    assert max(energy) < 1e-6
    assert np.abs(sim.angular_momentum() - l0).max() < 1e-12 * np.abs(l0).max()
    assert np.abs(sim.momentum() - p0).max() < 1e-12 * scale_p
    assert stretch.min() > -0.05 * u and stretch.max() < 2.05 * u
    assert abs(stretch.mean() / u - 1) < 0.05
    assert lateral < 1e-9


def flip_times(sim, node, until):
    """Times at which the intermediate body component of the angular velocity changes sign."""
    t, y = [sim.time], [sim.node_angular_velocity(node)[1]]
    while sim.time < until:
        sim.run(steps=8)
        t.append(sim.time)
        y.append(sim.node_angular_velocity(node)[1])
    t, y = np.array(t), np.array(y)
    k = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def test_intermediate_axis_flips_with_jacobis_period():
    """A lone rigid body, inertia 1 : 100 : 1e4, spun about its intermediate axis with a 1e-3
    perturbation: it flips every half period T/2 = 2 K(m) / rate of Jacobi's elliptic
    solution (m = 1 - 1e-6, a nearly separatrix orbit), within 1e-4 (measured 1.5e-6);
    |L| conserved to 1e-10, the energy error O(dt^2) (halving dt divides it by ~4).
    The step is explicit: a net without lines has no elastic step, so dt is given (an automatic
    step is refused, see below)."""
    net, p = lone_body(inertia=(1.0, 100.0, 1e4))
    w0 = np.array([1e-3, 1.0, 1e-5])
    T = rigid_body_flip_period(p["inertia"], w0)
    errs = []
    for dt in (1e-3, 5e-4):
        sim = cosnet.Simulation(net, dt=dt)
        sim.node_angular_velocity(p["body"])[:] = w0
        e0, l0 = sim.energy(), np.linalg.norm(sim.angular_momentum())
        flips = flip_times(sim, p["body"], 3.2 * T)
        half = np.diff(flips)
        print(f"dt {dt}: half periods {half} analytic {T / 2:.8g}; energy {abs(sim.energy() / e0 - 1):.3g}")
        assert len(half) >= 5
        assert np.abs(half / (T / 2) - 1).max() < 1e-4
        assert abs(np.linalg.norm(sim.angular_momentum()) / l0 - 1) < 1e-10
        errs.append(abs(sim.energy() / e0 - 1))
    assert errs[0] < 1e-4
    assert 3.0 < errs[0] / errs[1] < 5.0, errs


def test_automatic_step_of_a_lone_rigid_body_is_finite_or_refused():
    """With no lines there is no elastic frequency; the automatic step must still be usable
    (finite) or refused with a ValueError asking for dt, never infinite."""
    net, p = lone_body()
    try:
        sim = cosnet.Simulation(net)
    except ValueError as e:
        assert "dt" in str(e)
        return
    assert math.isfinite(sim.dt) and sim.dt > 0
    sim.node_angular_velocity(p["body"])[:] = (1e-3, 1.0, 1e-5)
    sim.run(until=1.0)
    assert np.all(np.isfinite(sim.state.node_q))
