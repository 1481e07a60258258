"""Rigid contraction (§7): a stiff line and its end nodes become one extended rigid node."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.core.contract import contract
from cosnet.core.grid import build_line_grid
from cosnet.studies.lincos import analytic_modes
from cosnet.core.rotations import frame_from_tangent
from nets import STEEL

ROT_A = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
ROT_B = Rotation.from_rotvec([-0.6, 0.4, 0.1]).as_matrix()


def star(stiff_material=STEEL):
    """Line 'core' from a to b, with other lines hanging off both ends (offsets, frames X)."""
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), frame=ROT_A, mass=0.3, inertia=[1e-3, 2e-3, 3e-3], name="a")
    b = net.add_node((0.0, 0.0, 0.5), frame=ROT_B, mass=0.2, inertia=[4e-4, 5e-4, 6e-4], name="b")
    c = net.add_node((0.4, 0.0, -0.1), mass=0.05, name="c")
    d = net.add_node((-0.3, 0.3, 0.8), name="d")
    e = net.add_node((0.2, -0.4, 0.6), fixed=True, name="e")
    sec = cosnet.Circle(0.01)
    net.add_line(a, b, material=stiff_material, section=sec, elements=5, name="core")
    # a start frame X whose d3 follows the line, with a chosen d1
    t = np.array([0.4, 0.0, -0.1]) - ROT_A @ np.array([0.02, 0.01, 0.0])
    Xd = frame_from_tangent(t, np.array([0.3, 1.0, 0.2]))
    net.add_line(a, c, material=STEEL, section=cosnet.Rectangle(0.02, 0.01), elements=4, name="ac",
                 start_offset=(0.02, 0.01, 0.0), start_frame=ROT_A.T @ Xd)
    net.add_line(d, b, material=STEEL, section=sec, elements=4, name="db", end_offset=(0.0, 0.03, -0.01))
    net.add_line(b, e, material=STEEL, section=sec, elements=3, name="be", d1=(1.0, 0.0, 0.0))
    return net


def end_points(net):
    return {l.name: (l.start.position + l.start.frame @ l.start_offset,
                     l.end.position + l.end.frame @ l.end_offset) for l in net.lines}


def test_mass_is_conserved_and_other_lines_keep_their_ends():
    net = star()
    new = contract(net, net.line("core"), name="ab")
    assert [n.name for n in new.nodes] == ["ab", "c", "d", "e"]
    assert [l.name for l in new.lines] == ["ac", "db", "be"]
    assert new.total_mass() == pytest.approx(net.total_mass(), rel=1e-13)
    core = net.line("core")
    m_core = STEEL.density * core.section.A * core.length
    assert new.node("ab").mass == pytest.approx(0.3 + 0.2 + m_core, rel=1e-13)   # (7.9)
    before, after = end_points(net), end_points(new)
    for name, ends in after.items():
        for p_new, p_old in zip(ends, before[name]):
            assert np.allclose(p_new, p_old, atol=1e-14)
    assert new.node("e").fixed_position and new.node("e").locked_axes.all()


def test_other_lines_keep_their_junction_frames_and_grids():
    net = star()
    new = contract(net, "core")
    for line in new.lines:
        g_new, g_old = build_line_grid(line), build_line_grid(net.line(line.name))
        for side in (0, 1):       # the end directors D(nu) X(nu, lambda) of the engine
            assert np.allclose(g_new.end_frames[side], g_old.end_frames[side], atol=1e-13)
        assert np.allclose(g_new.frames, g_old.frames, atol=1e-13)
        assert np.allclose(g_new.curvature, g_old.curvature, atol=1e-12)


def test_centroid_and_inertia_of_rod_between_point_masses_match_hand_formulas():
    L, r, ma, mb = 0.8, 0.01, 0.3, 0.7
    Ia, Ib = np.array([1e-3, 2e-3, 3e-3]), np.array([4e-4, 5e-4, 6e-4])
    net = cosnet.Net()
    a = net.add_node((1.0, 2.0, 3.0), mass=ma, inertia=Ia, name="a")
    b = net.add_node((1.0, 2.0, 3.0 + L), mass=mb, inertia=Ib, name="b")
    sec = cosnet.Circle(r)
    net.add_line(a, b, material=STEEL, section=sec, elements=7, name="rod")
    node = contract(net, "rod").nodes[0]
    mr = STEEL.density * sec.A * L
    M = ma + mb + mr
    zc = (mb * L + mr * L / 2) / M
    assert node.mass == pytest.approx(M, rel=1e-13)
    assert np.allclose(node.position, (1.0, 2.0, 3.0 + zc), atol=1e-14)
    assert np.allclose(node.frame, np.eye(3))                     # D(nu_c) = D(nu_a)
    transverse = (ma * zc**2 + mb * (L - zc) ** 2 + mr * L**2 / 12 + mr * (L / 2 - zc) ** 2
                  + STEEL.density * sec.I11 * L)
    axial = STEEL.density * (sec.I11 + sec.I22) * L
    expect = np.diag(Ia + Ib + np.array([transverse, transverse, axial]))
    assert np.allclose(node.inertia, expect, rtol=1e-12, atol=1e-18)


def test_fixed_end_stays_fixed_and_pinned_end_turns_about_its_point():
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=True, name="a")
    b = net.add_node((0.0, 0.0, 0.5), mass=0.1, name="b")
    c = net.add_node((0.5, 0.0, 0.5), name="c")
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=3, name="ab")
    net.add_line(b, c, material=STEEL, section=cosnet.Circle(0.01), elements=3, name="bc")
    clamped = contract(net, "ab").nodes[0]
    assert clamped.fixed_position and clamped.locked_axes.all()
    assert np.allclose(clamped.position, 0.0)
    pinned_net = cosnet.Net()
    a = pinned_net.add_node((0.0, 0.0, 0.0), mass=np.inf, inertia=[0.0, 0.0, 0.0], name="a")
    b = pinned_net.add_node((0.0, 0.0, 0.5), mass=0.1, name="b")
    sec = cosnet.Circle(0.01)
    pinned_net.add_line(a, b, material=STEEL, section=sec, elements=3, name="ab")
    pinned = contract(pinned_net, "ab").nodes[0]
    assert pinned.fixed_position and not pinned.locked_axes.any()
    mr = STEEL.density * sec.A * 0.5
    about_pin = 0.1 * 0.25 + mr * 0.25 / 3 + STEEL.density * sec.I11 * 0.5   # m L^2 / 3 about an end
    assert pinned.inertia[0, 0] == pytest.approx(about_pin, rel=1e-12)


def test_stiffer_than_contracts_a_rigid_loop_and_refuses_a_soft_self_loop():
    rigid = replace(STEEL, E=STEEL.E * 1e3, G=STEEL.G * 1e3, name="rigid")
    net = cosnet.Net()
    p = [net.add_node(x, mass=0.1, name=f"p{i}") for i, x in
         enumerate([(0, 0, 0), (0.3, 0, 0), (0, 0.3, 0), (0, 0, 1.0)])]
    sec = cosnet.Circle(0.01)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        net.add_line(p[i], p[j], material=rigid, section=sec, elements=2, name=f"r{i}{j}")
    net.add_line(p[0], p[3], material=STEEL, section=sec, elements=3, name="soft")
    new = contract(net, stiffer_than=STEEL.E * 10)
    assert [n.name for n in new.nodes] == ["p0+p1+p2", "p3"] and [l.name for l in new.lines] == ["soft"]
    assert new.total_mass() == pytest.approx(net.total_mass(), rel=1e-13)
    net.add_line(p[1], p[2], material=STEEL, section=sec, elements=2, name="chord")
    with pytest.raises(ValueError, match="line 'chord'.*itself"):
        contract(net, stiffer_than=STEEL.E * 10)
    with pytest.raises(ValueError, match="no line"):
        contract(net, stiffer_than=STEEL.E * 1e6)
    with pytest.raises(ValueError, match="exactly one"):
        contract(net)


def flexible_with_stiff_arm(factor, post_elements=4, arm_elements=4):
    """Clamped post with an arm scaled by 'factor' in E and G, ending in a point mass."""
    arm = replace(STEEL, E=STEEL.E * factor, G=STEEL.G * factor, name=f"steel x{factor:g}")
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    corner = net.add_node((0.0, 0.0, 0.6), mass=0.05, inertia=[1e-5, 1e-5, 1e-5], name="corner")
    tip = net.add_node((0.3, 0.1, 0.6), mass=0.2, name="tip")
    net.add_line(root, corner, material=STEEL, section=cosnet.Circle(0.006), elements=post_elements,
                 name="post")
    net.add_line(corner, tip, material=arm, section=cosnet.Circle(0.008), elements=arm_elements,
                 name="arm")
    return net


def test_frequencies_approach_the_contracted_net_as_the_line_stiffens():
    rigid = analytic_modes(contract(flexible_with_stiff_arm(1.0), "arm"), count=5).omega
    table = {f: analytic_modes(flexible_with_stiff_arm(f), count=5).omega for f in (1e2, 1e3, 1e4)}
    print("\nfactor   " + "  ".join(f"omega_{k + 1:d}".rjust(12) for k in range(5)))
    for f, w in table.items():
        print(f"{f:8.0e} " + "  ".join(f"{x:12.6f}" for x in w))
    print("rigid    " + "  ".join(f"{x:12.6f}" for x in rigid))
    errs = [np.abs(table[f] - rigid) / rigid for f in (1e2, 1e3, 1e4)]
    for k in range(5):
        assert errs[0][k] > errs[1][k] > errs[2][k]       # monotone approach, mode by mode
        assert all(table[f][k] <= rigid[k] * (1 + 1e-9) for f in table)   # a constraint stiffens
    assert errs[2].max() < 1e-4


def start_in_mode(sim, mode, amplitude):
    """Set every velocity to the mode's, scaled so the largest node displacement is 'amplitude'."""
    from cosnet.core.rotations import matrix_from_quat
    w = mode.omega * amplitude / np.abs(mode.node_displacement).max()
    for line in sim.net.lines:
        n = line.elements
        u, _ = mode.line_shape(line, np.linspace(0.0, 1.0, n + 1))
        sim.line_velocities(line)[1:-1] = w * u[1:-1]
        _, th = mode.line_shape(line, (np.arange(n) + 0.5) / n)
        D = sim.line_directors(line)
        sim.line_angular_velocities(line)[:] = np.einsum("eji,ej->ei", D, w * th)
    for node in sim.net.nodes:
        if node.fixed_position:
            continue
        i, a = node.index, mode.node_rotation[node.index]
        lever = sim.state.node_x[i] - sim.node_position(node)      # reference point -> composite centre
        sim.node_velocity(node)[:] = w * (mode.node_displacement[i] + np.cross(a, lever))
        R = matrix_from_quat(sim.state.node_q[i])
        sim.node_angular_velocity(node)[:] = (R.T @ (w * a)) * (sim.model.node_locked[i] == 0)


