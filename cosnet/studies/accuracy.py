"""How accurate is a scene's run, and what does accuracy cost? (``cosnet accuracy SCENE``)

The scene is run over a short window from its initial state at successive refinements:

* time: the base element counts, dt, dt/2, dt/4, for both steppers ("verlet", order 2;
  "pefrl", order 4). dt starts at the scene's step (or the estimated stable step), shortened
  so the window is a whole number of steps;
* space: every line's element count x1, x2, x4 (the net rebuilt from the scene file with
  scaled ``elements``), all with PEFRL at one small dt, so their time error is negligible.

For each series of three runs u1, u2, u4 of a probe vector u (default: the positions of all
nodes at the end of the window) Richardson extrapolation gives the observed order
``p = log2(|u1 - u2| / |u2 - u4|)``, the extrapolated value
``u* = u4 + (u4 - u2) / (2^p - 1)`` and every run's error estimate ``|u - u*|`` (Euclidean
norm over all probe coordinates). An observed order outside [0.5, 8] (a series in round-off,
or not yet asymptotic: high modes excited by a sharp start keep Verlet's phase errors large
at the stable step) is flagged; the series then gets no credit for convergence: each run's
error is its distance from the finest run, and the finest run's error its distance from the
one before it. The nominal order (2, 4; 2 in space) is then used for extrapolating to
settings that were not run.

Fast modes (docs/fast_modes.md): every ``fast_modes`` setting is run on the base mesh with
Verlet at its own stable step. Its error is its distance from the full scheme ("resolve",
the limit of a Verlet time series on the base mesh: the scene's own series when the scene
resolves its fast modes, else one series run for the purpose) plus the base mesh's space
error. When the scene itself treats its fast modes, the distance between its own limit and
the full scheme's is added to the errors of its own settings, so that every setting is
measured against the same answer.

The errors of a setting (element factor f, stepper, dt) are then estimated as the sum of its
space error (from the space series) and its time error ``C dt^p`` (fitted on the time
series of that stepper on the base mesh; the time error at a fixed dt is taken to depend
little on the mesh, since the probes move with the slow modes). The cost of a setting is
the wall time per simulated second, measured for every run and scaled by
elements x steps for the settings not run. The recommendation is the cheapest setting
whose estimated error is below the tolerance.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..kernels.stepping import steps_to
from ..core.fast_modes import FAST_MODES
from ..output.record import parse_probe
from ..scene.loader import Probe, Scene, build_scene, load_scene, read_toml

STEPPERS = ("verlet", "pefrl")
NOMINAL_ORDER = {"verlet": 2.0, "pefrl": 4.0, "space": 2.0}
FACTORS = (1, 2, 4)


# ---------------------------------------------------------------------- scenes and probes
def scaled_scene(path, factor: int) -> Scene:
    """The scene of ``path`` with every line's element count multiplied by ``factor``
    (polylines given by ``points`` are resampled by Net.add_line)."""
    path = Path(path)
    if isinstance(factor, bool) or not isinstance(factor, int) or factor < 1:
        raise ValueError(f"scaled_scene: factor must be a positive integer, got {factor!r}")
    data = read_toml(path)
    lines = data.get("lines")
    if factor != 1 and isinstance(lines, dict):
        for table in lines.values():
            n = table.get("elements") if isinstance(table, dict) else None
            if isinstance(n, int) and not isinstance(n, bool) and n >= 1:
                table["elements"] = n * factor
    return build_scene(data, path)


def resolve_probes(scene: Scene, names) -> list[Probe]:
    """Probes named NODE, LINE or LINE@s (s in [0, 1]; the nearest vertex, which is the same
    material point at every element factor when s * elements is an integer), whose positions
    are compared; default: every node."""
    net = scene.net
    if not names:
        return [Probe(n.name, node=n) for n in net.nodes]
    out = []
    for text in names:
        try:
            probe = parse_probe(text, net)
        except ValueError as e:
            raise ValueError(f"--probe {e}; nodes are {sorted(n.name for n in net.nodes)}, "
                             f"lines {[l.name for l in net.lines]}") from None
        if probe.field != "position":
            raise ValueError(f"--probe {text!r}: the accuracy study compares positions; give the "
                             f"point without :{probe.field}")
        out.append(probe)
    return out


def probe_vector(sim, probes) -> np.ndarray:
    return np.concatenate([np.asarray(p.position(sim), dtype=float) for p in probes])


# ---------------------------------------------------------------------- runs
@dataclass
class Run:
    factor: int
    stepper: str
    dt: float
    steps: int
    elements: int
    wall: float                 # s of wall time for the window
    value: np.ndarray = field(repr=False)
    error: float = math.nan     # estimated error (filled by richardson)

    @property
    def cost(self) -> float:
        """Wall time per simulated second."""
        return self.wall / (self.steps * self.dt)


def run_window(scene: Scene, probes, stepper: str, steps: int, window: float,
               fast_modes: str | None = None) -> Run:
    """Run ``scene`` from its initial state over ``window`` in exactly ``steps`` steps (with
    another fast_modes setting if given)."""
    dt = window / steps
    extra = {} if fast_modes is None else {"fast_modes": fast_modes}
    sim = scene.simulation(stepper=stepper, dt=dt, force_dt=True, **extra)
    t0 = time.perf_counter()
    sim.run(steps=steps)
    wall = time.perf_counter() - t0
    return Run(0, stepper, dt, steps, scene.net.element_count, wall, probe_vector(sim, probes))


def warm_up(scene: Scene):
    """Compile both steppers for this scene's effects (so timings exclude compilation)."""
    for s in STEPPERS:
        scene.simulation(stepper=s).run(steps=1)


