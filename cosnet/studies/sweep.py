"""Sweeps and ensembles: many variants of one scene run as Dask tasks, results in one Zarr store.

``sweep(scene, vary=[...])`` plans the variants (cosnet.studies.variants: every one validated by the
scene loader before anything runs), runs each with ``run_probes`` -- the frames and probes of
``cosnet run`` -- on a Dask cluster (a LocalCluster of one single-threaded worker process per
core unless a scheduler address or a Client is given) and writes the finished variants into
``OUT/<name>.zarr`` (at most ``flush_every`` seconds after they arrive, default FLUSH_EVERY,
and on an interrupt), an
xarray Dataset:

    dims        variant, time (the output frames), component (x, y, z)
    coords      variant; one per varied key, named by its dotted path; time (the nominal frame
                times k * interval, when every variant shares them); component
    per probe   float64 (variant, time, component): the probe's position at each frame
    per variant status ("ok", "pending", or the failure's message), steps, dt, wall_time,
                compiled (kernels compiled rather than loaded from the on-disk cache), worker,
                key (hash of the variant's scene document and end time: what --resume matches)
    frame_time  (variant, time): the exact simulated time of each frame (steps * dt)

A failing variant (instability, refused dt, any exception) is recorded and the others go on;
a dead worker's tasks are rescheduled by Dask; ``resume=True`` reruns only the variants whose
status is still "pending" (or "lost:" to a cluster failure).
"""

from __future__ import annotations

import json
import logging
import math
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..output import outdir
from . import sweep_store
from ..core.limits import check_variants
from .runner import run_probes, schedule
from ..scene.cases import scene_path
from ..scene.loader import build_scene, read_toml
from .sweep_store import PENDING, SCALARS, Store, package_version
from .variants import parse_values, parse_vary, plan, split_path

CHUNK_BYTES = 1 << 20
FLUSH_EVERY = 2.0  # s: the longest a finished variant waits on the client before it is written
SPEC_KEYS = ("scene", "vary", "zip", "ensemble", "until", "plot", "name")


@dataclass
class SweepSpec:
    """What to sweep: the base scene ``path`` and its parsed TOML ``doc``, the variation
    ``axes`` [(key, values)], ``zipped``, ``ensemble`` size, ``until`` override, default
    ``plot`` quantity and the store's ``name``."""

    path: Path
    doc: dict
    axes: list
    zipped: bool = False
    ensemble: int = 0
    until: float | None = None
    plot: str | None = None
    name: str | None = None
    title: str | None = None


def read_spec(path, vary=(), zipped=None, ensemble=None, until=None) -> SweepSpec:
    """A sweep from a scene file (variations given here) or a sweep file ([sweep] with scene,
    vary, zip, ensemble, until, plot, name); the arguments add to or override the file's."""
    path = Path(path)
    data = read_toml(path)
    spec = SweepSpec(path, data, [])
    if "sweep" in data:
        extra = sorted(set(data) - {"sweep", "title", "description"})
        if extra:
            raise ValueError(f"{path}: [sweep] files hold only [sweep] (and title); found {extra[0]!r}")
        s = data["sweep"]
        if not isinstance(s, dict):
            raise ValueError(f"{path}: [sweep] must be a table")
        bad = sorted(set(s) - set(SPEC_KEYS))
        if bad:
            raise ValueError(f"{path}: [sweep] {bad[0]}: unknown key; keys are {', '.join(SPEC_KEYS)}")
        if not isinstance(s.get("scene"), str):
            raise ValueError(f"{path}: [sweep] scene: is required: a scene file (relative to "
                             f"this file) or a ready case name")
        rel = path.parent / s["scene"]
        base = rel if rel.is_file() else scene_path(s["scene"])
        vary_t = s.get("vary", {})
        if not isinstance(vary_t, dict):
            raise ValueError(f"{path}: [sweep] vary: must be a table of KEY = [values] or "
                             f"\"linspace(a, b, n)\"")
        spec = SweepSpec(Path(base), read_toml(base), [], bool(s.get("zip", False)),
                         s.get("ensemble", 0), s.get("until"), s.get("plot"),
                         s.get("name", path.stem), data.get("title"))
        for key, v in vary_t.items():
            split_path(key, str(path))
            vals = parse_values(v, key, str(path)) if isinstance(v, str) else (
                v if isinstance(v, list) else [v])
            if not vals:
                raise ValueError(f"{path}: [sweep.vary] {key}: no values")
            spec.axes.append((key, vals))
    for text in vary:
        key, vals = parse_vary(text, str(spec.path))
        spec.axes = [a for a in spec.axes if a[0] != key] + [(key, vals)]
    if zipped is not None:
        spec.zipped = zipped
    if ensemble is not None:
        spec.ensemble = ensemble
    if until is not None:
        spec.until = until
    return spec


