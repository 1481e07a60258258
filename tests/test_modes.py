"""Discrete normal modes: exact Hessian, beam frequencies and their convergence, rigid modes,
and agreement with the time stepper."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.engine.measure import energies
from cosnet.kernels.motion import place_line_ends
from cosnet.studies.modes import linearise, modes, rigid_basis
from cosnet.engine.flatten import flatten
from nets import STEEL, cantilever, free_net

EB_CLAMPED_FREE = (1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910)
EB_FREE_FREE = 4.7300407449
RADIUS = 0.002       # L / r = 500: Timoshenko corrections below 0.08 % for the first five modes
RUBBER = cosnet.Material(E=5e6, G=2e6, density=1000.0, name="rubber")


def bending_scale(radius, length=1.0):
    sec = cosnet.Circle(radius)
    return math.sqrt(STEEL.E * sec.I11 / (STEEL.density * sec.A)) / length**2


# ---------------------------------------------------------------- exact Hessian
def arc_net():
    """A clamped wall, an extended rigid body (non-diagonal inertia, turned frame, offsets), a
    pinned node, a node with a locked axis, and a line built on a circular arc with the matching
    rest curvature (stress free), closing a loop."""
    net = cosnet.Net()
    frame = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    inertia = np.array([[2e-3, 1e-4, 0.0], [1e-4, 3e-3, 2e-4], [0.0, 2e-4, 4e-3]])
    # arc in the plane of e1, e2 about centre c: 4 equal chords turning by dphi
    c, rad, dphi, n_arc = np.array([0.2, -0.1, 0.3]), 0.5, 0.25, 4
    e1, e2 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.6, 0.8])
    phis = dphi * np.arange(n_arc + 1)
    pts = c + rad * (np.cos(phis)[:, None] * e1 + np.sin(phis)[:, None] * e2)
    xi = np.array([0.05, 0.02, -0.03])
    body = net.add_node(pts[0] - frame @ xi, frame=frame, mass=0.4, inertia=inertia, name="body")
    wall = net.add_node((0.0, -0.6, 0.0), fixed=True, name="wall")
    pin = net.add_node(pts[-1], mass=np.inf, name="pin")
    lock = net.add_node((0.9, 0.5, 0.9), mass=0.05, inertia=[1e-5, np.inf, 2e-5], name="lock")
    kappa = dphi / (2 * rad * math.sin(0.5 * dphi))     # turning angle per Voronoi length
    u0 = lambda s: np.zeros(3) if s < 1e-9 or s > 1 - 1e-9 else np.array([kappa, 0.0, 0.0])
    net.add_line(wall, body, material=RUBBER, section=cosnet.Rectangle(0.03, 0.02), elements=3,
                 end_offset=(0.0, -0.05, 0.02), name="strut")
    net.add_line(body, pin, material=RUBBER, section=cosnet.Circle(0.02), elements=n_arc,
                 start_offset=xi, points=pts, rest_curvature=u0, d1=np.cross(e1, e2), name="arc")
    net.add_line(pin, lock, material=RUBBER, section=cosnet.Ellipse(0.02, 0.012), elements=3,
                 d1=(0.0, 0.0, 1.0), name="tie")
    net.add_line(lock, body, material=RUBBER, section=cosnet.Circle(0.015), elements=3,
                 end_offset=(0.02, 0.06, 0.0), name="back")
    return net


def quat_mul(a, b):
    aw, av, bw, bv = a[:, :1], a[:, 1:], b[:, :1], b[:, 1:]
    return np.hstack([aw * bw - np.sum(av * bv, axis=1, keepdims=True),
                      aw * bv + bw * av + np.cross(av, bv)])


def quat_exp(phi):
    xyzw = Rotation.from_rotvec(phi).as_quat()
    return np.hstack([xyzw[:, 3:], xyzw[:, :3]])


def energy_of(model, state, lin):
    """Strain energy as a function of the reduced coordinates q (the nonlinear chart: vertices
    and centres of mass translate, frames turn by exp of the body rotation)."""
    work = type(state)(*(a.copy() for a in state))

    def U(q):
        raw = np.zeros(lin.T.shape[0])
        raw[lin.reduced] = q
        dx, alpha, dc, phi = lin.split(raw)
        work.x[:] = lin.x0 + dx
        work.q[:] = quat_mul(lin.q0, quat_exp(alpha))
        work.node_x[:] = lin.node_x0 + dc
        work.node_q[:] = quat_mul(lin.node_q0, quat_exp(phi))
        place_line_ends(model, work)
        return energies(model, work)[2]
    return U


def test_hessian_equals_finite_difference_hessian_of_the_strain_energy():
    net = arc_net()
    model, state, _ = flatten(net)
    lin = linearise(model, state, net)
    K = lin.K.toarray()
    n = K.shape[0]
    U = energy_of(model, state, lin)
    assert U(np.zeros(n)) < 1e-20                      # the arc's rest curvature makes it stress free
    # steps: 1e-4 rad for rotations, 1e-4 of the shortest element for translations
    is_rot = np.zeros(lin.T.shape[0], dtype=bool)
    nv, ne, nn = lin.sizes
    is_rot[3 * nv:3 * (nv + ne)] = True
    is_rot[3 * (nv + ne + nn):] = True
    h = np.where(is_rot[lin.reduced], 1e-4, 1e-4 * model.element_rest_length.min())
    E = np.diag(h)
    fd = np.empty((n, n))
    for i in range(n):
        fd[i, i] = (U(2 * E[i]) + U(-2 * E[i])) / (4 * h[i] ** 2)      # U(0) = 0
        for j in range(i):
            fd[i, j] = fd[j, i] = (U(E[i] + E[j]) - U(E[i] - E[j]) - U(E[j] - E[i])
                                   + U(-E[i] - E[j])) / (4 * h[i] * h[j])
    d = np.sqrt(np.diag(K))
    assert np.all(np.diag(K) > 0)
    rel = np.abs(fd - K) / np.outer(d, d)             # each entry against its natural scale
    print(f"\n{n} coordinates; largest relative Hessian error {rel.max():.2e}")
    assert rel.max() < 1e-6, np.unravel_index(rel.argmax(), rel.shape)
    # the clamps remove exactly the rigid motions: none is left in this net
    assert rigid_basis(lin, net).shape[1] == 0
    assert np.linalg.eigvalsh(K / np.outer(d, d)).min() > 0


def test_rigid_motions_cost_no_energy_and_free_net_reports_six():
    net = free_net(4)
    res = modes(net, count=4)
    assert res.rigid_modes == 6
    R = rigid_basis(res.lin, net)
    K = res.lin.K
    assert np.abs(K @ R).max() < 1e-10 * abs(K).max() * np.abs(R).max()
    # elastic modes are M-orthogonal to the rigid motions, and M-orthonormal
    M = res.lin.M
    assert np.abs(R.T @ (M @ res.vectors)).max() < 1e-8 * np.abs(R).max()
    assert np.allclose(res.vectors.T @ (M @ res.vectors), np.eye(4), atol=1e-9)
    assert res.omega[0] > 0.1


def test_stress_free_check_names_the_prestressed_line():
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True, name="a")
    b = net.add_node((1, 0, 0), name="b")
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=4,
                 rest_curvature=(0.5, 0.0, 0.0), name="bent")
    with pytest.raises(ValueError, match="line 'bent'.*not stress free"):
        modes(net)
    with pytest.raises(ValueError, match="count"):
        modes(cantilever(4)[0], count=0)
    # a fresh Simulation is at rest: same spectrum; once moved, it is refused
    net = cantilever(6)[0]
    sim = cosnet.Simulation(net)
    assert np.allclose(modes(sim, count=4).omega, modes(net, count=4).omega, rtol=1e-12)
    sim.state.v[3, 2] = 1.0
    sim.run(steps=10)
    with pytest.raises(ValueError, match="line 'rod'.*not yet run"):
        modes(sim)


# ---------------------------------------------------------------- beam frequencies
def cantilever_table(n):
    """beta L of the first five bending frequencies (one per degenerate pair) and the axial and
    torsional quarter-wave frequencies relative to their exact values."""
    net, line, root, tip = cantilever(n=n, radius=RADIUS)
    res = modes(net, count=10)
    pairs = res.omega.reshape(5, 2)
    assert np.allclose(pairs[:, 0], pairs[:, 1], rtol=1e-9), pairs    # round section: double roots
    assert np.all(pairs[1:, 0] > 1.5 * pairs[:-1, 0])
    beta_l = np.sqrt(pairs[:, 0] / bending_scale(RADIUS))
    ratios = []
    for kind, speed in (("axial", math.sqrt(STEEL.E / STEEL.density)),
                        ("torsion", math.sqrt(STEEL.G / STEEL.density))):
        exact = 0.5 * math.pi * speed
        near = modes(net, count=4, sigma=exact)
        share = []
        for j in range(len(near)):
            dx, alpha, _, _ = near.raw(j)
            m = net_kinetic_shares(near, j, dx, alpha)
            share.append(m[kind])
        j = int(np.argmax(share))
        assert share[j] > 0.99, (kind, share)
        ratios.append(near.omega[j] / exact)
    return beta_l, np.array(ratios)


def net_kinetic_shares(res, j, dx, alpha):
    """Share of mode j's kinetic energy (u^T M u = 1) in axial (x) translation and in twist
    (alpha_3) of a single clamped rod (node 1 is its free tip)."""
    model = res.lin.model
    _, _, dc, phi = res.raw(j)
    axial = np.sum(model.vertex_mass[1:-1] * dx[1:-1, 0] ** 2) + model.node_mass[1] * dc[1, 0] ** 2
    twist = np.sum(model.element_inertia[:, 2] * alpha[:, 2] ** 2) + model.node_inertia[1, 2] * phi[1, 2] ** 2
    return {"axial": axial, "torsion": twist}


def test_cantilever_frequencies_converge_to_euler_bernoulli_and_quarter_waves():
    """The first five bending frequencies against the exact ones of the continuous Timoshenko
    rod the grid discretises (cosnet.studies.lincos.analytic_modes), the axial and torsional ones
    against their quarter waves: the staggered grid is centred, so each error is C l^2 +
    O(l^4) and every halving of l divides it by 4 within a few % (orders in (1.9, 2.1)). Shear
    and rotary inertia lower the Timoshenko frequencies below Euler-Bernoulli's by a share of
    order (beta L r / L)^2 (below 0.08 % for the fifth mode at L / r = 500)."""
    ns = (20, 40, 80, 320)
    rows = [cantilever_table(n) for n in ns]
    exact = cosnet.analytic_modes(cantilever(n=20, radius=RADIUS)[0], count=10).omega.reshape(5, 2)[:, 0]
    eb = np.array(EB_CLAMPED_FREE) ** 2 * bending_scale(RADIUS)
    assert np.all((exact < eb) & (1 - exact / eb < (np.array(EB_CLAMPED_FREE) * RADIUS) ** 2))
    errs = np.abs([np.concatenate([b ** 2 * bending_scale(RADIUS) / exact - 1, r - 1]) for b, r in rows])
    names = [f"bend{k + 1}" for k in range(5)] + ["axial", "torsion"]
    orders = np.log2(errs[:2] / errs[1:3])
    print("\nrelative frequency error vs the exact Timoshenko rod (bending) and quarter waves (axial, torsion)")
    print("      n " + " ".join(f"{s:>9}" for s in names))
    for n, e in zip(ns, errs):
        print(f"{n:7d} " + " ".join(f"{x:9.2e}" for x in e))
    for a, b, o in zip(ns[:2], ns[1:3], orders):
        print(f"{a:3d}->{b:3d} " + " ".join(f"{x:9.2f}" for x in o))
    assert np.all(errs[1] < errs[0]) and np.all(errs[2] < errs[1])
    assert np.all((orders > 1.9) & (orders < 2.1)), orders
    assert errs[-1].max() < 5e-3, errs[-1]                # within 0.5 % at 320 elements


def test_free_free_rod_has_six_rigid_modes_and_classical_first_bending():
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), name="a")
    b = net.add_node((0.0, 0.0, 1.0), name="b")
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(RADIUS), elements=80)
    res = modes(net, count=2)
    assert res.rigid_modes == 6
    beta_l = np.sqrt(res.omega / bending_scale(RADIUS))
    print("\nfree-free beta L:", beta_l, "Euler-Bernoulli:", EB_FREE_FREE)
    assert res.omega[0] == pytest.approx(res.omega[1], rel=1e-9)
    assert abs((beta_l[0] / EB_FREE_FREE) ** 2 - 1) < 5e-3


# ---------------------------------------------------------------- time stepper
def oscillation_omega(sim, res, j, periods=2.0, samples=60):
    """Frequency from the zero crossings of modal coordinate j; also the largest other modal
    coordinate relative to the largest of mode j."""
    period = 2 * math.pi / res.omega[j]
    sub = max(1, int(period / samples / sim.dt))
    t, eta = [sim.time], [res.coordinates(sim)]
    while sim.time < periods * period:
        sim.run(steps=sub)
        t.append(sim.time)
        eta.append(res.coordinates(sim))
    t, eta = np.array(t), np.array(eta)
    y = eta[:, j]
    k = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))
    k = k[(t[k] > 0.25 * period)]
    crossings = t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
    half = np.polyfit(np.arange(len(crossings)), crossings, 1)[0]
    others = np.delete(eta, j, axis=1)
    return math.pi / half, np.abs(others).max() / np.abs(y).max()


@pytest.mark.parametrize("which", ["free_net", "cantilever"])
def test_time_stepper_oscillates_at_the_modal_frequency_and_stays_in_the_mode(which):
    if which == "free_net":
        net, j, amp = free_net(4), 0, 1e-4     # lowest elastic mode of a net with a rigid body
    else:
        net, j, amp = cantilever(n=12)[0], 2, 1e-5   # second bending mode
    res = modes(net, count=8)
    sim = cosnet.Simulation(net)
    res.excite(sim, j, amp)
    omega, leak = oscillation_omega(sim, res, j)
    print(f"\n{which}: mode {j} omega {res.omega[j]:.6g}, stepper {omega:.6g}, leak {leak:.2e}")
    assert omega == pytest.approx(res.omega[j], rel=5e-3)
    assert leak < 1e-2


# ---------------------------------------------------------------- rigid-mode counting
def rod_with_ends(start, end, elements=6):
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), name="a", **start)
    b = net.add_node((0.0, 0.6, 0.8), name="b", **end)
    net.add_line(a, b, material=RUBBER, section=cosnet.Rectangle(0.03, 0.02), elements=elements,
                 start_offset=(0.02, 0.0, 0.0) if start.get("mass", 0) != np.inf else (0, 0, 0))
    return net


PIN = dict(mass=np.inf)


@pytest.mark.parametrize("start, end, rigid", [
    (dict(), dict(), 6),                                   # free
    (PIN, dict(), 3),                                      # swings and spins about the pin
    (dict(mass=np.inf, inertia=[np.inf, 0.0, 0.0]), dict(), 2),   # one rotation axis locked
    (PIN, PIN, 1),                                         # spins about the line through the pins
    (dict(fixed=True), dict(), 0),                         # clamped
])
def test_rigid_mode_count_matches_the_zero_eigenvalues(start, end, rigid):
    net = rod_with_ends(start, end)
    res = modes(net, count=2)
    assert res.rigid_modes == rigid
    K, M = res.lin.K.toarray(), res.lin.M.diagonal()
    w2 = np.linalg.eigvalsh(K / np.sqrt(np.outer(M, M)))
    assert np.sum(w2 < 1e-9 * w2.max()) == rigid          # independent count of zero frequencies
    assert res.omega[0] ** 2 == pytest.approx(w2[rigid], rel=1e-8)


# ---------------------------------------------------------------- VTK output
def test_main_modes_writes_an_animated_series_of_each_mode(tmp_path, capsys):
    import xml.etree.ElementTree as ET

    import meshio
    from cosnet.studies.modes import main_modes, spectrum_table, write_modes
    net, line, root, tip = cantilever(n=8)
    res = main_modes(net, 3)
    assert capsys.readouterr().out == ""                  # the library prints nothing
    assert f"{res.omega[2]:.6g}" in spectrum_table(res)
    assert write_modes(res, tmp_path, frames=16, amplitude=0.01) == tmp_path
    spectrum = np.loadtxt(tmp_path / "spectrum.csv", delimiter=",", skiprows=1)
    assert np.allclose(spectrum[:, 1], res.omega)
    for j in range(3):
        frames = [(float(d.get("timestep")), d.get("file"))
                  for d in ET.parse(tmp_path / f"mode_{j:02d}.pvd").getroot().iter("DataSet")]
        assert len(frames) == 16
        assert frames[4][0] == pytest.approx(0.25 * 2 * math.pi / res.omega[j])
        mesh = meshio.read(tmp_path / frames[4][1])          # a quarter period: full amplitude
        disp = mesh.point_data["displacement"][:line.elements + 1]
        shape = res.line_displacement(j, line)
        assert np.allclose(disp, 0.01 * shape / res.peak_displacement(j), atol=1e-12)
        assert np.abs(disp).max() == pytest.approx(0.01)
        assert np.allclose(mesh.points[:9], res.lin.x0 + disp)


def test_cosnet_modes_command_prints_and_writes_the_spectrum_of_a_case(tmp_path):
    """`cosnet modes t_junction` lists the same frequencies as cosnet.modes on the case's net,
    the exact (§6) ones beside them within 2 %, and writes a series per mode that meshio opens."""
    import subprocess
    import sys
    import meshio
    from pathlib import Path
    from cosnet.output.io import read_pvd
    from cosnet.scene.loader import load_scene
    case = Path(__file__).resolve().parents[1] / "cases" / "t_junction.toml"
    r = subprocess.run([sys.executable, "-m", "cosnet.cli", "modes", str(case), "--count", "3",
                        "--out", str(tmp_path), "--frames", "4", "--analytic"],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    net = load_scene(case).net
    want = modes(net, count=3).omega
    rows = (tmp_path / "spectrum.csv").read_text().splitlines()[1:]
    got = np.array([float(row.split(",")[1]) for row in rows])
    assert np.allclose(got, want, rtol=1e-9)
    exact = modes(net, count=3, method="analytic").omega
    assert np.all(np.abs(got - exact) / exact < 0.02)
    assert "analytic (rad/s)" in r.stdout
    head = (tmp_path / "spectrum.csv").read_text().splitlines()[0].split(",")
    assert head[-3:] == ["analytic_omega_rad_s", "analytic_frequency_hz", "relative_difference"]
    table = np.loadtxt(tmp_path / "spectrum.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, head.index("analytic_omega_rad_s")], exact, rtol=1e-9)
    np.testing.assert_allclose(table[:, head.index("analytic_frequency_hz")], exact / (2 * math.pi), rtol=1e-9)
    np.testing.assert_allclose(table[:, -1], (got - exact) / exact, rtol=1e-5)
    for j in range(3):
        frames = read_pvd(tmp_path / f"mode_{j:02d}.pvd")
        assert len(frames) == 4
        assert np.all(np.isfinite(meshio.read(tmp_path / f"mode_{j:02d}_000.vtu").points))
    bad = subprocess.run([sys.executable, "-m", "cosnet.cli", "modes", str(case), "--count", "0"],
                         capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert bad.returncode == 2 and "--count" in bad.stderr