@dataclass
class Series:
    kind: str                   # "verlet", "pefrl" or "space"
    runs: list
    order: float
    nominal: bool               # True: the observed order was unusable, nominal order used
    observed: float             # raw observed order (may be nan)
    limit: np.ndarray = field(repr=False)


def richardson(kind: str, runs: list) -> Series:
    """Observed order, extrapolated value and per-run error estimates of three runs, each
    refined by 2 from the previous one."""
    u1, u2, u4 = (r.value for r in runs)
    d1, d2 = float(np.linalg.norm(u1 - u2)), float(np.linalg.norm(u2 - u4))
    scale = max(float(np.linalg.norm(u4)), 1e-300)
    p = math.log2(d1 / d2) if d1 > 0 and d2 > 0 else math.nan
    nominal = not (math.isfinite(p) and 0.5 <= p <= 8.0) or d2 < 1e-13 * scale
    q = NOMINAL_ORDER[kind] if nominal else p
    if nominal:
        # not asymptotic (or in round-off): no credit for convergence, the finest run is
        # taken to be as far from the answer as from the run before it
        limit = u4
        for r in runs:
            r.error = float(np.linalg.norm(r.value - u4))
        runs[-1].error = d2
    else:
        limit = u4 + (u4 - u2) / (2.0**q - 1.0)
        for r in runs:
            r.error = float(np.linalg.norm(r.value - limit))
    return Series(kind, runs, q, nominal, p, limit)


# ---------------------------------------------------------------------- the study
@dataclass
class Setting:
    factor: int
    stepper: str
    dt: float
    elements: int
    error: float
    cost: float
    measured: bool
    fast_modes: str = "resolve"


@dataclass
class Study:
    scene: Scene
    window: float
    probes: list
    series: dict                # kind -> Series
    settings: list
    tol: float | None = None

    def recommend(self, tol: float) -> Setting | None:
        ok = [s for s in self.settings if s.error <= tol]
        return min(ok, key=lambda s: s.cost) if ok else None


def _steps_for(window: float, dt: float) -> int:
    return max(1, steps_to(window, dt))


def time_series(scene: Scene, stepper: str, window: float, probes=None, log=None,
                dt: float | None = None, fast_modes: str | None = None) -> Series:
    """Runs at dt, dt/2, dt/4 (dt: the scene's step, shortened to divide the window) and
    their Richardson estimates (with another fast_modes setting if given)."""
    say = log or (lambda msg: None)
    extra = {} if fast_modes is None else {"fast_modes": fast_modes}
    dt0 = scene.simulation(stepper=stepper, **extra).dt if dt is None else dt
    n0 = _steps_for(window, dt0)
    pr = resolve_probes(scene, probes)
    runs = []
    for k in range(3):
        say(f"  {stepper:6s} dt = {window / (n0 * 2**k):.4g} s" + (f", fast_modes {fast_modes}" if extra else ""))
        runs.append(run_window(scene, pr, stepper, n0 * 2**k, window, fast_modes))
    return richardson(stepper, runs)


