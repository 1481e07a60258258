"""A step calls its kernels through the addresses in its table's slots (kernels/slots.py),
each effect's with its record pinned: a new combination of effects compiles the new kind's
kernels and nothing else, not even the step, and computes what the kernels compute; a slot
bound to another kernel or another hook, a record of another type, too few slots or slots
bound in another process end in a clear error, never a jump."""

from typing import NamedTuple

import numpy as np
import pytest
from numba import njit

import cosnet
from cosnet.compiling import CompileLog
from cosnet.engine.registry import Effect
from cosnet.kernels.compose import CORE, load_kernel
from cosnet.kernels.slots import SLOT_ADDRESS, SLOT_RECORD
from cosnet.kernels.compiler import CACHED
from nets import free_net


class SlotPullParams(NamedTuple):
    nodes: np.ndarray     # (k,) int64
    force: np.ndarray     # (k, 3) N


@load_kernel(SlotPullParams)
@njit(**CACHED)
def add_slot_pull(p, model, state, loads):
    """Update loads.node_f given p: a constant force on each node."""
    for j in range(p.nodes.shape[0]):
        for c in range(3):
            loads.node_f[p.nodes[j], c] += p.force[j, c]


class SlotPull(Effect):
    """A constant force on one node, a kind of its own (no other test declares it)."""
    record = SlotPullParams

    def __init__(self, node, force):
        self.node, self.force = node, np.asarray(force, dtype=float)

    def bind(self, on):
        on.check_node(self.node, "SlotPull")
        return SlotPullParams(np.array([self.node.index], dtype=np.int64), self.force.reshape(1, 3).copy())


def test_a_new_effect_kind_compiles_its_own_kernels_alone():
    """Two simulations of one free net: gravity alone, then gravity and a force of a kind no
    other test declares. The second compiles the new kind's kernels alone (the kernel, its
    slot wrapper, the pin of its record), not the step (one for every combination of
    effects), the internal loads, the updates or gravity; and the free net's
    momentum grows by F t more than under gravity alone (internal forces cancel exactly), the
    new kernel reached through its slot."""
    net = free_net(n=3)
    weight = cosnet.Simulation(net, [cosnet.Gravity()])
    start = weight.momentum()
    weight.run(steps=50)
    force = np.array([0.3, -0.2, 0.5])
    sim = cosnet.Simulation(net, [cosnet.Gravity(), SlotPull(net.nodes[0], force)])
    with CompileLog(llvm=False) as log:
        sim.run(steps=50)
    roots = {k.root.rsplit(".", 1)[-1] for k in log.kernels}
    assert roots <= {"add_slot_pull", "pin_record"}, roots
    # the log names the slot wrapper by its hook and kernel (its time, its plan are theirs);
    # nothing is compiled where an earlier run left these kernels in the cache
    compiled = {k.name for k in log.kernels}
    assert not compiled or "load:test_slots.add_slot_pull" in compiled, compiled
    gained = (sim.momentum() - start) - (weight.momentum() - start)
    np.testing.assert_allclose(gained, force * sim.time, rtol=1e-9)


def _stepped(effects):
    net = free_net(n=3)
    sim = cosnet.Simulation(net, effects(net))
    sim.run(steps=1)
    return sim, sim._stepper()


def _call(sim, step, slots, hooks=None):
    table = (slots, sim.step_table[1] if hooks is None else hooks)
    step(sim.model, sim.state, sim.loads, table, sim.dt, 1, sim.backend)


def test_a_slot_holding_another_kernel_raises_instead_of_calling_it():
    sim, step = _stepped(lambda net: [cosnet.NodeLoad(net.nodes[0], force=(0.0, 0.0, 1.0)), cosnet.Damping(0.5)])
    slots = sim.step_table[0]
    rows = len(slots)
    assert rows == len(CORE) + 3   # the node load's load and account kernels, damping's flow
    for a in range(rows):
        for b in range(a + 1, rows):   # any two kernels exchanged, one effect's two hooks too
            swapped = slots.copy()
            swapped[[a, b]] = swapped[[b, a]]
            with pytest.raises(RuntimeError, match="not bound to the"):
                _call(sim, step, swapped)
    for a in range(len(CORE), rows):   # a kernel given in another hook's rows, its row saying so
        moved = slots.copy()
        moved[a, SLOT_ADDRESS] = slots[len(CORE) + (a - len(CORE) + 1) % 3, SLOT_ADDRESS]
        with pytest.raises(RuntimeError, match="not bound to the kernel of its hook"):
            _call(sim, step, moved)
    with pytest.raises(RuntimeError, match="slots missing"):
        _call(sim, step, np.ascontiguousarray(slots[:-1]))
    with pytest.raises(RuntimeError, match="slots missing"):
        _call(sim, step, slots, np.ascontiguousarray(sim.step_table[1][:-1]))
    unbound = np.zeros_like(slots)             # as a copied simulation's: another process's
    with pytest.raises(RuntimeError, match="not bound in this process"):
        _call(sim, step, unbound)


def test_a_kernel_given_another_effect_s_record_raises_instead_of_reading_it():
    """Each effect's record is pinned with the tag of its type, which its kernels check: a
    kernel pointed at the record of another kind of effect raises, and one given no record
    at all is not called."""
    sim, step = _stepped(lambda net: [cosnet.NodeLoad(net.nodes[0], force=(0.0, 0.0, 1.0)), cosnet.Damping(0.5)])
    slots = sim.step_table[0]
    load_row, flow_row = len(CORE), len(CORE) + 1
    crossed = slots.copy()
    crossed[load_row, SLOT_RECORD] = slots[flow_row, SLOT_RECORD]
    with pytest.raises(RuntimeError, match="record other than"):
        _call(sim, step, crossed)
    unpinned = slots.copy()
    unpinned[load_row, SLOT_RECORD] = 0
    with pytest.raises(RuntimeError, match="without its record"):
        _call(sim, step, unpinned)


def test_slots_bound_in_another_process_are_bound_again_before_a_run():
    """A simulation whose slots name another process (as after a fork or a copy) binds them
    again before stepping, and steps as one bound here: the same state bit for bit."""
    a, b = (cosnet.Simulation(free_net(n=3), [cosnet.Gravity()]) for _ in range(2))
    a.run(steps=5)
    b.run(steps=5)
    b.step_table[0][:, 2] = -1
    b._slots_process = None
    a.run(steps=20)
    b.run(steps=20)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)


def test_a_copied_simulation_steps_its_own_records():
    """A simulation copied in this process carries its original's table; its records, pinned
    anew at each call, are its own: the copy and the original, given different forces, move
    apart as their forces say, and the original is unchanged by the copy's run."""
    import copy
    net = free_net(n=3)
    a = cosnet.Simulation(net, [cosnet.NodeLoad(net.nodes[0], force=(0.0, 0.0, 1.0))])
    a.run(steps=5)
    b = copy.deepcopy(a)
    load = next(r for r in b.kernel_records if hasattr(r, "force"))
    load.force[:] = -load.force
    start = a.momentum()
    a.run(steps=50)
    b.run(steps=50)
    np.testing.assert_allclose(a.momentum() - start, [0.0, 0.0, 1.0 * 50 * a.dt], atol=1e-12)
    np.testing.assert_allclose(b.momentum() - start, [0.0, 0.0, -1.0 * 50 * b.dt], atol=1e-12)
