"""Output of a run: the same files from Python as from the CLI, frames at the requested
times, probes of any field, a callback at every frame, and progress that tells the truth
(docs/output.md, whose code blocks run here)."""

import io
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosnet import cli

from cosnet.output import record
from cosnet.output.io import read_output
from cosnet.scene.loader import load_scene
from nets import ROD_SCENE

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "output.md"

SCENE = ROD_SCENE.format(title="probed rod", E="2.0e9", G="8.0e8", elements=6, rest="""\
[[effects]]
kind = "gravity"
[run]
until = 0.05
output_interval = 0.0125
probes = ["tip", "tip:velocity", "tip:angular_velocity", "rod@0.5:force", "rod:strain", "rod@0:curvature"]
""")


@pytest.fixture
def scene_file(tmp_path):
    p = tmp_path / "probed.toml"
    p.write_text(SCENE)
    return p


def test_python_writes_the_files_the_cli_writes(scene_file, tmp_path):
    a, b = tmp_path / "cli", tmp_path / "py"
    assert cli.main(["run", str(scene_file), "--out", str(a)]) == 0
    scene = load_scene(scene_file)
    sim = scene.simulation()
    sim.run(scene.run.until, out=b, every=scene.run.interval, probes=scene.run.probes)
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert "lines_000004.vtu" in names and "lines_000005.vtu" not in names
    for name in names:
        if name.endswith(".npz"):
            with np.load(a / name) as ca, np.load(b / name) as cb:
                assert ca.files == cb.files
                for key in ca.files:
                    np.testing.assert_array_equal(ca[key], cb[key], err_msg=key)
        else:
            assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_frames_land_on_the_requested_times_and_resume_bit_identically(scene_file, tmp_path):
    """0.0125 s is no multiple of dt: the run steps by 0.0125 / n, n the fewest whole steps
    that fit, and lands on k * 0.0125; a run continued from frame 2 equals the uninterrupted
    one."""
    scene = load_scene(scene_file)
    dt = scene.simulation().dt
    assert abs(0.0125 / dt - round(0.0125 / dt)) > 0.01
    full, cut = tmp_path / "full", tmp_path / "cut"
    assert cli.main(["run", str(scene_file), "--out", str(full)]) == 0
    times = read_output(full).times
    assert np.all(np.abs(times - 0.0125 * np.arange(5)) <= 1e-15)
    sim = scene.simulation()
    assert sim.steps == 0
    sim.run(0.025, out=cut, every=0.0125, probes=scene.run.probes)   # frames 0, 1, 2 only
    assert cli.main(["run", str(scene_file), "--out", str(cut), "--resume"]) == 0
    for name in sorted(p.name for p in full.iterdir()):
        if not name.endswith(".npz"):
            assert (full / name).read_bytes() == (cut / name).read_bytes(), name
    with np.load(full / "checkpoint.npz") as ca, np.load(cut / "checkpoint.npz") as cb:
        for key in ca.files:
            np.testing.assert_array_equal(ca[key], cb[key], err_msg=key)
        assert int(ca["steps"]) == 4 * math.ceil(0.0125 / dt)    # n whole steps per interval
        assert float(ca["dt"]) == 0.0125 / math.ceil(0.0125 / dt)


def test_landing_on_frames_keeps_one_step_length_and_the_energy_bounded(tmp_path):
    """A chain of rigid links at its stable step, a frame every 0.02 s: every step has the
    same length (time = steps * dt to round-off), and Verlet's energy error stays bounded.
    With a shortened step before each frame the step length switched 50 times a second, which
    pumped the highest modes: the energy grew by 1e7 J within 1.1 s and the watch stopped it."""
    scene = load_scene(REPO / "cases" / "chain.toml")
    sim = scene.simulation()
    e0, kinetic = sim.energy(), sim.energy_parts()["kinetic"]
    worst = []
    sim.run(1.2, every=0.02, callback=lambda s: worst.append(abs(s.energy() - e0)))
    assert len(worst) == 61
    assert abs(sim.time - sim.steps * sim.dt) <= 1e-12 * sim.time
    assert max(worst) < 1e-3 * kinetic


def test_probes_record_the_named_fields_in_named_columns(scene_file, tmp_path):
    out = tmp_path / "out"
    assert cli.main(["run", str(scene_file), "--out", str(out)]) == 0
    rows = (out / "probes.csv").read_text().splitlines()
    head = rows[0].split(",")
    assert head[:5] == ["frame", "time", "tip_x", "tip_y", "tip_z"]
    assert head[5:8] == ["tip:velocity_x", "tip:velocity_y", "tip:velocity_z"]
    assert "rod@0.5:force_z" in head and "rod:strain_x" in head and "rod@0:curvature_y" in head
    last = dict(zip(head, map(float, rows[-1].split(","))))
    series = read_output(out)
    frame = series.frame(len(series.times) - 1)
    tip = series.node_names.index("tip")
    for f in ("velocity", "angular_velocity"):
        np.testing.assert_array_equal([last[f"tip:{f}_{a}"] for a in "xyz"], frame["nodes"][f][tip])
    rod = frame["lines"]["rod"]
    np.testing.assert_array_equal([last[f"rod@0.5:force_{a}"] for a in "xyz"], rod["force"][3])
    np.testing.assert_array_equal([last[f"rod:strain_{a}"] for a in "xyz"], rod["strain"][3])
    np.testing.assert_array_equal([last[f"rod@0:curvature_{a}"] for a in "xyz"], rod["curvature"][0])
    # the tip velocity is the rate of the tip position: compare with the central difference
    sim = load_scene(scene_file).simulation()
    tip_node = sim.net.node("tip")
    sim.run(steps=100)
    x0 = sim.node_position(tip_node).copy()
    sim.run(steps=2)
    x2 = sim.node_position(tip_node).copy()
    sim2 = load_scene(scene_file).simulation()
    sim2.run(steps=101)
    v1 = record.parse_probe("tip:velocity", sim2.net).value(sim2)
    np.testing.assert_allclose(v1, (x2 - x0) / (2 * sim.dt), rtol=1e-3, atol=1e-9)


