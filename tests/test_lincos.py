"""Analytic normal modes (§6): classical beam frequencies, junctions with offsets, rigid modes."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.studies.lincos import analytic_modes
from nets import STEEL

EB_CLAMPED_FREE = (1.8751040687, 4.6940911330, 7.8547574382)
EB_FREE_FREE = 4.7300407449


def rod(length=1.0, radius=0.005, root_fixed=True, tip_mass=0.0, section=None):
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=root_fixed, name="root")
    b = net.add_node((0.0, 0.0, length), mass=tip_mass, name="tip")
    sec = section or cosnet.Circle(radius)
    line = net.add_line(a, b, material=STEEL, section=sec, elements=4, name="rod")
    return net, line, sec


def bending_scale(sec, length):
    """sqrt(E I / (rho A)) / L^2: omega = (beta L)^2 x this (Euler-Bernoulli)."""
    return math.sqrt(STEEL.E * sec.I11 / (STEEL.density * sec.A)) / length**2


def test_clamped_free_bending_matches_euler_bernoulli_and_is_doubly_degenerate():
    net, line, sec = rod(radius=0.005)                       # L / r = 200
    res = analytic_modes(net, count=6)
    assert res.rigid_modes == 0
    beta_l = np.sqrt(res.omega / bending_scale(sec, 1.0))
    print("\nclamped-free beta L:", beta_l[::2], "Euler-Bernoulli:", EB_CLAMPED_FREE)
    for k in range(3):
        w1, w2 = res.omega[2 * k], res.omega[2 * k + 1]
        assert w1 == pytest.approx(w2, rel=1e-9)              # two bending planes, one frequency
        assert beta_l[2 * k] == pytest.approx(EB_CLAMPED_FREE[k], rel=5e-3)
        # Timoshenko (shear, rotary inertia) lies below Euler-Bernoulli
        assert beta_l[2 * k] < EB_CLAMPED_FREE[k]
        if k:
            assert res.omega[2 * k] > res.omega[2 * k - 1] * 1.5
        # the pair's tip displacements are perpendicular bending directions
        tips = [m.line_shape(line, 1.0)[0][0] for m in res.shapes[2 * k:2 * k + 2]]
        assert abs(tips[0][2]) < 1e-9 * np.linalg.norm(tips[0])
        assert abs(np.dot(tips[0], tips[1])) < 1e-6 * np.linalg.norm(tips[0]) * np.linalg.norm(tips[1])


def test_clamped_free_first_shape_is_euler_bernoulli_and_mass_normalised():
    net, line, sec = rod(radius=0.005)
    mode = analytic_modes(net, count=1).shapes[0]
    s = np.linspace(0.0, 1.0, 21)
    u, _ = mode.line_shape(line, s)
    b = EB_CLAMPED_FREE[0]
    sig = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))
    phi = np.cosh(b * s) - np.cos(b * s) - sig * (np.sinh(b * s) - np.sin(b * s))
    phi /= math.sqrt(STEEL.density * sec.A * 1.0)            # unit modal mass: int rho A phi^2 = 1
    lateral = np.linalg.norm(u[:, :2], axis=1) * np.sign(u[-1, :2] @ u[:, :2].T)
    assert np.abs(lateral - phi).max() < 2e-3 * np.abs(phi).max()
    assert np.allclose(mode.node_displacement[1], u[-1], rtol=1e-8, atol=1e-12)


def test_axial_and_torsional_quarter_waves_are_exact():
    net, line, sec = rod(radius=0.02)
    w_ax = math.pi / 2 * math.sqrt(STEEL.E / STEEL.density)
    w_tor = math.pi / 2 * math.sqrt(STEEL.G / STEEL.density)
    res = analytic_modes(net, omega_max=1.01 * w_ax)
    kinds = {}
    for m in res.shapes:
        u, th = m.line_shape(line, 1.0)
        if abs(u[0, 2]) > 0.99 * np.linalg.norm(u[0]) and np.linalg.norm(th) < 1e-9:
            kinds.setdefault("axial", []).append(m.omega)
        if abs(th[0, 2]) > 0.99 * np.linalg.norm(th[0]) and np.linalg.norm(u) < 1e-9:
            kinds.setdefault("torsion", []).append(m.omega)
    print(f"\naxial {kinds['axial']} vs {w_ax}; torsion {kinds['torsion']} vs {w_tor}")
    assert kinds["axial"] == [pytest.approx(w_ax, rel=1e-6)]
    assert kinds["torsion"] == [pytest.approx(w_tor, rel=1e-6)]


def test_tip_mass_matches_classical_frequency_equation():
    ratio = 0.5                                            # tip mass / rod mass
    sec = cosnet.Circle(0.005)
    m_rod = STEEL.density * sec.A * 1.0
    net, line, _ = rod(radius=0.005, tip_mass=ratio * m_rod)
    res = analytic_modes(net, count=6)

    def f(bl):
        return (1 + math.cos(bl) * math.cosh(bl)
                + ratio * bl * (math.cos(bl) * math.sinh(bl) - math.sin(bl) * math.cosh(bl)))

    grid = np.linspace(0.1, 12.0, 2000)
    vals = [f(x) for x in grid]
    roots = [brentq(f, grid[i], grid[i + 1]) for i in range(len(grid) - 1) if vals[i] * vals[i + 1] < 0][:3]
    beta_l = np.sqrt(res.omega[::2] / bending_scale(sec, 1.0))
    print("\ntip mass beta L:", beta_l, "classical:", roots)
    assert np.allclose(beta_l, roots, rtol=5e-3)
    assert np.allclose(res.omega[::2], res.omega[1::2], rtol=1e-9)


def test_free_free_rod_skips_six_rigid_modes():
    net, line, sec = rod(radius=0.005, root_fixed=False)
    res = analytic_modes(net, count=2)
    assert res.rigid_modes == 6
    beta_l = np.sqrt(res.omega / bending_scale(sec, 1.0))
    print("\nfree-free beta L:", beta_l, "Euler-Bernoulli:", EB_FREE_FREE)
    assert beta_l == pytest.approx([EB_FREE_FREE] * 2, rel=5e-3)


def l_frame(split: bool):
    """Clamped vertical post + horizontal arm; the corner is a point junction, or an extended
    rigid node of negligible mass placed elsewhere, turned, with offsets to the same corner."""
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    tip = net.add_node((0.6, 0.0, 0.8), mass=0.2, name="tip")
    corner_pt = np.array([0.0, 0.0, 0.8])
    sec = cosnet.Rectangle(0.02, 0.012)
    if split:
        R = Rotation.from_rotvec([0.3, -0.5, 0.7]).as_matrix()
        pos = corner_pt + np.array([0.05, -0.03, 0.02])
        corner = net.add_node(pos, frame=R, mass=1e-12, inertia=np.full(3, 1e-15), name="corner")
        xi = R.T @ (corner_pt - pos)
        kw1, kw2 = dict(end_offset=xi), dict(start_offset=xi)
    else:
        corner = net.add_node(corner_pt, name="corner")
        kw1 = kw2 = {}
    net.add_line(root, corner, material=STEEL, section=sec, elements=4, d1=(1, 0, 0), name="post", **kw1)
    net.add_line(corner, tip, material=STEEL, section=sec, elements=4, d1=(0, 1, 0), name="arm", **kw2)
    return net


def test_l_frame_spectrum_is_the_same_with_a_split_corner_node():
    one = analytic_modes(l_frame(False), count=8)
    two = analytic_modes(l_frame(True), count=8)
    print("\nL-frame omega:", one.omega, "\nsplit corner: ", two.omega)
    assert one.rigid_modes == two.rigid_modes == 0
    assert np.allclose(one.omega, two.omega, rtol=1e-8)
    assert np.all(np.diff(one.omega) > 1e-6 * one.omega[1:])   # rectangle: no degeneracy


def test_stocky_pinned_rod_shows_timoshenko_shear_correction():
    L, r, kappa = 0.5, 0.05, 0.9
    sec = cosnet.Circle(r, shear_coefficient=kappa)
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), mass=np.inf, inertia=[0.0, 0.0, np.inf], name="a")
    b = net.add_node((0.0, 0.0, L), mass=np.inf, inertia=[0.0, 0.0, 0.0], name="b")
    line = net.add_line(a, b, material=STEEL, section=sec, elements=4)
    E, G, rho = STEEL.E, STEEL.G, STEEL.density
    w_eb = [(n * math.pi / L) ** 2 * math.sqrt(E * sec.I11 / (rho * sec.A)) for n in (1, 2)]
    res = analytic_modes(net, omega_max=1.02 * w_eb[1])
    assert res.rigid_modes == 0
    bending = [m.omega for m in res.shapes
               if np.linalg.norm(m.line_shape(line, 0.37)[0][0, :2]) > 1e-6]
    timo = []
    for n in (1, 2):    # sin(n pi s / L) exactly; lower root of the Timoshenko dispersion relation
        k = n * math.pi / L
        qa = rho * sec.A * rho * sec.I11
        qb = (kappa * G * sec.A * rho * sec.I11 * k**2 + rho * sec.A * E * sec.I11 * k**2
              + rho * sec.A * kappa * G * sec.A)
        qc = kappa * G * sec.A * E * sec.I11 * k**4
        timo.append(math.sqrt(2 * qc / (qb + math.sqrt(qb * qb - 4 * qa * qc))))
    print("\nstocky pinned rod: cosnet", bending, "\nTimoshenko", timo, "\nEuler-Bernoulli", w_eb)
    assert bending == pytest.approx([timo[0], timo[0], timo[1], timo[1]], rel=1e-8)
    assert timo[0] < 0.97 * w_eb[0] and timo[1] < 0.9 * w_eb[1]     # a real shear correction


def test_bad_input_is_refused():
    net, line, _ = rod()
    with pytest.raises(ValueError, match="count"):
        analytic_modes(net, count=0)
    curved = cosnet.Net()
    a = curved.add_node((0.0, 0.0, 0.0), fixed=True)
    b = curved.add_node((1.0, 0.0, 0.0))
    curved.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=3,
                    points=[(0, 0, 0), (0.5, 0.2, 0), (1, 0, 0)], name="bent")
    with pytest.raises(ValueError, match="line 'bent'.*straight"):
        analytic_modes(curved, count=1)
    pre = cosnet.Net()
    a = pre.add_node((0.0, 0.0, 0.0), fixed=True)
    b = pre.add_node((0.0, 0.0, 1.0))
    pre.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=3,
                 end_frame=Rotation.from_rotvec([0.2, 0, 0]).as_matrix(), name="twisted")
    with pytest.raises(ValueError, match="line 'twisted'.*end_frame"):
        analytic_modes(pre, count=1)


def tip_body(on_arm: bool):
    """Cantilever carrying a rigid body whose centroid sits off the rod's end: either an extended
    node with an offset (6.36), or a point mass on a stiff, nearly massless arm."""
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    end = np.array([0.0, 0.0, 0.7])
    centroid = end + np.array([0.12, 0.05, 0.03])
    R = Rotation.from_rotvec([0.4, 0.1, -0.6]).as_matrix()
    body = dict(frame=R, mass=0.4, inertia=[2e-4, 3e-4, 1e-4], name="body")
    sec = cosnet.Circle(0.006)
    if on_arm:
        tip = net.add_node(end, name="tip")
        b = net.add_node(centroid, **body)
        # 1e5 x stiffer than the rod: stiff enough to be rigid to 1e-6, soft enough to stay well
        # conditioned (at 1e6 x, round-off in the transfer matrices reaches 1e-5).
        arm = cosnet.Material(E=2e16, G=8e15, density=1e-6, name="rigid-light")
        net.add_line(root, tip, material=STEEL, section=sec, elements=4, name="rod")
        net.add_line(tip, b, material=arm, section=cosnet.Circle(0.01), elements=2, name="arm")
    else:
        b = net.add_node(centroid, **body)
        net.add_line(root, b, material=STEEL, section=sec, elements=4, name="rod",
                     end_offset=R.T @ (end - centroid))
    return net


def test_extended_node_offset_equals_mass_on_a_rigid_arm():
    off = analytic_modes(tip_body(False), count=6)
    arm = analytic_modes(tip_body(True), count=6)
    print("\noffset node:", off.omega, "\nrigid arm:  ", arm.omega)
    assert np.allclose(off.omega, arm.omega, rtol=1e-5)
