"""The cosnet command, run as a user runs it (subprocess): info, run --until, errors, a run
killed by a signal and resumed, and off-screen rendering."""

import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from cosnet.output.io import read_output
from cosnet.scene.loader import load_scene
from nets import ROD_SCENE
from procs import spawn

REPO = Path(__file__).resolve().parents[1]

TINY = ROD_SCENE.format(title="tiny rod", E="2.0e9", G="8.0e8", elements=6, rest="""\
[[effects]]
kind = "gravity"
[[effects]]
kind = "damping"
translational = 2.0
[run]
until = 1.0
output_interval = 0.01
probes = ["tip"]
""")


def cosnet(*args, **kw):
    return subprocess.run([sys.executable, "-m", "cosnet.cli", *map(str, args)], capture_output=True,
                          text=True, cwd=kw.pop("cwd", REPO), timeout=kw.pop("timeout", 120), **kw)


@pytest.fixture
def tiny(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(TINY)
    return p


def test_info_reports_size_mass_dt_and_effects(tiny):
    r = cosnet("info", tiny)
    assert r.returncode == 0, r.stderr
    scene = load_scene(tiny)
    sim = scene.simulation()
    assert "3 nodes" not in r.stdout and "2 nodes, 1 lines, 6 elements, 7 vertices" in r.stdout
    assert f"{scene.net.total_mass():.6g} kg" in r.stdout
    # 0.05 kg tip + rho A L of the rod
    assert scene.net.total_mass() == pytest.approx(0.05 + 1000 * math.pi * 1e-4 * 0.5, rel=1e-12)
    assert f"{sim.stable_dt():.4g} s" in r.stdout
    assert "Gravity" in r.stdout and "Damping" in r.stdout


def test_run_until_writes_the_frames_up_to_that_time(tiny, tmp_path):
    out = tmp_path / "out"
    r = cosnet("run", tiny, "--out", out, "--until", 0.05)
    assert r.returncode == 0, r.stderr
    assert "steps/s" in r.stderr and "ETA" in r.stderr
    series = read_output(out)
    dt = load_scene(tiny).simulation().dt
    assert len(series.times) == 6                           # t = 0, 0.01, ..., 0.05
    assert series.times[0] == 0.0
    assert 0.05 <= series.times[-1] < 0.05 + dt
    assert np.all(np.abs(np.diff(series.times) - 0.01) < dt)
    tip = series.node_series("tip")
    assert tip[-1, 2] < 0.0                                 # it fell under gravity
    rows = (out / "probes.csv").read_text().splitlines()
    assert len(rows) == 7 and rows[0] == "frame,time,tip_x,tip_y,tip_z"
    assert float(rows[-1].split(",")[4]) == tip[-1, 2]
    assert (out / "checkpoint.npz").exists()


def test_errors_are_one_line_with_exit_code_2(tiny, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace("elements = 6", "elemnts = 6"))
    r = cosnet("info", bad)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "[lines.rod]" in lines[0] and "elemnts" in lines[0]
    r = cosnet("run", tiny, "--out", tmp_path / "o", "--resume")
    assert r.returncode == 2 and "nothing to resume" in r.stderr


def test_unstable_run_stops_within_a_frame_and_leaves_valid_files(tiny, tmp_path):
    """A forced dt three times the stable one: the run stops with time, place and a safe dt,
    within one output interval of blowing up; every frame on disk opens and is finite, and the
    checkpoint holds the last good state."""
    import meshio
    dt = load_scene(tiny).simulation().dt
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace("probes = [\"tip\"]", f"probes = [\"tip\"]\ndt = {3 * dt!r}\nforce_dt = true"))
    out = tmp_path / "out"
    r = cosnet("run", bad, "--out", out, "--until", 0.2)
    assert r.returncode == 3, r.stderr
    assert "unstable at t = " in r.stderr and "line 'rod'" in r.stderr and "a dt below" in r.stderr
    t_fail = float(r.stderr.split("unstable at t = ")[1].split()[0])
    series = read_output(out)
    assert t_fail - series.times[-1] <= 0.01 + 3 * dt       # lost at most one output interval
    for k in range(len(series.times)):
        fr = series.frame(k)
        assert all(np.all(np.isfinite(v)) for line in fr["lines"].values() for v in line.values())
        assert all(np.all(np.isfinite(v)) for v in fr["nodes"].values())
    for vtu in sorted(out.glob("*.vtu")):
        assert np.all(np.isfinite(meshio.read(vtu).points))
    ckpt = np.load(out / "checkpoint.npz")
    assert all(np.all(np.isfinite(ckpt[k])) for k in ckpt.files if ckpt[k].dtype.kind == "f")


