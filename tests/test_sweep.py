"""cosnet sweep: variants as Dask tasks, equal bit for bit to the same scenes run one by one.

Clusters here are real: a LocalCluster of two worker processes, and a `dask scheduler` with
`dask worker` processes started on 127.0.0.1. Scenes are tiny (a 4-element cantilever, a
few hundred steps) so that the whole file stays short.
"""

import json
import os
import re
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")
xr = pytest.importorskip("xarray")

from cosnet import cli, load_scene
from nets import write_sweep_scene as write_scene
from procs import spawn
from cosnet.studies.runner import run_probes
from cosnet.scene.loader import build_scene
from cosnet.studies.sweep import sweep
from cosnet.studies.variants import parse_vary, plan, set_path

def read_csv(path):
    rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return rows[:, 1], rows[:, 2:]


# ---------------------------------------------------------------------- variations
def test_vary_forms():
    assert parse_vary("materials.steel.E=1e11, 2e11,3e11", "s") == ("materials.steel.E", [1e11, 2e11, 3e11])
    assert parse_vary("lines.rod.elements=linspace(4, 16, 4)", "s")[1] == [4, 8, 12, 16]
    assert parse_vary("k=linspace(0, 1, 3)", "s")[1] == [0.0, 0.5, 1.0]
    assert parse_vary("k=logspace(9, 11, 3)", "s")[1] == [1e9, 1e10, 1e11]
    assert parse_vary("k=geomspace(2, 8, 3)", "s")[1] == pytest.approx([2.0, 4.0, 8.0], rel=1e-15)
    assert parse_vary("run.stepper=verlet,pefrl", "s")[1] == ["verlet", "pefrl"]
    assert parse_vary("g=[0, 0, -9.81], [0, 0, -1.62]", "s")[1] == [[0, 0, -9.81], [0, 0, -1.62]]
    doc = {"lines": {"λ1": {"elements": 8}}, "effects": [{"kind": "gravity"}, {"kind": "damping"}]}
    set_path(doc, 'lines."λ1".elements', 4, "s")
    set_path(doc, "effects[1].translational", 2.0, "s")
    set_path(doc, "initial.perturbation.seed", 3, "s")
    assert doc["lines"]["λ1"]["elements"] == 4 and doc["effects"][1]["translational"] == 2.0
    assert doc["initial"] == {"perturbation": {"seed": 3}}


def test_product_zip_and_ensemble(tmp_path):
    path = write_scene(tmp_path / "s.toml", V="0.01")
    doc = __import__("tomllib").loads(path.read_text())
    axes = [parse_vary("materials.steel.E=1e11,2e11", "s"), parse_vary("lines.rod.elements=4,6", "s")]
    assert [v.values for v in plan(doc, path, axes)] == [
        {"materials.steel.E": 1e11, "lines.rod.elements": 4}, {"materials.steel.E": 1e11, "lines.rod.elements": 6},
        {"materials.steel.E": 2e11, "lines.rod.elements": 4}, {"materials.steel.E": 2e11, "lines.rod.elements": 6}]
    zipped = plan(doc, path, axes, zipped=True, ensemble=2)
    assert [(v.values["lines.rod.elements"], v.values["initial.perturbation.seed"]) for v in zipped] == [
        (4, 7), (4, 8), (6, 7), (6, 8)]
    assert zipped[1].scene.initial.seed == 8 and zipped[1].scene.net.lines[0].elements == 4
    assert len({v.key for v in zipped}) == 4


BAD = [  # --vary, what the one-line error says
    ("materials.steel.EE=1e11", "[materials.steel] EE: unknown key"),
    ("materials.steel.E=stiff", "[materials.steel] E:"),
    ("materials.steel.E=", "--vary materials.steel.E: no values"),
    ("materials.steel.E=linspace(1e11, 2e11)", "cannot parse linspace(1e11, 2e11)"),
    ("materials.steel.E=logspace(a, b, 3)", "cannot parse logspace(a, b, 3)"),
    ("materials.steel.E=sweep(1, 2, 3)", "ranges are linspace"),
    ("effects[3].g=1", "effects is a list of 1 tables"),
]


