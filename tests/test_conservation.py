"""Conservation laws and exact constraints of the discrete net."""

import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import cosnet
from cosnet.core.rotations import matrix_from_quat, quat_from_matrix
from cosnet.kernels.backend import Parallel, ParallelSplit, Serial
from cosnet.kernels.elastic import LONG_LINE
from cosnet.kernels.motion import place_line_ends
from nets import free_net, perturb, smooth_motion

FULL = os.environ.get("COSNET_FULL") == "1"


def test_loads_are_the_exact_gradient_of_the_strain_energy():
    """Forces and torques (vertices, elements, nodes with offsets) = -grad U (3.25)."""
    rng = np.random.default_rng(0)
    sim = cosnet.Simulation(free_net(n=3))
    m, s, loads = sim.model, sim.state, sim.loads
    s.x[:] += 0.02 * rng.standard_normal(s.x.shape)
    for arr in (s.q, s.node_q):
        for i in range(arr.shape[0]):
            turn = Rotation.from_rotvec(0.2 * rng.standard_normal(3)).as_matrix()
            arr[i] = quat_from_matrix(matrix_from_quat(arr[i]) @ turn)
    place_line_ends(m, s)
    sim.evaluate_loads()

    def strain():
        place_line_ends(m, s)
        return sim.energy_parts()["strain"]

    def slope(get, put, h=1e-6):
        put(h)
        up = strain()
        put(-2 * h)
        um = strain()
        put(h)
        return -(up - um) / (2 * h)

    pairs = []
    interior = np.flatnonzero(m.vertex_inv_mass > 0)
    for i in interior[::2]:
        for k in range(3):
            pairs.append((slope(None, lambda d: s.x.__setitem__((i, k), s.x[i, k] + d)), loads.f[i, k]))
    for e in range(0, s.q.shape[0], 2):
        for k in range(3):
            q0 = s.q[e].copy()
            def put(d, e=e, k=k):
                s.q[e] = quat_from_matrix(matrix_from_quat(s.q[e]) @ Rotation.from_rotvec(d * np.eye(3)[k]).as_matrix())
            pairs.append((slope(None, put), loads.tau[e, k]))
            s.q[e] = q0
    for nd in range(s.node_x.shape[0]):
        for k in range(3):
            move = lambda d: s.node_x.__setitem__((nd, k), s.node_x[nd, k] + d)
            pairs.append((slope(None, move), loads.node_f[nd, k]))
            q0 = s.node_q[nd].copy()
            def put(d, nd=nd, k=k):
                turn = Rotation.from_rotvec(d * np.eye(3)[k]).as_matrix()
                s.node_q[nd] = quat_from_matrix(turn @ matrix_from_quat(s.node_q[nd]))
            pairs.append((slope(None, put), loads.node_tau[nd, k]))
            s.node_q[nd] = q0
    p = np.array(pairs)
    assert np.abs(p[:, 0] - p[:, 1]).max() < 1e-7 * np.abs(p).max()


def test_compiled_energies_equal_the_sums_of_the_strains_and_velocities():
    """kernels/energy.py's one pass = (3.25) summed from measure.line_strains, and the kinetic
    energy of the moving masses and free axes; its worst strain is the largest |v - d3|_1, a
    NaN counting as the worst."""
    from cosnet.engine.measure import block_of, element_stretch, energies, line_strains, worst_strain
    rng = np.random.default_rng(1)
    sim = cosnet.Simulation(free_net(n=3))
    m, s = sim.model, sim.state
    perturb(sim, rng)
    s.x[:] += 0.02 * rng.standard_normal(s.x.shape)
    for i in range(s.q.shape[0]):
        turn = Rotation.from_rotvec(0.5 * rng.standard_normal(3)).as_matrix()
        s.q[i] = quat_from_matrix(matrix_from_quat(s.q[i]) @ turn)
    place_line_ends(m, s)
    st = line_strains(m, s, block_of(m))
    u = 0.5 * sum(np.sum(m.element_rest_length * m.element_stiffness[:, k] * st.stretch[k] ** 2)
                  + np.sum(m.voronoi_rest_length * m.voronoi_stiffness[:, k] * st.curvature[k] ** 2)
                  for k in range(3))
    moving = m.vertex_inv_mass > 0
    kt = 0.5 * (np.sum(m.vertex_mass[moving, None] * s.v[moving] ** 2)
                + np.sum(m.node_mass[:, None] * s.node_v ** 2))
    free = m.node_locked == 0
    kr = 0.5 * (np.sum(m.element_inertia * s.w ** 2) + np.sum(m.node_inertia[free] * s.node_w[free] ** 2))
    assert np.allclose(energies(m, s), (kt, kr, u), rtol=1e-12, atol=0)
    strain = np.sum(np.abs(np.column_stack(element_stretch(m, s, block_of(m)))), axis=1)
    assert worst_strain(m, s) == (pytest.approx(strain.max(), rel=1e-12), int(np.argmax(strain)))
    s.x[9, 1] = np.nan   # vertex 9 joins elements 6 and 7 (line 2: vertices 8-11, elements 6-8)
    assert np.isnan(worst_strain(m, s)[0]) and worst_strain(m, s)[1] == 6


