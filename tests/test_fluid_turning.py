"""The fluid a line carries as it turns (kernels/added_mass.py): Lagrange's equations for the
entrained kinetic energy 1/2 u^T M(x) u give a straight line moving obliquely through still
water Munk's moment, and line and fluid together keep their energy. Every
simulation here declares (Gravity, Fluid), as tests/test_fluid.py does, so the suite compiles
one step for both."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import cosnet

RHO = 1000.0
LENGTH, RADIUS, ELEMENTS = 1.0, 0.025, 16
SPEED, ATTACK = 1.0, math.radians(40.0)   # the line's speed and its angle to the line's axis
ADDED = (1.0, 0.0)                        # C_an, C_at: a slender body's


def oblique_line(dt=None, added_law="lagrange"):
    """A free straight line along x through the origin, neutrally buoyant in still water, no
    drag and no gravity, every point moving at SPEED at ATTACK to the line."""
    mat = cosnet.Material(E=2e9, G=8e8, density=RHO)
    net = cosnet.Net()
    a, b = net.add_node((-0.5 * LENGTH, 0.0, 0.0)), net.add_node((0.5 * LENGTH, 0.0, 0.0))
    net.add_line(a, b, material=mat, section=cosnet.Circle(RADIUS), elements=ELEMENTS)
    fluid = cosnet.Fluid(RHO, drag=(0.0, 0.0), added_mass=ADDED, added_mass_law=added_law, buoyancy=False)
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0)), fluid], dt=dt, force_dt=dt is not None)
    v = SPEED * np.array([math.cos(ATTACK), math.sin(ATTACK), 0.0])
    sim.state.v[:] = v
    sim.state.node_v[:] = v
    return sim


def rigid_parts(sim):
    """(m, A_n, A_t, I, I_a): the line's mass, its added mass across and along it, and their
    moments of inertia about the centre for a turn in the plane, as the discrete line holds
    them (lumped at the vertices and nodes, the elements' and nodes' own rotary inertia)."""
    m = sim.model
    x = sim.state.x[:, 0]
    mass = m.vertex_mass.copy()
    mass[[0, -1]] = m.node_mass          # a line end's share is its node's
    a_n = RHO * math.pi * RADIUS ** 2 * ADDED[0] * m.voronoi_rest_length
    a_t = RHO * math.pi * RADIUS ** 2 * ADDED[1] * m.voronoi_rest_length
    inertia = float(mass @ x ** 2 + m.element_inertia[:, 0].sum() + m.node_inertia[:, 0].sum())
    return float(mass.sum()), float(a_n.sum()), float(a_t.sum()), inertia, float(a_n @ x ** 2)


def kirchhoff(parts, until, times):
    """The rigid body's planar motion in ideal fluid (Kirchhoff's equations): the impulse P
    (body and fluid) is constant, the velocity V = P.t t / (m + A_t) + P.n n / (m + A_n), and
    (I + I_a) theta'' = (A_t - A_n) (V.t) (V.n), theta the axis's angle. Returns theta and
    the centre's path at ``times``."""
    m, an, at, inertia, ia = parts
    v0 = SPEED * np.array([math.cos(ATTACK), math.sin(ATTACK)])
    impulse = np.array([(m + at) * v0[0], (m + an) * v0[1]])   # theta = 0 at the start

    def velocity(theta):
        t, n = np.array([math.cos(theta), math.sin(theta)]), np.array([-math.sin(theta), math.cos(theta)])
        return (impulse @ t) / (m + at) * t + (impulse @ n) / (m + an) * n, t, n

    def rate(_, y):
        v, t, n = velocity(y[0])
        return [y[1], (at - an) * (v @ t) * (v @ n) / (inertia + ia), v[0], v[1]]

    out = solve_ivp(rate, (0.0, until), [0.0, 0.0, 0.0, 0.0], t_eval=times, rtol=1e-11, atol=1e-12)
    return out.y[0], out.y[2:].T


def axis_and_centre(sim):
    x = sim.state.x
    d = x[-1] - x[0]
    return math.atan2(d[1], d[0]), 0.5 * (x[0] + x[-1])[:2]


def test_a_line_moving_obliquely_turns_broadside_by_munks_moment_as_kirchhoff_says():
    sim = oblique_line()
    parts = rigid_parts(sim)
    times = np.linspace(0.1, 0.6, 6)
    theta, centre = kirchhoff(parts, 0.6, times)
    assert theta[-1] < -0.3   # it turns, toward broadside (about 20 degrees of 50 here)
    for k, t in enumerate(times):
        sim.run(until=t)
        angle, mid = axis_and_centre(sim)
        assert angle == pytest.approx(theta[k], rel=1e-3, abs=5e-5)
        assert np.allclose(mid, centre[k], rtol=0.0, atol=5e-5)


def test_line_and_fluid_keep_their_energy_at_order_two_and_still_water_supplies_nothing():
    # the line's and the entrained fluid's kinetic energy (with the added mass of the present
    # positions) drift at the scheme's order, and what the still water gives (the resampled
    # added mass's energy and the turning forces' work, which cancel) vanishes at that order.
    # (Munk's moment moves about a tenth of the energy into the turn by 0.3 s; the bound is
    # 1e-8 of the whole.)
    def run(dt):
        sim = oblique_line(dt)
        e0 = sim.energy()
        sim.run(until=0.3)
        assert sim.dissipated() == 0.0
        assert abs(axis_and_centre(sim)[0]) > 0.1   # it has turned
        return abs(sim.energy() - e0) / e0, abs(sim.supplied()) / e0

    coarse, fine = run(oblique_line().dt), run(0.5 * oblique_line().dt)
    assert coarse[0] < 1e-8 and coarse[1] < 1e-8
    assert coarse[0] / fine[0] == pytest.approx(4.0, rel=0.15)
    assert coarse[1] / fine[1] == pytest.approx(4.0, rel=0.15)


def test_morisons_law_leaves_the_turning_forces_out():
    # Morison's equation (MoorDyn's) has no force of the entrained fluid turning: the same
    # line keeps its heading, and a bad law is refused in one line
    sim = oblique_line(added_law="morison")
    sim.run(until=0.3)
    assert abs(axis_and_centre(sim)[0]) < 1e-9
    with pytest.raises(ValueError, match="^Fluid: added_mass_law must be 'lagrange' or 'morison', got 'munk'$"):
        cosnet.Fluid(RHO, added_mass=ADDED, added_mass_law="munk")
