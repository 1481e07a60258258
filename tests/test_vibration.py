"""Analytic frequencies and static deflections of single rods and a pendulum."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.core.rotations import matrix_from_quat
from nets import STEEL, cantilever

BETA_L = (1.8751040687, 4.6940911330, 7.8547574382)


def eb_shape(beta_l, s):
    """Clamped-free Euler-Bernoulli mode shape at s in [0, 1] and its slope."""
    b = beta_l
    sig = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))
    x = b * s
    phi = np.cosh(x) - np.cos(x) - sig * (np.sinh(x) - np.sin(x))
    dphi = b * (np.sinh(x) + np.sin(x) - sig * (np.cosh(x) - np.cos(x)))
    return phi, dphi


def measured_omega(sim, signal, periods_guess, omega_guess, samples_per_period=40):
    """Angular frequency from the zero crossings of signal(sim) (which starts at zero)."""
    period = 2 * math.pi / omega_guess
    n_sub = max(1, int(period / samples_per_period / sim.dt))
    t, y = [sim.time], [signal(sim)]
    while sim.time < periods_guess * period:
        sim.run(steps=n_sub)
        t.append(sim.time)
        y.append(signal(sim))
    t, y = np.array(t), np.array(y)
    k = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))
    k = k[y[k] != 0] if len(k) > 2 else k
    crossings = t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
    crossings = crossings[crossings > 0.25 * period]
    half = np.polyfit(np.arange(len(crossings)), crossings, 1)[0]
    return math.pi / half


def bending_omega(n, mode, radius=0.01, length=1.0):
    net, line, root, tip = cantilever(n=n, length=length, radius=radius)
    sim = cosnet.Simulation(net)
    m = sim.model
    s = np.linspace(0, 1, n + 1)
    phi, dphi = eb_shape(BETA_L[mode], s)
    amp = 1e-3
    sim.line_velocities(line)[:, 2] = amp * phi
    # elements turn with the velocity's slope: w = d(v_z)/ds about -y (lab), in body frame
    smid = 0.5 * (s[1:] + s[:-1])
    slope = amp * eb_shape(BETA_L[mode], smid)[1] / length
    D = matrix_from_quat(sim.state.q)
    sim.line_angular_velocities(line)[:] = np.einsum("eji,j->ei", D, np.array([0.0, -1.0, 0.0])) * slope[:, None]
    weights = m.vertex_mass * phi
    sec = cosnet.Circle(radius)
    exact = BETA_L[mode] ** 2 / length**2 * math.sqrt(STEEL.E * sec.I11 / (STEEL.density * sec.A))
    omega = measured_omega(sim, lambda sim: weights @ sim.line_positions(line)[:, 2], 1.6, exact)
    return omega, exact


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_clamped_free_bending_frequencies(mode):
    """First three bending frequencies within 1% of Euler-Bernoulli (slender rod, L/r = 100,
    60 elements: the third mode has 20 elements per wavelength)."""
    omega, exact = bending_omega(60, mode)
    assert abs(omega / exact - 1) < 0.01, (omega, exact)


def test_bending_frequency_converges_at_order_two():
    """The first bending frequency against the exact frequency of the continuous Timoshenko
    rod it discretises (cosnet.studies.lincos.analytic_modes: shear and rotary inertia included), not
    Euler-Bernoulli's: the Euler-Bernoulli value differs from it by a fixed O((r/L)^2) that
    would flatten the observed order as the error falls towards it. The staggered grid is
    centred (the strains are differences over one element, the Voronoi points halfway), so the
    error is C l^2 + O(l^4): from n = 5 on, each halving divides it by 4 within a few %."""
    errs = []
    for n in (5, 10, 20):
        omega, _ = bending_omega(n, 0)
        exact = cosnet.analytic_modes(cantilever(n=n, length=1.0, radius=0.01)[0], count=1).omega[0]
        errs.append(abs(omega / exact - 1))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    print("first bending mode relative error for n = 5, 10, 20:", errs, "orders", orders)
    assert np.all((orders > 1.9) & (orders < 2.1)), orders


@pytest.mark.parametrize("kind", ["axial", "torsion"])
def test_clamped_free_axial_and_torsional_frequencies(kind):
    """Quarter-wave frequencies pi/2 sqrt(E/rho)/L and pi/2 sqrt(G/rho)/L within 1%."""
    n = 20
    net, line, root, tip = cantilever(n=n)
    sim = cosnet.Simulation(net)
    s = np.linspace(0, 1, n + 1)
    shape = np.sin(0.5 * np.pi * s)
    if kind == "axial":
        sim.line_velocities(line)[:, 0] = 1e-3 * shape
        weights = sim.model.vertex_mass * shape
        signal = lambda sim: weights @ (sim.line_positions(line)[:, 0] - s)
        exact = 0.5 * math.pi * math.sqrt(STEEL.E / STEEL.density)
    else:
        smid = np.sin(0.25 * np.pi * (s[1:] + s[:-1]))
        sim.line_angular_velocities(line)[:, 2] = 1e-3 * smid
        J = sim.model.element_inertia[:, 2]
        d0 = matrix_from_quat(sim.state.q.copy())
        # twist: the d3 component of each element's rotation from its initial frame
        signal = lambda sim: np.sum(J * smid * Rotation.from_matrix(
            np.einsum("eji,ejk->eik", d0, matrix_from_quat(sim.state.q))).as_rotvec()[:, 2])
        exact = 0.5 * math.pi * math.sqrt(STEEL.G / STEEL.density)
    omega = measured_omega(sim, signal, 2.6, exact)
    assert abs(omega / exact - 1) < 0.01, (omega, exact)


def test_static_end_loaded_cantilever_matches_timoshenko():
    """Damped to rest under a tip load P: w = P L^3/(3 E I) + P L/(k G A) within 1%."""
    n, L, r = 20, 1.0, 0.02
    net, line, root, tip = cantilever(n=n, length=L, radius=r)
    sec = cosnet.Circle(r)
    EI = STEEL.E * sec.I11
    P = 1e-4 * 3 * EI / L**3      # tip deflection 1e-4 L: linear regime
    omega1 = BETA_L[0] ** 2 * math.sqrt(EI / (STEEL.density * sec.A)) / L**2
    sim = cosnet.Simulation(net, effects=[cosnet.NodeLoad(tip, force=(0, 0, -P)),
                                          cosnet.Damping(2.0 * omega1)])
    sim.run(until=14.0 / omega1)
    w = -sim.node_position(tip)[2]
    exact = P * L**3 / (3 * EI) + P * L / (sec.shear_coefficient * STEEL.G * sec.A)
    assert abs(w / exact - 1) < 0.01, (w, exact)
    assert np.abs(sim.line_velocities(line)).max() < 1e-3 * omega1 * exact   # at rest


def test_heavy_point_mass_on_light_stiff_line_swings_as_a_pendulum():
    """Small-amplitude period of a mass M on a light rod (mass m) pinned at the top:
    T = 2 pi sqrt((M + m/3) L / ((M + m/2) g)) (1 + theta0^2 / 16)."""
    L, M, g, r = 1.0, 1.0, 9.81, 0.05
    A = math.pi * r * r
    rod_mass = 1e-3 * M
    E = 1e5 / A                               # EA = 1e5 N: stretch under M g ~ 1e-4
    mat = cosnet.Material(E=E, poisson=0.3, density=rod_mass / (A * L))
    net = cosnet.Net()
    pivot = net.add_node((0, 0, 0), mass=np.inf, name="pivot")       # pinned: free rotation
    bob = net.add_node((0, 0, -L), mass=M, name="bob")                 # point mass (type ii)
    net.add_line(pivot, bob, material=mat, section=cosnet.Circle(r), elements=4)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0, 0, -g))])
    theta0 = 0.05
    omega_small = math.sqrt(g / L)
    sim.node_velocity(bob)[:] = (theta0 * omega_small * L, 0, 0)   # start at the bottom
    m = rod_mass
    exact_T = 2 * math.pi * math.sqrt((M + m / 3) * L / ((M + m / 2) * g)) * (1 + theta0**2 / 16)
    omega = measured_omega(sim, lambda sim: sim.node_position(bob)[0], 1.6, omega_small)
    assert abs(2 * math.pi / omega / exact_T - 1) < 2e-3, (2 * math.pi / omega, exact_T)