# ---------------------------------------------------------------------- on the workers
def run_batch(items: list, until: float | None, vtk: str | None = None) -> list:
    """Update [(index, result dict)] given [(index, scene document, path)]: each variant
    built and run single-threaded (its VTK series written into ``vtk``/variant_NNNN when
    ``vtk`` is a directory); anything a variant raises becomes its status."""
    from distributed import get_worker
    try:
        who = get_worker().address
    except ValueError:
        who = ""
    out = []
    for index, doc, path in items:
        try:
            series = None if vtk is None else Path(vtk) / variant_dir(index)
            res = run_probes(build_scene(doc, path), until, threads=1, vtk=series)
            rec = dict(times=res.times, probes=res.probes, status=res.status, steps=res.steps,
                       dt=res.dt, wall=res.wall, compiled=res.compiled)
        except Exception as e:  # recorded, never lost: the sweep goes on
            rec = dict(status=f"{type(e).__name__}: {' '.join(str(e).split())}")
        rec["worker"] = who
        out.append((index, rec))
    return out


def variant_dir(index: int) -> str:
    """The folder of a variant's VTK series inside the sweep's series folder."""
    return f"variant_{index:04d}"


def warm_up(doc: dict, path: str) -> int:
    """Update numba's on-disk cache given a variant: build and take one step, so its kernels
    are compiled (and saved) by one process while the others wait for it, instead of by every
    worker at once, each spending the same minute. Returns the number of compilations it
    needed."""
    from numba.core import event

    from .runner import CompileCounter
    counter = CompileCounter()
    with event.install_listener("numba:compile", counter):
        build_scene(doc, path).simulation(threads=1).run(steps=1)
    return counter.count


# ---------------------------------------------------------------------- the store
def _store_vars(variants, frames, probes):
    n, nt = len(variants), frames + 1
    return {
        **{p: (("variant", "time", "component"), np.full((n, nt, 3), np.nan)) for p in probes},
        "frame_time": (("variant", "time"), np.full((n, nt), np.nan)),
        "status": (("variant",), np.array([PENDING] * n, dtype=object)),
        **{var: (("variant",), np.full(n, blank)) for var, _, blank in SCALARS},
        "worker": (("variant",), np.array([""] * n, dtype=object)),
        "key": (("variant",), np.array([v.key for v in variants], dtype=object)),
    }


def _coord(values):
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64 if all(isinstance(v, int) for v in values) else float)
    if all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=bool)
    return np.array([v if isinstance(v, str) else repr(v) for v in values], dtype=object)


