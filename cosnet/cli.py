"""The ``cosnet`` command.

    cosnet run [SCENE] [--out DIR] [--until T] [--resume]   run a scene, writing a VTK series
    cosnet info SCENE                                        net size, mass, stable dt, effects
    cosnet modes SCENE [--count K] [--out DIR] [--analytic]  normal modes: spectrum, VTK shapes
    cosnet render DIR [--png|--gif|--mp4] [--field NAME]     pictures of a written series
    cosnet accuracy SCENE [--tol E] [--window T] [--probe P]  error and cost of refinements
    cosnet sweep SCENE [--vary KEY=VALUES] [--ensemble N]    variants as Dask tasks, one Zarr store

``run`` writes a frame, a probes row and a checkpoint every output interval. Frame k sits
exactly at step ceil(k * interval / dt), and the steps between frames are taken in chunks
whose boundaries depend only on the absolute step count, so ``--resume`` (continue from the
last checkpoint in DIR) reproduces an uninterrupted run bit for bit.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

CHECKPOINT = "checkpoint.npz"
PROBES = "probes.csv"
CHUNK = 2000  # steps per compiled call; boundaries at multiples of CHUNK (see module docstring)


def cases_dir() -> Path:
    """The ready cases: cases/ of a source checkout, or the copy installed as cosnet.cases."""
    here = Path(__file__).resolve().parent
    for cand in (here.parent / "cases", here / "cases"):
        if (cand / "bridge.toml").exists():
            return cand
    raise ValueError("the ready cases (cases/*.toml) were not found next to the package")


def default_scene() -> Path:
    """cases/bridge.toml, the suspension bridge of Figure 1.1."""
    return cases_dir() / "bridge.toml"


def scene_path(arg: str | None) -> Path:
    """A scene file given on the command line, or the name of a ready case (``cantilever``,
    ``hard/column``), or the default case when none is given."""
    if arg is None:
        return default_scene()
    p = Path(arg)
    if p.is_file() or p.suffix == ".toml":
        return p
    case = cases_dir() / f"{arg}.toml"
    if case.exists():
        return case
    names = sorted(str(c.relative_to(cases_dir()).with_suffix("")) for c in cases_dir().rglob("*.toml"))
    raise ValueError(f"{arg}: no such scene file, nor a ready case; cases are {', '.join(names)}")


def frame_steps(k: int, interval: float, dt: float, end_steps: int) -> int:
    """Step count at which output frame k is written."""
    return min(int(math.ceil(k * interval / dt - 1e-9)), end_steps)


def advance_to(sim, target: int, progress=None):
    """Step ``sim`` to ``target`` steps in chunks aligned on multiples of CHUNK."""
    while sim.steps < target:
        n = min(target, (sim.steps // CHUNK + 1) * CHUNK) - sim.steps
        sim.run(steps=n)
        if progress is not None:
            progress(sim)


class Progress:
    """One status line on stderr: simulated time, steps per second, estimated time left."""

    def __init__(self, until: float, dt: float, stream=sys.stderr):
        self.until, self.dt, self.stream = until, dt, stream
        self.t0 = time.perf_counter()
        self.steps0 = None
        self.last = 0.0

    def __call__(self, sim, force=False):
        now = time.perf_counter()
        if self.steps0 is None:
            self.steps0, self.t0 = sim.steps, now
            return
        if not force and now - self.last < 0.5:
            return
        self.last = now
        rate = (sim.steps - self.steps0) / max(now - self.t0, 1e-9)
        left = max(self.until - sim.time, 0.0) / self.dt / rate if rate > 0 else math.inf
        self.stream.write(f"\r  t = {sim.time:.5g} / {self.until:.5g} s  {rate:,.0f} steps/s  "
                          f"ETA {left:.0f} s   ")
        self.stream.flush()


def _probe_header(probes) -> str:
    cols = ["frame", "time"] + [f"{p.name}_{a}" for p in probes for a in "xyz"]
    return ",".join(cols) + "\n"


def _probe_row(k, sim, probes) -> str:
    vals = [repr(float(x)) for p in probes for x in p.position(sim)]
    return ",".join([str(k), repr(sim.time)] + vals) + "\n"


def _keep_probe_rows(path: Path, header: str, last_frame: int):
    rows = [header]
    if path.exists():
        for line in path.read_text().splitlines(keepends=True)[1:]:
            if line.strip() and int(line.split(",", 1)[0]) <= last_frame:
                rows.append(line)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text("".join(rows))
    os.replace(tmp, path)


def cmd_run(args) -> int:
    from .io import SeriesWriter
    from .scene import load_scene
    scene = load_scene(scene_path(args.scene))
    out = Path(args.out)
    until = scene.run.until if args.until is None else float(args.until)
    if not until > 0:
        raise ValueError(f"--until must be positive, got {args.until}")
    sim = scene.simulation()
    ckpt = out / CHECKPOINT
    probes = scene.run.probes
    header = _probe_header(probes)
    interval = min(scene.run.interval, until)
    if args.resume:
        if not ckpt.exists():
            raise ValueError(f"{out}: nothing to resume (no {CHECKPOINT})")
        sim.load_checkpoint(ckpt)
    end = int(math.ceil(until / sim.dt - 1e-9))
    frames = int(math.ceil(until / interval - 1e-9))
    if args.resume:
        k = next((j for j in range(frames + 1) if frame_steps(j, interval, sim.dt, end) == sim.steps), None)
        if k is None:
            raise ValueError(f"{ckpt}: its step {sim.steps} is not an output frame of this run "
                             f"(same scene and --until needed to resume)")
        writer = SeriesWriter(out, scene.net, resume_after=k)
        _keep_probe_rows(out / PROBES, header, k)
        print(f"resuming {scene.path} from frame {k} at t = {sim.time:.6g} s", file=sys.stderr)
    else:
        writer = SeriesWriter(out, scene.net)
        (out / PROBES).write_text(header)
        k = writer.write(sim)
        with open(out / PROBES, "a") as f:
            f.write(_probe_row(k, sim, probes))
        sim.save_checkpoint(ckpt)
    print(f"{scene.title}: {len(scene.net.lines)} lines, {scene.net.element_count} elements, "
          f"dt = {sim.dt:.4g} s, {end - sim.steps} steps to t = {until:g} s -> {out}", file=sys.stderr)
    progress = Progress(until, sim.dt)
    progress(sim)
    with open(out / PROBES, "a") as pf:
        while k < frames:
            k += 1
            advance_to(sim, frame_steps(k, interval, sim.dt, end), progress)
            writer.write(sim)
            pf.write(_probe_row(k, sim, probes))
            pf.flush()
            sim.save_checkpoint(ckpt)
    progress(sim, force=True)
    sys.stderr.write(f"\ndone: {writer.frames} frames in {out}\n")
    return 0


def cmd_info(args) -> int:
    from .scene import load_scene
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
    print(f"dt         {sim.dt:.4g} s ({'auto' if scene.run.dt is None else 'from the scene'})")
    print(f"run        until {scene.run.until:g} s = {math.ceil(scene.run.until / sim.dt):,} steps, "
          f"output every {scene.run.interval:g} s")
    print(f"effects    {'; '.join(scene.describe_effects()) or 'none'}")
    if scene.run.probes:
        print(f"probes     {', '.join(p.name for p in scene.run.probes)}")
    return 0


def cmd_modes(args) -> int:
    from .modes import main_modes
    from .scene import load_scene
    scene = load_scene(scene_path(args.scene))
    if args.count < 1:
        raise ValueError(f"--count must be a positive integer, got {args.count}")
    out = None if args.no_output else Path(args.out)
    res = main_modes(scene, count=args.count, out_dir=out, frames=args.frames, sigma=args.sigma)
    if args.analytic:
        from .lincos import analytic_modes
        exact = analytic_modes(scene.net, count=len(res))
        print("mode  discrete (rad/s)  analytic (rad/s)  relative difference")
        for j, (w, we) in enumerate(zip(res.omega, exact.omega)):
            print(f"{j:4d}  {w:16.8g}  {we:16.8g}  {(w - we) / we:+.2e}")
    return 0


def cmd_render(args) -> int:
    from .render import render
    kind = "gif" if args.gif else "mp4" if args.mp4 else "png"
    path = render(args.dir, kind=kind, field=args.field, output=args.output, frame=args.frame,
                  every=args.every)
    print(path)
    return 0


def cmd_accuracy(args) -> int:
    """Exit code 0 with a recommendation, 1 when no setting reaches --tol."""
    from .accuracy import check_tol, report, study
    tol = check_tol(args.tol)
    if args.window is not None and not (math.isfinite(args.window) and args.window > 0):
        raise ValueError(f"--window must be a positive number of seconds, got {args.window}")
    path = scene_path(args.scene)
    log = (lambda msg: print(msg, file=sys.stderr)) if args.verbose else None
    st = study(path, window=args.window, probes=args.probe, log=log)
    text, best = report(st, tol)
    print(text)
    return 0 if best is not None else 1


def cmd_sweep(args) -> int:
    """Exit code 0 when every variant ran to the end, 1 when some failed."""
    from .sweep import sweep
    from .sweep_report import plot, summary
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
               resume=args.resume, progress=progress)
    sys.stderr.write("\n")
    store = ds.encoding.get("source", "")
    print(summary(ds, args.plot or None))
    print(f"results: {store}")
    if args.plot is not None:
        print(f"plot: {plot(ds, Path(store).with_suffix('.png'), args.plot or None)}")
    return 0 if all(str(s) == "ok" for s in ds["status"].values) else 1


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cosnet", description="Dynamics of Cosserat nets.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene and write a VTK time series")
    r.add_argument("scene", nargs="?", help="scene file or ready case name (default: bridge)")
    r.add_argument("--out", default="out", help="output directory (default: ./out)")
    r.add_argument("--until", type=float, help="end time in s (default: the scene's [run] until)")
    r.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    i = sub.add_parser("info", help="describe a scene")
    i.add_argument("scene", help="scene file or ready case name")
    m = sub.add_parser("modes", help="normal modes of a scene's net (§6): spectrum and VTK mode shapes")
    m.add_argument("scene", help="scene file or ready case name")
    m.add_argument("--count", type=int, default=6, help="how many elastic modes (default 6)")
    m.add_argument("--out", default="modes", help="directory for spectrum.csv and mode_JJ.pvd (default ./modes)")
    m.add_argument("--no-output", action="store_true", help="print the spectrum only")
    m.add_argument("--frames", type=int, default=16, help="frames per animated period (default 16)")
    m.add_argument("--sigma", type=float, default=0.0, help="find the modes nearest this angular frequency")
    m.add_argument("--analytic", action="store_true",
                   help="also the exact modes of the continuous net (straight uniform lines)")
    v = sub.add_parser("render", help="render a written series off screen")
    v.add_argument("dir")
    g = v.add_mutually_exclusive_group()
    g.add_argument("--png", action="store_true", help="one picture (default: the last frame)")
    g.add_argument("--gif", action="store_true", help="an animated GIF of the series")
    g.add_argument("--mp4", action="store_true", help="an MP4 movie (needs ffmpeg)")
    v.add_argument("--field", default="velocity", help="line field to colour by (magnitude)")
    v.add_argument("--frame", type=int, default=-1, help="frame for --png (default: last)")
    v.add_argument("--every", type=int, default=1, help="use every n-th frame for --gif/--mp4")
    v.add_argument("--output", help="file to write (default: DIR/render.png|gif|mp4)")
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
    s.add_argument("--resume", action="store_true", help="keep the finished variants of the store")
    s.add_argument("--plot", nargs="?", const="", metavar="PROBE[:x|y|z|norm]",
                   help="PNG of a probe's displacement against the first varied key")
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    try:
        return {"run": cmd_run, "info": cmd_info, "modes": cmd_modes, "render": cmd_render,
                "accuracy": cmd_accuracy, "sweep": cmd_sweep}[args.command](args)
    except ValueError as e:
        print(f"cosnet: error: {e}", file=sys.stderr)
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
