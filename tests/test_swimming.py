"""A flagellum swims: a free elastic filament in Stokes flow (cosnet.Fluid with resistive-force
coefficients c_n = 2 c_t), bent by a travelling wave of rest curvature (cosnet.ActiveCurvature),
swims against the wave at the speed resistive-force theory gives the prescribed stroke
(cosnet.studies.swimming: force- and moment-free, recoil of the finite body included); for
small amplitude that speed tends to Taylor's and Gray & Hancock's V (kb)^2 / 2 (c_n / c_t - 1)."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.studies.swimming import swimming_velocity

LENGTH, WAVES, PERIOD = 1.0, 4, 1.0
K = 2 * math.pi * WAVES / LENGTH          # wave number
C_N, C_T = 2.0, 1.0                       # N s/m^2


def curvature(kb):
    """kappa(s, t) = b k^2 sin(omega t - k s): the stroke of amplitude b = kb / k."""
    return lambda s, t: kb * K * np.sin(2 * math.pi * t / PERIOD - K * s)


def flagellum(kb, stiffness=3e-2, radius=0.005, elements=64):
    """A free filament along x, bending stiffness EI = ``stiffness`` (stiff against the drag:
    its shape is the stroke's to ~0.1 %), light (m / c_t ~ 1 % of the period): the speed within
    0.2 % of the rigid stroke's."""
    E = stiffness / (math.pi * radius ** 4 / 4)
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.0)), net.add_node((LENGTH, 0.0, 0.0))
    line = net.add_line(a, b, material=cosnet.Material(E=E, G=E / 2.6, density=100.0),
                        section=cosnet.Circle(radius), elements=elements)
    stroke = cosnet.ActiveCurvature(line, curvature=(0.0, kb * K, 0.0), period=PERIOD,
                                    wavelength=LENGTH / WAVES, ramp_time=PERIOD)
    return cosnet.Simulation(net, [stroke, cosnet.Fluid(1000.0, resistance=(C_N, C_T))])


def centre(sim):
    m = sim.model.vertex_mass
    return (sim.state.x * m[:, None]).sum(axis=0) / m.sum()


def test_a_flagellum_swims_at_the_speed_resistive_force_theory_gives_its_stroke():
    kb = 0.2
    sim = flagellum(kb)
    sim.run(until=2 * PERIOD)                 # the stroke ramped up over the first period
    start = centre(sim)
    t0 = sim.time
    sim.run(until=4 * PERIOD)
    swum = centre(sim) - start
    speed = np.linalg.norm(swum) / (sim.time - t0)
    assert swum[0] < 0 and abs(swum[1]) < 1e-3 * abs(swum[0])   # against the wave, along the body
    assert speed == pytest.approx(swimming_velocity(curvature(kb), LENGTH, C_N, C_T, PERIOD), rel=2e-3)


def test_resistive_force_theory_tends_to_the_small_amplitude_law():
    # V (kb)^2 / 2 (c_n / c_t - 1), V = omega / k; the finite swimmer's recoil takes a share
    # that does not vanish with the amplitude, the stroke's finite amplitude one ~ (kb)^2
    V = 2 * math.pi / PERIOD / K
    ratios = [swimming_velocity(curvature(kb), LENGTH, C_N, C_T, PERIOD) / (V * kb * kb / 2 * (C_N / C_T - 1))
              for kb in (0.05, 0.1, 0.2)]
    assert 0.95 < ratios[0] < 1.0 and ratios[0] > ratios[1] > ratios[2]
    # the amplitude's share, ratio(0.1) - ratio(0.2) against ratio(0.05) - ratio(0.1): (0.04 - 0.01) / (0.01 - 0.0025)
    assert (ratios[1] - ratios[2]) / (ratios[0] - ratios[1]) == pytest.approx(4.0, rel=0.1)
