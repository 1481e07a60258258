"""The output of a run, written while it runs: a VTK series (cosnet.output.io), probes.csv,
energy.csv and a checkpoint, every output interval. ``cosnet run`` and ``Simulation.run(out=...)`` both write
through ``Recorder``, so their files are the same.

Frame k sits at t_k = min(t_0 + k * interval, until), t_0 the time of frame 0 (0 for a
scene). The run's step is the scene's dt shortened to interval / n, n the fewest whole steps
that fit in an interval (``Schedule.fit_step``), so every step of a run has one length and the frames
land on t_k to the round-off of the clock's sum; only a last interval shorter than the others
(until not a multiple of it) ends with one shortened step. (A shortened step before every
frame would change the step length periodically, and position Verlet near its stability limit
is then parametrically unstable: its invariant energy depends on the step, and switching
between two of them pumps the highest modes, as a chain of rigid links showed within a second.)
Each interval is stepped in chunks of CHUNK_STEPS counted from its start, so a run resumed from the
checkpoint of frame k (``resume=True``) reproduces an uninterrupted one bit for bit.

Probes (``[run] probes``, ``probes=[...]``) are "NODE", "LINE@s" (the vertex nearest the arc
fraction s; "LINE" is its midpoint; "LINE@start", "LINE@end" its ends) and either followed by
":FIELD" to record a field other than the position; probes.csv holds one row per frame:
frame, time, then the columns PROBE_x, PROBE_y, PROBE_z of each probe (PROBE as written, e.g.
``rod@0.5:force_x``). A jointed end also has the fields joint_angle and joint_rate (its
coordinates in the columns _x, _y, _z; zero past the joint's own) and joint_reaction (the
torque the line exerts on the node through the joint, lab).

energy.csv holds the energy budget at every frame (J): frame, time, then kinetic, strain,
potential (energy() is their sum), dissipated, driver, actuation, loads and supplied (the
accounts of sim.dissipated(), driver_work(), actuation_work(), load_work() and supplied()).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core import checks
from ..engine.registry import end_probe_owners
from ..engine.registry import ACCOUNTS
from .io import (ENERGY, ENERGY_COLUMNS, LINE_FIELDS, NODE_FIELDS, PROBES, PVD, SeriesWriter, drawn_shapes,
                 node_point_fields, read_pvd, replace_atomically)
from ..kernels.compiler import in_cache
from ..kernels.stepping import CHUNK_STEPS, steps_to

CHECKPOINT = "checkpoint.npz"
PROBE_LINE_FIELDS = ("position",) + LINE_FIELDS
PROBE_NODE_FIELDS = ("position",) + NODE_FIELDS


@dataclass
class Probe:
    """A point recorded at every output frame: a node's reference point or the vertex of a
    line nearest to the arc-length fraction s ("LINE@s"; plain "LINE" is its midpoint), and
    the field recorded there (a 3-vector: see PROBE_NODE_FIELDS, PROBE_LINE_FIELDS)."""

    name: str
    node: object = None
    line: object = None
    vertex: int = 0
    field: str = "position"
    end: str = ""       # "start" or "end" for a probe of a line's end ("LINE@start")
    owner: Any = None   # the effect class whose end_probe gives the field (a joint's angle, ...)

    def position(self, sim) -> np.ndarray:
        if self.node is not None:
            return sim.node_position(self.node)
        return sim.line_positions(self.line)[self.vertex].copy()

    def value(self, sim) -> np.ndarray:
        """(3,) the probe's field now (SI, lab frame; strain and curvature in the director frame)."""
        if self.field == "position":
            return self.position(sim)
        if self.node is not None:
            return node_point_fields(sim, self.node)[self.field]
        if self.owner is not None:
            return np.asarray(self.owner.end_probe(sim, self.line, self.end, self.field), dtype=float)
        return np.asarray(sim.line_fields(self.line)[self.field][self.vertex], dtype=float)

    def columns(self) -> list[str]:
        return [f"{self.name}_{a}" for a in "xyz"]


