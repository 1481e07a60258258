"""Fault injection on the cosnet command: runs killed (SIGKILL) at random points and resumed
end bit for bit where an uninterrupted run ends; Ctrl-C leaves a resumable run; two runs into
one directory never interleave; a corrupted checkpoint is refused in one line; and a fuzzer
that mutates the ready cases gets either a one-line refusal or a valid short run, never a
traceback. Seeded and derandomised, so CI sees the same faults every time."""

from __future__ import annotations

import contextlib
import io
import math
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cosnet import cli
from cosnet.output.io import read_output
from test_cli import REPO, TINY, cosnet
from test_scene import dumps
from procs import spawn

# 101 frames of the tiny rod: runs long enough that a signal sent a few frames in lands
# before the end even when this process is starved for a while (at 0.3 s, 31 frames took
# under half a second, and a loaded machine let a run finish before its Ctrl-C)
UNTIL = 1.0
FRAMES = 101


def command(*args):
    return [sys.executable, "-m", "cosnet.cli", *map(str, args)]


def frames_written(out: Path) -> int:
    try:
        return (out / "series.pvd").read_text().count("<DataSet") // 2
    except OSError:
        return 0


def stop_after(proc, out: Path, frames: int, sig, extra: float = 0.0):
    """Send ``sig`` to ``proc`` once ``out`` holds ``frames`` frames (plus ``extra`` s)."""
    deadline = time.time() + 120
    while frames_written(out) < frames and proc.poll() is None and time.time() < deadline:
        time.sleep(0.005)
    time.sleep(extra)
    proc.send_signal(sig)
    return proc.wait(timeout=120)


def one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cosnet: error: "), stderr
    assert "Traceback" not in stderr
    return lines[0]


def assert_same_run(a: Path, b: Path):
    """Every frame, the probes, the energy budget and the checkpoint of two runs are identical."""
    ra, rb = read_output(a), read_output(b)
    np.testing.assert_array_equal(ra.times, rb.times)
    for k in range(len(ra.times)):
        fa, fb = ra.frame(k), rb.frame(k)
        for f, arr in fa["lines"]["rod"].items():
            np.testing.assert_array_equal(arr, fb["lines"]["rod"][f], err_msg=f"frame {k} {f}")
        for f, arr in fa["nodes"].items():
            np.testing.assert_array_equal(arr, fb["nodes"][f], err_msg=f"frame {k} {f}")
    assert (a / "probes.csv").read_text() == (b / "probes.csv").read_text()
    assert (a / "energy.csv").read_text() == (b / "energy.csv").read_text()
    with np.load(a / "checkpoint.npz") as ca, np.load(b / "checkpoint.npz") as cb:
        assert ca.files == cb.files
        for key in ca.files:
            np.testing.assert_array_equal(ca[key], cb[key], err_msg=key)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    p = tmp_path_factory.mktemp("scene") / "tiny.toml"
    p.write_text(TINY)
    return p


@pytest.fixture(scope="module")
def full(scene, tmp_path_factory):
    """The uninterrupted run every faulted run must end equal to."""
    out = tmp_path_factory.mktemp("full") / "out"
    r = cosnet("run", scene, "--out", out, "--until", UNTIL)
    assert r.returncode == 0, r.stderr
    assert len(read_output(out).times) == FRAMES
    return out


def test_killed_at_random_points_and_resumed_ends_bit_identical(scene, full, tmp_path):
    """SIGKILL during the first run, again during its resumption, then resume to the end."""
    rng = np.random.default_rng(2026)
    first = int(rng.integers(2, 10))
    second = int(rng.integers(first + 3, 22))
    out = tmp_path / "cut"
    for k, args in ((first, ()), (second, ("--resume",))):
        proc = spawn(command("run", scene, "--out", out, "--until", UNTIL, *args), cwd=REPO,
                     stderr=subprocess.DEVNULL)
        code = stop_after(proc, out, k, signal.SIGKILL, extra=float(rng.uniform(0.0, 0.02)))
        assert code == -signal.SIGKILL, "the run ended before it could be killed"
        assert k <= len(read_output(out).times) < FRAMES    # every listed frame opens
    r = cosnet("run", scene, "--out", out, "--until", UNTIL, "--resume")
    assert r.returncode == 0, r.stderr
    assert_same_run(full, out)


