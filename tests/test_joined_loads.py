"""Loads declared one after another run as one record (cosnet.engine.simulation.joined_records): their
number is not part of the compiled step's type, each row keeps its own amplitude, and each
declared effect's record is a view into the joined one."""

import math

import numba
import numpy as np
import pytest

import cosnet
from nets import free_net

T = 0.3


def _loads(net):
    body, a, b = net.node("body"), net.node("a"), net.node("b")
    return [cosnet.NodeLoad(body, force=(1.0, -2.0, 3.0), times=[0.0, 1.0], values=[0.0, 2.0]),
            cosnet.NodeLoad(a, torque=(0.0, 0.0, 0.5), omega=3.0, phase=0.5),
            cosnet.NodeLoad(b, force=(0.0, 0.0, -5.0))]


def _node_loads(sim):
    sim.state.clock[0] = T
    sim.evaluate_loads()
    return sim.loads.node_f.copy(), sim.loads.node_tau.copy()


def test_a_run_of_node_loads_is_one_record_whatever_its_length():
    net = free_net()
    three = cosnet.Simulation(net, effects=[cosnet.Gravity(), *_loads(net)])
    six = cosnet.Simulation(net, effects=[cosnet.Gravity(), *_loads(net), *_loads(net)])
    assert [len(s.load_records) for s in (three, six)] == [2, 2]
    assert three.load_records[1].nodes.shape == (3,) and six.load_records[1].nodes.shape == (6,)
    # the same kernels serve both (their records typed alike): adding a load changes numbers,
    # not the compiled code
    assert numba.typeof(three.step_groups) == numba.typeof(six.step_groups)
    # separated by another effect, runs stay apart (the loads add up in the declared order)
    split = cosnet.Simulation(net, effects=[_loads(net)[0], cosnet.Gravity(), *_loads(net)[1:]])
    assert [type(p).__name__ for p in split.load_records] == ["NodeLoadParams", "GravityParams", "NodeLoadParams"]


def test_each_row_keeps_its_amplitude_and_its_own_record_is_live():
    net = free_net()
    loads = _loads(net)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(), *loads])
    f, tau = _node_loads(sim)
    for load in loads:                      # switch every load off through its own record
        rec = sim.effect_params(load)
        assert np.shares_memory(rec.force, sim.load_records[1].force)
        rec.force[:] = 0.0
        rec.torque[:] = 0.0
    f0, tau0 = _node_loads(sim)
    body, a, b = (net.node(n).index for n in ("body", "a", "b"))
    # table: 0 -> 2 over 1 s; harmonic: sin(omega t + phase); constant: 1
    np.testing.assert_allclose(f[body] - f0[body], 0.6 * np.array([1.0, -2.0, 3.0]), rtol=1e-12, atol=1e-12)
    assert tau[a, 2] - tau0[a, 2] == pytest.approx(0.5 * math.sin(3.0 * T + 0.5), rel=1e-12)
    np.testing.assert_allclose(f[b] - f0[b], [0.0, 0.0, -5.0], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(f[a], f0[a])   # a carries a torque only


def test_a_corrupted_joined_table_is_refused_before_a_step():
    net = free_net()
    sim = cosnet.Simulation(net, effects=[*_loads(net)])
    sim.effect_params(sim.effects[0]).table[1] = 99   # past the pooled amplitude tables
    with pytest.raises(ValueError, match=r"node load\.table is not an offset table of 3 rows into 2 table entries"):
        sim.run(steps=1)


def test_the_loads_work_closes_the_energy_balance_at_order_two():
    """Node loads (a table, a harmonic torque, a constant force, on a free body and two
    junctions) and a harmonic line load on the free net, its lines swinging: the loads do
    work (sim.load_work(), the kicks' quadrature of F . v + L . w, per joined row), and
    energy - load_work is constant to position Verlet's error, falling four-fold when the
    step halves, where without the account the drift is the loads' work itself."""
    from cosnet.core.samples import smooth_motion
    net = free_net()
    effects = lambda: [*_loads(net), cosnet.LineLoad(net.line("l2"), force_per_length=(0.0, 2.0, 1.0),
                                                     torque_per_length=(0.3, 0.0, 0.0), omega=7.0)]
    drift, work = [], 0.0
    for halves in (1, 2):
        sim = cosnet.Simulation(net, effects=effects())
        sim.dt /= halves
        smooth_motion(sim)
        e0, worst = sim.energy(), 0.0
        for _ in range(20):
            sim.run(steps=50 * halves)
            worst = max(worst, abs(sim.energy() - sim.load_work() - e0))
        drift.append(worst)
        work = abs(sim.load_work())
    assert work > 1e3 * drift[0]            # the loads did work, far above the scheme's error
    assert 3.5 < drift[0] / drift[1] < 4.5, drift
