"""The ``cosnet`` command.

    cosnet run [SCENE] [--out DIR] [--until T] [--resume|--overwrite] [--no-limits]
                                                             run a scene, writing a VTK series
    cosnet info SCENE                                        net size, mass, stable dt, effects
    cosnet modes SCENE [--count K] [--out DIR] [--analytic]  normal modes: spectrum, VTK shapes
    cosnet render DIR [--png|--gif|--mp4|--html] [--field NAME] [--clim LO HI] [--view V] [--warp F]
                                                             pictures of a run or of modes
    cosnet view DIR [--port P] [--no-browser]                the run's page (--html) on localhost
    cosnet plot DIR [PROBE ...] [--energy] [--output FILE]   probes and energy budget over time
    cosnet accuracy SCENE [--tol E] [--window T] [--probe P]  error and cost of refinements
    cosnet sweep SCENE [--vary KEY=VALUES] [--vtk] [--resume|--overwrite]
                                                             variants as Dask tasks, one Zarr store
    cosnet sweep --check STORE                               every file of a store against its manifest

``run`` writes a frame, a probes row, an energy row and a checkpoint at every multiple of the output
interval (cosnet.output.record, which ``Simulation.run(out=...)`` uses too), each only after the
state has passed every test of the instability watch (so on instability the checkpoint holds
the last state that passed); ``--resume`` (continue
from the last checkpoint in DIR) reproduces an uninterrupted run bit for bit.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
from pathlib import Path

from .core.units import one_line
from .scene.cases import cases_dir, default_scene, scene_path
from .studies.sweep_store import package_version


def _threads_option(text) -> dict:
    """The Simulation keyword of --threads (none when not given: the scene's, else automatic)."""
    if text is None:
        return {}
    from .engine.simulation import check_threads
    try:
        return {"threads": check_threads(int(text))}
    except ValueError as e:
        raise ValueError(f"--threads {e}" if text.strip().lstrip("+-").isdigit()
                         else f"--threads must be an integer, got {text!r}") from None


def cmd_run(args) -> int:
    from .compiling import CompileLog, compiling_alongside
    from .scene.loader import load_scene
    scene = load_scene(scene_path(args.scene), limits=not args.no_limits)
    out = Path(args.out)
    until = scene.run.until if args.until is None else float(args.until)
    if not (math.isfinite(until) and until > 0):
        raise ValueError(f"--until must be a positive number of seconds, got {args.until}")
    threads = _threads_option(args.threads)
    status = CompileStatus(sys.stderr)
    # the log and the second process from the build on: building compiles too (the fluid's
    # sample, the drives' poses), and the kick compiles alongside meanwhile
    with CompileLog(status, llvm=False) as log, compiling_alongside(scene.path, threads=threads.get("threads")):
        sim = scene.simulation(**threads)
        status.clear()
        return _checked_run(args, scene, sim, out, until, log, status)


def _checked_run(args, scene, sim, out: Path, until: float, log, status) -> int:
    from .core.limits import check_run
    from .output import outdir
    from .studies.runner import schedule
    interval = schedule(scene, until).interval
    if interval < sim.dt:
        what = "until" if interval == until else "output_interval"
        raise ValueError(f"{scene.path}: [run] {what}: {interval:g} s is shorter than one step "
                         f"(dt = {sim.dt:.4g} s){'; frames would repeat' if what != 'until' else ''}")
    if scene.run.limits and not args.no_limits:
        source = "[run] dt" if isinstance(scene.run.dt, float) else f"the stable step of {sim.stiffest()}"
        check_run(until / sim.dt, until / interval, f"dt = {sim.dt:.4g} s ({source})",
                  f"{scene.path}: [run] until = {until:g} s")
    with outdir.locked(out):
        outdir.prepare(out, resume=args.resume, overwrite=args.overwrite)
        from .output.record import kernels_compiled
        if not kernels_compiled(sim):
            print("compiling kernels (first run only)...", file=sys.stderr)
        return _record(args, scene, sim, out, until, log, status)


class CompileStatus:
    """A CompileLog report writing one status line on ``stream``: kernels compiled, of how
    many (when this machine has compiled the step before), the one under way, and the seconds
    left by this machine's earlier times; at most every ``every`` s. ``clear()`` wipes the
    line before other output."""

    def __init__(self, stream, every: float = 0.25):
        self.stream, self.every = stream, every
        self.last = -every
        self.shown = False

    def __call__(self, status):
        import time
        now = time.monotonic()
        if now - self.last < self.every and not status.waiting:
            return
        self.last = now
        if status.waiting:
            text = f"waiting for another process compiling {status.kernel}"
        else:
            of = "" if status.expected is None else f" of about {max(status.expected, status.done)}"
            left = "" if status.left is None else f", about {status.left:.0f} s left"
            text = f"compiling kernels: {status.done}{of} ({status.kernel}{left})"
        self.stream.write(f"\r  {text:<76.76}")
        self.stream.flush()
        self.shown = True

    def clear(self):
        if self.shown:
            self.stream.write("\r" + " " * 78 + "\r")
            self.shown = False


def _record(args, scene, sim, out: Path, until: float, log, status) -> int:
    from .output.record import Progress, Recorder
    rec = Recorder(out, sim, until, scene.run.interval, scene.run.probes, resume=args.resume)
    status.clear()
    if args.resume and rec.done:
        print(f"{scene.path}: already at t = {sim.time:.6g} s = --until; nothing to do", file=sys.stderr)
        return 0
    if args.resume:
        print(f"resuming {scene.path} from frame {rec.k} at t = {sim.time:.6g} s", file=sys.stderr)
    print(f"{scene.title}: {len(scene.net.lines)} lines, {scene.net.element_count} elements, "
          f"dt = {sim.dt:.4g} s, {rec.steps_left()} steps to t = {until:g} s -> {out}", file=sys.stderr)
    print(f"fast_modes {fast_modes_line(sim)}", file=sys.stderr)
    progress = Progress(until, sim.dt)

    def tick(sim, force=False):   # the progress line replaces the compilation's
        status.clear()
        progress(sim, force)
    rec.run(tick)
    tick(sim, force=True)
    took = log.seconds + log.waited   # the waits for the kick compiled alongside included
    compiled = f" (compiling {len(log.kernels)} kernels took {took:.0f} s)" if log.kernels else ""
    sys.stderr.write(f"\ndone: {rec.writer.frames} frames in {out}{compiled}\n")
    return 0


def fast_modes_line(sim) -> str:
    """The fast-modes setting in force, the stable step it gives (against "resolve") and the
    step "auto" would give."""
    from .studies.accuracy import dt_with, summary
    est, auto = sim.stable_dt(), dt_with(sim, "auto")
    text = f"{summary(sim)}: stable dt {est:.4g} s"
    if sim.fast_modes != "resolve":
        full = dt_with(sim, "resolve")
        text += f" ({est / full:.3g}x the {full:.4g} s of \"resolve\")"
    return text + f"; \"auto\" gives {auto:.4g} s ({auto / est:.3g}x)"


def cmd_compile(args) -> int:
    """Compile scenes' kernels into numba's cache, several processes at once: a kernel two of
    them need is compiled by one while the other waits for it (kernels/compiler.py)."""
    import concurrent.futures as cf
    import multiprocessing

    from .compiling import compile_scene, die_with_parent
    if args.all:
        paths = sorted(cases_dir().glob("*.toml"))
    else:
        paths = [scene_path(a) for a in args.scenes or [None]]
    jobs = min(args.jobs or os.cpu_count() or 1, len(paths))
    failed = 0
    # the workers die with this process: a killed `cosnet compile` leaves none compiling on
    with cf.ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"),
                                initializer=die_with_parent) as pool:
        # one scene: a second process compiles its kick alongside; several: a scene per process
        running = {pool.submit(compile_scene, str(p), len(paths) == 1): p for p in paths}
        try:
            for done in cf.as_completed(running):
                name = running[done]
                try:
                    r = done.result()
                except (ValueError, RuntimeError) as e:
                    failed += 1
                    print(f"{name}: {one_line(e)}", file=sys.stderr)
                    continue
                what = (f"compiled {r['kernels']} kernels in {r['seconds']:.0f} s" if r["kernels"]
                        else "all kernels cached")
                print(f"{name}: {what}", file=sys.stderr)
        except BaseException:
            for f in running:
                f.cancel()
            raise
    return 2 if failed else 0


