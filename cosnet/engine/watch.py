"""The instability watch: the tests run on a simulation's state between compiled calls.

A hash of the state seals what the watch last saw, so a state changed from outside between
runs is told from one the watch has already passed; a scan for non-finite values runs after
every compiled call, the strain, energy and flutter tests at most every CHUNK_STEPS steps
and before anything is written (``check``). The index tables the kernels trust are checked
again only when their seal changed (cosnet.engine.bounds).
"""

from __future__ import annotations

import numpy as np

from ..core.fast_modes import STRAIN_GUARD, FastModesError
from . import measure
from .bounds import table_error, table_seal
from ..kernels.checksum import scan_state
from ..kernels.stepping import CHUNK_STEPS

STRAIN_LIMIT = 1.0  # |v - v0| beyond this (100 % stretch or shear) means the run has blown up
ENERGY_GROWTH = 10.0  # energy rising by this many times its scale, with nothing feeding it in
# a node turning against its line end (measure.node_wobble) by more than WOBBLE_FLOOR rad at
# the grid scale, grown by WOBBLE_GROWTH times at each of two samples in a row, is fluttering
WOBBLE_FLOOR = 1e-3
WOBBLE_GROWTH = 3.0
# what the watch calls each state array, and what its rows run over
STATE_NAMES = {"x": "position", "v": "velocity", "q": "orientation", "w": "angular velocity",
               "node_x": "node position", "node_v": "node velocity", "node_q": "node orientation",
               "node_w": "node angular velocity", "node_hold": "node held momentum", "clock": "time"}
STATE_ROWS = {"x": "vertex", "v": "vertex", "q": "element", "w": "element", "clock": "clock"}


class InstabilityError(RuntimeError):
    """The simulation blew up. Attributes: time, where (line/node and element), quantity,
    safe_dt; the message says all four."""

    def __init__(self, time, where, quantity, dt, safe_dt, advice=None):
        self.time, self.where, self.quantity, self.safe_dt = time, where, quantity, safe_dt
        advice = advice or f"a dt below {safe_dt:.4g} s should be stable"
        super().__init__(f"unstable at t = {time:.6g} s: {quantity} at {where}; dt = {dt:.4g} s, {advice}")


def locate(net, model, rows: str, idx: int, label: str | None = None) -> str:
    """Name row ``idx`` of a net-wide array whose rows run over ``rows`` ("node", "element",
    "vertex" or "clock"): "node 'a'", or "line 'x' element k" with k counted along the line
    (``label`` replaces the word element or vertex)."""
    if rows == "clock":
        return "the clock"
    if rows == "node":
        return f"node {net.nodes[idx].name!r}"
    offsets = model.line_element_offsets if rows == "element" else model.line_vertex_offsets
    line = int(np.searchsorted(offsets, idx, side="right") - 1)
    return f"line {net.lines[line].name!r} {label or rows} {idx - offsets[line]}"