def fast_mode_settings(scene: Scene, window: float, probes, full: Series, space_error: float,
                       log=None) -> list[Setting]:
    """One Setting per fast_modes setting but the scene's own: the base mesh, Verlet at that
    setting's stable step, its error measured against ``full`` (the limit of a Verlet series
    with "resolve") plus ``space_error``."""
    say = log or (lambda msg: None)
    pr = resolve_probes(scene, probes)
    # a series without credible extrapolation: its finest run may be off by its own error
    slack = full.runs[-1].error if full.nominal else 0.0
    out = []
    for fm in FAST_MODES:
        if fm == scene.run.fast_modes:
            continue            # the scene's own setting is in the time series already
        dt = scene.simulation(stepper="verlet", fast_modes=fm).dt
        steps = _steps_for(window, dt)
        say(f"  verlet dt = {window / steps:.4g} s, fast_modes {fm}")
        r = run_window(scene, pr, "verlet", steps, window, fm)
        err = float(np.linalg.norm(r.value - full.limit)) + slack
        out.append(Setting(1, "verlet", r.dt, r.elements, space_error + err, r.cost, True, fm))
    return out


def study(path, window: float | None = None, probes=None, factors=FACTORS, log=None) -> Study:
    """Run the refinement series of the scene at ``path`` and estimate the error and cost of
    settings (element factor in ``factors``, stepper, dt / 2^k)."""
    base = load_scene(path)
    if window is None:
        window = 0.05 * base.run.until
    window = float(window)
    if not (math.isfinite(window) and window > 0):
        raise ValueError(f"window must be a positive number of seconds, got {window}")
    if len(factors) != 3 or list(factors) != [factors[0], 2 * factors[0], 4 * factors[0]]:
        raise ValueError(f"element factors must be f, 2f, 4f, got {factors}")
    say = log or (lambda msg: None)
    scenes = {f: (base if f == 1 else scaled_scene(path, f)) for f in factors}
    warm_up(base)
    series = {}
    # time series on the base mesh, for each stepper
    for stepper in STEPPERS:
        series[stepper] = time_series(scenes[factors[0]], stepper, window, probes, say)
        for r in series[stepper].runs:
            r.factor = factors[0]
    # space series at one small PEFRL step: a quarter of the finest mesh's stable step
    fine = scenes[factors[-1]]
    n_s = 4 * _steps_for(window, fine.simulation(stepper="pefrl").dt)
    runs = []
    for f in factors:
        say(f"  pefrl  x{f} elements, dt = {window / n_s:.4g} s")
        r = run_window(scenes[f], resolve_probes(scenes[f], probes), "pefrl", n_s, window)
        r.factor = f
        runs.append(r)
    series["space"] = richardson("space", runs)
    settings = _settings(scenes, factors, series, window)
    full = series["verlet"]
    if base.run.fast_modes != "resolve":
        full = time_series(base, "verlet", window, probes, say, fast_modes="resolve")
        # the scene's own treatment moves its answer away from the full scheme's
        model = float(np.linalg.norm(series["verlet"].limit - full.limit))
        for s in settings:
            s.error += model
    settings += fast_mode_settings(base, window, probes, full, series["space"].runs[0].error, say)
    settings.sort(key=lambda s: s.cost)
    return Study(base, window, resolve_probes(base, probes), series, settings)


def _settings(scenes, factors, series, window) -> list[Setting]:
    space = {r.factor: r.error for r in series["space"].runs}
    measured = {(r.factor, r.stepper, r.steps): r for s in series.values() for r in s.runs}
    out = []
    for stepper in STEPPERS:
        ts = series[stepper]
        # time error C dt^p, C from the two finer runs of the series
        logc = np.mean([math.log(max(r.error, 1e-300)) - ts.order * math.log(r.dt)
                        for r in ts.runs[1:]])
        # cost per element-step for this stepper (median over its runs)
        per = float(np.median([r.wall / (r.steps * r.elements) for s in series.values()
                               for r in s.runs if r.stepper == stepper]))
        for f in factors:
            sc = scenes[f]
            n0 = _steps_for(window, sc.simulation(stepper=stepper).dt)
            for k in range(3):
                steps = n0 * 2**k
                dt = window / steps
                r = measured.get((f, stepper, steps))
                if f == factors[0] and ts.runs[k].steps == steps:
                    e_time = ts.runs[k].error            # this run's own estimate
                else:
                    e_time = math.exp(logc + ts.order * math.log(dt))
                err = space[f] + e_time
                cost = r.cost if r is not None else per * sc.net.element_count / dt
                out.append(Setting(f, stepper, dt, sc.net.element_count, err, cost, r is not None,
                                   sc.run.fast_modes))
    out.sort(key=lambda s: s.cost)
    return out