def simulated_omega(net, body, mode):
    """Angular frequency of the simulated net started in 'mode', from the body's zero crossings."""
    sim = cosnet.Simulation(net)
    start_in_mode(sim, mode, 1e-4)
    x0 = sim.node_position(body).copy()
    d = mode.node_displacement[body.index]
    period = 2 * math.pi / mode.omega
    sub = max(1, int(period / 60 / sim.dt))
    t, y = [0.0], [0.0]
    while sim.time < 1.3 * period:
        sim.run(steps=sub)
        t.append(sim.time)
        y.append((sim.node_position(body) - x0) @ d)
    t, y = np.array(t), np.array(y)
    k = np.flatnonzero(np.sign(y[1:]) != np.sign(y[:-1]))[1:]      # skip the start at zero
    crossings = t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
    return math.pi / np.mean(np.diff(np.concatenate([[0.0], crossings])))


def test_simulated_contracted_net_converges_to_its_analytic_frequency_at_second_order():
    errors = []
    for n in (8, 16):
        net = contract(flexible_with_stiff_arm(1.0, post_elements=n), "arm")
        mode = analytic_modes(net, count=1).shapes[0]
        measured = simulated_omega(net, net.node("corner+tip"), mode)
        errors.append(abs(measured - mode.omega) / mode.omega)
        print(f"\npost elements {n}: simulated {measured:.5f} rad/s, analytic {mode.omega:.5f}, "
              f"relative error {errors[-1]:.2e}")
    assert errors[1] < 2e-3
    assert 3.0 < errors[0] / errors[1] < 5.0