def cmd_info(args) -> int:
    from .scene.loader import load_scene
    scene = load_scene(scene_path(args.scene))
    net = scene.net
    sim = scene.simulation()
    nv = sum(l.elements + 1 for l in net.lines)
    fixed = [n.name for n in net.nodes if n.fixed_position]
    bodies = [n.name for n in net.nodes if 0 < n.mass < math.inf]
    est = sim.stable_dt()
    print(f"scene      {scene.path}  ({scene.title})")
    print(f"net        {len(net.nodes)} nodes, {len(net.lines)} lines, {net.element_count} elements, "
          f"{nv} vertices")
    print(f"nodes      fixed: {', '.join(fixed) or '-'}; with mass: {', '.join(bodies) or '-'}")
    print(f"mass       {net.total_mass():.6g} kg (nodes of finite mass and lines)")
    print(f"stable dt  {est:.4g} s (estimate, {sim.stepper}; stiffest at {sim.stiffest()})")
    given = "auto" if scene.run.dt is None else "the highest mode's" if scene.run.dt == "tight" else "from the scene"
    print(f"dt         {sim.dt:.4g} s ({given})")
    print(f"fast_modes {fast_modes_line(sim)}")
    print(f"run        until {scene.run.until:g} s = {math.ceil(scene.run.until / sim.dt):,} steps, "
          f"output every {scene.run.interval:g} s")
    print(f"effects    {'; '.join(scene.describe_effects()) or 'none'}")
    if scene.run.probes:
        print(f"probes     {', '.join(p.name for p in scene.run.probes)}")
    return 0


