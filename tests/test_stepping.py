"""Time stepping: convergence orders, the stable-dt estimate, §5 scaling."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.kernels.stepping import SCHEMES, stability_interval
from nets import cantilever, free_net, perturb


def tip_run(stepper, dt, T):
    net, line, root, tip = cantilever(n=4, length=0.5, radius=0.02, tip_mass=0.5)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity((0, 0, -9.81))], stepper=stepper,
                            dt=dt, force_dt=True)
    sim.line_velocities(line)[:, 2] = 0.02 * np.sin(0.5 * np.pi * np.linspace(0, 1, 5))
    sim.node_velocity(tip)[:] = (0, 0, 0.02)
    sim.run(steps=int(round(T / dt)))
    return sim.line_positions(line).copy()


def test_scheme_table_is_consistent_and_gives_the_known_stability_intervals():
    """Each scheme's drifts and kicks sum to one step and read the same backwards; Verlet is
    stable up to omega h = 2 exactly, PEFRL (four kicks a step) up to about 3."""
    for scheme in SCHEMES.values():
        assert math.isclose(sum(scheme.drifts), 1.0) and math.isclose(sum(scheme.kicks), 1.0)
        assert len(scheme.drifts) == len(scheme.kicks) + 1
        assert scheme.drifts == scheme.drifts[::-1] and scheme.kicks == scheme.kicks[::-1]  # symmetric
    assert stability_interval("verlet") == pytest.approx(2.0, abs=1e-3)   # the grid's spacing
    assert 2.9 < stability_interval("pefrl") < 3.1


@pytest.mark.parametrize("stepper, divisors, span", [
    ("verlet", (8, 16, 32), 256),     # asymptotic once omega_max h is small
    ("pefrl", (1, 2, 4), 2000),       # smaller errors: a longer span keeps them above round-off
])
def test_convergence_order_in_dt(stepper, divisors, span):
    order = SCHEMES[stepper].order
    est = cosnet.Simulation(cantilever(n=4, length=0.5, radius=0.02, tip_mass=0.5)[0],
                            stepper="verlet").dt
    T = span * est
    ref = tip_run("pefrl", est / 64, T)
    errs = np.array([np.abs(tip_run(stepper, est / k, T) - ref).max() for k in divisors])
    orders = np.log2(errs[:-1] / errs[1:])
    print(stepper, "errors", errs, "observed orders", orders)
    assert np.all(np.abs(orders - order) < 0.3), orders


def stable(net_factory, dt, stepper, steps=3000):
    sim = cosnet.Simulation(net_factory(), stepper=stepper, dt=dt, force_dt=True)
    perturb(sim, np.random.default_rng(0), 1e-3, 1e-2)
    e0 = sim.energy()
    try:
        for _ in range(6):
            sim.run(steps=steps // 6)
            if not abs(sim.energy()) < 100 * abs(e0):
                return False
    except cosnet.InstabilityError:
        return False
    return True


def tee_with_body():
    mat = cosnet.Material(E=1e7, G=4e6, density=1000.0)
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True)
    b = net.add_node((0, 0, 1), mass=2.0, inertia=np.diag([1e-2, 1e-2, 2e-2]))
    c = net.add_node((0.5, 0, 1))
    d = net.add_node((-0.5, 0, 1.2))
    net.add_line(a, b, material=mat, section=cosnet.Circle(0.02), elements=8, end_offset=(0, 0, -0.05))
    net.add_line(b, c, material=mat, section=cosnet.Rectangle(0.02, 0.01), elements=5, start_offset=(0.05, 0, 0))
    net.add_line(b, d, material=mat, section=cosnet.Circle(0.01), elements=5)
    return net


@pytest.mark.parametrize("stepper", ["verlet", "pefrl"])
@pytest.mark.parametrize("factory", [lambda: cantilever(n=10)[0], lambda: free_net(4), tee_with_body],
                         ids=["cantilever", "free_net", "tee_with_body"])
def test_stable_dt_estimate_is_safe_and_within_factor_two(factory, stepper):
    """The estimate runs stably, and the first unstable dt (scanning up by 5%) lies below
    twice the estimate: cautious, but not wasteful."""
    est = cosnet.Simulation(factory(), stepper=stepper).dt
    assert stable(factory, est, stepper)
    f = 1.0
    while f < 2.0 and stable(factory, f * est, stepper):
        f *= 1.05
    print(stepper, "first unstable dt / estimate =", f)
    assert 1.0 < f < 2.0


@pytest.mark.parametrize("stepper", ["verlet", "pefrl"])
@pytest.mark.parametrize("factory", [lambda: cantilever(n=10)[0], lambda: free_net(4), tee_with_body],
                         ids=["cantilever", "free_net", "tee_with_body"])
def test_the_tight_step_is_the_highest_modes_and_a_fifth_more_is_unstable(factory, stepper):
    """dt="tight" takes the linearised net's highest mode (clamps, a body on offsets, PEFRL):
    it runs stably, 1.2 times it (1.08 times the linear limit) does not, and it is not below
    the bound's step."""
    tight = cosnet.Simulation(factory(), stepper=stepper, dt="tight").dt
    assert tight >= cosnet.Simulation(factory(), stepper=stepper).dt
    assert stable(factory, tight, stepper) and not stable(factory, 1.2 * tight, stepper)