class Watch:
    """The watch over one Simulation (``sim.watch``): ``start`` at the start of a run, ``after_chunk``
    after each compiled call, ``check`` before anything is written."""

    def __init__(self, sim) -> None:
        self.sim = sim
        self.energy_watched = all(not e.adds_energy for e in sim.effects)  # nothing feeds energy in
        self.e_start: float | None = None  # the energy test's reference (None: taken at the next test)
        self.scale = 0.0
        self.tested_at: int | None = None   # step count at the last strain/energy test
        self.wobble: list[float] = []       # measure.node_wobble's angle at the last three samples
        self.wobble_at: int | None = None   # step count at the last of them
        self.seal: int | None = None        # hash of the state as the last run() or check() saw it
        self.passed: int | None = None      # hash of the last state that passed every test
        self.tables: tuple | None = None    # bounds.table_seal of the tables last found valid
        self.check_tables("Simulation")

    def check_tables(self, who: str):
        """Raise ValueError (one line, starting with who) if an index table the kernels trust
        is out of range or an array has the wrong shape; a no-op while their seal is unchanged."""
        sim = self.sim
        seal = table_seal(sim.model, sim.state, sim.loads, sim.kernel_records)
        if seal == self.tables:
            return
        problem = table_error(sim.model, sim.state, sim.loads, sim.kernel_records, sim.kernel_effects)
        if problem:  # the kernels index by these tables unchecked
            raise ValueError(f"{who}: {problem}")
        self.tables = seal

    def start(self):
        """At the start of a run: scan the state, and start new references if it was changed
        from outside since the watch last saw it."""
        self._reseal(self._scan())

    def after_chunk(self):
        """After a compiled call: scan for non-finite values; the other tests at most every
        CHUNK_STEPS steps (and at the first call)."""
        # the hash tells the next run() or check() whether the state was changed in between
        self.seal = self._scan()
        if self.tested_at is not None and self.sim.steps - self.tested_at < CHUNK_STEPS:
            return
        self._test()

    def check(self):
        """Every test on the current state now; a state that already passed costs one scan."""
        seal = self._scan()
        if seal == self.passed:
            return
        self._reseal(seal)
        self._test()

    def _scan(self) -> int:
        """One pass over the state: stop on its first non-finite value; return its hash."""
        seal, field, row = scan_state(self.sim.state)
        if field is not None:
            where = locate(self.sim.net, self.sim.model, STATE_ROWS.get(field, "node"), row)
            self._fail(f"non-finite {STATE_NAMES[field]}", where)
        return seal

    def _reseal(self, seal: int):
        """Keep the references across run() calls, so slow growth over many short runs is
        still seen; a state changed from outside since the watch last saw it (found by its
        hash) starts new references at the next test."""
        if self.seal is not None and self.seal != seal:
            self.e_start = None
            self.wobble, self.wobble_at = [], None
        self.seal = seal

    def _test(self):
        """The strain, flutter and energy tests on the state sealed in self.seal."""
        sim = self.sim
        self.tested_at = sim.steps
        check_strain(sim)
        worst, e = measure.worst_strain(sim.model, sim.state)
        if worst > STRAIN_LIMIT:
            quantity = f"strain |v - v0| = {worst:.3g} (limit {STRAIN_LIMIT:g})"
            if sim.dt <= sim.stable_dt():
                quantity += (" although dt is within the stable step: the loads likely exceed what "
                             "the line can bear (a physical overload, not a time-step problem)")
            self._fail(quantity, locate(sim.net, sim.model, "element", e))
        # growth is judged per sample: samples at least CHUNK_STEPS apart, never the extra
        # tests before writes
        if self.wobble_at is None or sim.steps - self.wobble_at >= CHUNK_STEPS:
            self.wobble_at = sim.steps
            self._test_wobble()
        if self.energy_watched:
            self._test_energy()
        self.passed = self.seal

    def _test_wobble(self):
        """Stop a node whose vibration against its line end keeps growing at the grid scale:
        a flutter of the discrete net that no smaller dt removes (docs/rolled_cantilever.md)."""
        sim = self.sim
        angle, rate, a = measure.node_wobble(sim.model, sim.state, sim.dt)
        h = self.wobble = (self.wobble + [angle])[-3:]
        if len(h) < 3 or angle < WOBBLE_FLOOR or not h[2] > WOBBLE_GROWTH * h[1] > WOBBLE_GROWTH ** 2 * h[0] > 0:
            return
        node = locate(sim.net, sim.model, "node", int(sim.model.attach_node[a]))
        line = sim.net.lines[a // 2]
        raise InstabilityError(
            sim.time, node,
            f"a flutter of the discretised net (it turns at {rate:.3g} rad/s against the end "
            f"element of line {line.name!r}, a {angle:.2g} rad vibration at the grid scale grown "
            f"{h[1] / h[0]:.3g} and {h[2] / h[1]:.3g} times over the last two samples; a dead, "
            f"constant-direction torque on a node without rotary inertia of its own drives such flutter)",
            sim.dt, sim.dt, advice="a smaller dt does not remove it; give the node a rotary "
            "inertia of its own (a fitting) or use another number of elements (docs/rolled_cantilever.md)")

    def _test_energy(self):
        sim = self.sim
        p = sim.energy_parts()
        e_now = p["kinetic"] + p["strain"] + p["potential"]
        size = p["kinetic"] + p["strain"] + abs(p["potential"])
        if self.e_start is None:
            # floor: round-off of a net at rest must not count as growth (1e-6 strain energy),
            # nor Verlet's error on the energy an effect can feed the motion (a net let go
            # from rest under gravity: its weight times its size)
            floor = 1e-12 * float(np.sum(sim.model.element_stiffness[:, 2] * sim.model.element_rest_length))
            floor = max(floor, sum(e.energy_scale(sim) for e in sim.effects))
            self.e_start, self.scale = e_now, max(size, floor)
            return
        if self.scale > 0 and e_now - self.e_start > ENERGY_GROWTH * self.scale:
            worst, e = measure.worst_strain(sim.model, sim.state)
            self._fail(f"energy grew from {self.e_start:.4g} J to {e_now:.4g} J with nothing "
                       f"feeding it (largest strain {worst:.3g})", locate(sim.net, sim.model, "element", e))
        self.scale = max(self.scale, size)

    def _fail(self, quantity: str, where: str):
        sim = self.sim
        est = sim.stable_dt()
        safe = est if sim.dt > est else 0.5 * sim.dt
        raise InstabilityError(sim.time, where, quantity, sim.dt, safe)


def check_strain(sim):
    """Raise FastModesError if a softened line's stretch or shear passed STRAIN_GUARD."""
    soft = [k for k, f in enumerate(sim.line_factors) if f.softened]
    if not soft:
        return
    sx, sy, sz = measure.element_stretch(sim.model, sim.state, measure.block_of(sim.model))
    s = np.abs(sx) + np.abs(sy) + np.abs(sz)
    eo = sim.model.line_element_offsets
    for k in soft:
        seg = s[eo[k]:eo[k + 1]]
        if seg.size and np.max(seg) > STRAIN_GUARD:
            e = int(np.argmax(seg))
            raise FastModesError(
                f"line {sim.net.lines[k].name!r}: fast_modes 'soften' cannot hold at t = {sim.time:.6g} s: "
                f"strain {seg[e]:.3g} at element {e} exceeds {STRAIN_GUARD:g} (its stretch and shear "
                f"stiffness are softened); use fast_modes = \"rotary\" or \"resolve\" for it")