def _new_store(store: Path, spec: SweepSpec, variants, until):
    """Build the store of ``variants`` beside ``store`` and rename it into place whole (an
    existing store is removed once the new one is in)."""
    import xarray as xr
    plans = {schedule(v.scene, until) for v in variants}
    frames = max(p.frames for p in plans)
    probes = _probe_names(variants)
    coords: dict = {"variant": np.arange(len(variants)),
              "component": np.array(["x", "y", "z"], dtype=object)}
    for key in variants[0].values:
        coords[key] = ("variant", _coord([v.values[key] for v in variants]))
    if len(plans) == 1:
        coords["time"] = next(iter(plans)).times()
    ds = xr.Dataset(_store_vars(variants, frames, probes), coords=coords,
                    attrs=dict(scene=str(spec.path), title=spec.title or variants[0].scene.title,
                               varied=list(variants[0].values), zip=int(spec.zipped),
                               ensemble=int(spec.ensemble or 0), plot=spec.plot or ""))
    rows = chunk_rows(len(variants), frames + 1)
    enc = {k: {"chunks": (rows,) + ds[k].shape[1:]} for k in ds.data_vars}
    new = sweep_store.hidden(store, "new")
    try:
        ds.to_zarr(new, mode="w", encoding=enc, zarr_format=2, consolidated=True)
        sweep_store.write_manifest(dict(probes=probes, variants=[v.key for v in variants],
                                        values=[_plain(v.values) for v in variants], until=until,
                                        scene=str(spec.path), files=scene_digests(spec)), new)
        sweep_store.install(new, store)
    except BaseException:
        shutil.rmtree(new, ignore_errors=True)
        raise
    return ds


def _plain(values: dict) -> dict:
    """A variant's varied values as JSON can hold them."""
    return json.loads(json.dumps(values, default=repr))


def scene_digests(spec: SweepSpec) -> dict:
    """{path: sha256} of the scene file and of every file it names (meshes, tables): what
    --resume finds unchanged, or refuses."""
    paths = [spec.path]

    def walk(node):
        if isinstance(node, dict):
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)
        elif isinstance(node, str) and node and len(node) < 4096:
            p = spec.path.parent / node
            try:
                if p.is_file():
                    paths.append(p)
            except OSError:
                pass
    walk(spec.doc)
    return {str(p): sweep_store.digest(p)[1] for p in dict.fromkeys(paths)}


def chunk_rows(n: int, nt: int) -> int:
    """Variants per chunk of the store: as many as fit CHUNK_BYTES of a probe's series. A
    chunk per variant made creating, writing and reading a store cost a file per variant
    and variable (seconds of the client's time for a few hundred variants, on the cores the
    workers need)."""
    return max(1, min(n, CHUNK_BYTES // (24 * max(nt, 1))))


# ---------------------------------------------------------------------- driving the cluster
CONNECT_TIMEOUT = 10   # s: an unreachable --scheduler is an error after this long, not a hang


def _client(client, scheduler, workers):
    """(client, cluster to close or None)."""
    from distributed import Client
    if client is not None:
        return client, None
    if scheduler is not None:
        try:
            return Client(scheduler, timeout=f"{CONNECT_TIMEOUT}s"), None
        except (OSError, TimeoutError) as e:
            raise ValueError(f"--scheduler {scheduler}: cannot reach it within {CONNECT_TIMEOUT} s "
                             f"({' '.join(str(e).split())})") from None
    n = workers or os.cpu_count() or 1
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"--workers must be a positive integer, got {workers!r}")
    cluster = local_cluster(n)
    return Client(cluster), cluster


# Dask's periodic chores, slowed down for clusters of a few processes that share the cores
# with the simulation: the event-loop tick every 20 ms, the system monitor every 0.5 s and the
# workers' statistical profiler (a stack sample every 10 ms) cost an idle 2-worker cluster 0.17
# CPU seconds per second, 0.05 with these
QUIET = {"distributed.admin.tick.interval": "1s",
         "distributed.admin.system-monitor.interval": "2s",
         "distributed.worker.profile.enabled": False}


# s: a worker that has lost its scheduler stops after this long (the local cluster's workers
# also end at once with the process that started them: distributed ties each to its parent)
DEATH_TIMEOUT = 30


def local_cluster(n: int):
    """The LocalCluster of a sweep: n single-threaded worker processes on 127.0.0.1, with
    distributed's chores slowed down (QUIET) and cosnet imported by each worker as it starts
    (in parallel, not when its first task arrives)."""
    import dask
    from distributed import LocalCluster
    with dask.config.set(QUIET):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                            dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR,
                            preload=["cosnet.studies.sweep"], death_timeout=DEATH_TIMEOUT)


