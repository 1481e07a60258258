"""Stiff problems at the automatic time step: a 1e6 stiffness contrast across one junction,
and nearly inextensible, nearly unshearable lines."""

import math

import numpy as np

import cosnet
from nets_hard import (BETA_L, STEEL, excite_bending_mode, slender_cantilever, stiffness_contrast,
                       zero_crossing_omega)


def test_soft_line_on_a_steel_stub_vibrates_at_its_own_clamped_frequency():
    """A line 1e6 times softer than the steel stub it hangs from (one point junction): the
    stub clamps it, so its first bending frequency is Euler-Bernoulli's for a clamped-free
    line (20 elements: within 1 %, measured 0.3 %); the junction stays put (its motion is
    below 1e-5 of the soft tip's, the compliance ratio being 1e-6); the energy error stays
    at Verlet's O((omega dt)^2) level although the step is set by the steel (1e-6)."""
    net, p = stiffness_contrast(ratio=1e6, soft_elements=20)
    sim = cosnet.Simulation(net)
    assert sim.stiffest().startswith("line 'stub'")       # the steel sets the step
    line, mat, sec, L = p["soft"], p["material"], p["section"], p["length"]
    exact = BETA_L[0] ** 2 / L**2 * math.sqrt(mat.E * sec.I11 / (mat.density * sec.A))
    signal = excite_bending_mode(sim, line, amplitude=1e-3)
    e0 = sim.energy()
    j0, t0 = sim.node_position(p["joint"]).copy(), sim.node_position(p["tip"]).copy()
    worst = {"joint": 0.0, "tip": 0.0, "energy": 0.0}

    def record(sim):
        worst["joint"] = max(worst["joint"], np.linalg.norm(sim.node_position(p["joint"]) - j0))
        worst["tip"] = max(worst["tip"], np.linalg.norm(sim.node_position(p["tip"]) - t0))
        worst["energy"] = max(worst["energy"], abs(sim.energy() / e0 - 1))

    omega = zero_crossing_omega(sim, signal, 1.6, exact, record=record)
    print(f"omega {omega:.6g} exact {exact:.6g} rel {omega / exact - 1:.3g}; joint/tip motion "
          f"{worst['joint'] / worst['tip']:.3g}; energy error {worst['energy']:.3g}; {sim.steps} steps")
    assert abs(omega / exact - 1) < 0.01, (omega, exact)
    assert worst["joint"] < 1e-5 * worst["tip"], worst
    assert worst["energy"] < 1e-6, worst


def test_nearly_inextensible_unshearable_line_bends_as_euler_bernoulli():
    """L / r = 300 steel cantilever: E A / (E I / L^2) = 4 (L/r)^2 = 3.6e5 and k G A / (E I / L^2)
    = 1.4e5, so stretch and shear are 1e5 times stiffer than bending and set the step; the
    first bending frequency still matches Euler-Bernoulli within 1 % (measured 0.2 %), and
    the energy error stays below 1e-6."""
    net, p = slender_cantilever(slenderness=300.0, elements=20)
    sim = cosnet.Simulation(net)
    sec, L = p["section"], p["length"]
    assert STEEL.E * sec.A * L**2 / (STEEL.E * sec.I11) > 3e5
    exact = BETA_L[0] ** 2 / L**2 * math.sqrt(STEEL.E * sec.I11 / (STEEL.density * sec.A))
    signal = excite_bending_mode(sim, p["line"], amplitude=1e-3)
    e0 = sim.energy()
    errs = []
    omega = zero_crossing_omega(sim, signal, 1.6, exact, record=lambda s: errs.append(abs(s.energy() / e0 - 1)))
    print(f"omega {omega:.6g} exact {exact:.6g} rel {omega / exact - 1:.3g}; dt {sim.dt:.3g}; "
          f"energy error {max(errs):.3g}; {sim.steps} steps")
    assert abs(omega / exact - 1) < 0.01, (omega, exact)
    assert max(errs) < 1e-6