def parse_probe(text: str, net) -> Probe:
    """The Probe named by ``text`` ("NODE", "LINE", "LINE@s", each optionally ":FIELD");
    ValueError with one line saying what is wrong."""
    if not isinstance(text, str):
        raise ValueError(f"a probe must be a string such as 'tip' or 'rod@0.5:velocity', got {text!r}")
    point, colon, field = text.partition(":")
    nodes = {n.name for n in net.nodes}
    owners: dict = {}   # the fields effects offer at a line end, and which effect
    if point in nodes:
        probe = Probe(text, node=net.node(point))
        valid: tuple[str, ...] = PROBE_NODE_FIELDS
    else:
        lname, _, frac = point.partition("@")
        try:
            line = net.line(lname)
        except KeyError:
            raise ValueError(f"{text!r} names no node or line (use NODE, LINE or LINE@s, "
                             f"then optionally :FIELD)") from None
        try:
            s = {"start": 0.0, "end": 1.0}[frac] if frac in ("start", "end") else float(frac) if frac else 0.5
        except ValueError:
            s = -1.0
        if not 0.0 <= s <= 1.0:
            raise ValueError(f"{text!r}: after @ comes a number in [0, 1], start or end")
        probe = Probe(text, line=line, vertex=int(round(s * line.elements)))
        valid = PROBE_LINE_FIELDS
        if frac in ("start", "end"):
            probe.end = frac
            owners = end_probe_owners(line, frac)
            valid += tuple(owners)
    if colon:
        if field not in valid:
            kind = "node" if probe.node is not None else "line point"
            raise ValueError(f"{text!r}: unknown field {field!r}; a {kind} has {', '.join(valid)}")
        probe.field = field
        if probe.end and field in owners:
            probe.owner = owners[field]
    return probe


def probe_header(probes) -> str:
    return ",".join(["frame", "time"] + [c for p in probes for c in p.columns()]) + "\n"


def probe_row(k, sim, probes) -> str:
    vals = [repr(float(x)) for p in probes for x in p.value(sim)]
    return ",".join([str(k), repr(sim.time)] + vals) + "\n"


def energy_header() -> str:
    return ",".join(("frame", "time", *ENERGY_COLUMNS)) + "\n"


def energy_values(sim) -> tuple:
    """The energy budget of sim now, in ENERGY_COLUMNS' order (J)."""
    parts = sim.energy_parts()
    return (parts["kinetic"], parts["strain"], parts["potential"],
            *(getattr(sim, read)() for read, _ in ACCOUNTS.values()))


def energy_row(k, t, values) -> str:
    return ",".join([str(k), repr(t)] + [repr(float(v)) for v in values]) + "\n"


def keep_probe_rows(path: Path, header: str, last_frame: int):
    """Keep the whole rows of frames up to last_frame (a row torn by a kill or a full disk
    is dropped)."""
    rows, width = [header], header.count(",")
    if path.exists():
        for line in path.read_text(errors="replace").splitlines(keepends=True)[1:]:
            first = line.split(",", 1)[0]
            if (line.endswith("\n") and line.count(",") == width and first.isdigit()
                    and int(first) <= last_frame):
                rows.append(line)
    replace_atomically(path, lambda tmp: tmp.write_text("".join(rows)))


@dataclass(frozen=True)
class Schedule:
    """The output frames of a run, the one schedule of ``cosnet run``, ``Simulation.run(out=...)``,
    a sweep's variants and their stores: frame k at t_k = min(start + k * interval, until) for
    k = 0 .. frames, the interval at most until - start, so the last frame lands on until."""

    start: float
    until: float
    interval: float

    @classmethod
    def over(cls, start: float, until: float, every: float) -> Schedule:
        """Frames every ``every`` seconds from ``start`` to ``until`` (both checked by the caller)."""
        return cls(float(start), float(until), min(float(every), float(until) - float(start)))

    @property
    def frames(self) -> int:
        """The number of frames after frame 0."""
        return steps_to(self.until - self.start, self.interval)

    def time(self, k: int) -> float:
        """The time of frame k."""
        return min(self.start + k * self.interval, self.until)

    def times(self) -> np.ndarray:
        """(frames + 1,) the times of every frame."""
        return np.array([self.time(k) for k in range(self.frames + 1)])

    def frame_at(self, t: float, tol: float):
        """The frame whose time is t to within ``tol``, or None."""
        return next((k for k in range(self.frames + 1) if abs(self.time(k) - t) <= tol), None)

    def fit_step(self, sim) -> float:
        """Update sim.dt to interval / n, n the fewest whole steps of at most sim.dt in an
        interval (the frames then need no shortened steps); return it."""
        n = max(1, steps_to(self.interval, sim.dt))
        sim.dt = self.interval / n
        return sim.dt


