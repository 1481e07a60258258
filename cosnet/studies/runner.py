"""A scene run to its probe series: the frames and probes of ``cosnet run`` as arrays.

``run_probes`` steps a scene exactly as ``cosnet run`` does (frame k at t_k = k * interval,
reached by cosnet.output.record's ``advance_to``, each frame passed by the watch before it is
recorded), so its series equal the run's probes.csv bit for bit; it writes nothing.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba.core import event

from ..output.record import Schedule, advance_to


@dataclass
class ProbeSeries:
    """One run's record: ``times`` (frames,) at which the frames were taken (NaN after a
    failure), ``probes`` name -> (frames, 3) values (positions, or the probe's field), ``status`` "ok" or the failure's
    one-line message, ``steps`` taken, ``dt``, ``wall`` seconds and ``compiled`` (how many
    kernels had to be compiled, not loaded from the on-disk cache, during the run)."""

    times: np.ndarray
    probes: dict
    status: str = "ok"
    steps: int = 0
    dt: float = math.nan
    wall: float = 0.0
    compiled: int = 0
    extra: dict = field(default_factory=dict)


def schedule(scene, until: float | None = None) -> Schedule:
    """The output frames of a scene's run to ``until`` (default: the scene's), as ``cosnet run``
    chooses them; a non-positive ``until`` is a ValueError."""
    until = scene.run.until if until is None else float(until)
    if not until > 0:
        raise ValueError(f"--until must be positive, got {until}")
    return Schedule.over(0.0, until, scene.run.interval)


def run_probes(scene, until: float | None = None, threads: int | None = None,
               vtk=None) -> ProbeSeries:
    """Update a ProbeSeries given a Scene run to ``until`` (default: the scene's). A failure
    (instability, a refused dt, ...) ends the record early with its message as the status;
    frames not reached stay NaN. With ``vtk`` (a directory), each frame is also written there
    as a VTK series (cosnet.output.io.SeriesWriter: series.pvd, frames, meta.json)."""
    from ..output.io import SeriesWriter, drawn_shapes
    plan = schedule(scene, until)
    frames = plan.frames
    probes = scene.run.probes
    times = np.full(frames + 1, np.nan)
    series = {p.name: np.full((frames + 1, 3), np.nan) for p in probes}
    out = ProbeSeries(times, series)
    counter = CompileCounter()
    event.register("numba:compile", counter)
    t0 = time.perf_counter()
    try:
        sim = scene.simulation() if threads is None else scene.simulation(threads=threads)
        out.dt = plan.fit_step(sim)
        writer = None if vtk is None else SeriesWriter(vtk, scene.net, shapes=drawn_shapes(sim))
        for k in range(frames + 1):
            if k:
                advance_to(sim, plan.time(k))
            sim.check()
            if writer is not None:
                writer.write(sim)
            times[k] = sim.time
            for p in probes:
                series[p.name][k] = p.value(sim)
            out.steps = sim.steps
    except (ValueError, RuntimeError, FloatingPointError) as e:
        out.status = " ".join(str(e).split()) or type(e).__name__
    finally:
        event.unregister("numba:compile", counter)
        out.wall = time.perf_counter() - t0
        out.compiled = counter.count
    return out


class CompileCounter(event.Listener):
    """Counts outermost compilations: numba fires "numba:compile" only on a cache miss, and
    the functions a kernel calls compile inside it (counted once, with their caller)."""

    def __init__(self):
        self.count = 0
        self.depth = 0

    def on_start(self, ev):
        self.depth += 1
        self.count += self.depth == 1

    def on_end(self, ev):
        self.depth -= 1
