"""Greenhill's problem: a straight line, both ends clamped, one end turned about the line's axis
(free to slide along it, so no axial force) buckles at the critical twist of the linear theory.

Reference (Greenhill 1883; Timoshenko & Gere, Theory of Elastic Stability, 2nd ed., §2.18;
the same linearisation as cosseratbench 0.3.0's `twist` experiment at zero tension). A
sideways displacement w = x + i y of a rod of bending stiffness B = E I under an axial twisting
moment M obeys B w'''' - i M w''' = 0. With m = M L / B and z = s / L its solutions are
w = a + b z + c z^2 + d exp(i m z); clamped ends, w = w' = 0 at z = 0 and z = 1, leave a
nonzero solution where the 4 x 4 determinant vanishes, which reduces to tan(m/2) = m/2: the
smallest root is m/2 = 4.4934, M_cr = 8.9868 E I / L = 2.8606 pi E I / L. The straight rod
carries M = G J theta / L under a twist theta, so it buckles at theta_cr = M_cr L / (G J)
(test_greenhill_root_of_the_clamped_determinant checks the reduction numerically).

Measurement: several lines side by side, independent, are each turned smoothly to a level
(a fraction of theta_cr) and held, starting very slightly bent. Under mass-proportional damping
at one rate nu on velocities and angular velocities alike, every mode of the linearised line
about the twisted straight state grows or decays as exp(s t) with s^2 + nu s = lambda, lambda
the mode's stiffness eigenvalue over its mass (its generalised mass includes the rotary
inertia, so the `rotary` fast-modes setting, which scales that inertia only, leaves the zero of
lambda - the static loss of stability - where it is). The growth rate s of a line past
threshold gives lambda exactly; lambda is interpolated linearly to zero between the two lowest
growing levels. Lines below threshold must stay straight (their bend decays).

Measured so (verlet, the stable step): critical twist / theta_cr - 1 = 1.6e-2, 2.7e-3 and
-1.6e-4 at n = 8, 16, 32, converging at order 2 to a limit about 1e-3 below Greenhill's: the
Cosserat line shears and stretches, which lowers its critical twist by O((r/L)^2), r/L = 0.02.
"""

import numpy as np
import pytest

import cosnet

E, G, RHO, LENGTH, RADIUS = 1e6, 1e6 / 3.0, 1000.0, 1.0, 0.02
MATERIAL = cosnet.Material(E=E, G=G, density=RHO)
EI, GJ = E * np.pi * RADIUS ** 4 / 4, G * np.pi * RADIUS ** 4 / 2
NU = 2.0            # 1/s, damping rate of velocities and angular velocities
RAMP, HOLD = 2.0, 10.0
LEVELS = (0.98, 1.005, 1.01, 1.02, 1.03, 1.04)
BEND = 1e-4         # initial bend, in line lengths
LINEAR = 1e-2       # m: beyond this sideways distance growth is no longer exponential
FRAME = 0.05        # s between samples


def greenhill_m():
    """The smallest root of tan(x) = x, doubled: M_cr L / (E I) for clamped ends."""
    x = 4.49
    for _ in range(50):   # Newton on sin x - x cos x
        x -= (np.sin(x) - x * np.cos(x)) / (x * np.sin(x))
    return 2.0 * x


THETA_CR = greenhill_m() * EI / GJ


def clamped_determinant(m):
    """det of w, w' at z = 0 and z = 1 for w = a + b z + c z^2 + d exp(i m z)."""
    e = np.exp(1j * m)
    rows = [[1, 0, 0, 1], [0, 1, 0, 1j * m], [1, 1, 1, e], [0, 1, 2, 1j * m * e]]
    return np.linalg.det(np.array(rows, dtype=complex))


def test_greenhill_root_of_the_clamped_determinant():
    """The determinant's smallest nonzero root is the 2.8606 pi of tan(m/2) = m/2."""
    m = greenhill_m()
    assert m == pytest.approx(2.8606 * np.pi, rel=2e-5)
    assert abs(clamped_determinant(m)) < 1e-10
    grid = np.linspace(0.5, m - 0.05, 400)   # and none below it
    assert min(abs(clamped_determinant(x)) for x in grid) > 1e-3


def growth_rate(n, level):
    """Growth rate (1/s) of the sideways bend of a line of n elements held at level x THETA_CR,
    fitted once the ramp's transient has decayed (as exp(-NU t / 2)), while the bend is small
    (the run stops there: a buckled line goes on to coil, which says nothing more about the
    threshold)."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=True)
    b = net.add_node((LENGTH, 0.0, 0.0))
    line = net.add_line(a, b, material=MATERIAL, section=cosnet.Circle(RADIUS), elements=n)
    turn = cosnet.Path(times=[0.0, RAMP], values=[0.0, level * THETA_CR])
    drive = cosnet.Drive(b, rotation=turn, axis=(1.0, 0.0, 0.0), slide=True)
    sim = cosnet.Simulation(net, [cosnet.Damping(NU), drive], fast_modes="rotary")
    x = sim.line_positions(line)
    x[:, 2] += BEND * LENGTH * (1.0 - np.cos(2.0 * np.pi * x[:, 0] / LENGTH)) / 2.0
    times, bends = [], []
    while sim.time < RAMP + HOLD - 1e-9 and not (bends and bends[-1] >= LINEAR):
        sim.run(until=sim.time + FRAME)
        times.append(sim.time)
        bends.append(np.linalg.norm(x[:, 1:] - x[0, 1:], axis=1).max())
    times, bends = np.array(times), np.array(bends)
    use = (times > RAMP + 3.0) & (bends < LINEAR)
    assert use.sum() >= 10, f"n = {n}, level {level}: too few samples before the bend grew large"
    return np.polyfit(times[use], np.log(bends[use]), 1)[0]


def measured_critical_twist(n):
    """(critical twist / THETA_CR, growth rates) for lines of n elements."""
    s = np.array([growth_rate(n, level) for level in LEVELS])
    lam = s * s + NU * s
    growing = np.flatnonzero(s > 0.1)
    assert growing.size >= 2, f"n = {n}: fewer than two levels grew: rates {s}"
    i, j = growing[:2]
    return LEVELS[i] - lam[i] * (LEVELS[j] - LEVELS[i]) / (lam[j] - lam[i]), s


def test_clamped_line_twisted_buckles_at_greenhills_twist_converging_with_n():
    errors = []
    for n in (8, 16, 32):
        level, s = measured_critical_twist(n)
        assert s[0] < -0.1 * NU, f"n = {n}: a line at {LEVELS[0]} of the critical twist did not stay straight"
        errors.append(level - 1.0)
    assert abs(errors[-1]) < 0.01, errors
    # second order in space: the error falls about fourfold from n = 8 to 16, and further at 32
    assert abs(errors[0]) > 2.5 * abs(errors[1]) > 2.5 * abs(errors[2]), errors
