"""The simulation driver: flattens a net once, binds the declared effects, and advances the
state with a compiled symplectic stepper (no Python loop over lines or elements per step)."""

from __future__ import annotations

import math
import numbers
from functools import lru_cache

import numba
import numpy as np

from . import kernels  # noqa: F401  (package import; registers nothing)
from . import checkpoint, measure
from . import fast_modes as _fast
from .checkpoint import fingerprint
from .active import ActiveCurvature
from .drives import Drive
from .effects import Effect
from .flatten import flatten, matrix_from_quat
from .kernels import effects as _effect_kernels  # noqa: F401  (registers the built-in kernels)
from .kernels.backend import Parallel, Serial
from .bounds import table_error
from .kernels.checksum import scan_state
from .kernels.layout import empty_loads
from .kernels.motion import place_line_ends
from .kernels.stepping import PEFRL_CHI, PEFRL_LAMBDA, PEFRL_XI, advance_pefrl, advance_verlet, evaluate_loads
from .net import Line, Net, Node

STEPPERS = {"verlet": advance_verlet, "pefrl": advance_pefrl}
CHUNK_STEPS = 2000  # steps between the watch's strain and energy checks within a run (non-finite values: every
                    # run() call; all of them: before every write, see check())
PARALLEL_MIN_ELEMENTS = 20_000  # below this a parallel region's launch costs more than it saves


STRAIN_LIMIT = 1.0  # |v - d3| beyond this (100 % stretch or shear) means the run has blown up
# what the instability watch calls each state array
STATE_NAMES = {"x": "position", "v": "velocity", "q": "orientation", "w": "angular velocity",
               "node_x": "node position", "node_v": "node velocity", "node_q": "node orientation",
               "node_w": "node angular velocity", "node_hold": "node held momentum", "clock": "time"}
ENERGY_GROWTH = 10.0  # energy rising by this many times its scale, with nothing feeding it in
# a node turning against its line end (measure.node_wobble) by more than WOBBLE_FLOOR rad at
# the grid scale, grown by WOBBLE_GROWTH times at each of two checks in a row, is fluttering
WOBBLE_FLOOR = 1e-3
WOBBLE_GROWTH = 3.0


def check_threads(threads) -> int:
    """Return threads if it is an integer from 1 to the number of threads numba may use
    (NUMBA_NUM_THREADS), else raise ValueError saying so."""
    available = numba.config.NUMBA_NUM_THREADS
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)) \
            or not 1 <= threads <= available:
        raise ValueError(f"must be an integer from 1 to {available}, got {threads!r}")
    return int(threads)


class InstabilityError(RuntimeError):
    """The simulation blew up. Attributes: time, where (line/node and element), quantity,
    safe_dt; the message says all four."""

    def __init__(self, time, where, quantity, dt, safe_dt, advice=None):
        self.time, self.where, self.quantity, self.safe_dt = time, where, quantity, safe_dt
        advice = advice or f"a dt below {safe_dt:.4g} s should be stable"
        super().__init__(f"unstable at t = {time:.6g} s: {quantity} at {where}; dt = {dt:.4g} s, {advice}")


@lru_cache(maxsize=None)
def stability_interval(stepper: str) -> float:
    """Largest omega*h for which the scheme is stable on the harmonic oscillator."""
    def step_matrix(wh):
        drift = lambda c: np.array([[1.0, c], [0.0, 1.0]])
        kick = lambda c: np.array([[1.0, 0.0], [-wh * wh * c, 1.0]])
        if stepper == "verlet":
            seq = [drift(0.5), kick(1.0), drift(0.5)]
        else:
            xi, lam, chi = PEFRL_XI, PEFRL_LAMBDA, PEFRL_CHI
            seq = [drift(xi), kick(0.5 - lam), drift(chi), kick(lam), drift(1 - 2 * (chi + xi)),
                   kick(lam), drift(chi), kick(0.5 - lam), drift(xi)]
        m = np.eye(2)
        for s in seq:
            m = s @ m
        return m
    grid = np.linspace(1e-3, 8.0, 8000)
    for wh in grid:
        if abs(np.trace(step_matrix(wh))) > 2.0:
            return float(wh)
    return float(grid[-1])