@pytest.mark.parametrize("probe, message", [
    ("tip:speed", "'tip:speed': unknown field 'speed'; a node has position, velocity, angular_velocity, d1, d2, d3"),
    ("rod@0.5:spin", "a line point has position, velocity, d1, d2, d3, force, torque, strain, curvature"),
    ("mast@0.5:force", "'mast@0.5:force' names no node or line"),
])
def test_unknown_probe_or_field_is_one_line_naming_the_table(tmp_path, probe, message):
    p = tmp_path / "bad.toml"
    p.write_text(SCENE.replace('probes = ["tip",', f'probes = ["{probe}", "tip",'))
    with pytest.raises(ValueError) as err:
        load_scene(p)
    text = str(err.value)
    assert "\n" not in text and "[run] probes" in text and str(p) in text and message in text


def test_callback_is_called_at_every_output_time(scene_file, tmp_path):
    seen = []
    sim = load_scene(scene_file).simulation()
    sim.run(0.03, every=0.01, callback=lambda s: seen.append(s.time))
    np.testing.assert_allclose(seen, [0.0, 0.01, 0.02, 0.03], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="probes are written to probes.csv in out"):
        sim.run(0.05, probes=["tip"])
    with pytest.raises(ValueError, match="go with until, not steps"):
        sim.run(steps=3, out=tmp_path / "o")
    with pytest.raises(ValueError, match="callback must be callable"):
        sim.run(0.05, callback=3)


def test_resuming_a_finished_run_says_so(scene_file, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["run", str(scene_file), "--out", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["run", str(scene_file), "--out", str(out), "--resume"]) == 0
    err = capsys.readouterr().err
    assert "already at t = 0.05 s = --until; nothing to do" in err and "steps/s" not in err


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class _Sim:
    def __init__(self, steps, time):
        self.steps, self.time = steps, time


def test_progress_rate_and_eta_count_only_steps_after_the_first_chunk(monkeypatch):
    clock = _Clock()
    monkeypatch.setattr(record.time, "perf_counter", clock)
    out = io.StringIO()
    p = record.Progress(until=10.0, dt=1e-3, stream=out)
    clock.now += 30.0                 # the first chunk: 30 s, mostly compilation
    p(_Sim(2000, 2.0))
    assert out.getvalue() == ""
    clock.now += 2.0                  # 4000 more steps in 2 s
    p(_Sim(6000, 6.0))
    assert "2,000 steps/s" in out.getvalue() and "ETA 2 s" in out.getvalue()


def test_compiled_kernels_are_known_after_a_run(scene_file):
    sim = load_scene(scene_file).simulation()
    sim.run(steps=1)
    assert record.kernels_compiled(sim)


def _blocks(kind):
    return re.findall(rf"```{kind}\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_documented_python_and_commands_run(tmp_path):
    (tmp_path / "cases").symlink_to(REPO / "cases")
    env = dict(os.environ, PYTHONPATH=str(REPO))
    [code] = _blocks("python")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                       timeout=300, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("6 frames; tip heights [0.0, -0.000")
    assert (tmp_path / "out_py" / "probes.csv").read_text().splitlines()[0].endswith(
        "rod@0.5:force_z,tip:angular_velocity_x,tip:angular_velocity_y,tip:angular_velocity_z")
    [commands] = _blocks("sh")
    results = []
    for line in commands.strip().splitlines():
        argv = line.split()
        assert argv[0] == "cosnet"
        results.append(subprocess.run([sys.executable, "-m", "cosnet.cli", *argv[1:]], cwd=tmp_path,
                                      capture_output=True, text=True, timeout=300, env=env))
    assert [r.returncode for r in results] == [0, 0], results[-1].stderr
    assert len(read_output(tmp_path / "out").times) == 6
    assert "already at t = 0.05 s = --until; nothing to do" in results[1].stderr
    [toml] = _blocks("toml")
    body = SCENE.split("[run]")[0] + toml
    (tmp_path / "doc.toml").write_text(body)
    assert [p.name for p in load_scene(tmp_path / "doc.toml").run.probes] == [
        "tip", "tip:velocity", "rod@0.5:force", "rod@0.25:curvature"]