def post_top_path(net, times):
    """Position of the post's top end at the given times, the net falling from rest under gravity."""
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()])
    out = []
    for t in times:
        sim.run(until=t)
        out.append(sim.line_positions(net.line("post"))[-1].copy())
    return np.array(out), sim.dt


def test_trajectories_under_gravity_approach_the_contracted_net_which_steps_faster():
    """Released under gravity, the post's top follows the contracted net ever closer as the arm
    stiffens; what remains is the arm's lumped mass distribution (the contracted body has the
    exact one, (7.9)/(7.21)), which 16 arm elements make small. The contracted net has no arm
    frequency to resolve, so its automatic dt is larger — the speed-up is printed."""
    times = np.linspace(0.015, 0.06, 4)
    rigid, dt_rigid = post_top_path(contract(flexible_with_stiff_arm(1.0), "arm"), times)
    motion = np.abs(rigid - (0.0, 0.0, 0.6)).max()
    errs, dts = [], []
    for f in (1e1, 1e2, 1e3):
        path, dt = post_top_path(flexible_with_stiff_arm(f, arm_elements=16), times)
        errs.append(np.abs(path - rigid).max() / motion)
        dts.append(dt)
        print(f"\narm stiffness x{f:g}: dt = {dt:.3g} s, path error {errs[-1]:.2e} of the motion")
    print(f"contracted: dt = {dt_rigid:.3g} s: {dt_rigid / dts[0]:.0f}x fewer steps than x10, "
          f"{dt_rigid / dts[-1]:.0f}x fewer than x1e3")
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 2e-3
    assert dt_rigid > dts[0] > dts[1] > dts[2]
