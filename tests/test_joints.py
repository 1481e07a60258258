"""Penalty joints (spherical, hinge, fixed) between line ends: the constraint errors fall as
1/k, the springs conserve energy up to Verlet's bounded O(dt^2) error, the hinge keeps the
second line in its plane, the fixed joint keeps the relative rotation, and a stiff fixed joint
converges to the exact junction of the same T."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.core.rotations import matrix_from_quat
from nets import STEEL

KINDS = {"spherical": cosnet.SphericalJoint, "hinge": cosnet.HingeJoint, "fixed": cosnet.FixedJoint}
NORMAL = np.array([0.0, 1.0, 0.0])  # the hinge plane x-z holds both lines as built


def pair(kind, k, kt=1.0, n=6, push=0.3, g=(0.0, 0.0, -9.81)):
    """Line a clamped at the origin along x, line b hanging from a's end along -z on its own
    node, joined there; b is pushed out of the x-z plane at speed ``push``. Returns (sim, a, b)."""
    net = cosnet.Net()
    a0 = net.add_node((0.0, 0.0, 0.0), fixed=True)
    a1 = net.add_node((0.5, 0.0, 0.0))
    b0 = net.add_node((0.5, 0.0, 0.0))
    b1 = net.add_node((0.5, 0.0, -0.5))
    sec = cosnet.Circle(0.01)
    a = net.add_line(a0, a1, material=STEEL, section=sec, elements=n, name="a")
    b = net.add_line(b0, b1, material=STEEL, section=sec, elements=n, name="b")
    extra = {} if kind == "spherical" else {"kt": kt}
    if kind == "hinge":
        extra["normal"] = NORMAL
    joint = KINDS[kind](a, "end", b, "start", k=k, **extra)
    sim = cosnet.Simulation(net, [cosnet.Gravity(g), joint])
    sim.line_velocities(b)[1:-1, 1] = push * np.arange(1, n) / n
    sim.node_velocity(b1)[1] = push
    return sim, a, b


def end_frame(sim, line, at):
    """Line-end frame D X (1.3) and position of the start (at = 0) or end (at = -1) of line."""
    m, s = sim.model, sim.state
    a = 2 * line.index + (0 if at == 0 else 1)
    nd = m.attach_node[a]
    return matrix_from_quat(s.node_q[nd]) @ matrix_from_quat(m.attach_frame[a]), sim.line_positions(line)[at]


def errors(sim, a, b, ea0, eb0):
    """(gap, out-of-plane tangent s, relative rotation angle change) of the joint a end - b start."""
    ea, xa = end_frame(sim, a, -1)
    eb, xb = end_frame(sim, b, 0)
    normal = ea @ ea0.T @ NORMAL
    dev = (ea0.T @ eb0).T @ (ea.T @ eb)
    angle = math.acos(min(1.0, max(-1.0, (np.trace(dev) - 1.0) / 2.0)))
    return np.array([np.linalg.norm(xb - xa), abs(eb[:, 2] @ normal), angle])


def worst_errors(sim, a, b, until=0.02, samples=20):
    ea0, _ = end_frame(sim, a, -1)
    eb0, _ = end_frame(sim, b, 0)
    worst = np.zeros(3)
    for i in range(samples):
        sim.run(until=until * (i + 1) / samples)
        worst = np.maximum(worst, errors(sim, a, b, ea0, eb0))
    return worst


@pytest.mark.parametrize("kind", KINDS)
def test_constraint_error_falls_as_one_over_k(kind):
    """Under a steady load (gravity tilted out of the x-z plane, from rest) the gap, and for
    hinge / fixed the out-of-plane tangent or the rotation deviation, fall ten-fold when k
    and kt rise ten-fold. (A sudden push would be caught with an error ~ 1/sqrt(k).)"""
    measured = [worst_errors(*pair(kind, k, kt=kt, push=0.0, g=(0.0, 5.0, -9.81)))
                for k, kt in ((1e6, 1e5), (1e7, 1e6))]
    ratio = measured[0] / measured[1]
    assert 6.0 < ratio[0] < 16.0, ratio
    which = {"hinge": 1, "fixed": 2}.get(kind)
    if which is not None:
        assert 6.0 < ratio[which] < 16.0, ratio


@pytest.mark.parametrize("kind", KINDS)
def test_energy_is_conserved_with_second_order_error(kind):
    """nu = 0: the joint springs are conservative; the energy error of Verlet stays bounded
    and falls four-fold when dt halves."""
    worst = []
    for f in (1.0, 0.5):
        sim, a, b = pair(kind, 1e7, kt=1e5, push=3.0)   # the hinge / fixed springs store ~1 J
        sim.dt *= f
        e0 = sim.energy()
        w = 0.0
        for i in range(20):
            sim.run(until=0.01 * (i + 1) / 20)
            w = max(w, abs(sim.energy() - e0))
        worst.append(w)
    scale = sim.energy_parts()["kinetic"]
    assert worst[0] < 1e-3 * scale
    assert 3.0 < worst[0] / worst[1] < 5.0, worst


def test_hinge_keeps_the_line_in_its_plane_and_the_fixed_joint_its_angle():
    """Pushed out of the plane at 3 m/s, the line on a spherical joint swings out of it by
    7 degrees in 0.02 s; on a hinge it stays in the plane within 0.05 degree, and on a fixed
    joint it also keeps its right angle to line a."""
    free = worst_errors(*pair("spherical", 1e7, push=3.0))
    hinge = worst_errors(*pair("hinge", 1e7, kt=1e5, push=3.0))
    fixed = worst_errors(*pair("fixed", 1e7, kt=1e5, push=3.0))
    assert free[1] > 0.1 and free[2] > 0.1               # a real swing out of the plane
    assert hinge[1] < 0.01 * free[1] and hinge[1] < 1e-3
    assert hinge[2] > 0.1 * free[2]                      # ... while it turns about the hinge
    assert fixed[2] < 0.01 * free[2] and fixed[2] < 1e-3


def tee(k=None, kt=None, n=6):
    """The T of cases/t_junction.toml: beam A-J-B clamped at both ends, stem J-C with 2 kg at
    C. With k: the stem starts on its own node at J, held to the left beam's end by a fixed
    joint. Returns (sim, C)."""
    net = cosnet.Net()
    A = net.add_node((0.0, 0.0, 0.0), fixed=True)
    J = net.add_node((1.0, 0.0, 0.0))
    B = net.add_node((2.0, 0.0, 0.0), fixed=True)
    C = net.add_node((1.0, 0.0, -0.8), mass=2.0, inertia=(1e-3, 1e-3, 1e-3))
    sec = cosnet.Circle(0.02)
    left = net.add_line(A, J, material=STEEL, section=sec, elements=n)
    net.add_line(J, B, material=STEEL, section=sec, elements=n)
    start = J if k is None else net.add_node((1.0, 0.0, 0.0))
    stem = net.add_line(start, C, material=STEEL, section=sec, elements=n)
    effects = [cosnet.Gravity()]
    if k is not None:
        effects.append(cosnet.FixedJoint(left, "end", stem, "start", k=k, kt=kt))
    return net, effects, C


def tip_path(net, effects, C, dt, until=0.02, samples=20):
    sim = cosnet.Simulation(net, effects, dt=dt)
    path = []
    for i in range(samples):
        sim.run(until=until * (i + 1) / samples)
        path.append(sim.node_position(C).copy())
    return np.array(path)


def test_stiff_fixed_joint_converges_to_the_exact_junction():
    """The stem's tip swings under gravity the same way whether the stem is welded to the
    beam at one node or held by a fixed joint; the difference falls ~ten-fold per decade of
    stiffness (all runs at the step of the stiffest)."""
    stiff = [(1e7, 1e5), (1e8, 1e6), (1e9, 1e7)]
    dt = cosnet.Simulation(*tee(*stiff[-1])[:2]).dt
    exact = tip_path(*tee(), dt=dt)
    swing = np.abs(exact - (1.0, 0.0, -0.8)).max()
    diff = [np.abs(tip_path(*tee(k, kt), dt=dt) - exact).max() / swing for k, kt in stiff]
    assert diff[0] > 5 * diff[1] > 25 * diff[2], diff
    assert diff[2] < 1e-3, diff


def test_stable_step_shrinks_with_the_joint_stiffness():
    """The joint's squared frequency k (1/m_a + 1/m_b) + kt (1/J_a + 1/J_b) adds to the net's
    own bound, so 1/dt^2 = own + c k is linear in k (kt = k / 1000): its values at k = 1e2,
    1e10 and 1e12 lie on one line, to round-off; and dt falls as 1/sqrt(k) once the joint
    rules: dt(1e10) / dt(1e12) = 10 sqrt((1 + own / c 1e12) / (1 + own / c 1e10)), which is 10
    less at most own / (2 c 1e10)."""
    ks = (1e2, 1e10, 1e12)
    dts = [pair("fixed", k, kt=1e-3 * k)[0].stable_dt() for k in ks]
    assert dts[0] >= dts[1] > dts[2]
    inv = [1.0 / dt ** 2 for dt in dts]
    c = (inv[2] - inv[0]) / (ks[2] - ks[0])
    own = inv[0] - c * ks[0]
    assert inv[1] == pytest.approx(own + c * ks[1], rel=1e-9)
    assert 0 <= 10.0 - dts[1] / dts[2] <= 10.0 * own / (2 * c * ks[1]) * (1 + 1e-9)


def test_joint_keywords_and_bad_input():
    net = cosnet.Net()
    n0, n1, n2 = (net.add_node((x, 0.0, 0.0)) for x in (0.0, 1.0, 2.0))
    a = net.add_line(n0, n1, material=STEEL, section=cosnet.Circle(0.01), elements=2, name="a")
    b = net.add_line(n1, n2, material=STEEL, section=cosnet.Circle(0.01), elements=2, name="b")
    j = cosnet.FixedJoint(line_a=a, end_a="end", line_b=b, end_b="start", k=1e4, kt=1.0)
    assert (j.line_a, j.end_a, j.line_b, j.end_b) == (a, "end", b, "start")
    with pytest.raises(ValueError, match="'start' or 'end'"):
        cosnet.SphericalJoint(a, "middle", b, "start", k=1.0)
    for bad in (0.0, -1.0, float("nan"), "stiff"):
        with pytest.raises(ValueError, match="k must be"):
            cosnet.SphericalJoint(a, "end", b, "start", k=bad)
    with pytest.raises(ValueError, match="kt must be"):
        cosnet.HingeJoint(a, "end", b, "start", k=1.0, kt=0.0)
    with pytest.raises(ValueError, match="itself"):
        cosnet.SphericalJoint(a, "end", a, "end", k=1.0)
    with pytest.raises(ValueError, match="normal"):
        cosnet.HingeJoint(a, "end", b, "start", k=1.0, kt=1.0, normal=(0, 0, 0))
    with pytest.raises(ValueError, match="Line"):
        cosnet.SphericalJoint(n0, "end", b, "start", k=1.0)
    other, line_elsewhere = cosnet.Net(), None
    m0, m1 = other.add_node((0.0, 0.0, 0.0)), other.add_node((1.0, 0.0, 0.0))
    line_elsewhere = other.add_line(m0, m1, material=STEEL, section=cosnet.Circle(0.01), elements=2)
    with pytest.raises(ValueError, match="not a line of this simulation's net"):
        cosnet.Simulation(net, [cosnet.SphericalJoint(line_elsewhere, "end", b, "start", k=1.0)])


def test_fixed_joint_rest_angle_about_a_lab_axis_is_the_built_relative_rotation():
    """Giving the built relative rotation of the two end frames as angle and lab axis rests the
    joint exactly where angle=None (the built geometry) does."""
    sim, a, b = pair("fixed", k=1e6, kt=1.0)
    ea, _ = end_frame(sim, a, -1)
    eb, _ = end_frame(sim, b, 0)
    rotvec = Rotation.from_matrix(ea.T @ eb).as_rotvec()          # in line a's end frame
    theta = float(np.linalg.norm(rotvec))
    assert theta > 1.0                                              # the lines meet at a right angle
    on = cosnet.Binding(sim.net, sim.model, sim.state)
    built = cosnet.FixedJoint(a, "end", b, "start", k=1e6, kt=1.0).bind(on)
    given = cosnet.FixedJoint(a, "end", b, "start", k=1e6, kt=1.0, angle=theta,
                              axis=ea @ rotvec / theta).bind(on)
    q0, q1 = built.rest_rotation[0], given.rest_rotation[0]
    assert min(np.abs(q0 - q1).max(), np.abs(q0 + q1).max()) < 1e-12