def test_killed_run_resumes_to_the_uninterrupted_result(tiny, tmp_path):
    """SIGKILL mid-run, then --resume: same frames and the same final state, bit for bit."""
    full, cut = tmp_path / "full", tmp_path / "cut"
    until = 0.5
    proc = spawn([sys.executable, "-m", "cosnet.cli", "run", str(tiny), "--out", str(cut),
                  "--until", str(until)], cwd=REPO, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while time.time() < deadline:
        if (cut / "series.pvd").exists() and (cut / "series.pvd").read_text().count("<DataSet") >= 2 * 4:
            break
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL, "the run finished before it could be killed"
    written = len(read_output(cut).times)
    assert 4 <= written < 51
    r = cosnet("run", tiny, "--out", cut, "--until", until, "--resume")
    assert r.returncode == 0, r.stderr
    r = cosnet("run", tiny, "--out", full, "--until", until)
    assert r.returncode == 0, r.stderr
    a, b = read_output(full), read_output(cut)
    np.testing.assert_array_equal(a.times, b.times)
    for k in (0, written - 1, written, len(a.times) - 1):
        np.testing.assert_array_equal(a.frame(k)["lines"]["rod"]["position"], b.frame(k)["lines"]["rod"]["position"])
        np.testing.assert_array_equal(a.frame(k)["lines"]["rod"]["force"], b.frame(k)["lines"]["rod"]["force"])
    with np.load(full / "checkpoint.npz") as ca, np.load(cut / "checkpoint.npz") as cb:
        for key in ca.files:
            np.testing.assert_array_equal(ca[key], cb[key], err_msg=key)
    assert (full / "probes.csv").read_text() == (cut / "probes.csv").read_text()
    assert (full / "energy.csv").read_text() == (cut / "energy.csv").read_text()


def test_default_scene_is_the_bridge(tmp_path):
    from cosnet.scene.cases import default_scene
    scene = load_scene(default_scene())
    assert default_scene().name == "bridge.toml"
    assert {"west_n_top", "east_s_top", "deck_n06"} <= {n.name for n in scene.net.nodes}


def test_render_png_and_gif_off_screen(tiny, tmp_path):
    out = tmp_path / "out"
    assert cosnet("run", tiny, "--out", out, "--until", 0.02).returncode == 0
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    r = cosnet("render", out, "--png", "--field", "force", env=env)
    assert r.returncode == 0, r.stderr
    from PIL import Image
    img = Image.open(out / "render.png")
    assert img.size == (1024, 768)
    pixels = np.asarray(img.convert("L"))
    assert pixels.min() < 200 < pixels.max()              # something was drawn on the background
    if __import__("importlib").util.find_spec("imageio") is not None:     # the movie extra
        r = cosnet("render", out, "--gif", "--output", tmp_path / "m.gif", env=env)
        assert r.returncode == 0, r.stderr
        assert Image.open(tmp_path / "m.gif").n_frames == 3
    r = cosnet("render", out, "--png", "--field", "nonsense", env=env)
    assert r.returncode == 2 and "nonsense" in r.stderr


# ---------------------------------------------------------------------- faults (docs/faults.md)
def main_err(capsys, *argv):
    """cosnet.cli.main in this process: (exit code, the one line it wrote to stderr)."""
    from cosnet import cli
    try:
        code = cli.main([str(a) for a in argv])
    except SystemExit as e:   # argparse
        code = e.code
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cosnet"), err
    return code, err[0]


def test_a_second_run_into_one_out_is_refused_unless_overwrite(tiny, tmp_path, capsys):
    out = tmp_path / "out"
    assert cosnet("run", tiny, "--out", out, "--until", 0.02).returncode == 0
    (out / "notes.txt").write_text("mine")
    (out / "lines_000099.vtu").write_text("a later frame of an older, longer run")
    code, err = main_err(capsys, "run", tiny, "--out", out, "--until", 0.01)
    assert code == 2 and err == (f"cosnet: error: {out}: holds a run already (*.vtu, checkpoint.npz, "
                                 f"energy.csv, meta.json, probes.csv, series.pvd); pass --overwrite to replace it "
                                 f"or --resume to continue it")
    assert len(read_output(out).times) == 3                  # untouched
    r = cosnet("run", tiny, "--out", out, "--until", 0.01, "--overwrite")
    assert r.returncode == 0, r.stderr
    assert len(read_output(out).times) == 2
    assert sorted(p.name for p in out.glob("*.vtu")) == ["lines_000000.vtu", "lines_000001.vtu",
                                                         "nodes_000000.vtu", "nodes_000001.vtu"]
    assert (out / "notes.txt").read_text() == "mine"
    assert len((out / "probes.csv").read_text().splitlines()) == 3
    code, err = main_err(capsys, "run", tiny, "--out", out, "--overwrite", "--resume")
    assert code == 2 and "not allowed with argument" in err


def test_an_out_that_is_a_file_is_refused_in_one_line(tiny, tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("")
    code, err = main_err(capsys, "run", tiny, "--out", f, "--until", 0.01)
    assert code == 2 and err.startswith(f"cosnet: error: {f}: exists and is not a directory")


@pytest.mark.parametrize("edit,until,message", [
    (("[run]", "[run]\ndt = 1e-30\nforce_dt = true"), None,
     r"\[run\] until = 1 s: 1e\+30 steps of dt = 1e-30 s \(\[run\] dt\) exceed the limit of 1,000,000,000 steps; "
     r"set \[run\] limits = false in the scene or pass --no-limits to go ahead"),
    (("output_interval = 0.01", "output_interval = 1e-12"), None,
     r"\[run\] output_interval: 1e-12 s is shorter than one step \(dt = [\d.e-]+ s\); frames would repeat"),
    (("output_interval = 0.01", "output_interval = 1e-9"), 1e-9, r"\[run\] until: 1e-09 s is shorter than one step"),
    (("[run]", "[run]\nlimits = false"), math.inf, r"--until must be a positive number of seconds, got inf"),
    (("elements = 6", "elements = 1e9"), None,
     r"\[lines\.rod\] elements: must be a positive integer, got 1000000000\.0"),
    (("elements = 6", "elements = 1_000_000_000"), None,
     r"\[lines\.rod\] elements: 1,000,000,000 elements in the net need about 2e\+03 GB of memory"),
])
def test_nonsense_is_refused_up_front_with_its_numbers(tiny, tmp_path, capsys, edit, until, message):
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace(*edit))
    extra = () if until is None else ("--until", until)
    code, err = main_err(capsys, "run", bad, "--out", tmp_path / "o", *extra)
    assert code == 2 and re.search(message, err), err
    assert not (tmp_path / "o").exists()


def test_a_joint_stiff_enough_for_1e151_steps_is_refused_naming_it(tmp_path, capsys):
    case = (REPO / "cases" / "elastica_joints.toml").read_text()
    assert "\nkind = \"spherical_joint\"" in case and "\nk = 1.0e6\n" in case
    bad = tmp_path / "stiff.toml"
    bad.write_text(case.replace("\nk = 1.0e6\n", "\nk = 1.0e300\n", 1))   # the spherical joint's
    code, err = main_err(capsys, "run", bad, "--out", tmp_path / "o")
    assert code == 2 and re.search(r"[\d.]+e\+1\d\d steps of dt = [\d.]+e-1\d\d s \(the stable step of "
                                   r"SphericalJoint.*\) exceed the limit", err), err


def test_unreadable_scenes_and_bad_options_end_in_one_line(tmp_path, capsys):
    utf = tmp_path / "latin1.toml"
    utf.write_bytes(TINY.replace("tiny rod", "tiny r\xf6d").encode("latin-1"))
    assert main_err(capsys, "info", utf) == (2, f"cosnet: error: {utf}: not UTF-8 text: byte 0xf6 in line 2 "
                                                 f"(TOML files are UTF-8)")
    deep = tmp_path / "deep.toml"
    deep.write_text(TINY.replace("position = [0.5, 0.0, 0.0]", "position = " + "[" * 5000 + "]" * 5000))
    assert main_err(capsys, "run", deep) == (2, f"cosnet: error: {deep}: arrays or tables nested too deeply to read")
    code, err = main_err(capsys, "modes", "cantilever", "--frames", "0")
    assert code == 2 and err == ("cosnet modes: error: argument --frames: must be a positive integer, got '0' "
                                 "(see cosnet modes --help)")


def test_out_of_memory_ends_in_one_line(tiny, capsys, monkeypatch):
    import cosnet.scene.loader

    def exhausted(*a, **kw):
        raise MemoryError
    monkeypatch.setattr(cosnet.scene.loader, "load_scene", exhausted)
    assert main_err(capsys, "info", tiny) == (2, f"cosnet: error: {tiny}: out of memory: too large for this machine")


def test_compile_ahead_leaves_the_run_nothing_to_compile(tiny, tmp_path):
    """`cosnet compile SCENE` fills the cache with every kernel `cosnet run SCENE` needs: the
    run then compiles nothing, and compiling again finds everything cached."""
    r = cosnet("compile", tiny, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stderr.startswith(f"{tiny}: ")
    run = cosnet("run", tiny, "--out", tmp_path / "out", "--until", 0.02)
    assert run.returncode == 0, run.stderr
    assert "compiling" not in run.stderr   # no status line, no "(compiling N kernels took ...)"
    again = cosnet("compile", tiny)
    assert again.returncode == 0 and again.stderr == f"{tiny}: all kernels cached\n", again.stderr
    bad = cosnet("compile", tmp_path / "nothing.toml")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "nothing.toml" in bad.stderr


def test_an_error_no_check_of_cosnet_raised_is_an_internal_error(monkeypatch, capsys):
    """A ValueError raised inside a library (numpy's LinAlgError here) is not a refusal of
    bad input: the command says "internal error", names where it came from and exits 70
    (EX_SOFTWARE), so that a fuzzer counting refusals (exit 2) fails on it."""
    import cosnet.scene.loader as loader
    from cosnet.cli import main

    assert main(["info", "no_such_scene_file.toml"]) == 2              # a refusal stays one
    assert capsys.readouterr().err.startswith("cosnet: error: ")

    def broken(*args, **kw):
        return np.linalg.inv(np.zeros((2, 2)))      # singular: raised in numpy
    monkeypatch.setattr(loader, "load_scene", broken)
    assert main(["info", "cantilever"]) == 70
    err = capsys.readouterr().err.strip()
    assert err.startswith("cosnet: internal error: Singular matrix (LinAlgError from numpy") and "\n" not in err


def test_python_dash_m_cosnet_is_the_command():
    from importlib.metadata import version
    out = subprocess.run([sys.executable, "-m", "cosnet", "--version"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == f"cosnet {version('cosnet')}"