# ---------------------------------------------------------------------- report
def _fmt(x: float) -> str:
    return f"{x:.3g}"


def report(st: Study, tol: float | None) -> tuple[str, Setting | None]:
    """The text printed by ``cosnet accuracy``: the series, the settings table and the
    recommendation."""
    lines = [f"{st.scene.title}: accuracy over a window of {st.window:g} s from t = 0, probes: "
             f"{', '.join(p.name for p in st.probes)} (error = Euclidean norm over all probe "
             f"coordinates, m)"]
    lines.append("")
    lines.append("refinement series (Richardson extrapolation)")
    for kind, s in st.series.items():
        what = "dt halved, x1 elements" if kind != "space" else "elements doubled, PEFRL, small dt"
        flag = ""
        if s.nominal:
            why = "at round-off" if s.runs[-1].error < 1e-12 * max(
                float(np.linalg.norm(s.limit)), 1e-300) * 10 else "not asymptotic"
            flag = f" (observed {s.observed:.2f}: {why}, errors not extrapolated)"
        errs = ", ".join(_fmt(r.error) for r in s.runs)
        lines.append(f"  {kind:6s} {what:34s} order {s.order:.2f}{flag}; errors {errs}")
    lines.append("")
    head = ["elements", "stepper", "fast modes", "dt [s]", "est. error [m]", "wall s / sim s", ""]
    rows = []
    for s in st.settings:
        rows.append([f"x{s.factor} ({s.elements})", s.stepper, s.fast_modes, f"{s.dt:.4g}", _fmt(s.error),
                     _fmt(s.cost), "run" if s.measured else "estimated"])
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
    fmt = lambda r: "  ".join(c.rjust(w) for c, w in zip(r, widths)).rstrip()
    lines.append(fmt(head))
    lines.append("  ".join("-" * w for w in widths))
    lines.extend(fmt(r) for r in rows)
    best = None
    if tol is not None:
        best = st.recommend(tol)
        lines.append("")
        if best is None:
            top = min(st.settings, key=lambda s: s.error)
            lines.append(f"no setting reaches tol = {tol:g} m; the most accurate is x{top.factor} "
                         f"elements, {top.stepper}, fast_modes {top.fast_modes}, dt = {top.dt:.4g} s (est. error "
                         f"{_fmt(top.error)} m): refine further or relax --tol")
        else:
            lines.append(f"recommended for tol = {tol:g} m: x{best.factor} elements "
                         f"({best.elements}), stepper {best.stepper}, fast_modes {best.fast_modes}, "
                         f"dt = {best.dt:.4g} s "
                         f"(est. error {_fmt(best.error)} m, {_fmt(best.cost)} s of wall time "
                         f"per simulated second)")
    return "\n".join(lines), best


def check_tol(tol) -> float:
    try:
        t = float(tol)
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a positive number (an error in m), got {tol!r}") from None
    if not (math.isfinite(t) and t > 0):
        raise ValueError(f"tol must be a positive number (an error in m), got {tol!r}")
    return t


def summary(sim) -> str:
    """One line: the setting in force, per-treatment line counts and the factors' range."""
    counts: dict[str, int] = {}
    for f in sim.line_factors:
        counts[f.treatment] = counts.get(f.treatment, 0) + 1
    parts = [f"{n} {t}" for t, n in counts.items()]
    rot = max((f.rotary for f in sim.line_factors), default=1.0)
    soft = min((min(f.axial, f.shear) for f in sim.line_factors), default=1.0)
    extra = f"; rotary inertia x{rot:.3g}" if rot != 1.0 else ""
    extra += f"; stretch/shear stiffness down to x{soft:.3g}" if soft < 1.0 else ""
    return f"{sim.fast_modes} (lines: {', '.join(parts) or 'none'}{extra})"


def dt_with(sim, setting: str) -> float:
    """The stable step sim's net would have with another fast_modes setting (lines' own
    settings still win)."""
    if sim.fast_modes == setting:
        return sim.stable_dt()
    from ..engine.simulation import Simulation
    other = Simulation(sim.net, effects=sim.effects, stepper=sim.stepper, safety=sim.safety,
                       threads=sim.threads, fast_modes=setting)
    return other.stable_dt()
