"""A sweep's store under faults: nothing finished is lost, nothing is silently replaced.

Two sweeps at once, a repeated command, the client killed (SIGKILL) mid-variant, a full disk
(a real tmpfs) during a flush, a crash inside a commit, a truncated or deleted chunk, an
unreachable scheduler, a --vary that expands past the limit: each ends in one line with an
exit code, and a store that --check finds whole and --resume completes bit for bit.
"""

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")
xr = pytest.importorskip("xarray")

from cosnet import cli

from cosnet.core import limits

from cosnet.studies import sweep_store
from cosnet.studies.runner import run_probes
from cosnet.scene.loader import build_scene
from cosnet.studies.sweep import DEATH_TIMEOUT, check, sweep
from cosnet.studies.sweep_store import MANIFEST, Store
from cosnet.studies.variants import set_path
from nets import write_sweep_scene
from procs import session, spawn, started, wait_until
from test_fault_injection import command
from test_io import small_disk  # noqa: F401 -- the tmpfs fixture

E = [1e11, 1.5e11, 2e11, 2.5e11, 3e11, 3.5e11]
VARY = "materials.steel.E=" + ",".join(map(repr, E))
HOST = socket.gethostname()


@pytest.fixture(scope="module")
def long_scene(tmp_path_factory):
    """(scene, each variant's tip series run on its own) of variants long enough (about 1 s
    each) that a sweep of them can be caught running."""
    path = write_sweep_scene(tmp_path_factory.mktemp("long") / "s.toml", T="2.0")
    return path, reference(path)


def one_line(err: str) -> str:
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("cosnet: error:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def reference(path, values=E):
    """Each variant's tip series run on its own, as ``cosnet run`` runs it."""
    import tomllib
    out = []
    for v in values:
        doc = tomllib.loads(Path(path).read_text())
        set_path(doc, "materials.steel.E", v, str(path))
        out.append(run_probes(build_scene(doc, path)).probes["tip"])
    return np.array(out)


def files(store: Path) -> dict:
    return {k: (store / k).read_bytes() for k in sweep_store.store_files(store)}


def written(store: Path) -> list:
    try:
        return json.loads((store / MANIFEST).read_text())["done"]
    except (OSError, ValueError):
        return []


# ---------------------------------------------------------------------- refusals
def test_a_repeated_sweep_is_refused_and_overwrite_replaces(tmp_path, client, capsys):
    path = write_sweep_scene(tmp_path / "s.toml")
    first = sweep(path, vary=[VARY], out=tmp_path, client=client, name="r").load()
    before = files(tmp_path / "r.zarr")
    assert cli.main(["sweep", str(path), "--vary", "materials.steel.E=1e11,2e11", "--out", str(tmp_path),
                     "--name", "r"]) == 2
    assert one_line(capsys.readouterr().err) == (
        f"cosnet: error: {tmp_path / 'r.zarr'}: holds a sweep already (6 variants, 6 written); "
        f"pass --resume to continue it or --overwrite to replace it")
    assert files(tmp_path / "r.zarr") == before           # not a byte changed
    again = sweep(path, vary=["materials.steel.E=1e11,2e11"], out=tmp_path, client=client, name="r",
                  overwrite=True).load()
    assert again.sizes["variant"] == 2 and np.array_equal(again["tip"].values, first["tip"].values[[0, 2]])
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".r.zarr")] == []