def advance_to(sim, t: float, progress=None):
    """Step ``sim`` to time ``t``: whole steps of dt in chunks of CHUNK_STEPS, then one shortened
    step that lands on t (none if the whole steps already end within 1e-9 dt of it)."""
    whole = steps_to(t - sim.time, sim.dt) - 1
    while whole > 0:
        n = min(whole, CHUNK_STEPS)
        sim.run(steps=n)
        whole -= n
        if progress is not None:
            progress(sim)
    last = t - sim.time
    if last > 1e-9 * sim.dt:
        dt = sim.dt
        sim.dt = last
        try:
            sim.run(steps=1)
        finally:
            sim.dt = dt


def kernels_compiled(sim) -> bool:
    """Whether the compiled code of this simulation's step is at hand (in memory, or in
    numba's cache on disk) or will be compiled at the first step: the stepper, every kernel it
    calls through its slots and the pins of the effects' records (the stepper, one for every
    combination of effects, is cached after any scene's first run); True when unknown."""
    from ..kernels.compose import step_calls
    from ..kernels.slots import pin_record
    try:
        model, state, loads, _, _, _, backend = signature = sim.step_signature()
        if sim.advance_kernel.signatures and sim._slots_process == os.getpid():
            return True
        needed = [(sim.advance_kernel, signature)] + step_calls(sim.step_groups, model, state, loads, backend)
        needed += [(pin_record, sig) for sig in sim._pins.signatures()]
        return all(sig in kernel.overloads or in_cache(kernel, sig) for kernel, sig in needed)
    except Exception:   # another numba: no way to tell, say nothing
        return True


class Progress:
    """One status line on ``stream``: simulated time, steps per second and the time left,
    from the steps run since the first chunk (which may include compilation)."""

    def __init__(self, until: float, dt: float, stream=sys.stderr):
        self.until, self.dt, self.stream = until, dt, stream
        self.t0 = None
        self.steps0 = None
        self.last = 0.0

    def __call__(self, sim, force=False):
        now = time.perf_counter()
        if self.steps0 is None:          # after the first chunk: start counting from here
            self.steps0, self.t0 = sim.steps, now
            return
        if not force and now - self.last < 0.5:
            return
        self.last = now
        ran, took = sim.steps - self.steps0, now - self.t0
        if ran <= 0 or took <= 0:
            return
        rate = ran / took
        left = max(self.until - sim.time, 0.0) / self.dt / rate
        self.stream.write(f"\r  t = {sim.time:.5g} / {self.until:.5g} s  {rate:,.0f} steps/s  "
                          f"ETA {left:.0f} s   ")
        self.stream.flush()