def cmd_modes(args) -> int:
    from .studies.modes import comparison_table, main_modes, spectrum_table, write_modes
    from .scene.loader import load_scene
    scene = load_scene(scene_path(args.scene))
    res = main_modes(scene, count=args.count, sigma=args.sigma, analytic=args.analytic)
    print(spectrum_table(res))
    if res.analytic is not None:
        print(comparison_table(res))
    if not args.no_output:
        out = write_modes(res, Path(args.out), frames=args.frames)
        print(f"wrote {len(res)} mode series to {out}")
    return 0


def cmd_render(args) -> int:
    import contextlib

    from .output import outdir
    from .output.render import choose, render
    kind = "gif" if args.gif else "mp4" if args.mp4 else "html" if args.html else "png"
    src = Path(args.dir)
    # a picture written into a run's directory is a write: not while a run or sweep holds it
    # (--output elsewhere renders the frames written so far)
    held = (outdir.locked(src, "render") if args.output is None and (src / outdir.LOCK).exists()
            else contextlib.nullcontext())
    with held:
        field, frame, why = args.field, args.frame, None
        if kind == "html":
            from .output.webpage import write_html
            print(write_html(args.dir, output=args.output, every=args.every, min_radius=args.min_radius,
                             mode=args.mode))
            return 0
        if kind == "png" and (field is None or frame is None):
            field, frame, why = choose(args.dir, field, frame, args.mode)
        path = render(args.dir, kind=kind, field=field, output=args.output, frame=frame,
                      every=args.every, clim=args.clim, view=args.view, warp=args.warp,
                      min_radius=args.min_radius, window_size=args.size, mode=args.mode)
    if why:
        print(f"frame {frame}, coloured by {field}: {why}", file=sys.stderr)
    print(path)
    return 0


