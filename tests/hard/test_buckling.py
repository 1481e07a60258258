"""Large deflections through instabilities: Euler buckling of a clamped-free column under a
load sweep, and the snap-through of a shallow clamped arch."""

import math

import numpy as np
from scipy.optimize import brentq

import cosnet
from nets_hard import STEEL, column, elastica_tip_deflection, shallow_arch

IMPERFECTION = 1e-4   # lateral tip force / axial load


def settled_tip_deflection(net, p, load_ratio, w1):
    """Tip deflection (lab x) of the column under a tip load P = load_ratio * P_cr (with a
    lateral imperfection force), ramped in over 5/w1 and damped at 0.3 w1 for 80/w1."""
    P = load_ratio * p["P_cr"]
    load = cosnet.NodeLoad(p["top"], force=(IMPERFECTION * P, 0.0, -P), times=[0.0, 5.0 / w1], values=[0.0, 1.0])
    sim = cosnet.Simulation(net, effects=[load, cosnet.Damping(0.3 * w1)])
    sim.run(until=80.0 / w1)
    return sim.node_position(p["top"])[0], sim


def test_column_buckles_at_eulers_load_and_follows_the_elastica():
    """Load sweep at 0.94, 0.98, 1.02, 1.1 P_cr (P_cr = pi^2 E I / (4 L^2), L / r = 50):
    below, the tip deflects as the linear beam-column, delta = e (tan kL - kL) / k per unit
    imperfection e (inverting it gives P_cr within 2 %, measured 0.1 %); above, it buckles
    (delta > 0.1 L): the critical load lies within 2 % of Euler's. At 1.1 P_cr the deflection
    matches the inextensible elastica, 2 sqrt(m) L / K(m) with K(m) = (pi/2) sqrt(1.1),
    within 2 % (large deflection: 0.51 L)."""
    net, p = column(length=1.0, radius=0.02, elements=16)
    L, EI = p["length"], p["EI"]
    sec = cosnet.Circle(0.02)
    w1 = 1.8751**2 * math.sqrt(EI / (STEEL.density * sec.A)) / L**2
    deflection = {}
    for ratio in (0.94, 0.98, 1.02, 1.1):
        d, sim = settled_tip_deflection(net, p, ratio, w1)
        deflection[ratio] = d
        if ratio != 1.02:           # (near P_cr the motion is slow: there it need only buckle)
            assert np.abs(sim.state.v).max() < 1e-3 * w1 * abs(d)        # settled
    print("tip deflection / L:", {k: round(v / L, 5) for k, v in deflection.items()})
    for ratio in (0.94, 0.98):
        # delta / (e L) = (tan x - x) / x with x = k L = (pi/2) sqrt(P / P_cr_measured)
        target = deflection[ratio] / (IMPERFECTION * L)
        x = brentq(lambda x: (math.tan(x) - x) / x - target, 1e-6, 0.5 * math.pi - 1e-12)
        p_cr = ratio * p["P_cr"] * (0.5 * math.pi / x) ** 2
        print(f"P = {ratio} P_cr: inferred P_cr / Euler = {p_cr / p['P_cr']:.5f}")
        assert abs(p_cr / p["P_cr"] - 1) < 0.02
    assert deflection[0.98] < 0.02 * L and deflection[1.02] > 0.1 * L
    exact = elastica_tip_deflection(1.1, L)
    print(f"elastica at 1.1 P_cr: {deflection[1.1] / L:.5f} L, exact {exact / L:.5f} L")
    assert abs(deflection[1.1] / exact - 1) < 0.02


def test_shallow_arch_snaps_through_and_back():
    """A clamped shallow arch (span 1 m, rise h = 5 cm, L/r = 50) loaded quasi-statically at
    its crown (steps of 20 P0, P0 = E I h / span^3, damped): the crown sinks smoothly, then
    jumps in one load step from above the chord to below it (the inverted state, a drop
    > h); unloaded to 150 P0 it stays inverted although loading gave an upright state at
    140 and 160 P0 (two stable equilibria: the snap-through hysteresis); at 100 P0 it snaps
    back onto the loading branch (same state to 1e-6 h), and unloaded it returns to the
    stress-free arch (crown at h to 1e-9, strain energy 0)."""
    net, p = shallow_arch(elements=8)
    h, span, EI = p["rise"], p["span"], p["EI"]
    sec = cosnet.Circle(0.01)
    w1 = 22.4 * math.sqrt(EI / (STEEL.density * sec.A)) / span**2   # clamped-clamped beam
    P0 = EI * h / span**3
    levels = [100, 120, 140, 160, 180, 200, 150, 100, 0]
    ramp, hold = 5.0 / w1, 40.0 / w1
    times, values = [0.0], [0.0]
    for c in levels:
        times += [times[-1] + ramp, times[-1] + ramp + hold]
        values += [c, c]
    load = cosnet.NodeLoad(p["crown"], force=(0.0, 0.0, -P0), times=times, values=values)
    sim = cosnet.Simulation(net, effects=[load, cosnet.Damping(w1)])
    z = []
    for i in range(len(levels)):
        sim.run(until=times[2 * i + 2] - 0.5 * sim.dt)
        z.append(sim.node_position(p["crown"])[2] / h)
        assert np.abs(sim.state.v).max() < 1e-4 * w1 * h          # a settled equilibrium
    print("crown / h at", levels, ":", np.round(z, 6))
    up = z[:5]
    assert all(a > b for a, b in zip(up, up[1:])) and up[-1] > 0.5       # upright, sinking
    assert z[5] < 0 and up[-1] - z[5] > 1.0                               # the jump
    assert z[6] < 0 and z[2] > 0.5 and z[3] > 0.5                        # hysteresis at 150 P0
    assert abs(z[7] - z[0]) < 1e-6                                        # back on the upright branch
    assert abs(z[8] - 1.0) < 1e-9 and sim.energy_parts()["strain"] < 1e-12 * P0 * h