def _batches(todo: list, batch: int | None, nworkers: int) -> list[list]:
    """Groups of variants per task: a few tasks per worker, so per-task overhead stays
    small while the load still balances."""
    size = batch or max(1, len(todo) // (4 * max(nworkers, 1)))
    return [todo[i:i + size] for i in range(0, len(todo), size)]


def sweep(scene, vary=(), zip=False, ensemble=None, until=None, out="out", name=None,
          client=None, scheduler=None, workers=None, batch=None, resume=False, overwrite=False,
          limits=True, retries=1, progress=None, vtk=False, flush_every=None):
    """Run a sweep and return its Dataset (opened from ``OUT/<name>.zarr``).

    scene: a scene file or sweep file (or ready case name); vary: ["KEY=VALUES", ...];
    zip: combine the variations element by element instead of as a product; ensemble: N
    seeds of [initial.perturbation]; until: end time for every variant; client / scheduler
    ("tcp://HOST:PORT") / workers (LocalCluster size, default one per core); batch: variants
    per task (default: about four tasks per worker); resume: keep the finished variants of an
    existing store (and run again those a check finds damaged); overwrite: replace an existing
    store (else it is refused); limits: refuse more than limits.MAX_VARIANTS variants;
    progress: called with a dict (done, failed, running, total, eta, dashboard) as the sweep
    goes; vtk: also write each variant's VTK series into OUT/<name>.vtk/variant_NNNN (written
    by the workers: on a cluster of several machines OUT must be a folder they share);
    flush_every: the longest a finished variant waits on the client before it is written (s;
    default FLUSH_EVERY; 0 writes each task's results as they arrive). OUT stays locked for the whole sweep, as a
    run locks its directory.
    """
    try:
        import distributed  # noqa: F401
        import xarray as xr
        import zarr  # noqa: F401
    except ImportError as e:
        raise ValueError(f"sweeps need the 'sweep' extra: pip install 'cosnet[sweep]' "
                         f"({e.name} is missing)") from None

    if resume and overwrite:
        raise ValueError("--resume continues a store and --overwrite replaces it: give one")
    spec = read_spec(scene_path(str(scene)), vary, zip if zip else None, ensemble, until)
    if limits:
        check_variants(variant_count(spec), str(spec.path))
    variants = plan(spec.doc, spec.path, spec.axes, spec.zipped, spec.ensemble or 0, spec.until)
    store = Path(out) / f"{name or spec.name or spec.path.stem}.zarr"
    series = str(store.with_suffix(".vtk").resolve()) if vtk else None
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise ValueError(f"--batch must be a positive integer, got {batch!r}")
    flush_every = FLUSH_EVERY if flush_every is None else flush_every
    if isinstance(flush_every, bool) or not isinstance(flush_every, (int, float)) or not flush_every >= 0:
        raise ValueError(f"--flush-every must be a number of seconds >= 0, got {flush_every!r}")
    with outdir.locked(Path(out), "sweep"):
        sweep_store.tidy(store)
        status = _status(store, spec, variants, resume, overwrite)
        todo = [v for v, s in zip_(variants, status or [PENDING] * len(variants))
                if s == PENDING or s.startswith("lost:")]
        if status is None and overwrite:   # the workers may start writing series before the store is made
            shutil.rmtree(store.with_suffix(".vtk"), ignore_errors=True)
        if todo or status is None:
            def open_store():
                if status is None:
                    _new_store(store, spec, variants, spec.until)
                return Store(store, _probe_names(variants))
            _run_all(open_store, spec, todo, client, scheduler, workers, batch, retries, progress, series,
                     flush_every)
    return xr.open_zarr(store)


def variant_count(spec: SweepSpec) -> int:
    """How many variants ``spec`` plans, counted before any is built."""
    lens = [len(v) for _, v in spec.axes]
    n = (max(lens) if spec.zipped else math.prod(lens)) if lens else 1
    ens = spec.ensemble if isinstance(spec.ensemble, int) and not isinstance(spec.ensemble, bool) else 0
    return n * max(ens, 1)


def _status(store: Path, spec: SweepSpec, variants, resume: bool, overwrite: bool) -> list | None:
    """Each variant's status in the store to continue, or None for a new store (refusing a
    store that exists unless ``resume`` or ``overwrite``)."""
    if store.exists() and not sweep_store.is_store(store):
        raise ValueError(f"{store}: exists and is not a sweep store; choose another --out or --name")
    if not store.exists() or overwrite:
        return None
    old = Store(store, _probe_names(variants))
    if not resume:
        raise ValueError(f"{store}: holds a sweep already ({old.n} variants, {len(old.done)} written); "
                         f"pass --resume to continue it or --overwrite to replace it")
    if old.man.get("cosnet") != package_version():
        raise ValueError(f"{store}: was begun by cosnet {old.man.get('cosnet')}, this is cosnet "
                         f"{package_version()}: its variants would not all be computed alike; finish it "
                         f"with that version, or pass --overwrite")
    if old.man["variants"] != [v.key for v in variants]:
        raise ValueError(f"{store}: holds another sweep (its variants' scenes differ from "
                         f"these); use another --out or --name, or drop --resume")
    now = scene_digests(spec)
    for path, sha in old.man["files"].items():
        if now.get(path) != sha:
            raise ValueError(f"{store}: {path} has changed since the sweep began; "
                             f"use another --out or --name, or --overwrite")
    damage = old.check()
    if damage:
        _repair(old, damage, store, spec, variants)
    return old.status()


def _repair(old: Store, damage, store: Path, spec: SweepSpec, variants):
    """Make a damaged store whole before it is continued: the files the plan makes from a
    new store built aside (only when such a file is damaged), the damaged variants pending."""
    import tempfile
    if all(old.chunk(k) is not None for k in damage.files):
        old.repair(damage, {})
        return
    with tempfile.TemporaryDirectory(dir=store.parent, prefix=f".{store.name}.ref-") as tmp:
        ref = Path(tmp) / store.name
        _new_store(ref, spec, variants, spec.until)
        reference = {k: (ref / k).read_bytes() for k in damage.files if (ref / k).is_file()}
    old.repair(damage, reference)


def check(store) -> tuple[int, str]:
    """(exit code, one line) of ``cosnet sweep --check STORE``: 0 when every file of the
    store matches its manifest, 1 when some are damaged (naming the variants affected)."""
    store = Path(store)
    if not store.is_dir() or not sweep_store.is_store(store):
        raise ValueError(f"{store}: not a sweep store (no {sweep_store.MANIFEST})")
    with outdir.locked(store.parent, "check"):
        s = Store(store)
        damage = s.check()
    head = f"{store}: {s.n} variants, {len(s.done)} written"
    if damage:
        return 1, f"{head}; {damage.line()}; --resume runs them again"
    return 0, f"{head}; every file intact (generation {s.man['generation']}, cosnet {s.man['cosnet']})"


zip_ = zip  # the builtin, as ``sweep`` takes a ``zip`` flag


def _probe_names(variants) -> list[str]:
    return list(dict.fromkeys(p.name for v in variants for p in v.scene.run.probes))


def _run_all(open_store, spec, todo, client, scheduler, workers, batch, retries, progress, series=None,
             flush_every=FLUSH_EVERY):
    """Run the variants ``todo`` on the cluster, writing each task's results into the store
    ``open_store()`` creates or opens -- while the first variant compiles the kernels on a
    worker, or, when this machine's cache holds them, while the first variants run."""
    from distributed import as_completed
    client, cluster = _client(client, scheduler, workers)
    try:
        if not todo:
            open_store()
            return
        # a local cluster shares this machine's kernel cache: when it holds the step already,
        # every worker loads it at once and nothing needs warming
        info = client.scheduler_info()
        nthreads = sum(w["nthreads"] for w in info["workers"].values()) or 1
        dash = getattr(client, "dashboard_link", None) if _has_dashboard(info) else None
        groups = _batches(todo, batch, nthreads)

        def submit():
            return {client.submit(run_batch, [(v.index, v.doc, str(spec.path)) for v in g],
                                  spec.until, series, pure=False, retries=retries): g for g in groups}
        if cluster is not None and _kernels_cached(todo[0]):
            # every worker loads the step from this machine's cache at once: the variants
            # start now, and the store is created while the first of them run
            futures = submit()
            out = open_store()
        else:
            warm = client.submit(warm_up, todo[0].doc, str(spec.path), pure=False)
            out = open_store()
            try:
                warm.result()
            except Exception:  # the variant fails in its own task, with its message recorded
                pass
            futures = submit()
        track = _Tracker(len(todo), len(groups[0]), dash, progress)
        track.update(client)
        buffer = _Buffer(out, flush_every)

        def tick():
            buffer.flush(due=True)
            track.update(client)
        try:
            for fut in _poll(as_completed(futures), tick):
                try:
                    results = fut.result()
                except Exception as e:  # the cluster gave up on this task (e.g. KilledWorker)
                    msg = " ".join(str(e).split())
                    results = [(v.index, dict(status=f"lost: {type(e).__name__}: {msg}"))
                               for v in futures[fut]]
                buffer.add(results)
                for _, rec in results:
                    track.finished(rec["status"] == "ok")
                track.update(client, force=True)
        finally:  # at the end, and on an interrupt or an error: what arrived is kept
            buffer.flush()
    finally:
        if cluster is not None:
            client.close()
            cluster.close()


class _Buffer:
    """Finished variants held on the client and written into the store together, at most
    ``every`` seconds after the first of them arrived (and at the end or on an interrupt):
    one write per variable for many tasks, instead of one per task on the process that
    shares the cores with the workers."""

    def __init__(self, store: Store, every: float = FLUSH_EVERY):
        self.store, self.since, self.every = store, math.inf, every
        self.held: list = []

    def add(self, results: list):
        if not self.held:
            self.since = time.monotonic()
        self.held.extend(results)
        self.flush(due=True)

    def flush(self, due: bool = False):
        """Write what is held (only once ``every`` seconds have passed, when ``due``)."""
        if not self.held or (due and time.monotonic() - self.since < self.every):
            return
        held, self.held = self.held, []
        self.store.write(held)


def _kernels_cached(variant) -> bool:
    """Whether the on-disk cache holds the step of this variant's simulation (False when
    the variant cannot even be built: its own task will say why)."""
    from ..output.record import kernels_compiled
    try:
        return kernels_compiled(variant.scene.simulation(threads=1))
    except Exception:  # noqa: BLE001 -- any failure: warm up as before
        return False


def _has_dashboard(info) -> bool:
    """Whether the scheduler serves the dashboard (its pages need bokeh, here as there)."""
    from importlib.util import find_spec
    return bool(info.get("services", {}).get("dashboard")) and find_spec("bokeh") is not None


def _poll(ac, tick, every=0.5):
    """The futures of ``ac`` as they finish, calling ``tick`` at least every ``every`` s."""
    while not ac.is_empty():
        ready = ac.next_batch(block=False)
        if not ready:
            tick()
            time.sleep(0.05)
            continue
        yield from ready


class _Tracker:
    """Counts of done / failed / running variants and an ETA, reported through a callback."""

    def __init__(self, total, per_task, dashboard, callback):
        self.total, self.per_task, self.dashboard, self.cb = total, per_task, dashboard, callback
        self.done = self.failed = self.running = 0
        self.t0 = time.perf_counter()
        self.last = -math.inf

    def finished(self, ok: bool):
        self.done += 1
        self.failed += not ok

    def update(self, client, force=False):
        now = time.perf_counter()
        if self.cb is None or (not force and now - self.last < 0.5):
            return
        self.last = now
        try:
            busy = sum(min(1, len(keys)) for keys in client.processing().values())
        except Exception:  # the scheduler is busy or gone: the counts stay as they were
            busy = 0
        self.running = min(busy * self.per_task, self.total - self.done)
        rate = self.done / max(now - self.t0, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else math.inf
        self.cb(dict(done=self.done, failed=self.failed, running=self.running, total=self.total,
                     eta=eta, elapsed=now - self.t0, dashboard=self.dashboard))
