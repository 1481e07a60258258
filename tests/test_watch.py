"""The instability watch stops a blown-up run early with a useful message."""

import numpy as np
import pytest

import cosnet
from cosnet.kernels.stepping import CHUNK_STEPS
from nets import cantilever, free_net, smooth_motion


def test_forced_large_dt_stops_with_time_place_and_safe_dt():
    net, line, root, tip = cantilever(n=10)
    est = cosnet.Simulation(net).dt
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()], dt=3 * est, force_dt=True)
    with pytest.raises(cosnet.InstabilityError) as info:
        sim.run(steps=50 * CHUNK_STEPS)
    err = info.value
    assert sim.steps <= 50 * CHUNK_STEPS and err.time <= sim.time
    assert "line 'rod'" in err.where
    assert err.safe_dt == pytest.approx(est)
    assert "a dt below" in str(err) and "t = " in str(err)
    # the estimate it suggests does run
    ok = cosnet.Simulation(net, effects=[cosnet.Gravity()], dt=err.safe_dt)
    ok.run(steps=2 * CHUNK_STEPS)
    assert np.all(np.isfinite(ok.state.x))


def test_watch_is_silent_on_a_healthy_run():
    sim = cosnet.Simulation(free_net(3), effects=[cosnet.Damping(0.1)])
    smooth_motion(sim)
    sim.run(steps=3 * CHUNK_STEPS)
    assert sim.steps == 3 * CHUNK_STEPS


def test_overload_at_a_stable_dt_is_called_physical_not_a_step_problem():
    """A tip pull of 3 EA stretches the rod beyond 100 %: the watch stops it, and since dt is
    within the stable step it says the load, not the step, is at fault."""
    net, line, root, tip = cantilever(n=4, radius=0.002, material=cosnet.Material(E=1e6, G=4e5, density=1e3))
    EA = 1e6 * np.pi * 0.002 ** 2
    sim = cosnet.Simulation(net, effects=[cosnet.NodeLoad(tip, force=(3 * EA, 0.0, 0.0))])
    with pytest.raises(cosnet.InstabilityError, match="physical overload") as info:
        sim.run(until=2.0)
    assert "line 'rod'" in info.value.where


def test_energy_reference_survives_many_short_runs():
    """Energy growth is measured from the first check, not from each run() call, but a state
    changed from outside between runs starts a new reference at the next check."""
    sim = cosnet.Simulation(free_net(3))
    smooth_motion(sim)
    sim.run(steps=10)
    e0 = sim.watch.e_start
    assert e0 == pytest.approx(sim.energy(), rel=1e-6)
    for _ in range(5):
        sim.run(steps=CHUNK_STEPS // 2)
    assert sim.watch.e_start == e0
    sim.state.v[:] *= 2.0
    sim.run(steps=CHUNK_STEPS)
    assert sim.watch.e_start == pytest.approx(sim.energy(), rel=1e-6) and sim.watch.e_start > 1.5 * e0


def test_short_runs_still_stop_at_the_first_non_finite_value():
    """The strain and energy checks run every CHUNK_STEPS steps at most, but a non-finite
    value stops the very run() call that produced it, whatever its length."""
    sim = cosnet.Simulation(free_net(3))
    smooth_motion(sim)
    for _ in range(3):
        sim.run(steps=1)
    sim.state.w[2, 1] = np.nan
    with pytest.raises(cosnet.InstabilityError, match="non-finite") as info:
        sim.run(steps=1)
    assert "line 'l1'" in info.value.where


def test_watch_looks_again_after_many_short_runs():
    """Runaway strain reached through many one-step runs is caught within CHUNK_STEPS steps."""
    net, line, root, tip = cantilever(n=4, radius=0.002, material=cosnet.Material(E=1e6, G=4e5, density=1e3))
    EA = 1e6 * np.pi * 0.002 ** 2
    sim = cosnet.Simulation(net, effects=[cosnet.NodeLoad(tip, force=(3 * EA, 0.0, 0.0))])
    limit = int(2.0 / sim.dt) + CHUNK_STEPS
    with pytest.raises(cosnet.InstabilityError, match="physical overload"):
        for _ in range(limit):
            sim.run(steps=1)


def test_soft_rod_let_go_under_gravity_is_not_called_unstable():
    """Released from rest with no potential energy at its height, a soft rod's energy is all
    exchanged with gravity; Verlet's bounded error on that exchange is no instability."""
    soft = cosnet.Material(E=2e6, G=8e5, density=1000.0)
    net, line, root, tip = cantilever(n=8, length=0.5, radius=0.01, material=soft)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()])
    sim.run(until=0.3)
    assert sim.line_positions(line)[-1, 2] < -0.01          # it did swing down
    assert abs(sim.energy()) < 1e-3 * sim.net.total_mass() * 9.81 * 0.5


def test_a_heavy_fitting_swinging_against_its_wire_is_not_called_flutter():
    """Two pinned fittings of 1 kg m^2 hold a 100 m steel wire let go straight under gravity:
    as the wire swings they turn against its end elements in a slow mode of theirs (omega dt
    0.04, some 170 steps a period), and the swing's energy passes in and out of it. That is
    motion the step resolves, its energy conserved, not the grid-scale flutter the watch
    stops (it stopped this run at 14.6 s as such)."""
    steel = cosnet.Material(E=1e11, poisson=0.3, density=7850.0)
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, -2.0), mass=np.inf, inertia=(1.0, 1.0, 1.0))
    b = net.add_node((100.0, 0.0, -2.0), mass=np.inf, inertia=(1.0, 1.0, 1.0))
    net.add_line(a, b, material=steel, section=cosnet.Circle(0.02), elements=100)
    sim = cosnet.Simulation(net, [cosnet.Gravity()], fast_modes="rotary")
    e0, turning = sim.energy(), 0.0
    for k in range(25):
        sim.run(until=k + 1.0)
        turning = max(turning, float(np.abs(sim.state.node_w).max()))
    assert turning > 0.1                                   # the fittings did swing against the wire
    weight = net.total_mass() * 9.81
    assert abs(sim.energy() - e0) < 1e-6 * weight * 10.0   # 0.1 J of a swing of some 6 kJ


def test_state_hash_sees_every_kind_of_outside_change():
    """The hash the watch compares between run() calls changes with any edit of the state:
    a doubled velocity, two signs flipped (in one lane of the hash, or in two), a frame
    copied over its neighbour's, the lowest bit of one angular velocity, the clock."""
    from cosnet.kernels.checksum import scan_state
    sim = cosnet.Simulation(free_net(3))
    smooth_motion(sim)
    sim.run(steps=10)
    s = sim.state

    def flip(rows, col):
        s.x[rows, col] *= -1.0

    def lowest_bit():
        bits = s.w.view(np.uint64)
        bits[5, 2] ^= np.uint64(1)

    edits = [lambda: s.v.__imul__(2.0), lambda: flip([0, 4], 0), lambda: flip([0, 1], 1),
             lambda: s.q.__setitem__(2, s.q[3]), lowest_bit, lambda: s.clock.__iadd__(1e-9)]
    for edit in edits:
        before, field, _ = scan_state(s)
        assert field is None
        edit()
        assert scan_state(s)[0] != before