def test_ctrl_c_exits_130_and_leaves_a_resumable_run(scene, full, tmp_path):
    out = tmp_path / "cut"
    # started with SIGINT ignored, as a shell starts a background job: still interrupted
    proc = spawn(command("run", scene, "--out", out, "--until", UNTIL), cwd=REPO,
                 stderr=subprocess.PIPE, text=True, then=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.time() + 120
    while frames_written(out) < 4 and proc.poll() is None and time.time() < deadline:
        time.sleep(0.005)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "cosnet: interrupted (resume with --resume)"
    assert "Traceback" not in err
    r = cosnet("run", scene, "--out", out, "--until", UNTIL, "--resume")
    assert r.returncode == 0, r.stderr
    assert_same_run(full, out)


def test_two_runs_into_one_directory_one_is_refused(scene, full, tmp_path):
    """Started together: one writes the run, the other is refused in one line (the directory
    is locked, or already holds a run), and the probes are not interleaved."""
    out = tmp_path / "both"
    procs = [spawn(command("run", scene, "--out", out, "--until", UNTIL), cwd=REPO,
                   stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [(p.wait(timeout=180), p.stderr.read()) for p in procs]
    codes = sorted(c for c, _ in results)
    assert codes == [0, 2], results
    refusal = one_error_line(next(e for c, e in results if c == 2))
    assert re.search(r"another run \(process \d+ on \S+\) is writing into it|holds a run already", refusal)
    assert_same_run(full, out)


def test_a_directory_locked_by_a_running_run_is_refused(scene, tmp_path):
    """A run into a directory another run holds is refused, and so is a picture that would
    be written into it."""
    import os
    import socket

    from cosnet.output import outdir
    out = tmp_path / "held"
    with outdir.locked(out):
        runs = [cosnet("run", scene, "--out", out, "--until", 0.02), cosnet("render", out, "--png")]
    for r in runs:
        assert r.returncode == 2
        assert one_error_line(r.stderr) == (f"cosnet: error: {out}: another run (process {os.getpid()} on "
                                            f"{socket.gethostname()}) is writing into it; wait for it to "
                                            f"end or choose another --out")
    assert not (out / "series.pvd").exists() and not (out / "render.png").exists()


@pytest.mark.parametrize("damage", ["truncated", "random bytes"])
def test_a_corrupted_checkpoint_is_refused_in_one_line(scene, full, tmp_path, damage):
    out = tmp_path / "copy"
    shutil.copytree(full, out)
    ckpt = out / "checkpoint.npz"
    data = ckpt.read_bytes()
    if damage == "truncated":
        ckpt.write_bytes(data[: len(data) // 2])
    else:
        ckpt.write_bytes(np.random.default_rng(7).bytes(len(data)))
    r = cosnet("run", scene, "--out", out, "--until", UNTIL, "--resume")
    assert r.returncode == 2
    assert "checkpoint.npz" in one_error_line(r.stderr)


# ---------------------------------------------------------------------- the scene fuzzer
# The footbridge is left out: its lorry is 26 node loads unrolled into the step, so each
# mutation that changes its effects costs a fresh compilation of about 40 s; figure_1_1 has
# the same kinds of tables and the other cases every kind of effect.
CASES = sorted(p for p in (REPO / "cases").glob("*.toml") if p.stem != "bridge")
EXTREMES = [math.nan, math.inf, -math.inf, -1.0, 0.0, -0.0, 1e300, -1e300, 1e-300, 10**30, -(10**30),
            2**63, 1e-12, 3]
ODD_NAMES = ["λ1", "", "a\nb", "\u2028", "名前", "x" * 300, "\x00", "a.b", "'q'", '"']


def paths_in(d, path=()):
    """(path of the containing table, key) of every key of a parsed scene."""
    items = d.items() if isinstance(d, dict) else enumerate(d) if isinstance(d, list) else ()
    for k, v in items:
        yield path, k
        yield from paths_in(v, path + (k,))


def container(data, path):
    for p in path:
        data = data[p]
    return data


@st.composite
def mutated_scenes(draw):
    """A ready case with one to three mutations: a key deleted, a value of another type, an
    extreme number (NaN, inf, negative, huge), a renamed table (unicode, empty, control
    characters), a value nested deeply."""
    case = draw(st.sampled_from(CASES))
    data = tomllib.loads(case.read_text())
    for _ in range(draw(st.integers(1, 3))):
        where = list(paths_in(data))
        path, key = draw(st.sampled_from(where))
        parent = container(data, path)
        old = parent[key]
        how = draw(st.sampled_from(["delete", "type", "extreme", "rename", "nest", "scale"]))
        if how == "delete" and isinstance(parent, dict):
            del parent[key]
        elif how == "type":
            parent[key] = draw(st.sampled_from(["text", True, 7, 2.5, [1, "a"], {"x": 1}, [], [[[]]]]))
        elif how == "extreme":
            parent[key] = draw(st.sampled_from(EXTREMES))
        elif how == "rename" and isinstance(parent, dict):
            new = draw(st.sampled_from(ODD_NAMES))
            items = [(new if k == key else k, v) for k, v in parent.items()]
            parent.clear()
            parent.update(items)
        elif how == "nest":
            for _ in range(draw(st.integers(2, 60))):
                old = [old]
            parent[key] = old
        elif how == "scale" and isinstance(old, (int, float)) and not isinstance(old, bool):
            parent[key] = old * draw(st.sampled_from([-1, 0, 1e-9, 1e9, 1e30]))
    return case.name, data


def run_in_process(argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = cli.main([str(a) for a in argv])
    return code, err.getvalue()


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_scenes())
def test_mutated_scenes_are_refused_in_one_line_or_run(mutated):
    """``cosnet info`` refuses in one line (exit 2) or describes the scene; a described scene
    then runs 20 steps (exit 0), or is refused in one line, or stops as unstable with the
    instability message (exit 3): never a traceback."""
    name, data = mutated
    from cosnet.scene.loader import load_scene
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / name
        p.write_text(dumps(data), encoding="utf-8")
        with contextlib.redirect_stdout(io.StringIO()):
            code, err = run_in_process(["info", p])
        if code == 2:
            one_error_line(err)
            return
        assert code == 0, err
        dt = load_scene(p).simulation().dt
        code, err = run_in_process(["run", p, "--out", Path(tmp) / "out", "--until", 20 * dt])
        assert "Traceback" not in err
        if code == 2:
            one_error_line(err)
        elif code == 3:   # exit 3 is the instability watch's: its message, on the one last line
            lines = [ln for ln in err.splitlines() if ln.strip()]
            assert [ln for ln in lines if "error" in ln] == lines[-1:], err
            assert lines[-1].startswith("cosnet: error: unstable at t = "), err
        else:
            assert code == 0, err


# ---------------------------------------------------------------------- docs/faults.md
def test_the_commands_of_docs_faults_run_as_written(tmp_path):
    text = (REPO / "docs" / "faults.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", text, re.S)
    lines = [ln for b in blocks for ln in b.splitlines() if ln.strip()]
    assert len(lines) == 3 and all(ln.startswith("cosnet run ") for ln in lines)
    for ln in lines:
        r = subprocess.run(command(*ln.split()[1:]), cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, (ln, r.stderr)
    assert len(read_output(tmp_path / "demo").times) == 4     # t = 0, 0.01, 0.02, 0.03
    r = subprocess.run(command(*lines[0].split()[1:]), cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "holds a run already" in one_error_line(r.stderr)
    toml = re.findall(r"```toml\n(.*?)```", text, re.S)
    assert toml == ["[run]\nuntil = 0.5\nlimits = false\n"]


def test_the_limits_key_of_docs_faults_lifts_the_element_limit(tmp_path, monkeypatch):
    """With the limit lowered below the cantilever's 10 elements, the case is refused, and
    loads with the [run] table of docs/faults.md (or limits=False)."""
    import cosnet.core.limits
    from cosnet.scene.loader import load_scene
    monkeypatch.setattr(cosnet.core.limits, "MAX_ELEMENTS", 5)
    toml = re.findall(r"```toml\n(.*?)```", (REPO / "docs" / "faults.md").read_text(), re.S)[0]
    case = (REPO / "cases" / "cantilever.toml").read_text()
    with pytest.raises(ValueError, match=r"10 elements in the net .* the limits are 5 elements"):
        load_scene(REPO / "cases" / "cantilever.toml")
    assert load_scene(REPO / "cases" / "cantilever.toml", limits=False).net.element_count == 10
    data = tomllib.loads(case)
    data["run"] = tomllib.loads(toml)["run"]
    p = tmp_path / "lifted.toml"
    p.write_text(dumps(data))
    assert load_scene(p).net.element_count == 10
