"""What is written has passed the watch; checkpoints refuse a model they were not written for;
the API refuses nonsense arguments with a clear ValueError."""

import math
import os
import re
import signal
import time
from pathlib import Path

import numpy as np
import pytest

import cosnet
from cosnet import cli
from cosnet.engine import measure
from cosnet.output.io import SeriesWriter, read_output
from cosnet.output.record import CHECKPOINT, PROBES, advance_to
from cosnet.studies.runner import schedule
from cosnet.scene.loader import load_scene
from cosnet.engine.watch import STRAIN_LIMIT
from nets import ROD_SCENE, STEEL, cantilever, free_net, smooth_motion

REPO = Path(__file__).resolve().parents[1]
RUBBER = cosnet.Material(E=5e6, G=2e6, density=1100.0, name="rubber")


def error_line(capsys) -> str:
    """The one error line the command printed (and nothing that looks like a traceback)."""
    err = capsys.readouterr().err
    lines = [l for l in err.splitlines() if l.startswith("cosnet: error:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ---------------------------------------------------------------------- the watch guards writes
def ring_scene(tmp_path, until):
    """cases/hard/closed_ring.toml at a forced step 1.25 times the estimate, frames every
    0.38 s: between two strain checks (2,000 steps apart) it blows up (strain 2.9 by t = 0.76 s)."""
    text = (REPO / "cases/hard/closed_ring.toml").read_text()
    text = re.sub(r"\[run\].*", f"[run]\nuntil = {until}\ndt = 2.5353e-4\nforce_dt = true\n"
                  f"output_interval = 0.38\n", text, flags=re.S)
    p = tmp_path / "ring.toml"
    p.write_text(text)
    return p


def test_blown_up_ring_writes_no_frame_or_checkpoint_that_failed_the_watch(tmp_path, capsys):
    scene_file = ring_scene(tmp_path, until=0.76)
    out = tmp_path / "out"
    assert cli.main(["run", str(scene_file), "--out", str(out)]) == 3
    assert "unstable" in error_line(capsys)
    series = read_output(out)
    assert len(series.times) >= 1
    for k in range(len(series.times)):
        frame = series.frame(k)
        for fields in frame["lines"].values():
            for name, a in fields.items():
                assert np.all(np.isfinite(a)), (k, name)
            assert np.abs(fields["strain"]).max() <= STRAIN_LIMIT
    assert not list(out.glob("*.tmp*"))
    # the checkpoint is the state of the last frame, bit for bit, and it passes the watch
    scene = load_scene(scene_file)
    plan = schedule(scene)
    sim = scene.simulation()
    plan.fit_step(sim)     # the run's step: dt shortened to a whole fraction of the interval
    sim.load_checkpoint(out / CHECKPOINT)
    assert sim.time == series.times[-1]
    assert measure.worst_strain(sim.model, sim.state)[0] <= STRAIN_LIMIT
    again = scene.simulation()
    plan.fit_step(again)
    for k in range(1, len(series.times)):   # as the run went: frame by frame
        advance_to(again, plan.time(k))
    again.check()      # the line ends placed on their nodes, as before every write
    for name, a in again.state._asdict().items():
        np.testing.assert_array_equal(a, getattr(sim.state, name), err_msg=name)
    rows = (out / PROBES).read_text().splitlines()
    assert len(rows) == 1 + len(series.times)


def steel_rod(n=6):
    """A steel cantilever at rest, and its line (the tests pull its interior vertices to 3
    times their distance from the root: strain 2 or more, finite everywhere)."""
    net, line, root, tip = cantilever(n=n)
    return cosnet.Simulation(net), line


def test_writers_refuse_a_state_that_fails_the_watch(tmp_path):
    sim, line = steel_rod()
    ckpt = tmp_path / "c.npz"
    writer = SeriesWriter(tmp_path / "o", sim.net)
    writer.write(sim)
    sim.save_checkpoint(ckpt)
    good = ckpt.read_bytes()
    sim.line_positions(line)[1:-1] *= 3.0
    with pytest.raises(cosnet.InstabilityError, match="strain"):
        writer.write(sim)
    with pytest.raises(cosnet.InstabilityError, match="strain"):
        sim.save_checkpoint(ckpt)
    assert writer.frames == 1 and ckpt.read_bytes() == good
    assert not (tmp_path / "o" / "lines_000001.vtu").exists() and not list(tmp_path.glob("*.tmp*"))


def test_check_runs_the_strain_test_between_chunk_checks():
    """run() checks strain every CHUNK_STEPS steps; check() does at once, and a passed state
    is not checked again (its hash is remembered)."""
    sim, line = steel_rod()
    sim.run(steps=1)                       # the first call checks everything
    sim.check()
    assert sim.watch.passed == sim.watch.seal
    sim.line_positions(line)[1:-1] *= 3.0
    sim.run(steps=1)                       # within a chunk: no strain test
    with pytest.raises(cosnet.InstabilityError, match="strain"):
        sim.check()


# ---------------------------------------------------------------------- checkpoint fingerprints
def checkpoint_of(tmp_path, net, **kw):
    sim = cosnet.Simulation(net, **kw)
    sim.run(steps=3)
    path = tmp_path / "c.npz"
    sim.save_checkpoint(path)
    return path


def test_ctrl_c_during_a_checkpoint_is_raised_after_it_is_whole(tmp_path, monkeypatch):
    """A SIGINT that arrives inside the write is held until the file is complete and renamed;
    the interrupt then reaches the caller, and the file restores the state bit for bit."""
    from cosnet.engine import checkpoint
    sim = cosnet.Simulation(cantilever(n=6)[0], dt=1e-6)
    sim.run(steps=3)
    savez = np.savez

    def interrupted_savez(*args, **kw):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)                  # the handler runs here, inside the write
        savez(*args, **kw)
    monkeypatch.setattr(checkpoint.np, "savez", interrupted_savez)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    path = tmp_path / "c.npz"
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.save_checkpoint(path)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.npz"]
    again = cosnet.Simulation(cantilever(n=6)[0], dt=1e-6)
    again.load_checkpoint(path)
    assert again.steps == 3
    for k, a in sim.state._asdict().items():
        np.testing.assert_array_equal(getattr(again.state, k), a)


def test_checkpoint_of_a_rubber_rod_is_refused_by_a_steel_rod(tmp_path):
    path = checkpoint_of(tmp_path, cantilever(n=6, material=RUBBER)[0], dt=1e-6)
    steel = cosnet.Simulation(cantilever(n=6, material=STEEL)[0], dt=1e-6)
    before = {k: a.copy() for k, a in steel.state._asdict().items()}
    with pytest.raises(ValueError) as info:
        steel.load_checkpoint(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg
    assert "materials/stiffness (line 'rod')" in msg and "masses (line 'rod'; node 'tip')" in msg
    assert "net geometry" not in msg and "dt (" not in msg
    assert steel.steps == 0
    for k, a in steel.state._asdict().items():
        np.testing.assert_array_equal(a, before[k])


def test_checkpoint_of_a_1m_rod_is_refused_by_a_2m_rod(tmp_path):
    path = checkpoint_of(tmp_path, cantilever(n=6, length=1.0)[0], dt=1e-6)
    with pytest.raises(ValueError, match=r"net geometry \(line 'rod'"):
        cosnet.Simulation(cantilever(n=6, length=2.0)[0], dt=1e-6).load_checkpoint(path)


def test_checkpoint_names_dt_stepper_effects_and_size_differences(tmp_path):
    net = free_net(3)
    path = checkpoint_of(tmp_path, net, effects=[cosnet.Damping(0.1)])
    sim = cosnet.Simulation(net, effects=[cosnet.Damping(0.1)])
    with pytest.raises(ValueError, match=r"dt \(.* s in the checkpoint, .* s here\)"):
        cosnet.Simulation(net, effects=[cosnet.Damping(0.1)], dt=0.5 * sim.dt, force_dt=True).load_checkpoint(path)
    with pytest.raises(ValueError, match=r"effects \(Damping\(translational=0.2/s"):
        cosnet.Simulation(net, effects=[cosnet.Damping(0.2)], dt=sim.dt, force_dt=True).load_checkpoint(path)
    # a parameter its description leaves out (the fluid's added mass): said as its record's arrays
    wet = [cosnet.Fluid(1000.0, drag=(1.0, 0.1), added_mass=(1.0, 0.0))]
    (tmp_path / "wet").mkdir()
    wet_path = checkpoint_of(tmp_path / "wet", net, effects=wet)
    drier = [cosnet.Fluid(1000.0, drag=(1.0, 0.1), added_mass=(0.5, 0.0))]
    with pytest.raises(ValueError, match=r"effects \(Fluid\(density=1000.*\): its record's arrays differ\)"):
        cosnet.Simulation(net, effects=drier, dt=cosnet.Simulation(net, effects=wet).dt,
                          force_dt=True).load_checkpoint(wet_path)
    with pytest.raises(ValueError, match=r"effects \(1 in the checkpoint, 2 here\)"):
        other = cosnet.Simulation(net, effects=[cosnet.Damping(0.1), cosnet.Gravity()], dt=sim.dt, force_dt=True)
        other.load_checkpoint(path)
    with pytest.raises(ValueError, match=r"stepper \(verlet in the checkpoint, pefrl here\)"):
        cosnet.Simulation(net, effects=[cosnet.Damping(0.1)], stepper="pefrl", dt=sim.dt,
                          force_dt=True).load_checkpoint(path)
    with pytest.raises(ValueError, match=r"net geometry \(3 lines and 3 nodes in the checkpoint, 1 and 2 here\)"):
        cosnet.Simulation(cantilever(n=3)[0], dt=sim.dt, force_dt=True).load_checkpoint(path)


def test_same_model_restores_bit_identically(tmp_path):
    net = free_net(3)
    a = cosnet.Simulation(net)
    smooth_motion(a)
    a.run(steps=20)
    path = tmp_path / "c.npz"
    a.save_checkpoint(path)
    b = cosnet.Simulation(net).load_checkpoint(path)
    assert b.steps == a.steps
    a.run(steps=30)
    b.run(steps=30)
    for name, x in a.state._asdict().items():
        np.testing.assert_array_equal(x, getattr(b.state, name), err_msg=name)


def test_checkpoint_without_fingerprint_or_damaged_is_refused_in_one_line(tmp_path):
    sim = cosnet.Simulation(free_net(3))
    old = tmp_path / "old.npz"
    np.savez(old, steps=0, dt=sim.dt, stepper=sim.stepper, **sim.state._asdict())
    with pytest.raises(ValueError, match="has no model fingerprint"):
        sim.load_checkpoint(old)
    good = tmp_path / "good.npz"
    sim.save_checkpoint(good)
    data = good.read_bytes()
    for name, damaged in [("truncated", data[: len(data) // 2]), ("garbage", b"\x00" * 300),
                          ("empty", b"")]:
        p = tmp_path / f"{name}.npz"
        p.write_bytes(damaged)
        with pytest.raises(ValueError, match="unreadable, truncated or corrupted") as info:
            sim.load_checkpoint(p)
        assert "\n" not in str(info.value) and str(p) in str(info.value)
    with pytest.raises(ValueError, match="unreadable"):
        sim.load_checkpoint(tmp_path / "missing.npz")


def test_edited_material_then_resume_is_refused(tmp_path, capsys):
    scene = tmp_path / "rod.toml"
    text = ROD_SCENE.format(title="rod", E="2.0e7", G="8.0e6", elements=4,
                            rest="[run]\nuntil = 0.004\noutput_interval = 0.002\n")
    scene.write_text(text)
    out = tmp_path / "out"
    assert cli.main(["run", str(scene), "--out", str(out)]) == 0
    capsys.readouterr()
    scene.write_text(text.replace("E = 2.0e7", "E = 4.0e7"))
    assert cli.main(["run", str(scene), "--out", str(out), "--resume"]) == 2
    line = error_line(capsys)
    assert "written for a different model" in line and "materials/stiffness (line 'rod')" in line


# ---------------------------------------------------------------------- API arguments
def test_safety_outside_0_1_is_refused():
    net = cantilever(n=4)[0]
    for bad in (100, 1.0001, 0, -1, math.nan, True, "0.5"):
        with pytest.raises(ValueError, match=r"safety must be a number in \(0, 1\]"):
            cosnet.Simulation(net, safety=bad)
    full = cosnet.Simulation(net, safety=1)
    assert cosnet.Simulation(net, safety=0.5).dt == pytest.approx(0.5 * full.dt, rel=1e-12)


def test_run_takes_only_non_negative_integer_steps():
    sim = cosnet.Simulation(cantilever(n=4)[0])
    for bad in (1.7, "5", True, np.bool_(True), -1, 2.0, np.float64(3)):
        with pytest.raises(ValueError, match="steps must be a non-negative integer"):
            sim.run(steps=bad)
    assert sim.steps == 0
    sim.run(steps=np.int64(3))
    sim.run(steps=np.int32(2))
    sim.run(steps=0)
    assert sim.steps == 5


def test_run_until_must_be_finite_and_not_in_the_past():
    sim = cosnet.Simulation(cantilever(n=4)[0])
    for bad in (math.inf, -math.inf, math.nan, "1", True):
        with pytest.raises(ValueError, match="until must be a finite time"):
            sim.run(until=bad)
    sim.run(steps=10)
    t = sim.time
    with pytest.raises(ValueError, match=rf"before the current time {t:.9g} s"):
        sim.run(until=t - 5 * sim.dt)
    sim.run(until=t)                 # where a run to t ends: nothing to do
    sim.run(until=t - 0.5 * sim.dt)  # within the last step's overshoot
    assert sim.steps == 10 and sim.time == t


def test_nan_node_velocity_is_caught_even_by_a_zero_step_run():
    net = free_net(3)
    sim = cosnet.Simulation(net)
    sim.node_velocity(net.node("a"))[1] = np.nan
    with pytest.raises(cosnet.InstabilityError, match=r"non-finite node velocity at node 'a'"):
        sim.run(steps=0)
    with pytest.raises(cosnet.InstabilityError, match=r"non-finite node velocity at node 'a'"):
        sim.run(until=sim.time)


# ---------------------------------------------------------------------- docs/watch.md
def test_docs_examples_run_as_shown(tmp_path, monkeypatch, capsys):
    """The Python block of docs/watch.md prints the text block after it; its commands run."""
    import shlex
    text = (REPO / "docs/watch.md").read_text()
    blocks = re.findall(r"```(\w+)\n(.*?)```", text, flags=re.S)
    python = [b for kind, b in blocks if kind == "python"]
    shown = [b for kind, b in blocks if kind == "text"]
    shell = [b for kind, b in blocks if kind == "sh"]
    assert len(python) == len(shown) == len(shell) == 1
    monkeypatch.chdir(tmp_path)
    exec(compile(python[0], "docs/watch.md", "exec"), {})
    assert capsys.readouterr().out == shown[0]
    for line in shell[0].strip().splitlines():
        argv = shlex.split(line)
        assert argv[0] == "cosnet"
        assert cli.main(argv[1:]) == 0, line
    assert len(read_output(tmp_path / "out").times) == 3