@pytest.mark.slow
def test_free_net_conserves_energy_and_momenta():
    """Undamped free net with an extended rigid body: bounded energy error, exact momenta."""
    steps = 100_000 if FULL else 20_000
    sim = cosnet.Simulation(free_net(n=4))
    smooth_motion(sim)
    sim.node_velocity(sim.net.node("body"))[:] = (0.3, -0.2, 0.1)
    e0, p0, l0 = sim.energy(), sim.momentum(), sim.angular_momentum()
    scale_p = np.abs(sim.state.v).sum(axis=1) @ sim.model.vertex_mass + np.abs(p0).sum()
    energies = []
    for _ in range(100):
        sim.run(steps=steps // 100)
        energies.append(sim.energy())
    err = (np.array(energies) - e0) / e0
    drift = abs(err[-10:].mean() - err[:10].mean())   # secular change: none for a symplectic scheme
    assert drift < 1e-4, drift
    assert np.abs(err).max() < 1e-3, np.abs(err).max()  # Verlet's bounded oscillation
    assert np.abs(sim.momentum() - p0).max() < 1e-9 * scale_p
    assert np.abs(sim.angular_momentum() - l0).max() < 1e-9 * np.abs(l0).max()
    assert np.all(np.abs(np.linalg.norm(sim.state.q, axis=1) - 1) < 1e-12)


def test_junction_conditions_hold_exactly_while_tumbling():
    """r_lambda = r(nu) + D(nu) xi and D_lambda = D(nu) X at every step (1.1)/(1.3)."""
    net = free_net(n=3)
    sim = cosnet.Simulation(net)
    perturb(sim, np.random.default_rng(2), scale_w=20.0)
    X = {}
    for line in net.lines:
        f = sim.line_fields(line)
        for node, row, side in ((line.start, 0, 0), (line.end, -1, 1)):
            frame = np.column_stack([f["d1"][row], f["d2"][row], f["d3"][row]])
            X[line.index, side] = sim.node_rotation(node).T @ frame
    worst = 0.0
    for _ in range(100):
        sim.run(steps=3)
        for line in net.lines:
            pos = sim.line_positions(line)
            f = sim.line_fields(line)
            for node, xi, row, side in ((line.start, line.start_offset, 0, 0), (line.end, line.end_offset, -1, 1)):
                D = sim.node_rotation(node)
                r = sim.node_position(node)
                worst = max(worst, np.abs(pos[row] - (r + D @ xi)).max())
                frame = np.column_stack([f["d1"][row], f["d2"][row], f["d3"][row]])
                worst = max(worst, np.abs(frame - D @ X[line.index, side]).max())
    assert worst < 1e-12, worst


def rigid_body(w0):
    net = cosnet.Net()
    n = net.add_node((0, 0, 0), mass=2.0, inertia=np.diag([1.0, 2.0, 3.0]), name="body")
    sim = cosnet.Simulation(net, dt=1e-3)
    sim.node_angular_velocity(n)[:] = w0
    return sim, n


@pytest.mark.parametrize("stepper", ["verlet", "pefrl"])
def test_free_rigid_body_conserves_energy_and_angular_momentum(stepper):
    net = cosnet.Net()
    n = net.add_node((0, 0, 0), mass=2.0, inertia=[[1.0, 0.2, 0.0], [0.2, 2.0, 0.1], [0.0, 0.1, 3.0]])
    sim = cosnet.Simulation(net, dt=2e-3, stepper=stepper)
    sim.node_angular_velocity(n)[:] = (0.3, 4.0, 0.5)
    sim.node_velocity(n)[:] = (1.0, -2.0, 0.5)
    e0, l0, p0 = sim.energy(), sim.angular_momentum(), sim.momentum()
    es = []
    for _ in range(100):
        sim.run(steps=50)
        es.append(sim.energy())
    assert np.abs(np.array(es) - e0).max() < 1e-4 * e0
    # the Lie-Poisson splitting conserves both exactly: what remains is round-off
    assert np.abs(sim.angular_momentum() - l0).max() < 1e-10 * np.abs(l0).max()
    assert np.abs(sim.momentum() - p0).max() < 1e-12 * np.abs(p0).max()


def test_a_symmetric_top_turns_as_its_two_commuting_flows():
    """A free body with two equal inertias A and a third C (a knot between collinear lines, a
    planar net's knot) turns as the flows of the two terms of its kinetic energy,
    |P|^2 / 2A and (1/C - 1/A) P3^2 / 2, which commute: R(t) = R0 exp(t P0 / A)
    exp(t (1/C - 1/A) P3 e3) (P the body momentum, P3 on the odd axis), and P turns about
    that axis. PEFRL takes the two flows exactly (round-off over a thousand steps); Verlet by
    their Cayley angles, whose error falls fourfold at half the step."""
    def turned(stepper, dt, until=2.0):
        net = cosnet.Net()
        n = net.add_node((0, 0, 0), mass=2.0, inertia=np.diag([1.5, 1.5, 0.5]))
        sim = cosnet.Simulation(net, dt=dt, force_dt=True, stepper=stepper)
        sim.node_angular_velocity(n)[:] = (2.0, -1.0, 5.0)
        m, i = sim.model, n.index
        a, c = sorted(set(m.node_inertia[i]), key=list(m.node_inertia[i]).count, reverse=True)
        axis = int(np.flatnonzero(m.node_inertia[i] == c)[0])
        p0 = m.node_inertia[i] * sim.state.node_w[i]
        r0 = matrix_from_quat(sim.state.node_q[i])
        sim.run(steps=round(until / dt))
        e = np.zeros(3)
        e[axis] = (1.0 / c - 1.0 / a) * p0[axis] * sim.time
        exact = r0 @ Rotation.from_rotvec(sim.time * p0 / a).as_matrix() @ Rotation.from_rotvec(e).as_matrix()
        return np.abs(matrix_from_quat(sim.state.node_q[i]) - exact).max()

    assert turned("pefrl", 2e-3) < 1e-12
    coarse, fine = turned("verlet", 2e-3), turned("verlet", 1e-3)
    assert 1e-9 < fine < coarse and coarse / fine == pytest.approx(4.0, rel=0.05)


def test_dzhanibekov_intermediate_axis_flips_others_stay():
    """Spin about the intermediate principal axis is unstable (it flips); about the others not."""
    for axis, flips in ((0, False), (1, True), (2, False)):
        w0 = np.full(3, 1e-3)
        w0[axis] = 5.0
        sim, n = rigid_body(w0)
        signs = []
        for _ in range(300):
            sim.run(steps=20)
            signs.append(np.sign(sim.node_angular_velocity(n)[axis]))
        assert (min(signs) < 0) == flips, axis


@pytest.mark.parametrize("stepper", ["verlet", "pefrl"])
def test_free_fall_is_exact(stepper):
    """A free, unstressed net under gravity falls as r0 + g t^2/2 exactly: external loads are
    applied once per step, not accumulated across the stages."""
    net = free_net(n=3)
    g = np.array([0.0, -3.0, -9.81])
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(g)], stepper=stepper)
    x0 = sim.state.x.copy()
    sim.run(steps=400)
    t = sim.time
    assert np.abs(sim.state.x - (x0 + 0.5 * g * t * t)).max() < 1e-12 * (1 + 0.5 * 9.81 * t * t)