def test_resume_refuses_another_sweep_a_changed_scene_or_another_version(tmp_path, client):
    path = write_sweep_scene(tmp_path / "s.toml")
    sweep(path, vary=["materials.steel.E=1e11,2e11"], out=tmp_path, client=client, name="r")
    with pytest.raises(ValueError, match="holds another sweep"):
        sweep(path, vary=["materials.steel.E=1e11,3e11"], out=tmp_path, client=client, name="r", resume=True)
    path.write_text(path.read_text() + "# a comment: the same variants, another file\n")
    with pytest.raises(ValueError, match=re.escape(f"{path} has changed since the sweep began")):
        sweep(path, vary=["materials.steel.E=1e11,2e11"], out=tmp_path, client=client, name="r", resume=True)
    manifest = tmp_path / "r.zarr" / MANIFEST
    doc = json.loads(manifest.read_text())
    manifest.write_text(json.dumps(dict(doc, cosnet="0.0.1")))
    with pytest.raises(ValueError, match="was begun by cosnet 0.0.1, this is cosnet"):
        sweep(path, vary=["materials.steel.E=1e11,2e11"], out=tmp_path, client=client, name="r", resume=True)
    with pytest.raises(ValueError, match="not a sweep store"):
        (tmp_path / "x.zarr").mkdir()
        sweep(path, vary=["materials.steel.E=1e11"], out=tmp_path, client=client, name="x", overwrite=True)


def test_more_variants_than_the_limit_are_refused_with_their_count(tmp_path, client, capsys, monkeypatch):
    path = write_sweep_scene(tmp_path / "s.toml")

    def planned(*a, **k):
        raise AssertionError("the variants were planned before the limit refused them")
    with monkeypatch.context() as m:
        m.setattr(sys.modules["cosnet.studies.sweep"], "plan", planned)
        assert cli.main(["sweep", str(path), "--vary", "materials.steel.E=linspace(1e11, 3e11, 200)",
                         "--vary", "materials.steel.G=linspace(7e10, 9e10, 200)", "--out", str(tmp_path)]) == 2
    assert one_line(capsys.readouterr().err) == (
        f"cosnet: error: {path}: the variations give 40,000 variants, above the limit of "
        f"{limits.MAX_VARIANTS:,}; pass --no-limits to go ahead")
    assert not (tmp_path / "s.zarr").exists()
    monkeypatch.setattr(limits, "MAX_VARIANTS", 2)
    with pytest.raises(ValueError, match="3 variants, above the limit of 2"):
        sweep(path, vary=["materials.steel.E=1e11,2e11,3e11"], out=tmp_path, client=client)
    ds = sweep(path, vary=["materials.steel.E=1e11,2e11,3e11"], out=tmp_path, client=client, limits=False)
    assert [str(s) for s in ds.status.values] == ["ok"] * 3


def test_an_unreachable_scheduler_is_one_line_naming_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(sys.modules["cosnet.studies.sweep"], "CONNECT_TIMEOUT", 2)
    with socket.socket() as s:   # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        addr = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    assert cli.main(["sweep", str(write_sweep_scene(tmp_path / "s.toml")), "--scheduler", addr,
                     "--out", str(tmp_path)]) == 2
    line = one_line(capsys.readouterr().err)   # the connection's time-out, not a hang, ended it
    assert line.startswith(f"cosnet: error: --scheduler {addr}: cannot reach it within 2 s")


