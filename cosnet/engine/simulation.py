"""The simulation driver: flattens a net once, binds the declared effects, and advances the
state with a compiled symplectic stepper (no Python loop over lines or elements per step)."""

from __future__ import annotations

import math
import numbers
import os
from typing import Any

import numba
import numpy as np

from .. import kernels  # noqa: F401  (package import; registers nothing)
from . import checkpoint, linearised, measure
from ..core import fast_modes as _fast
from .checkpoint import fingerprint
from .registry import ACCOUNTS, Binding, Effect, after_added_mass, implied_effects
from .flatten import flatten
from ..kernels import effects as _effect_kernels  # noqa: F401  (registers the built-in kernels)
from ..kernels.backend import Parallel, ParallelSplit, Serial
from ..kernels.compose import LOAD_HOOK, Pins, bind_slots, effect_rows, empty_table, run_slot, step_kernels
from ..kernels.elastic import LONG_LINE
from ..kernels.layout import TYPING_ONLY, Model, State, empty_loads, record_type, typed_call
from ..kernels.motion import place_line_ends
from ..kernels.stepping import (CHUNK_STEPS, advance_pefrl, advance_verlet, compile_orders,
                                stability_interval, steps_to)
from ..core.net import Line, Net, Node
from ..core.rotations import matrix_from_quat
from .watch import InstabilityError, Watch, locate  # noqa: F401  (InstabilityError: cosnet's export)

STEPPERS = {"verlet": advance_verlet, "pefrl": advance_pefrl}
# Below this many elements the threaded loops' launches (waking the sleeping pool: kernels/backend.py)
# cost more than the second thread saves: bench/throughput.py times 1 against 2 threads about it
# (docs/threads.md).
PARALLEL_MIN_ELEMENTS = 50_000


def check_threads(threads) -> int:
    """Return threads if it is an integer from 1 to the number of threads numba may use
    (NUMBA_NUM_THREADS), else raise ValueError saying so."""
    available = numba.config.NUMBA_NUM_THREADS
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) \
            or not 1 <= threads <= available:
        raise ValueError(f"must be an integer from 1 to {available}, got {threads!r}")
    return int(threads)


def backend_for(model, threads: int):
    """The backend stepping ``model`` on ``threads`` threads: ParallelSplit where a line is
    longer than LONG_LINE (its passes split across the threads), else Parallel, or Serial."""
    if threads == 1:
        return Serial()
    lengths = np.diff(model.line_element_offsets)
    return (ParallelSplit if lengths.size and lengths.max() > LONG_LINE else Parallel)(threads)


def joined_records(effects, records) -> tuple[list, list]:
    """Return (records, kernel records): each effect's record, and the (stage, record, effect
    class) of each record the step runs, where every run of effects of one class that declares ``join`` (one after
    another, so the loads still add up in the declared order) is one joined record and its
    effects' records are views into it."""
    own, kernel = list(records), []
    i = 0
    while i < len(effects):
        cls = type(effects[i])
        j = i + 1
        while cls.join is not None and j < len(effects) and type(effects[j]) is cls:
            j += 1
        if j - i > 1:
            joined, views = cls.join(records[i:j])
            own[i:j] = views
            kernel.append((cls.stage, joined, cls))
        else:
            kernel.append((cls.stage, records[i], cls))
        i = j
    return own, kernel