def test_runs_are_deterministic_and_thread_count_changes_only_round_off():
    """The same net gives bit-identical results run to run; the parallel loops (2 threads)
    agree with the serial ones to round-off."""
    def run(threads):
        sim = cosnet.Simulation(free_net(n=4), effects=[cosnet.Gravity()], threads=threads)
        smooth_motion(sim)
        sim.run(steps=300)
        return sim.state.x.copy(), sim.state.q.copy()
    a, b = run(1), run(1)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    c = run(2)
    assert type(cosnet.Simulation(free_net(n=4), threads=2).backend) is Parallel   # no line split
    assert np.abs(c[0] - a[0]).max() < 1e-12 * np.abs(a[0]).max()
    assert np.abs(c[1] - a[1]).max() < 1e-12


def test_a_long_line_split_across_threads_has_the_serial_loads():
    """A line longer than LONG_LINE is cut into parts computed on different threads (each
    pass of the internal loads finishing before the next): the loads on every vertex,
    element and line end equal the serial ones to round-off, also where elements turned by
    more than 0.2 rad take the exact log map, and for the short lines beside it. (The internal
    loads alone are compiled for each backend, as the step calls them, not a whole step.)"""
    from numba import njit

    from cosnet.kernels.backend import ENTRY
    from cosnet.kernels.elastic import internal_loads_on

    @njit(**{k: v for k, v in ENTRY.items() if k != "cache"})
    def internal_loads(backend, model, state, loads):
        internal_loads_on(backend, model, state, loads)
    net = cosnet.Net()
    mat = cosnet.Material(E=2e11, G=8e10, density=7850.0)
    a, b, c = net.add_node((0, 0, 0)), net.add_node((1, 0, 0)), net.add_node((1, 1, 0), fixed=True)
    net.add_line(a, b, material=mat, section=cosnet.Rectangle(0.02, 0.01), elements=LONG_LINE + 1000)
    net.add_line(b, c, material=mat, section=cosnet.Circle(0.01), elements=10)
    net.add_line(c, a, material=mat, section=cosnet.Circle(0.01), elements=7)
    rng = np.random.default_rng(3)
    loads = {}
    for threads, backend in ((1, Serial()), (2, ParallelSplit())):
        sim = cosnet.Simulation(net, threads=threads)
        m, s = sim.model, sim.state
        s.x[:] += 1e-5 * np.random.default_rng(1).standard_normal(s.x.shape)
        turn = 0.01 * np.random.default_rng(2).standard_normal((s.q.shape[0], 3))
        turn[::997] *= 50.0                         # some neighbours 0.5 rad apart
        s.q[:] = quat_from_matrix(matrix_from_quat(s.q) @ Rotation.from_rotvec(turn).as_matrix())
        s.node_q[:] = quat_from_matrix(Rotation.from_rotvec(0.1 * rng.standard_normal((3, 3))).as_matrix()) \
            if threads == 1 else loads[1][3]
        place_line_ends(m, s)
        assert type(sim.backend) is type(backend)
        internal_loads(sim.backend, m, s, sim.loads)
        loads[threads] = (sim.loads.f.copy(), sim.loads.tau.copy(), sim.loads.end_tau.copy(), s.node_q.copy())
    assert np.abs(loads[1][1]).max() > 1.0                      # the state is far from rest
    for serial, split in zip(loads[1][:3], loads[2][:3]):
        assert np.abs(split - serial).max() <= 1e-12 * np.abs(serial).max()