# ---------------------------------------------------------------------- processes
def test_two_sweeps_at_once_the_second_is_refused_naming_the_first(tmp_path, long_scene):
    """While a sweep runs, a second sweep into its store and a run into its directory are
    each refused in one line naming the sweep's process and host; the first sweep ends with
    every variant, equal to the variants run one by one."""
    path, ref = long_scene
    store = tmp_path / "s.zarr"
    lock = tmp_path / ".cosnet.lock"
    with started(command("sweep", path, "--vary", VARY, "--out", tmp_path, "--batch", "1", "--workers", "2"),
                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as first:
        # held from before the cluster starts: its pid is in the lock file
        assert wait_until(lambda: (lock.exists() and lock.read_text().startswith(f"{first.pid} "))
                          or first.poll() is not None, 120)
        assert first.poll() is None, first.communicate()
        second = [spawn(command(*argv), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                  for argv in (("sweep", path, "--vary", "materials.steel.E=1e11,2e11", "--out", tmp_path),
                               ("run", path, "--out", tmp_path))]
        for p in second:
            _, err = p.communicate(timeout=120)
            assert p.returncode == 2 and one_line(err) == (
                f"cosnet: error: {tmp_path}: another sweep (process {first.pid} on {HOST}) is writing "
                f"into it; wait for it to end or choose another --out"), err
        assert first.poll() is None, "the first sweep ended before the others were refused"
        out, err = first.communicate(timeout=300)
        assert first.returncode == 0, err
    ds = xr.open_zarr(store).load()
    assert [str(s) for s in ds.status.values] == ["ok"] * 6
    assert np.array_equal(ds["tip"].values, ref)


def test_a_killed_client_takes_its_workers_and_resumes_bit_for_bit(tmp_path, long_scene):
    """SIGKILL to the client alone, once some variants are written: its local cluster's
    workers end with it; the store is whole; --resume runs the rest, and every variant equals
    the same scene run on its own."""
    path, ref = long_scene
    store = tmp_path / "s.zarr"
    argv = ("sweep", path, "--vary", VARY, "--out", tmp_path, "--batch", "1", "--workers", "2",
            "--flush-every", "0")   # each variant written as it comes: killed between two of them
    with started(command(*argv), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                 start_new_session=True) as proc:
        assert wait_until(lambda: written(store) or proc.poll() is not None, 240)
        assert proc.poll() is None and len(written(store)) < 6, "the sweep ended before it could be killed"
        assert len(session(proc.pid)) > 1                       # the client and its workers
        proc.send_signal(signal.SIGKILL)
        assert proc.wait(timeout=10) == -signal.SIGKILL
        assert wait_until(lambda: not session(proc.pid), DEATH_TIMEOUT + 10), session(proc.pid)
    kept = written(store)
    code, line = check(store)
    assert code == 0 and "every file intact" in line, line
    before = xr.open_zarr(store).load()
    r = subprocess.run(command(*argv, "--resume"), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    ds = xr.open_zarr(store).load()
    assert [str(s) for s in ds.status.values] == ["ok"] * 6
    assert np.array_equal(ds["tip"].values, ref)
    assert np.array_equal(ds.wall_time.values[kept], before.wall_time.values[kept])   # not run again


# ---------------------------------------------------------------------- the store's own faults
def test_a_full_disk_during_a_flush_loses_nothing_written(tmp_path, client, small_disk):  # noqa: F811
    """A real tmpfs fills up once the first variant is written: the next flush stops the
    sweep with ENOSPC naming a file of the store, no new file is left, the store is whole and
    keeps what was written; with room again --resume ends with every variant equal to its own
    run."""
    path = write_sweep_scene(tmp_path / "s.toml")
    mnt = small_disk("size=4m")
    store = mnt / "s.zarr"
    filler = mnt / "filler"

    def fill(p):
        if written(store) and not filler.exists():
            try:
                with open(filler, "wb") as f:
                    while True:
                        f.write(b"\0" * 65536)
                        f.flush()
            except OSError:   # full
                pass
    with pytest.raises(OSError, match="No space left on device") as e:
        sweep(path, vary=[VARY], out=mnt, client=client, batch=1, progress=fill, flush_every=0)
    assert str(store) in str(e.value.filename)
    assert not [k for k in os.listdir(store) if ".g" in k or k.endswith(".tmp")]
    kept = written(store)
    assert 1 <= len(kept) < 6
    filler.unlink()
    code, line = check(store)
    assert code == 0, line
    ds = sweep(path, vary=[VARY], out=mnt, client=client, resume=True).load()
    assert [str(s) for s in ds.status.values] == ["ok"] * 6
    assert np.array_equal(ds["tip"].values, reference(path))


def test_a_commit_cut_short_lands_whole_or_not_at_all(tmp_path, client, monkeypatch):
    """A crash after the new chunks are written but before the manifest is replaced leaves
    the store as before (the new files are removed when it is opened); a crash after the
    manifest but before the renames is rolled forward when it is opened."""
    path = write_sweep_scene(tmp_path / "s.toml")
    full = sweep(path, vary=[VARY], out=tmp_path, client=client, name="r").load()
    root = tmp_path / "r.zarr"
    Store(root).forget([1, 4])
    before = files(root)
    rec = {"times": full.frame_time.values[1], "probes": {n: full[n].values[1] for n in ("tip", "rod@0.5")},
           "status": "ok", "steps": 3, "dt": 1e-6, "wall": 0.5, "compiled": 0, "worker": "w"}

    class Crash(Exception):
        pass

    def crash(*a, **k):
        raise Crash
    with monkeypatch.context() as m:                 # before the manifest: nothing lands
        m.setattr(sweep_store, "_write_json", crash)
        with pytest.raises(Crash):
            Store(root).write([(1, rec)])
    assert files(root) == before and written(root) == [0, 2, 3, 5]
    s = Store(root)
    with monkeypatch.context() as m:                 # after the manifest: the renames are left undone
        m.setattr(Store, "_roll_forward", lambda self: None)
        s.write([(1, rec)])
    assert any(k.endswith(f".g{s.man['generation']}") for k in os.listdir(root / "tip"))
    again = Store(root)                              # opened again: rolled forward
    assert not again.check() and written(root) == [0, 1, 2, 3, 5]
    ds = xr.open_zarr(root).load()
    assert np.array_equal(ds["tip"].values[1], full["tip"].values[1])
    assert [str(x) for x in ds.status.values] == ["ok", "ok", "ok", "ok", "pending", "ok"]


@pytest.mark.parametrize("harm", ["truncate", "delete"])
def test_a_damaged_chunk_is_named_by_check_and_rerun_by_resume(tmp_path, client, capsys, harm):
    path = write_sweep_scene(tmp_path / "s.toml")
    full = sweep(path, vary=[VARY], out=tmp_path, client=client, name="d").load()
    root = tmp_path / "d.zarr"
    chunk = root / "rod@0.5" / "0.0.0"
    if harm == "truncate":
        chunk.write_bytes(chunk.read_bytes()[:50])
    else:
        chunk.unlink()
    assert cli.main(["sweep", "--check", str(root)]) == 1
    why = "truncated" if harm == "truncate" else "missing"
    assert capsys.readouterr().out.strip() == (
        f"{root}: 6 variants, 6 written; damaged: variants 0, 1, 2, 3, 4, 5 (rod@0.5/0.0.0 {why}); "
        f"--resume runs them again")
    seen = []
    ds = sweep(path, vary=[VARY], out=tmp_path, client=client, name="d", resume=True,
               progress=seen.append).load()
    assert {p["total"] for p in seen} == {6}
    for name in ("tip", "rod@0.5", "frame_time"):
        assert np.array_equal(ds[name].values, full[name].values)
    assert cli.main(["sweep", "--check", str(root)]) == 0
    assert "every file intact" in capsys.readouterr().out


def test_damaged_metadata_is_rebuilt_from_the_plan(tmp_path, client):
    path = write_sweep_scene(tmp_path / "s.toml")
    full = sweep(path, vary=[VARY], out=tmp_path, client=client, name="m").load()
    root = tmp_path / "m.zarr"
    (root / ".zmetadata").write_text("{}")
    (root / "materials.steel.E" / "0").unlink()
    damage = Store(root).check()
    assert set(damage.files) == {".zmetadata", "materials.steel.E/0"} and damage.variants == []
    seen = []
    ds = sweep(path, vary=[VARY], out=tmp_path, client=client, name="m", resume=True,
               progress=seen.append).load()
    assert seen == [] and list(ds["materials.steel.E"].values) == E   # nothing to run again
    assert np.array_equal(ds["tip"].values, full["tip"].values)
    shutil.rmtree(root)
