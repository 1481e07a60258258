"""A step calls its kernels through the addresses in its records' slots (kernels/slots.py):
a new combination of effects compiles its step and the new kind's kernels, none of the others
again, and computes what the kernels compute; a slot bound to another kernel, too few slots or
slots bound in another process end in a clear error, never a jump."""

from typing import NamedTuple

import numpy as np
import pytest
from numba import njit

import cosnet
from cosnet.compiling import CompileLog
from cosnet.engine.registry import Effect
from cosnet.kernels.compose import CORE, load_kernel
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


def test_a_new_effect_kind_compiles_its_step_and_its_own_kernels_alone():
    """Two simulations of one free net: gravity alone, then gravity and a force of a kind no
    other test declares. The second compiles its step and the new kind's kernels (the kernel
    and its slot wrapper), none of the internal loads, updates or gravity; and the free net's
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
    assert roots <= {"advance_verlet", "add_slot_pull", "call"}, roots
    gained = (sim.momentum() - start) - (weight.momentum() - start)
    np.testing.assert_allclose(gained, force * sim.time, rtol=1e-9)


def _stepped(effects):
    net = free_net(n=3)
    sim = cosnet.Simulation(net, effects(net))
    sim.run(steps=1)
    return sim, sim._stepper()


def _call(sim, step, slots):
    records = sim.step_records[:3] + (slots,)
    step(sim.model, sim.state, sim.loads, records, sim.dt, 1, sim.backend)


def test_a_slot_holding_another_kernel_raises_instead_of_calling_it():
    sim, step = _stepped(lambda net: [cosnet.NodeLoad(net.nodes[0], force=(0.0, 0.0, 1.0)), cosnet.Damping(0.5)])
    slots = sim.step_records[3]
    rows = len(slots)
    assert rows == len(CORE) + 3   # the node load's load and account kernels, damping's flow
    for a in range(rows):
        for b in range(a + 1, rows):   # any two kernels exchanged, one effect's two hooks too
            swapped = slots.copy()
            swapped[[a, b]] = swapped[[b, a]]
            with pytest.raises(RuntimeError, match="not bound to the"):
                _call(sim, step, swapped)
    with pytest.raises(RuntimeError, match="slots missing"):
        _call(sim, step, np.ascontiguousarray(slots[:-1]))
    unbound = np.zeros_like(slots)             # as a copied simulation's: another process's
    with pytest.raises(RuntimeError, match="not bound in this process"):
        _call(sim, step, unbound)


def test_slots_bound_in_another_process_are_bound_again_before_a_run():
    """A simulation whose slots name another process (as after a fork or a copy) binds them
    again before stepping, and steps as one bound here: the same state bit for bit."""
    a, b = (cosnet.Simulation(free_net(n=3), [cosnet.Gravity()]) for _ in range(2))
    a.run(steps=5)
    b.run(steps=5)
    b.step_records[3][:, 2] = -1
    b._slots_process = None
    a.run(steps=20)
    b.run(steps=20)
    assert np.array_equal(a.state.x, b.state.x) and np.array_equal(a.state.v, b.state.v)