def test_scaled_net_follows_the_same_trajectory():
    """§5: the net in scaled units (T0, L0, A0, rho0) moves as the SI net after rescaling."""
    scale = cosnet.Scale(time=1e-3, length=0.5, area=1e-4, density=7850.0)
    si = free_net(3)
    scaled = scale.scaled(si)
    g = np.array([0.0, 0.0, -9.81])
    a = cosnet.Simulation(si, effects=[cosnet.Gravity(g)])
    b = cosnet.Simulation(scaled, effects=[cosnet.Gravity(g / scale.acceleration)], dt=a.dt / scale.time)
    for sim, v, w in ((a, 1.0, 1.0), (b, scale.time / scale.length, scale.time)):
        perturb(sim, np.random.default_rng(3), 0.2 * v, 2.0 * w)
    a.run(steps=500)
    b.run(steps=500)
    assert np.abs(b.state.x * scale.length - a.state.x).max() < 1e-12 * np.abs(a.state.x).max()
    assert math.isclose(b.energy() * scale.force * scale.length, a.energy(), rel_tol=1e-10)
    with pytest.raises(ValueError, match="kappa"):
        cosnet.Scale(time=1.0, length=1.0, area=1.0, density=1.0, torque=2.0)


def test_load_table_interpolates_as_numpy_and_holds_its_ends():
    """The step's allocation-free table lookup equals np.interp, ends held."""
    from cosnet.kernels.effects import interp_table
    rng = np.random.default_rng(3)
    times = np.cumsum(rng.uniform(0.01, 1.0, 12))
    values = rng.standard_normal(12)
    for t in np.concatenate([rng.uniform(times[0] - 1, times[-1] + 1, 200), times]):
        assert interp_table(t, times, values) == pytest.approx(np.interp(t, times, values), abs=1e-15)


def _drift_columns_of(q, w, J, ij, h, all_round):
    from numba import njit
    from cosnet.kernels.motion import count_not_round, spin_round_columns, spin_round_elements

    @njit
    def spin(q, w, J, ij, h, all_round):
        qc = (q[:, 0], q[:, 1], q[:, 2], q[:, 3])
        wc, jc, ijc = (w[:, 0], w[:, 1], w[:, 2]), (J[:, 0], J[:, 1], J[:, 2]), (ij[:, 0], ij[:, 1], ij[:, 2])
        if all_round:
            spin_round_columns(qc, wc, jc, ijc, h)
        else:
            spin_round_elements(qc, wc, jc, ijc, h)
        return count_not_round(ijc)
    return spin(q, w, J, ij, h, all_round)


def test_round_elements_turn_alike_in_the_vectorised_pass_and_beside_other_sections():
    """The pass for blocks of round sections alone gives the same bits as the pass that keeps
    the other sections' lanes; in a mixed block those lanes are left to the exact splitting."""
    rng = np.random.default_rng(7)
    n = 13
    q = rng.normal(size=(n, 4))
    q = np.asfortranarray(q / np.linalg.norm(q, axis=1)[:, None])
    w = np.asfortranarray(rng.normal(scale=30.0, size=(n, 3)))
    J = np.asfortranarray(np.tile([2e-9, 2e-9, 4e-9], (n, 1)))
    ij = np.asfortranarray(1.0 / J)
    runs = [[a.copy(order="F") for a in (q, w)] for _ in range(2)]
    assert _drift_columns_of(*runs[0], J, ij, 1e-4, True) == 0
    assert _drift_columns_of(*runs[1], J, ij, 1e-4, False) == 0
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])
    assert not np.array_equal(runs[0][0], q)   # they did turn
    J[5] = ij[5] = (1.0, 2.0, 3.0)             # one element of another section
    qm, wm = q.copy(order="F"), w.copy(order="F")
    assert _drift_columns_of(qm, wm, J, ij, 1e-4, False) == 1
    assert np.array_equal(qm[5], q[5]) and np.array_equal(wm[5], w[5])
    keep = np.arange(n) != 5
    assert np.array_equal(qm[keep], runs[0][0][keep]) and np.array_equal(wm[keep], runs[0][1][keep])