class Recorder:
    """Writes a run into directory ``out``: frames (series.pvd, lines_*.vtu, nodes_*.vtu,
    meta.json), probes.csv and checkpoint.npz at t_k = t_0 + k * every up to ``until``, and
    calls ``callback(sim)`` after each frame is written.

    probes: Probe objects or strings ("tip", "rod@0.5:velocity"; see parse_probe).
    resume: continue the run in ``out`` from its checkpoint (same net, stepper and until);
    otherwise the current state of ``sim`` is frame 0 and ``out`` is written afresh.
    """

    def __init__(self, out, sim, until: float, every: float, probes=(), callback=None,
                 resume: bool = False):
        if not checks.is_positive(until):
            raise ValueError(f"until must be a positive time in s, got {until!r}")
        if not checks.is_positive(every):
            raise ValueError(f"every must be a positive time in s, got {every!r}")
        if callback is not None and not callable(callback):
            raise ValueError(f"callback must be callable as callback(sim), got {callback!r}")
        self.out, self.sim, self.until = Path(out), sim, float(until)
        self.probes = [p if isinstance(p, Probe) else parse_probe(p, sim.net) for p in probes]
        self.callback = callback
        self.header = probe_header(self.probes)
        ckpt = self.out / CHECKPOINT
        if resume:
            if not ckpt.exists():
                raise ValueError(f"{self.out}: nothing to resume (no {CHECKPOINT})")
            if not (self.out / PVD).is_file():
                raise ValueError(f"{self.out / PVD}: missing, so there is no series to resume")
            self.start = read_pvd(self.out / PVD)[0][0]
        else:
            self.start = sim.time
        if not self.until > self.start:
            raise ValueError(f"until = {self.until!r} s must be later than the start, t = {self.start!r} s")
        self.schedule = Schedule.over(self.start, self.until, every)
        self.schedule.fit_step(sim)   # before the checkpoint, whose model fingerprint holds dt
        if resume:
            sim.load_checkpoint(ckpt)
        self.frames = self.schedule.frames
        if resume:
            self.k = self.frame_at(sim.time)
            if self.k is None:
                raise ValueError(f"{ckpt}: its time {sim.time!r} s is not an output frame of this run "
                                 f"(same scene and until needed to resume)")
            self.writer = SeriesWriter(self.out, sim.net, resume_after=self.k, shapes=drawn_shapes(sim))
            keep_probe_rows(self.out / PROBES, self.header, self.k)
            keep_probe_rows(self.out / ENERGY, energy_header(), self.k)
        else:
            self.writer = SeriesWriter(self.out, sim.net, shapes=drawn_shapes(sim))
            (self.out / PROBES).write_text(self.header)
            (self.out / ENERGY).write_text(energy_header())
            self.k = -1
            self.write()

    def frame_at(self, t: float):
        """The frame whose time is t (to within 1e-6 dt), or None."""
        return self.schedule.frame_at(t, 1e-6 * self.sim.dt)

    @property
    def done(self) -> bool:
        return self.k >= self.frames

    def steps_left(self) -> int:
        """Steps still to run (whole steps and the shortened ones)."""
        whole = max(0, steps_to(self.until - self.sim.time, self.sim.dt))
        return whole + (self.frames - self.k)

    def write(self):
        """Write the current state as the next frame, its probes row and the checkpoint."""
        sim = self.sim
        # the energies first: at a cold start their kernels compile here while the process
        # compiling alongside takes the step's kernels; the frame's reactions (a drive's) need
        # the whole step, and energies compiled after it kept this process busy alone at the end
        energy = energy_values(sim)
        self.k = self.writer.write(sim)
        with open(self.out / PROBES, "a") as f:
            f.write(probe_row(self.k, sim, self.probes))
        with open(self.out / ENERGY, "a") as f:
            f.write(energy_row(self.k, sim.time, energy))
        sim.save_checkpoint(self.out / CHECKPOINT)
        if self.callback is not None:
            self.callback(sim)

    def run(self, progress=None):
        """Run to ``until``, writing every frame."""
        while self.k < self.frames:
            advance_to(self.sim, self.schedule.time(self.k + 1), progress)
            self.write()
        return self.sim


def run_with_output(sim, until, out=None, every=None, probes=(), callback=None, overwrite=False):
    """Simulation.run(until, out=..., every=..., probes=..., callback=...): advance to
    ``until`` with a frame every ``every`` seconds (default: a 50th of the run), written into
    ``out`` (a Recorder, holding the directory's lock as ``cosnet run`` does; a directory
    that holds a run already is refused unless ``overwrite``) and/or passed to
    ``callback(sim)``."""
    if until is None:
        raise ValueError("Simulation.run: out, every, probes and callback need until")
    until = float(until)
    every = (until - sim.time) / 50.0 if every is None else every
    if out is not None:
        from . import outdir
        out = Path(out)
        with outdir.locked(out):
            outdir.prepare(out, resume=False, overwrite=overwrite)
            return Recorder(out, sim, until, every, probes, callback).run()
    if probes:
        raise ValueError("Simulation.run: probes are written to probes.csv in out; give out as well")
    if callback is not None and not callable(callback):
        raise ValueError(f"callback must be callable as callback(sim), got {callback!r}")
    if not checks.is_positive(every):
        raise ValueError(f"every must be a positive time in s, got {every!r}")
    start = sim.time
    if not until > start:
        raise ValueError(f"until = {until!r} s must be later than the start, t = {start!r} s")
    schedule = Schedule.over(start, until, every)
    schedule.fit_step(sim)
    for k in range(schedule.frames + 1):
        advance_to(sim, schedule.time(k))
        if callback is not None:
            callback(sim)
    return sim