def cmd_view(args) -> int:
    """Serve the run's page (written first if it is missing or older than the series) on
    localhost until interrupted."""
    import contextlib

    from .output import outdir
    from .output.io import PVD
    from .output.webpage import PAGE, serve, write_html
    src = Path(args.dir)
    series = src / PVD if (src / PVD).exists() else min(src.glob("mode_*.pvd"), default=None)
    if series is None:
        raise ValueError(f"{src}: not a cosnet output directory (no {PVD} or mode_JJ.pvd)")
    page = src / PAGE
    if not page.exists() or page.stat().st_mtime < series.stat().st_mtime:
        with outdir.locked(src, "view") if (src / outdir.LOCK).exists() else contextlib.nullcontext():
            write_html(src)
    try:
        serve(src, port=args.port, browser=not args.no_browser,
              ready=lambda url: print(f"serving {url} (Ctrl-C stops)", flush=True))
    except OSError as e:
        raise ValueError(f"--port {args.port}: {e.strerror or e}") from None
    except KeyboardInterrupt:
        pass
    return 0


def cmd_plot(args) -> int:
    import contextlib

    from .output import outdir
    from .output.io import read_output
    src = Path(args.dir)
    output = Path(args.output) if args.output else src / "plot.png"
    if output.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise ValueError(f"--output {output}: a plot is written as .png, .svg or .pdf")
    held = (outdir.locked(src, "plot") if args.output is None and (src / outdir.LOCK).exists()
            else contextlib.nullcontext())
    with held:
        fig = read_output(src).plot(*args.probes, energy=args.energy)
        fig.savefig(output, dpi=120)
    print(output)
    return 0


def cmd_accuracy(args) -> int:
    """Exit code 0 with a recommendation, 1 when no setting reaches --tol."""
    from .studies.accuracy import check_tol, report, study
    try:
        tol = check_tol(args.tol)
    except ValueError as e:   # the library names its parameter, the command its flag
        raise ValueError(f"--{e}") from None
    if args.window is not None and not (math.isfinite(args.window) and args.window > 0):
        raise ValueError(f"--window must be a positive number of seconds, got {args.window}")
    path = scene_path(args.scene)
    log = (lambda msg: print(msg, file=sys.stderr)) if args.verbose else None
    st = study(path, window=args.window, probes=args.probe, log=log)
    text, best = report(st, tol)
    print(text)
    return 0 if best is not None else 1


def cmd_sweep(args) -> int:
    """Exit code 0 when every variant ran to the end, 1 when some failed (with --check: 0
    when the store is intact, 1 when it is damaged)."""
    from .studies.sweep import check, sweep
    from .studies.sweep_report import plot, summary
    if args.check is not None:
        if args.scene is not None:
            raise ValueError("--check STORE takes the store alone, not a scene")
        code, line = check(args.check)
        print(line)
        return code
    if args.plot is not None:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise ValueError("--plot needs matplotlib: pip install 'cosnet[sweep]'") from None
    shown = {"counts": None, "at": -math.inf}

    def progress(p):
        if p["dashboard"] and "dash" not in shown:
            shown["dash"] = print(f"dashboard: {p['dashboard']}", file=sys.stderr)
        counts = (p["done"], p["failed"], p["running"])
        if counts == shown["counts"] and p["elapsed"] - shown["at"] < 5:
            return   # a new line only when the counts change, else every 5 s
        shown.update(counts=counts, at=p["elapsed"])
        eta = f"ETA {p['eta']:.0f} s" if math.isfinite(p["eta"]) else "ETA -"
        sys.stderr.write(f"\r  variants: {p['done']}/{p['total']} done, {p['failed']} failed, "
                         f"{p['running']} running  {eta}   ")
        sys.stderr.flush()

    ds = sweep(args.scene or str(default_scene()), vary=args.vary, zip=args.zip,
               ensemble=args.ensemble, until=args.until, out=args.out, name=args.name,
               scheduler=args.scheduler, workers=args.workers, batch=args.batch,
               resume=args.resume, overwrite=args.overwrite, limits=not args.no_limits,
               progress=progress, vtk=args.vtk, flush_every=args.flush_every)
    sys.stderr.write("\n")
    store = ds.encoding.get("source", "")
    print(summary(ds, args.plot or None))
    print(f"results: {store}")
    if args.vtk:
        print(f"VTK series: {Path(store).with_suffix('.vtk')}/variant_NNNN/series.pvd")
    if args.plot is not None:
        print(f"plot: {plot(ds, Path(store).with_suffix('.png'), args.plot or None)}")
    return 0 if all(str(s) == "ok" for s in ds["status"].values) else 1