class Simulation:
    """A net in motion.

    net: the Net (flattened once; later changes to it are not seen).
    effects: declared effects (Gravity, NodeLoad, LineLoad, Damping, ...); nothing else acts.
    stepper: "verlet" (position Verlet, order 2) or "pefrl" (order 4).
    dt: time step; None uses the estimated stable step ``stable_dt()`` (a bound), "tight" the
        step of the linearised net's highest mode ``stable_dt(tight=True)``. A dt above the
        bound is refused unless ``force_dt=True``.
    safety: the fraction of the estimated stability limit taken as the automatic step, in (0, 1].
    threads: None picks one thread for nets under 50,000 elements and numba's thread count
        above; an integer from 1 to that count forces that many (1 = serial loops). Results
        are bit-identical run to run for a given thread count (docs/threads.md).
    fast_modes: how lines treat their fast modes (rotary inertia, stretch and shear waves):
        "resolve" (as built), "rotary", "soften" or "auto"; a line's own setting overrides it
        (docs/fast_modes.md).
    """

    # declared here: the modules this one imports import it back (fast_modes, record), and
    # mypy types attributes first assigned in __init__ only after that cycle is resolved
    net: Net
    effects: list
    stepper: str
    safety: float
    fast_modes: str
    model: Model
    state: State
    grids: list
    loads: Any
    threads: int
    dt: float
    steps: int
    watch: Watch
    records: list          # each effect's kernel record (views into a joined one, for joined effects)
    kernel_records: list   # the records the kernels read, joined runs as one
    kernel_effects: list   # the effect class of each kernel record
    load_records: tuple
    flow_records: tuple
    step_groups: tuple     # (load, flow, constraint) records, in the order the step calls their kernels
    step_table: tuple      # (slots, hook rows): the step's kernels and the effects' pinned records (compose)
    advance_kernel: Any
    backend: Any
    _compiled_step: Any    # (the records it was typed for, the stepper's compiled entry)
    _pins: Any             # the effects' records where their kernels read them (compose.Pins)

    def __init__(self, net: Net, effects=(), stepper: str = "verlet", dt: float | str | None = None,
                 force_dt: bool = False, safety: float = 0.9, threads: int | None = None,
                 fast_modes: str = "resolve"):
        if not isinstance(net, Net):
            raise ValueError(f"Simulation: net must be a cosnet.Net, got {net!r}")
        if stepper not in STEPPERS:
            raise ValueError(f"Simulation: stepper must be one of {sorted(STEPPERS)}, got {stepper!r}")
        if isinstance(safety, bool) or not isinstance(safety, numbers.Real) or not 0 < safety <= 1:
            raise ValueError(f"Simulation: safety must be a number in (0, 1] (a fraction of the stable "
                             f"step), got {safety!r}; to step beyond the estimate give dt and force_dt=True")
        self.net = net
        self.stepper = stepper
        self.safety = float(safety)
        self.fast_modes = _fast.fast_modes_value("Simulation", fast_modes)
        self.model, self.state, self.grids = flatten(net, fast_modes, sum(e.load_scale(net) for e in effects),
                                                     any(getattr(e, "changes_rest_strain", False) for e in effects))
        self.line_factors = [g.factors for g in self.grids]
        self.loads = empty_loads(self.model)
        self.effects = list(effects)
        for e in self.effects:
            if not isinstance(e, Effect):
                raise ValueError(f"Simulation: effects must be cosnet effects, got {e!r}")
        self.effects = after_added_mass(self.effects) + implied_effects(net, self.grids)
        self.threads = self._choose_threads(threads)
        on = Binding(net, self.model, self.state, tuple(self.effects), threads=self.threads)
        bound: list = []
        for e in self.effects:   # in order: an effect may share arrays of one bound before it (sliders, a fluid's)
            bound.append(e.bind(on._replace(records=tuple(bound))))
        self.records, kernel_records = joined_records(self.effects, bound)
        self.kernel_records = [p for _, p, _ in kernel_records]   # what the kernels read
        self.kernel_effects = [cls for _, _, cls in kernel_records]   # the class declaring each
        self.load_records = tuple(p for stage, p, _ in kernel_records if stage == "load")
        self.flow_records = tuple(p for stage, p, _ in kernel_records if stage == "flow")
        constraints = tuple(p for stage, p, _ in kernel_records if stage == "constraint")
        self.step_groups = (self.load_records, self.flow_records, constraints)
        self._pins = Pins(self.step_groups)
        self.advance_kernel = STEPPERS[stepper]
        self._new_step_table()
        self._scratch_state = None
        self.backend = backend_for(self.model, self.threads)
        if isinstance(dt, str) and dt != "tight":
            raise ValueError(f"Simulation: dt must be a positive number, None or 'tight', got {dt!r}")
        est = self.stable_dt(tight=dt == "tight")
        if dt is None or dt == "tight":
            if not math.isfinite(est):
                raise ValueError("Simulation: this net has no elastic stiffness to set a stable step "
                                 "(no lines, or none that can deform); give dt explicitly")
            dt = est
        else:
            dt = float(dt)
            if not math.isfinite(dt) or dt <= 0:
                raise ValueError(f"Simulation: dt must be a positive number, got {dt}")
            if dt > est and not force_dt:
                raise ValueError(f"Simulation: dt = {dt:.4g} s exceeds the estimated stable step "
                                 f"{est:.4g} s ({self.stiffest()}); dt='tight' takes the highest mode's, "
                                 f"force_dt=True insists")
        self.dt = dt
        self.steps = 0
        self.watch = Watch(self)
        self.fingerprint = fingerprint(self)   # before any step: the effects' counters are still zero

    # ------------------------------------------------------------------ stepping
    def _choose_threads(self, threads):
        if threads is None:
            big = self.model.element_rest_length.shape[0] >= PARALLEL_MIN_ELEMENTS
            return numba.config.NUMBA_NUM_THREADS if big else 1
        try:
            return check_threads(threads)
        except ValueError as e:
            raise ValueError(f"Simulation: threads {e}") from None

    def stable_dt(self, tight: bool = False) -> float:
        """Estimated largest stable step: safety * (scheme interval) / omega_max, with omega_max^2
        bounded from above by the net's plus the stiffness the declared effects add (penalty
        joints, contact). The net's is Gershgorin's bound on the linearised net (cheap, and
        0-30 % above the highest mode where neighbouring masses differ: line ends, submerged
        lines), or with ``tight`` that highest mode itself (a sparse eigenvalue solve about the
        current state, without the geometric stiffness of its strains)."""
        model = self._inertial_model()
        if tight:
            w2 = linearised.highest_omega2(model, self.state, self.net)
        else:
            w2, _, _ = measure.bound_max_omega2(model)
        w2 += sum(e.max_omega2(self) for e in self.effects)
        if w2 <= 0:
            return math.inf
        return self.safety * stability_interval(self.stepper) / math.sqrt(w2)

    def _inertial_model(self) -> Model:
        """The model the stable step is bounded on: with the masses the kick divides by (each
        vertex's and node's own plus the least added mass the effects give it, a submerged
        line's) and the bending stiffness effects hold in its place (an articulated end's)."""
        on = Binding(self.net, self.model, self.state, tuple(self.effects))
        pairs = list(zip(self.effects, self.records))
        extra = [a for a in (e.added_mass(p, on) for e, p in pairs) if a is not None]
        held = [h for h in (e.held_stiffness(p, on) for e, p in pairs) if h is not None]
        m = self.model
        if extra:
            m = m._replace(vertex_mass=m.vertex_mass + sum(v for v, _ in extra),
                           node_mass=m.node_mass + sum(n for _, n in extra))
        if held:
            bend = m.voronoi_stiffness.copy()
            for points, b in held:
                bend[points] = b
            m = m._replace(voronoi_stiffness=bend)
        return m

    def stiffest(self) -> str:
        """Where the highest frequency sits (for messages)."""
        w2, kind, idx = measure.bound_max_omega2(self._inertial_model())
        if self.effects:
            w2_effect, stiff = max(((e.max_omega2(self), i) for i, e in enumerate(self.effects)))
            if w2_effect > w2:
                return self.effects[stiff].describe()
        if w2 <= 0:
            return "nowhere (nothing elastic)"
        if kind == 2:
            return locate(self.net, self.model, "node", idx)
        return locate(self.net, self.model, "vertex" if kind == 0 else "element", idx)

    @property
    def time(self) -> float:
        return float(self.state.clock[0])

    def run(self, until: float | None = None, steps: int | None = None, *, out=None, every=None,
            probes=(), callback=None, overwrite: bool = False):
        """Advance to time ``until`` (the last step may overshoot by less than dt) or by
        ``steps`` steps (a non-negative integer; even zero steps scan the state for
        non-finite values). With ``out`` (a directory) or ``callback``, stop at every multiple
        of ``every`` seconds after the current time (default: 50 frames) and at ``until``,
        landing on each (dt shortened to a whole fraction of ``every``), and there write the files ``cosnet run``
        writes (``out``: series.pvd, frames, meta.json, probes.csv of ``probes`` such as
        ["tip", "rod@0.5:force"], checkpoint.npz; a directory holding a run already is
        refused unless ``overwrite``) and call ``callback(self)`` (cosnet.output.record)."""
        if out is not None or callback is not None or every is not None or probes:
            from ..output.record import run_with_output  # cycle: the writer (above the engine) steps a sim
            if steps is not None:
                raise ValueError("Simulation.run: out, every, probes and callback go with until, not steps")
            return run_with_output(self, until, out, every, probes, callback, overwrite)
        if (until is None) == (steps is None):
            raise ValueError("Simulation.run: give exactly one of until or steps")
        if steps is None:
            if isinstance(until, bool) or not isinstance(until, numbers.Real) or not math.isfinite(until):
                raise ValueError(f"Simulation.run: until must be a finite time in s, got {until!r}")
            # a run to `until` ends less than dt past it: an earlier until is no target of this run
            if until <= self.time - self.dt:
                raise ValueError(f"Simulation.run: until = {float(until):.9g} s is before the current "
                                 f"time {self.time:.9g} s")
            steps = max(0, steps_to(float(until) - self.time, self.dt))
        elif isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 0:
            raise ValueError(f"Simulation.run: steps must be a non-negative integer, got {steps!r}")
        steps = int(steps)
        self.watch.start()
        self._check_locked_axes()
        for e in self.effects:
            e.check_state(self)
        self.watch.check_tables("Simulation.run")
        place_line_ends(self.model, self.state)
        if self.steps == 0:
            for e in self.effects:
                e.start(self)
        while steps > 0:
            n = min(steps, CHUNK_STEPS)
            if self.threads > 1:
                numba.set_num_threads(self.threads)
            self._stepper()(self.model, self.state, self.loads, self.step_table, self.dt, n, self.backend)
            self.steps += n
            steps -= n
            self.watch.after_chunk()
        return self

    def step_signature(self) -> tuple:
        """The numba types the stepper is compiled for, here: the records typed by
        kernels.layout.record_type and the step's table (one compiled step whatever the nets'
        sizes and whatever their effects)."""
        return (record_type(self.model), record_type(self.state), record_type(self.loads),
                numba.typeof(self.step_table), numba.types.float64, numba.types.int64, numba.typeof(self.backend))

    def _new_step_table(self):
        """Give the step a table of its own, bound to no kernels: the next step binds it to
        those of this simulation's backend (bind_kernels). A copy stepped on another backend
        needs one: the slots of the table it shares hold the other backend's kernels, which
        its step refuses to call."""
        self.step_table = empty_table(self.step_groups)
        self._slots_process = None
        self._compiled_step = None

    def bind_kernels(self):
        """Compile (or load) the kernels the step calls (its own and the effects') and write
        their addresses in this process into the step table's slots (kernels.compose.bind_slots);
        returns the step table. Done once per process: a step called with slots bound
        elsewhere raises."""
        if TYPING_ONLY[0] or self._slots_process == os.getpid():
            return self.step_table
        model, state, loads, _, _, _, backend = self.step_signature()
        bind_slots(self.step_table, self.step_groups, model, state, loads, backend, self.advance_kernel,
                   compile_orders(step_kernels(self.step_groups))[0])
        self._slots_process = os.getpid()
        return self.step_table

    def evaluate_loads(self):
        """Update self.loads given the state, and return them: the internal loads (3.2)/(3.3),
        every load effect's, then the node balances (4.3)/(4.4), as a kick evaluates them (the
        stepper run for no steps). The line ends are where the state last put them."""
        self._stepper()(self.model, self.state, self.loads, self.step_table, 0.0, 0, self.backend)
        return self.loads

    def effect_loads(self, effect: Effect):
        """The loads of load effect ``effect`` alone at the present state, in loads of their
        own: its kernel, the very code the step calls (through its slot, kernels.compose.run_slot),
        run once (it changes nothing else but what it keeps from call to call, as in a step).
        An effect joined with others of its class into one kernel record (Effect.join) has
        no kernel of its own: the step runs them as one."""
        rows = effect_rows(self.step_groups, self.effect_params(effect), LOAD_HOOK)
        if not rows:
            raise ValueError(f"{effect.describe()}: no load kernel of its own in this simulation "
                             f"(not a load effect, or joined with the effects of its class beside it)")
        self.bind_kernels()
        self._pins(self.step_table)
        loads = empty_loads(self.model)
        if self.threads > 1:
            numba.set_num_threads(self.threads)
        typed_call(run_slot, self.model, self.state, loads, self.step_table, self.backend, rows[0], 0.0)
        return loads

    def _stepper(self):
        """The stepper compiled (or loaded from the cache) for step_signature, called directly:
        numba's own dispatch would type the records by their flags alone. Kept while the
        records are the same objects (their arrays, flags included, the same). The effects'
        records are pinned anew at each call (compose.Pins)."""
        self.bind_kernels()   # first: compiling the kernels in an order shared with compile_kick
        self._pins(self.step_table)
        key = (self.model, self.state, self.loads, self.step_table, self.backend)
        held = self._compiled_step
        if held is None or any(a is not b for a, b in zip(key, held[0])):
            sig = self.step_signature()
            self.advance_kernel.compile(sig)
            held = self._compiled_step = (key, self.advance_kernel.overloads[sig].entry_point)
        return held[1]

    def _check_locked_axes(self):
        bad = (self.model.node_locked > 0) & (self.state.node_w != 0)
        if np.any(bad):
            nd = int(np.argwhere(bad)[0, 0])
            raise ValueError(f"node {self.net.nodes[nd].name!r}: its angular velocity about a locked "
                             f"(infinite-inertia) axis must be zero")

    def check(self):
        """Run every test of the watch on the current state now: non-finite values, runaway
        strain, flutter, energy growth (InstabilityError on failure). A state that has already
        passed costs one pass over its bits. Writers call this before anything is written, so
        no frame, probe row or checkpoint holds a state that has not passed."""
        place_line_ends(self.model, self.state)
        self.watch.check()
        return self

    # ------------------------------------------------------------------ access
    def effect_params(self, effect: Effect):
        """The parameter record ``effect`` was bound to in this simulation (the very arrays its
        kernel reads and writes, counters included)."""
        for e, p in zip(self.effects, self.records):
            if e is effect:
                return p
        raise ValueError(f"{effect.describe()} is not an effect of this simulation")

    def check_node(self, node: Node, who: str = "Simulation"):
        Binding(self.net, self.model, self.state).check_node(node, who)

    def check_line(self, line: Line, who: str = "Simulation"):
        Binding(self.net, self.model, self.state).check_line(line, who)

    def vertex_range(self, line) -> slice:
        """The rows of ``line``'s vertices in the state's vertex arrays."""
        self.check_line(line)
        o = self.model.line_vertex_offsets
        return slice(o[line.index], o[line.index + 1])

    def element_range(self, line) -> slice:
        """The rows of ``line``'s elements in the state's element arrays."""
        self.check_line(line)
        o = self.model.line_element_offsets
        return slice(o[line.index], o[line.index + 1])

    def line_positions(self, line: Line) -> np.ndarray:
        """(n+1, 3) vertex positions, first row at the start node; a writable view (the end
        rows follow the nodes and are overwritten by them)."""
        return self.state.x[self.vertex_range(line)]

    def line_velocities(self, line: Line) -> np.ndarray:
        """(n+1, 3) vertex velocities; a writable view (end rows follow the nodes)."""
        return self.state.v[self.vertex_range(line)]

    def line_directors(self, line: Line) -> np.ndarray:
        """(n, 3, 3) element director frames, columns d1 d2 d3 (principal axes) in the lab."""
        return matrix_from_quat(self.state.q[self.element_range(line)])

    def line_angular_velocities(self, line: Line) -> np.ndarray:
        """(n, 3) element angular velocities in each element's body (director) frame; writable view."""
        return self.state.w[self.element_range(line)]

    def node_position(self, node: Node) -> np.ndarray:
        """(3,) position r(nu) of the node's reference point (the centroid of its own body)."""
        self.check_node(node)
        i = node.index
        d = matrix_from_quat(self.state.node_q[i])
        return self.state.node_x[i] - d @ self.model.node_com_offset[i]

    def node_rotation(self, node: Node) -> np.ndarray:
        """(3, 3) D(nu): columns d1 d2 d3 of the node's body frame in the lab."""
        self.check_node(node)
        i = node.index
        return matrix_from_quat(self.state.node_q[i]) @ matrix_from_quat(self.model.node_principal[i]).T

    def node_velocity(self, node: Node) -> np.ndarray:
        """(3,) velocity of the node's composite centre of mass (its body plus its line ends'
        lumped masses); a writable view."""
        self.check_node(node)
        return self.state.node_v[node.index]

    def node_angular_velocity(self, node: Node) -> np.ndarray:
        """(3,) angular velocity in the node's principal body frame (equal to its body frame
        when the inertia is diagonal); a writable view."""
        self.check_node(node)
        return self.state.node_w[node.index]

    # ------------------------------------------------------------------ diagnostics
    def _placed(self):
        """The state with every line end on its node (1.1), as the next step will see it; the
        state itself is left alone (an end follows a node written from outside at run())."""
        st = self.state._replace(x=self.state.x.copy(order="K"), v=self.state.v.copy(order="K"))
        place_line_ends(self.model, st)
        return st

    def _placed_scratch(self):
        """_placed into arrays this simulation keeps, for measures that return numbers: the
        same record at every call while the state's arrays are the same, so that the effects'
        energy kernels find their typed entry held (kernels.layout.typed_call)."""
        s, held = self.state, self._scratch_state
        if held is None or any(a is not b for f, a, b in zip(s._fields, held, s) if f not in ("x", "v")):
            held = self._scratch_state = s._replace(x=np.empty_like(s.x, order="K"), v=np.empty_like(s.v, order="K"))
        held.x[...], held.v[...] = s.x, s.v
        place_line_ends(self.model, held)
        return held

    def energy_parts(self) -> dict:
        """Energies by kind (J): kinetic (translational + rotational), strain, potential."""
        placed = self._placed_scratch()
        kt, kr, u = measure.energies(self.model, placed)
        # the effects read self.state: show them the placed copy for the moment
        state, self.state = self.state, placed
        try:
            pot = sum(e.potential_energy(self) for e in self.effects)
        finally:
            self.state = state
        return {"kinetic": kt + kr, "translational": kt, "rotational": kr, "strain": u, "potential": pot}

    def energy(self) -> float:
        """Total energy: kinetic (translational and rotational, lines and nodes), strain (3.25)
        and the potential of conservative effects (gravity)."""
        p = self.energy_parts()
        return p["kinetic"] + p["strain"] + p["potential"]

    def _drive(self, node: Node):
        self.check_node(node)
        for e in self.effects:
            if e.drives(node):
                return e
        return None

    def reaction(self, node: Node) -> tuple[np.ndarray, np.ndarray]:
        """(force, torque), each (3,), lab frame: what the drive of ``node`` supplies now to keep
        it on its prescription against the loads on it (m a - F; dL/dt - L about its centre of
        mass); zeros for a node without a drive. Damping flows are not part of it."""
        drive = self._drive(node)
        if drive is None:
            return np.zeros(3), np.zeros(3)
        place_line_ends(self.model, self.state)
        return drive.reaction(self, self.evaluate_loads)

    def driver_work(self) -> float:
        """Work done on the net by every drive so far (J): the kicks' quadrature of the
        drivers' power R.v + T.w, and the kinetic energy damping took from what they hold."""
        return sum(e.work(self) for e in self.effects if e.work_kind == "driver")

    def actuation_work(self) -> float:
        """Work done on the net by the active lines so far (J): the strain energy each change
        of an active curvature adds, and the muscle moments' work in the kicks."""
        return sum(e.work(self) for e in self.effects if e.work_kind == "actuation")

    def load_work(self) -> float:
        """Work done on the net by the declared node and line loads so far (J): the kicks'
        quadrature of their power, F . v + L . w."""
        return sum(e.work(self) for e in self.effects if e.work_kind == "load")

    def dissipated(self) -> float:
        """Energy taken out of the net so far (J) by the effects that account for it (damping,
        an obstacle's friction, a fluid's drag): energy() - driver_work() - actuation_work()
        - load_work() - supplied() + dissipated() is conserved to the scheme's order."""
        return sum(e.dissipated(self) for e in self.effects)

    def supplied(self) -> float:
        """Work done on the net so far (J) by the medium around it (a fluid's current, wind,
        waves), as the effects that feel it account for it."""
        return sum(e.supplied(self) for e in self.effects)

    def balance(self) -> float:
        """energy() - driver_work() - actuation_work() - load_work() - supplied() + dissipated()
        (J): constant but for the scheme's error (ACCOUNTS)."""
        return self.energy() + sum(sign * getattr(self, read)() for read, sign in ACCOUNTS.values())

    def momentum(self) -> np.ndarray:
        """(3,) total linear momentum of everything with finite mass."""
        return measure.momenta(self.model, self._placed_scratch())[0]

    def angular_momentum(self) -> np.ndarray:
        """(3,) total angular momentum about the origin."""
        return measure.momenta(self.model, self._placed_scratch())[1]

    def line_fields(self, line: Line) -> dict:
        """Per-vertex fields of a line, each (n+1, ...): position, velocity, d1, d2, d3, force
        n and torque m (lab), strain v - v0 and curvature u - u0 (director frame) (3.22)."""
        self.check_line(line)
        return self._fields(line.index, line.index + 1)

    def net_fields(self) -> dict:
        """The fields of line_fields for every vertex of the net, lines in order, each (nv, ...)."""
        return self._fields(0, len(self.net.lines))

    def _fields(self, l0: int, l1: int) -> dict:
        st = self._placed()
        f = measure.vertex_fields(self.model, st, l0, l1)
        o = self.model.line_vertex_offsets
        sl = slice(o[l0], o[l1])
        on = Binding(self.net, self.model, st, tuple(self.effects))
        for e, p in zip(self.effects, self.records):
            held = e.end_fields(p, on)
            if held is not None:
                vertices, frames, torque, curvature = held
                inside = (vertices >= sl.start) & (vertices < sl.stop)
                at = vertices[inside] - sl.start
                f["frames"][at], f["torque"][at], f["curvature"][at] = (frames[inside], torque[inside],
                                                                        curvature[inside])
        d = matrix_from_quat(f.pop("frames"))
        return {"position": st.x[sl].copy(), "velocity": st.v[sl].copy(),
                "d1": d[:, :, 0], "d2": d[:, :, 1], "d3": d[:, :, 2], **f}

    # ------------------------------------------------------------------ checkpoints
    def save_checkpoint(self, path):
        """Write the whole state (with step count, dt, stepper and the model's fingerprint) to
        an .npz file atomically, after the state has passed the watch (see check())."""
        checkpoint.save(self, path)

    def load_checkpoint(self, path):
        """Restore a state written by save_checkpoint, bit-exactly; refuse (ValueError, one
        line saying what differs) a checkpoint of another model, effects, dt or stepper."""
        return checkpoint.load(self, path)