class Simulation:
    """A net in motion.

    net: the Net (flattened once; later changes to it are not seen).
    effects: declared effects (Gravity, NodeLoad, LineLoad, Damping, ...); nothing else acts.
    stepper: "verlet" (position Verlet, order 2) or "pefrl" (order 4).
    dt: time step; None uses the estimated stable step ``stable_dt()``. A dt above the estimate
        is refused unless ``force_dt=True``.
    safety: the fraction of the estimated stability limit taken as the automatic step, in (0, 1].
    threads: None picks one thread for nets under 20,000 elements and numba's thread count
        above; an integer from 1 to that count forces that many (1 = serial loops). Results
        are bit-identical run to run for a given thread count (docs/threads.md).
    fast_modes: how lines treat their fast modes (rotary inertia, stretch and shear waves):
        "resolve" (as built), "rotary", "soften" or "auto"; a line's own setting overrides it
        (docs/fast_modes.md).
    """

    def __init__(self, net: Net, effects=(), stepper: str = "verlet", dt: float | None = None,
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
        self.model, self.state, self.grids = flatten(net, fast_modes, _fast.load_scale(net, effects))
        self.line_factors = [g.factors for g in self.grids]
        self.loads = empty_loads(self.model)
        self.effects = list(effects)
        for e in self.effects:
            if not isinstance(e, Effect):
                raise ValueError(f"Simulation: effects must be cosnet effects, got {e!r}")
        self._params = [e.bind(self) for e in self.effects]   # each effect's kernel record
        self._load_params = tuple(p for e, p in zip(self.effects, self._params) if e.stage == "load")
        self._flow_params = tuple(p for e, p in zip(self.effects, self._params) if e.stage == "flow")
        constraints = tuple(p for e, p in zip(self.effects, self._params) if e.stage == "constraint")
        self._step_effects = (self._load_params, self._flow_params, constraints)
        self._watch_energy = all(not e.adds_energy for e in self.effects)   # nothing feeds energy in
        self._e_start = None  # the energy watch's reference (None: taken at the next check)
        self._scale = 0.0
        self._watched_at = None   # step count at the last strain/energy check
        self._wobble = []         # measure.node_wobble's angle at the last three checks
        self._seal = None         # hash of the state as the last run() or check() saw it
        self._passed = None       # hash of the last state that passed the full check
        self._advance = STEPPERS[stepper]
        self.threads = self._choose_threads(threads)
        self._backend = Serial() if self.threads == 1 else Parallel(self.threads)
        est = self.stable_dt()
        if dt is None:
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
                                 f"{est:.4g} s ({self.stiffest()}); pass force_dt=True to insist")
        self.dt = dt
        self.steps = 0
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

    def stable_dt(self) -> float:
        """Estimated largest stable step: safety * (scheme interval) / omega_max, with omega_max
        bounded from above by Gershgorin's theorem on the linearised net plus the stiffness the
        declared effects add (penalty joints, contact)."""
        w2, _, _ = measure.bound_max_omega2(self.model)
        w2 += sum(e.max_omega2(self) for e in self.effects)
        if w2 <= 0:
            return math.inf
        return self.safety * stability_interval(self.stepper) / math.sqrt(w2)

    def stiffest(self) -> str:
        """Where the highest frequency sits (for messages)."""
        w2, kind, idx = measure.bound_max_omega2(self.model)
        if self.effects:
            w2_effect, stiff = max(((e.max_omega2(self), i) for i, e in enumerate(self.effects)))
            if w2_effect > w2:
                return self.effects[stiff].describe()
        if w2 <= 0:
            return "nowhere (nothing elastic)"
        if kind == 2:
            return f"node {self.net.nodes[idx].name!r}"
        offsets = self.model.line_vertex_offsets if kind == 0 else self.model.line_element_offsets
        l = int(np.searchsorted(offsets, idx, side="right") - 1)
        what = "vertex" if kind == 0 else "element"
        return f"line {self.net.lines[l].name!r} {what} {idx - offsets[l]}"

    @property
    def time(self) -> float:
        return float(self.state.clock[0])

    def run(self, until: float | None = None, steps: int | None = None, *, out=None, every=None,
            probes=(), callback=None, overwrite: bool = False):
        """Advance to time ``until`` (the last step may overshoot by less than dt) or by
        ``steps`` steps (a non-negative integer; even zero steps scan the state for
        non-finite values). With ``out`` (a directory) or ``callback``, stop at every multiple
        of ``every`` seconds after the current time (default: 50 frames) and at ``until``,
        landing on each with a shortened step, and there write the files ``cosnet run``
        writes (``out``: series.pvd, frames, meta.json, probes.csv of ``probes`` such as
        ["tip", "rod@0.5:force"], checkpoint.npz; a directory holding a run already is
        refused unless ``overwrite``) and call ``callback(self)`` (cosnet.record)."""
        if out is not None or callback is not None or every is not None or probes:
            from .record import run_with_output
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
            steps = max(0, int(math.ceil((float(until) - self.time) / self.dt - 1e-9)))
        elif isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 0:
            raise ValueError(f"Simulation.run: steps must be a non-negative integer, got {steps!r}")
        steps = int(steps)
        self._watch_start()
        self._check_locked_axes()
        for e in self.effects:
            e.check_state(self)
        problem = table_error(self.model, self.state, self.loads, self._params)
        if problem:  # the kernels index by these tables unchecked
            raise ValueError(f"Simulation.run: {problem}")
        place_line_ends(self.model, self.state)
        while steps > 0:
            n = min(steps, CHUNK_STEPS)
            if self.threads > 1:
                numba.set_num_threads(self.threads)
            self._advance(self.model, self.state, self.loads, self._step_effects, self.dt, n,
                          self._backend)
            self.steps += n
            steps -= n
            self._check_health()
        return self

    def _check_locked_axes(self):
        bad = (self.model.node_locked > 0) & (self.state.node_w != 0)
        if np.any(bad):
            nd = int(np.argwhere(bad)[0, 0])
            raise ValueError(f"node {self.net.nodes[nd].name!r}: its angular velocity about a locked "
                             f"(infinite-inertia) axis must be zero")

    def check(self):
        """Run every test of the watch on the current state now: non-finite values, runaway
        strain, energy growth (InstabilityError on failure). A state that has already passed
        costs one pass over its bits. Writers call this before anything is written, so no
        frame, probe row or checkpoint holds a state that has not passed."""
        place_line_ends(self.model, self.state)
        seal = self._scan()
        if seal == self._passed:
            return self
        self._reseal(seal)
        self._full_check()
        return self

    def _scan(self) -> int:
        """One pass over the state: stop on its first non-finite value; return its hash."""
        seal, field, row = scan_state(self.state)
        if field is not None:
            self._fail(f"non-finite {STATE_NAMES[field]}", self._where(STATE_NAMES[field], row))
        return seal

    def _reseal(self, seal: int):
        """Keep the energy watch's reference across run() calls, so slow growth over many
        short runs is still seen; a state changed from outside since the watch last saw it
        (found by its hash) starts a new reference at the next check."""
        if self._seal is not None and self._seal != seal:
            self._e_start = None
            self._wobble = []
        self._seal = seal

    def _watch_start(self):
        self._reseal(self._scan())

    def _check_health(self):
        """Stop with InstabilityError on non-finite values (every call), runaway strain or
        energy growth (at most every CHUNK_STEPS steps, and on the first call)."""
        # the hash tells the next run() or check() whether the state was changed in between
        self._seal = self._scan()
        if self._watched_at is not None and self.steps - self._watched_at < CHUNK_STEPS:
            return
        self._full_check()

    def _full_check(self):
        """The strain and energy tests on the state sealed in self._seal."""
        self._watched_at = self.steps
        _fast.check_strain(self)
        worst, e = measure.worst_strain(self.model, self.state)
        if worst > STRAIN_LIMIT:
            quantity = f"strain |v - d3| = {worst:.3g} (limit {STRAIN_LIMIT:g})"
            if self.dt <= self.stable_dt():
                quantity += (" although dt is within the stable step: the loads likely exceed what "
                             "the line can bear (a physical overload, not a time-step problem)")
            self._fail(quantity, self._where("element", e))
        self._watch_wobble()
        if self._watch_energy:
            self._watch_energy_growth()
        self._passed = self._seal

    def _watch_wobble(self):
        """Stop a node whose vibration against its line end keeps growing at the grid scale:
        a flutter of the discrete net that no smaller dt removes (docs/rolled_cantilever.md)."""
        angle, rate, a = measure.node_wobble(self.model, self.state)
        h = self._wobble = (self._wobble + [angle])[-3:]
        if len(h) < 3 or angle < WOBBLE_FLOOR or not h[2] > WOBBLE_GROWTH * h[1] > WOBBLE_GROWTH ** 2 * h[0] > 0:
            return
        node = self.net.nodes[int(self.model.attach_node[a])]
        line = self.net.lines[a // 2]
        raise InstabilityError(
            self.time, f"node {node.name!r}",
            f"a flutter of the discretised net (it turns at {rate:.3g} rad/s against the end "
            f"element of line {line.name!r}, a {angle:.2g} rad vibration at the grid scale grown "
            f"{h[1] / h[0]:.3g} and {h[2] / h[1]:.3g} times over the last two checks; a dead, "
            f"constant-direction torque on a node without rotary inertia of its own drives such flutter)",
            self.dt, self.dt, advice="a smaller dt does not remove it; give the node a rotary "
            "inertia of its own (a fitting) or use another number of elements (docs/rolled_cantilever.md)")

    def _watch_energy_growth(self):
        p = self.energy_parts()
        e_now = p["kinetic"] + p["strain"] + p["potential"]
        size = p["kinetic"] + p["strain"] + abs(p["potential"])
        if self._e_start is None:
            # floor: round-off of a net at rest must not count as growth (1e-6 strain energy),
            # nor Verlet's error on the energy an effect can feed the motion (a net let go
            # from rest under gravity: its weight times its size)
            floor = 1e-12 * float(np.sum(self.model.element_stiffness[:, 2] * self.model.element_rest_length))
            floor = max(floor, sum(e.energy_scale(self) for e in self.effects))
            self._e_start, self._scale = e_now, max(size, floor)
            return
        if self._scale > 0 and e_now - self._e_start > ENERGY_GROWTH * self._scale:
            worst, e = measure.worst_strain(self.model, self.state)
            self._fail(f"energy grew from {self._e_start:.4g} J to {e_now:.4g} J with nothing "
                       f"feeding it (largest strain {worst:.3g})", self._where("element", e))
        self._scale = max(self._scale, size)

    def _fail(self, quantity, where):
        est = self.stable_dt()
        safe = est if self.dt > est else 0.5 * self.dt
        raise InstabilityError(self.time, where, quantity, self.dt, safe)

    def _where(self, name: str, idx: int) -> str:
        if name == "time":
            return "the clock"
        if name.startswith("node"):
            return f"node {self.net.nodes[idx].name!r}"
        on_elements = name in ("orientation", "angular velocity", "element")
        offsets = self.model.line_element_offsets if on_elements else self.model.line_vertex_offsets
        l = int(np.searchsorted(offsets, idx, side="right") - 1)
        return f"line {self.net.lines[l].name!r} {'element' if on_elements else 'vertex'} {idx - offsets[l]}"

    # ------------------------------------------------------------------ access
    def effect_params(self, effect: Effect):
        """The parameter record ``effect`` was bound to in this simulation (the very arrays its
        kernel reads and writes, counters included)."""
        for e, p in zip(self.effects, self._params):
            if e is effect:
                return p
        raise ValueError(f"{effect.describe()} is not an effect of this simulation")

    def check_node(self, node: Node, who: str = "Simulation"):
        if not isinstance(node, Node) or node.index >= len(self.net.nodes) or self.net.nodes[node.index] is not node:
            raise ValueError(f"{who}: {node!r} is not a node of this simulation's net")

    def check_line(self, line: Line, who: str = "Simulation"):
        if not isinstance(line, Line) or line.index >= len(self.net.lines) or self.net.lines[line.index] is not line:
            raise ValueError(f"{who}: {line!r} is not a line of this simulation's net")

    def _vrange(self, line):
        self.check_line(line)
        o = self.model.line_vertex_offsets
        return slice(o[line.index], o[line.index + 1])

    def _erange(self, line):
        self.check_line(line)
        o = self.model.line_element_offsets
        return slice(o[line.index], o[line.index + 1])

    def line_positions(self, line: Line) -> np.ndarray:
        """(n+1, 3) vertex positions, first row at the start node; a writable view (the end
        rows follow the nodes and are overwritten by them)."""
        return self.state.x[self._vrange(line)]

    def line_velocities(self, line: Line) -> np.ndarray:
        """(n+1, 3) vertex velocities; a writable view (end rows follow the nodes)."""
        return self.state.v[self._vrange(line)]

    def line_directors(self, line: Line) -> np.ndarray:
        """(n, 3, 3) element director frames, columns d1 d2 d3 (principal axes) in the lab."""
        return matrix_from_quat(self.state.q[self._erange(line)])

    def line_angular_velocities(self, line: Line) -> np.ndarray:
        """(n, 3) element angular velocities in each element's body (director) frame; writable view."""
        return self.state.w[self._erange(line)]

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
    def energy_parts(self) -> dict:
        place_line_ends(self.model, self.state)
        kt, kr, u = measure.energies(self.model, self.state)
        pot = sum(e.potential_energy(self) for e in self.effects)
        return {"kinetic": kt + kr, "translational": kt, "rotational": kr, "strain": u, "potential": pot}

    def energy(self) -> float:
        """Total energy: kinetic (translational and rotational, lines and nodes), strain (3.25)
        and the potential of conservative effects (gravity)."""
        p = self.energy_parts()
        return p["kinetic"] + p["strain"] + p["potential"]

    def _drive(self, node: Node):
        self.check_node(node)
        for e in self.effects:
            if isinstance(e, Drive) and e.node is node:
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
        evaluate_loads(self.model, self.state, self.loads, self._load_params, self._backend)
        return drive.reaction(self, self.loads)

    def driver_work(self) -> float:
        """Work done on the net by every drive (the kicks' quadrature of the drivers' power
        R.v + T.w) and active curvature so far (J), so energy() - driver_work() is conserved to
        the scheme's order."""
        return sum(e.work(self) for e in self.effects if isinstance(e, (Drive, ActiveCurvature)))

    def momentum(self) -> np.ndarray:
        """(3,) total linear momentum of everything with finite mass."""
        place_line_ends(self.model, self.state)
        return measure.momenta(self.model, self.state)[0]

    def angular_momentum(self) -> np.ndarray:
        """(3,) total angular momentum about the origin."""
        place_line_ends(self.model, self.state)
        return measure.momenta(self.model, self.state)[1]

    def line_fields(self, line: Line) -> dict:
        """Per-vertex fields of a line, each (n+1, ...): position, velocity, d1, d2, d3, force
        n and torque m (lab), strain v - d3 and curvature u - u0 (director frame) (3.22)."""
        self.check_line(line)
        return self._fields(line.index, line.index + 1)

    def net_fields(self) -> dict:
        """The fields of line_fields for every vertex of the net, lines in order, each (nv, ...)."""
        return self._fields(0, len(self.net.lines))

    def _fields(self, l0: int, l1: int) -> dict:
        place_line_ends(self.model, self.state)
        f = measure.vertex_fields(self.model, self.state, l0, l1)
        d = matrix_from_quat(f.pop("frames"))
        o = self.model.line_vertex_offsets
        sl = slice(o[l0], o[l1])
        return {"position": self.state.x[sl].copy(), "velocity": self.state.v[sl].copy(),
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