@pytest.mark.parametrize("spec,said", BAD, ids=[b[0] for b in BAD])
def test_bad_vary_is_one_line_exit_2_before_anything_runs(tmp_path, capsys, spec, said):
    path = write_scene(tmp_path / "s.toml")
    out = tmp_path / "out"
    assert cli.main(["sweep", str(path), "--vary", spec, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"cosnet: error: {path}: ") and err.count("\n") == 1 and said in err
    assert not out.exists()   # nothing ran, no store


def test_bad_key_gets_the_scene_loaders_own_message(tmp_path, capsys):
    path = write_scene(tmp_path / "s.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text(path.read_text().replace("E = 2.1e11", "EE = 2.1e11\nE = 2.1e11"))
    with pytest.raises(ValueError) as e:
        load_scene(bad)
    cli.main(["sweep", str(path), "--vary", "materials.steel.EE=2.1e11", "--out", str(tmp_path)])
    assert capsys.readouterr().err == f"cosnet: error: {e.value}\n".replace(str(bad), str(path))


def test_missing_extra_is_named_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "zarr", None)   # as if not installed
    assert cli.main(["sweep", str(write_scene(tmp_path / "s.toml")), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == ("cosnet: error: sweeps need the 'sweep' extra: "
                                       "pip install 'cosnet[sweep]' (zarr is missing)\n")


# ---------------------------------------------------------------------- on a LocalCluster
def test_local_cluster_equals_cosnet_run_bit_for_bit(tmp_path, client, capsys):
    path = write_scene(tmp_path / "s.toml")
    values = ["1e11", "2.1e11", "4e11"]
    ds = sweep(path, vary=[f"materials.steel.E={','.join(values)}"], out=tmp_path / "sw", client=client,
               vtk=True)
    assert list(ds["materials.steel.E"].values) == [1e11, 2.1e11, 4e11]
    assert ds.sizes == {"variant": 3, "time": 4, "component": 3}
    assert list(ds.time.values) == pytest.approx([0.0, 0.004, 0.008, 0.012], abs=1e-15)
    for i, E in enumerate(values):
        run_dir = tmp_path / f"run{i}"
        assert cli.main(["run", str(write_scene(tmp_path / f"v{i}.toml", E=E)), "--out", str(run_dir)]) == 0
        t, cols = read_csv(run_dir / "probes.csv")
        assert np.array_equal(ds.frame_time.values[i], t)
        assert np.array_equal(ds["tip"].values[i], cols[:, 0:3])
        assert np.array_equal(ds["rod@0.5"].values[i], cols[:, 3:6])
        assert ds.status.values[i] == "ok" and ds.steps.values[i] > 0 and ds.dt.values[i] > 0
        # the variant's own VTK series (--vtk) holds the frames cosnet run wrote, byte for byte
        series = tmp_path / "sw" / "s.vtk" / f"variant_{i:04d}"
        frames = sorted(p.name for p in run_dir.glob("*.vtu"))
        assert frames and frames == sorted(p.name for p in series.glob("*.vtu"))
        for name in frames + ["series.pvd", "meta.json"]:
            assert (series / name).read_bytes() == (run_dir / name).read_bytes(), name
    # each worker process loads the kernels from the shared on-disk cache: no variant compiles
    assert list(ds.compiled.values) == [0, 0, 0]
    capsys.readouterr()


def test_unstable_variant_is_recorded_and_the_others_go_on(tmp_path, client):
    path = write_scene(tmp_path / "s.toml")
    ds = sweep(path, vary=["run.dt=2e-6,1e-4,2.2e-6", "run.force_dt=true,true,true"], zip=True,
               out=tmp_path, client=client, batch=3)
    status = [str(s) for s in ds.status.values]
    assert status[0] == status[2] == "ok"
    assert "unstable" in status[1].lower() or "non-finite" in status[1].lower(), status[1]
    tip = ds["tip"].values[1]
    assert np.isfinite(tip[0]).all() and np.isnan(tip[-1]).all()   # frames after the failure: NaN
    ref = run_probes(build_scene(ds_doc(path, {"run": {"dt": 2.2e-6, "force_dt": True}}), path))
    assert np.array_equal(ds["tip"].values[2], ref.probes["tip"])


def ds_doc(path, changes):
    import tomllib
    doc = tomllib.loads(Path(path).read_text())
    for table, kv in changes.items():
        doc[table].update(kv)
    return doc


def test_resume_runs_only_unfinished_variants(tmp_path, client):
    from cosnet.studies.sweep_store import Store
    path = write_scene(tmp_path / "s.toml")
    vary = ["materials.steel.E=1e11,2e11,3e11"]
    first = sweep(path, vary=vary, out=tmp_path, client=client, name="r").load()
    Store(tmp_path / "r.zarr").forget([1])   # as if killed before variant 1 came in
    seen = []
    again = sweep(path, vary=vary, out=tmp_path, client=client, name="r", resume=True,
                  progress=seen.append).load()
    assert seen and {p["total"] for p in seen} == {1}
    assert np.array_equal(again["tip"].values, first["tip"].values)
    assert np.array_equal(again.wall_time.values[[0, 2]], first.wall_time.values[[0, 2]])
    seen.clear()
    sweep(path, vary=vary, out=tmp_path, client=client, name="r", resume=True, progress=seen.append)
    assert seen == []   # nothing left to run
    with pytest.raises(ValueError, match="holds another sweep"):
        sweep(path, vary=["materials.steel.E=1e11,2e11"], out=tmp_path, client=client, name="r", resume=True)


def test_an_interrupted_sweep_keeps_what_arrived_and_resumes(tmp_path, client):
    """Finished variants wait on the client to be written together; an interrupt writes
    them before it leaves, and --resume runs only the rest."""
    path = write_scene(tmp_path / "s.toml")
    values = [1e11, 1.5e11, 2e11, 2.5e11, 3e11, 3.5e11]
    vary = ["materials.steel.E=" + ",".join(map(repr, values))]

    def stop(p):
        if p["done"]:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        sweep(path, vary=vary, out=tmp_path, client=client, name="i", batch=1, progress=stop)
    ds = xr.open_zarr(tmp_path / "i.zarr").load()
    status = [str(s) for s in ds.status.values]
    assert status.count("ok") == 1 and status.count("pending") == 5   # the first task: one variant
    done = status.index("ok")
    doc = ds_doc(path, {})
    set_path(doc, "materials.steel.E", values[done], str(path))
    assert np.array_equal(ds["tip"].values[done], run_probes(build_scene(doc, path)).probes["tip"])
    seen = []
    again = sweep(path, vary=vary, out=tmp_path, client=client, name="i", resume=True,
                  progress=seen.append).load()
    assert {p["total"] for p in seen} == {5} and [str(s) for s in again.status.values] == ["ok"] * 6
    assert again.wall_time.values[done] == ds.wall_time.values[done]


def test_ensemble_spreads_the_seeded_perturbation(tmp_path, client):
    path = write_scene(tmp_path / "s.toml", V="0.01")
    ds = sweep(path, ensemble=3, out=tmp_path, client=client)
    assert list(ds["initial.perturbation.seed"].values) == [7, 8, 9]
    tips = ds["tip"].values[:, -1, :]
    assert len({tuple(t) for t in tips}) == 3
    for i, seed in enumerate([7, 8, 9]):
        doc = ds_doc(path, {})
        set_path(doc, "initial.perturbation.seed", seed, str(path))
        assert np.array_equal(run_probes(build_scene(doc, path)).probes["tip"], ds["tip"].values[i])


# ---------------------------------------------------------------------- a scheduler at an address
def dask_exe():
    return str(Path(sys.executable).with_name("dask"))


def listening(proc, file: Path, log: Path, timeout=120.0) -> str:
    """The address the scheduler ``proc`` wrote to its scheduler file once it listened. It
    picks its own port: a port picked here and handed over could be taken by another process
    (a browser, a page server, another test's worker) before the scheduler binds it."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"dask scheduler exited: {log.read_text()[-600:]}")
        try:
            return json.loads(file.read_text())["address"]
        except (OSError, ValueError, KeyError):   # not written yet, or half written
            time.sleep(0.1)
    raise TimeoutError(f"dask scheduler did not listen within {timeout:g} s: {log.read_text()[-600:]}")


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    """(address, [worker processes]) of a `dask scheduler` and two `dask worker` processes
    without nannies (a killed worker stays dead), all killed with the test process."""
    log = tmp_path_factory.mktemp("dask")
    procs = [spawn([dask_exe(), "scheduler", "--host", "127.0.0.1", "--port", "0",
                    "--scheduler-file", str(log / "scheduler.json"), "--dashboard-address", "127.0.0.1:0"],
                   stdout=subprocess.DEVNULL, stderr=open(log / "scheduler.log", "w"))]
    try:
        addr = listening(procs[0], log / "scheduler.json", log / "scheduler.log")
        workers = [spawn([dask_exe(), "worker", addr, "--nthreads", "1", "--no-nanny", "--death-timeout", "60",
                          "--host", "127.0.0.1", "--dashboard-address", "127.0.0.1:0", "--name", f"w{i}"],
                         stdout=subprocess.DEVNULL, stderr=open(log / f"w{i}.log", "w"))
                   for i in range(2)]
        procs += workers
        from distributed import Client
        with Client(addr, timeout="60s") as c:
            c.wait_for_workers(2, timeout=120)
        yield addr, workers
    finally:
        for p in procs:   # our own processes; nothing of theirs needs a graceful close
            p.kill()
            p.wait()


def test_scheduler_address_from_the_command_line(tmp_path, scheduler, capsys):
    addr, _ = scheduler
    path = write_scene(tmp_path / "s.toml")
    assert cli.main(["sweep", str(path), "--vary", "materials.steel.E=1e11,2.1e11", "--scheduler", addr,
                     "--out", str(tmp_path), "--plot"]) == 0
    out = capsys.readouterr().out
    assert "2 ok, 0 failed, 0 pending of 2 variants" in out
    ds = xr.open_zarr(tmp_path / "s.zarr")
    run_dir = tmp_path / "run"
    cli.main(["run", str(write_scene(tmp_path / "v.toml", E="2.1e11")), "--out", str(run_dir)])
    t, cols = read_csv(run_dir / "probes.csv")
    assert np.array_equal(ds["tip"].values[1], cols[:, 0:3])
    png = tmp_path / "s.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


DOCS = Path(__file__).resolve().parent.parent / "docs" / "sweeps.md"


def doc_blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", DOCS.read_text(), re.S)


def test_docs_commands_and_python_run_as_written(tmp_path, scheduler, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SCHEDULER", scheduler[0])
    lines = [ln for b in doc_blocks("sh") for ln in b.splitlines() if ln.strip()]
    assert len(lines) == 5
    for line in lines:
        argv = [os.path.expandvars(a) for a in shlex.split(line)]
        assert argv[0] == "cosnet" and cli.main(argv[1:]) == 0, line
    assert cli.main([os.path.expandvars(a) for a in shlex.split(lines[2])][1:]) == 2   # again: refused
    assert "holds a sweep already (2 variants, 2 written)" in capsys.readouterr().err
    assert (tmp_path / "out" / "bridge_stiffness.png").stat().st_size > 0
    ens = xr.open_zarr(tmp_path / "out" / "cantilever.zarr")
    assert ens.sizes["variant"] == 6 and list(ens["initial.perturbation.seed"].values) == [0, 1, 2] * 2
    (code,) = doc_blocks("python")
    exec(compile(code, str(DOCS), "exec"), {})
    sag = xr.open_zarr(tmp_path / "out" / "cantilever_E.zarr")["tip"].values[:, -1, 2]
    assert sag.shape == (2,) and np.all(sag < 0)   # under gravity, the tip has gone down
    capsys.readouterr()


def test_a_killed_workers_tasks_complete_elsewhere(tmp_path, scheduler):
    from distributed import Client
    addr, workers = scheduler
    path = write_scene(tmp_path / "s.toml", T="0.2")
    values = [1e11, 1.5e11, 2e11, 2.5e11, 3e11, 3.5e11]
    killed = []
    with Client(addr, timeout="30s") as c:
        victim = next(a for a, w in c.scheduler_info()["workers"].items() if w["name"] == "w1")

        def progress(p):
            if not killed and c.processing().get(victim):
                workers[1].send_signal(signal.SIGKILL)
                killed.append(victim)
        ds = sweep(path, vary=["materials.steel.E=" + ",".join(map(repr, values))], out=tmp_path,
                   client=c, batch=1, progress=progress)
    assert killed and workers[1].wait(timeout=10) == -signal.SIGKILL
    assert [str(s) for s in ds.status.values] == ["ok"] * 6
    doc = ds_doc(path, {})
    for i, E in enumerate(values):
        set_path(doc, "materials.steel.E", E, str(path))
        assert np.array_equal(run_probes(build_scene(doc, path)).probes["tip"], ds["tip"].values[i])


# the code blocks of docs/sweeps.md run above, as written