def test_principal_axes_of_a_round_body_do_not_depend_on_the_lapack(monkeypatch):
    """Within a repeated inertia eigenvalue any basis is principal, and eigh may return any of
    them (it differs between LAPACK builds). Flattening takes the user's body axes projected
    on the eigenspace, signed so each axis's largest component is positive: an eigh that
    returns another basis of the repeated pair, with flipped signs, gives the same frame."""
    from cosnet.engine import flatten
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    I = R @ np.diag([3.0, 2.0, 2.0]) @ R.T         # the repeated pair spans (R e2, e3)
    free = np.zeros(3, dtype=bool)
    P, diag = flatten._principal_frame(I, free)
    assert np.allclose(diag, [2.0, 2.0, 3.0])
    assert np.allclose(P @ np.diag(diag) @ P.T, I) and np.isclose(np.linalg.det(P), 1.0)
    assert np.isclose(abs(P[2, 0]), 1.0)           # the user's z axis lies in the pair: kept

    eigh = np.linalg.eigh

    def other_lapack(a):
        vals, vecs = eigh(a)
        t = 0.3                                    # another basis of the repeated pair
        turn = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
        vecs = vecs.copy()
        vecs[:, :2] = vecs[:, :2] @ turn
        return vals, -vecs
    monkeypatch.setattr(flatten.np.linalg, "eigh", other_lapack)
    P2, diag2 = flatten._principal_frame(I, free)
    assert np.allclose(diag2, diag) and np.allclose(P2, P, atol=1e-12)