class _Parser(argparse.ArgumentParser):
    """Usage mistakes end in one line (like every other error), exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return n


def parser() -> argparse.ArgumentParser:
    p = _Parser(prog="cosnet", description="Dynamics of Cosserat nets.")
    p.add_argument("--version", action="version", version=f"cosnet {package_version()}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene and write a VTK time series")
    r.add_argument("scene", nargs="?", help="scene file or ready case name (default: bridge)")
    r.add_argument("--out", default="out", help="output directory (default: ./out)")
    r.add_argument("--until", type=float, help="end time in s (default: the scene's [run] until)")
    once = r.add_mutually_exclusive_group()
    once.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    once.add_argument("--overwrite", action="store_true",
                      help="replace the run already in --out (its frames, probes and checkpoint)")
    r.add_argument("--no-limits", action="store_true",
                   help="lift the limits on elements, memory, steps and frames (see docs/faults.md)")
    r.add_argument("--threads", help="threads for the step (default: the scene's [run] threads, else "
                   "by net size; see docs/threads.md)")
    c = sub.add_parser("compile", help="compile the kernels of scenes into the cache, ahead of their runs")
    c.add_argument("scenes", nargs="*", metavar="scene", help="scene files or ready case names (default: bridge)")
    c.add_argument("--all", action="store_true", help="every ready case of cases/")
    c.add_argument("--jobs", type=_positive_int, help="processes compiling at once (default: one per core)")
    i = sub.add_parser("info", help="describe a scene")
    i.add_argument("scene", help="scene file or ready case name")
    m = sub.add_parser("modes", help="normal modes of a scene's net (§6): spectrum and VTK mode shapes")
    m.add_argument("scene", help="scene file or ready case name")
    m.add_argument("--count", type=_positive_int, default=6, help="how many elastic modes (default 6)")
    m.add_argument("--out", default="modes", help="directory for spectrum.csv and mode_JJ.pvd (default ./modes)")
    m.add_argument("--no-output", action="store_true", help="print the spectrum only")
    m.add_argument("--frames", type=_positive_int, default=16, help="frames per animated period (default 16)")
    m.add_argument("--sigma", type=float, default=0.0, help="find the modes nearest this angular frequency")
    m.add_argument("--analytic", action="store_true",
                   help="also the exact modes of the continuous net (straight uniform lines)")
    v = sub.add_parser("render", help="render a written series (a run or `cosnet modes` output) off screen")
    v.add_argument("dir", help="output directory of `cosnet run` or `cosnet modes`, or a mode_JJ.pvd")
    g = v.add_mutually_exclusive_group()
    g.add_argument("--png", action="store_true", help="one picture (default: the last frame)")
    g.add_argument("--gif", action="store_true", help="an animated GIF (needs the movie extra)")
    g.add_argument("--mp4", action="store_true", help="an MP4 movie (needs the movie extra)")
    g.add_argument("--html", action="store_true",
                   help="one self-contained web page: 3-D view, time slider, colour menu (default DIR/view.html)")
    v.add_argument("--field", help="line field to colour by, as its magnitude (displacement is from the "
                                   "first frame; default velocity, or for a picture where velocity "
                                   "hardly varies, displacement)")
    v.add_argument("--frame", type=int, help="frame for --png, -1 the last (default: the frame where the lines "
                                             "are farthest from frame 0; a mode at a quarter period)")
    v.add_argument("--every", type=_positive_int, default=1, help="use every n-th frame for --gif/--mp4/--html")
    v.add_argument("--output", help="file to write (default: DIR/render.png|gif|mp4, DIR/view.html)")
    v.add_argument("--clim", type=float, nargs=2, metavar=("LO", "HI"),
                   help="colour range (default: the field's range over all frames)")
    v.add_argument("--view", default="iso", help="iso, xy, xz, yz or AZIMUTH,ELEVATION in degrees")
    v.add_argument("--warp", type=float, default=1.0,
                   help="exaggerate the motion from the first frame by this factor (default 1)")
    v.add_argument("--min-radius", type=float, help="draw thinner lines at this radius, m "
                   "(default 0.2%% of the scene's size)")
    v.add_argument("--size", type=int, nargs=2, default=(1024, 768), metavar=("W", "H"),
                   help="picture size in pixels (default 1024 768)")
    v.add_argument("--mode", type=int, help="mode J of a `cosnet modes` directory (default: 0)")
    w = sub.add_parser("view", help="serve a run's page (render --html) on localhost and open it")
    w.add_argument("dir", help="output directory of `cosnet run` or `cosnet modes`")
    w.add_argument("--port", type=int, default=0, help="port on 127.0.0.1 (default: any free one)")
    w.add_argument("--no-browser", action="store_true", help="serve without opening a browser")
    pl = sub.add_parser("plot", help="plot a run's probes and its energy budget over time")
    pl.add_argument("dir", help="output directory of `cosnet run`")
    pl.add_argument("probes", nargs="*", help="probes to plot, as named in [run] probes (default: all)")
    pl.add_argument("--energy", action="store_true",
                   help="plot the energy budget: kinetic, strain, potential, the accounts and the balance's drift")
    pl.add_argument("--output", help="file to write, .png, .svg or .pdf (default: DIR/plot.png)")
    a = sub.add_parser("accuracy", help="estimate the error and cost of refined settings")
    a.add_argument("scene", help="scene file or ready case name")
    a.add_argument("--tol", default="1e-4", help="position error to reach, m (default: 1e-4)")
    a.add_argument("--window", type=float, help="simulated window in s (default: 5%% of until)")
    a.add_argument("--probe", action="append", metavar="NODE|LINE@s",
                   help="probe point (repeatable; default: every node)")
    a.add_argument("--verbose", action="store_true", help="list the runs on stderr")
    s = sub.add_parser("sweep", help="run variants of a scene as Dask tasks into one Zarr store")
    s.add_argument("scene", nargs="?", help="scene file, sweep file ([sweep] table) or ready case name")
    s.add_argument("--vary", action="append", default=[], metavar="KEY=VALUES",
                   help="a dotted scene key and its values: V1,V2,... or linspace(a,b,n), "
                        "logspace(a,b,n), geomspace(a,b,n) (repeatable)")
    s.add_argument("--zip", action="store_true", help="combine the variations element by element "
                                                     "(default: the full product)")
    s.add_argument("--ensemble", type=int, metavar="N",
                   help="N seeds of the scene's [initial.perturbation] per variant")
    s.add_argument("--until", type=float, help="end time in s (default: the scene's [run] until)")
    s.add_argument("--out", default="out", help="directory of the store OUT/NAME.zarr (default ./out)")
    s.add_argument("--name", help="store name (default: the sweep or scene file's name)")
    s.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="use this Dask scheduler (default: a local cluster, one worker per core)")
    s.add_argument("--workers", type=int, help="local cluster size (default: one per core)")
    s.add_argument("--batch", type=int, help="variants per task (default: about 4 tasks per worker)")
    again = s.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true",
                       help="continue the store: run only its unfinished (or damaged) variants")
    again.add_argument("--overwrite", action="store_true", help="replace the store already at OUT/NAME.zarr")
    s.add_argument("--no-limits", action="store_true",
                   help="lift the limit on the number of variants (see docs/faults.md)")
    s.add_argument("--flush-every", type=float, metavar="SECONDS",
                   help="the longest a finished variant waits before it is written (default 2; 0: at once)")
    s.add_argument("--check", metavar="STORE",
                   help="check every file of a store against its manifest (exit 1 if damaged)")
    s.add_argument("--vtk", action="store_true",
                   help="also write each variant's VTK series to OUT/NAME.vtk/variant_NNNN")
    s.add_argument("--plot", nargs="?", const="", metavar="PROBE[:x|y|z|norm]",
                   help="PNG of a probe's displacement against the first varied key")
    return p


INTERNAL = 70   # EX_SOFTWARE: an error cosnet did not mean to raise


def _raised_outside(e: BaseException) -> str | None:
    """The module an exception was raised in when that is not cosnet's own (numpy, scipy, the
    standard library: an error no check of cosnet's refused), else None. cosnet's refusals are
    raised by its own code, which re-raises what it catches in its own words."""
    tb = e.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    if tb is None:
        return None
    path = Path(tb.tb_frame.f_code.co_filename).resolve()
    package = Path(__file__).resolve().parent
    ours = (package, package.parent / "kernels")
    if any(path.is_relative_to(p) for p in ours):
        return None
    return tb.tb_frame.f_globals.get("__name__", path.name)


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        # SIGINT stops a run resumably (exit 130) even in a process started with SIGINT
        # ignored, as a shell starts background jobs: Python then installs no handler
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return {"run": cmd_run, "compile": cmd_compile, "info": cmd_info, "modes": cmd_modes, "render": cmd_render,
                "plot": cmd_plot, "view": cmd_view, "accuracy": cmd_accuracy, "sweep": cmd_sweep}[args.command](args)
    except ValueError as e:
        origin = _raised_outside(e)
        if origin:    # not a refusal of cosnet's: a library's own error reached the command
            print(f"cosnet: internal error: {one_line(e)} ({type(e).__name__} from {origin}; "
                  f"please report it with the command)", file=sys.stderr)
            return INTERNAL
        print(f"cosnet: error: {one_line(e)}", file=sys.stderr)
        return 2
    except (MemoryError, RecursionError) as e:
        where = getattr(args, "scene", None) or getattr(args, "dir", None) or default_scene()
        what = "out of memory: too large for this machine" if isinstance(e, MemoryError) else "nested too deeply"
        print(f"cosnet: error: {one_line(where)}: {what}", file=sys.stderr)
        return 2
    except RuntimeError as e:  # InstabilityError and other run failures
        print(f"\ncosnet: error: {e}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print("\ncosnet: interrupted (resume with --resume)", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped (e.g. `| head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as e:  # a read-only or full disk, a path that is no directory, ...
        where = f"{e.filename}: " if e.filename else ""
        print(f"\ncosnet: error: {where}{e.strerror or e}", file=sys.stderr)
        return 2


def command() -> int:
    """The ``cosnet`` executable: main, then a quick exit. At exit Python collects its
    objects again and again as it tears the modules down; after a run the compiler leaves over
    a hundred thousand of them (a quarter of a second here), so they are frozen out of those
    collections: the process is ending anyway."""
    import gc

    code = main()
    gc.freeze()
    return code


if __name__ == "__main__":
    raise SystemExit(command())
