"""The thread count of a run: the Simulation argument, the scene's [run] threads, the
--threads flag (each validated in one line), and the automatic choice for large nets."""

import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import numba
import pytest

import cosnet
from cosnet.engine import simulation
from cosnet.scene.loader import build_scene, read_toml

REPO = Path(__file__).resolve().parents[1]
AVAILABLE = numba.config.NUMBA_NUM_THREADS


def scene_with(threads):
    data = read_toml(REPO / "cases" / "cantilever.toml")
    data["run"]["threads"] = threads
    return build_scene(data, "cantilever.toml")


def test_the_scene_key_sets_the_simulation_threads():
    assert scene_with(1).run.threads == 1
    assert scene_with(1).simulation().threads == 1


@pytest.mark.parametrize("bad", [0, -1, AVAILABLE + 1, 1.5, "2", True])
def test_a_bad_scene_key_is_one_line_naming_it(bad):
    with pytest.raises(ValueError) as e:
        scene_with(bad)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith("cantilever.toml: [run] threads: must be an integer from 1 to ")
    assert msg.endswith(f"got {bad!r}")


@pytest.mark.parametrize("bad", [str(AVAILABLE + 1), "two"])
def test_a_bad_flag_is_one_line_with_exit_code_2(bad, tmp_path):
    r = subprocess.run([sys.executable, "-m", "cosnet.cli", "run", "cantilever", "--out", str(tmp_path / "o"),
                        "--threads", bad], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("cosnet: error: --threads must be an integer")
    assert not (tmp_path / "o").exists()


def rod(elements):
    net = cosnet.Net()
    a, b = net.add_node((0, 0, 0), fixed=True), net.add_node((1, 0, 0))
    net.add_line(a, b, material=cosnet.Material(E=2e9, G=8e8, density=1000.0), section=cosnet.Circle(0.01),
                 elements=elements)
    return net


def test_the_simulation_argument_is_validated_and_the_default_follows_the_net_size():
    with pytest.raises(ValueError, match=rf"^Simulation: threads must be an integer from 1 to {AVAILABLE}, got 0$"):
        cosnet.Simulation(rod(4), threads=0)
    assert cosnet.Simulation(rod(4)).threads == 1
    assert cosnet.Simulation(rod(simulation.PARALLEL_MIN_ELEMENTS)).threads == AVAILABLE


@pytest.mark.parametrize("given, seen", [(None, "PASSIVE"), ("ACTIVE", "ACTIVE")])
def test_waiting_threads_sleep_unless_the_user_says_otherwise(given, seen):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if given:
        env["OMP_WAIT_POLICY"] = given
    r = subprocess.run([sys.executable, "-c", "import os, cosnet; print(os.environ['OMP_WAIT_POLICY'])"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == seen, r.stderr


def blocks(kind):
    return re.findall(rf"```{kind}\n(.*?)```", (REPO / "docs" / "threads.md").read_text(), re.S)


def test_the_documented_command_and_table_work(tmp_path):
    (command,) = blocks("sh")
    args = shlex.split(command)
    assert args[0] == "cosnet"
    r = subprocess.run([sys.executable, "-m", "cosnet.cli", *args[1:]], capture_output=True, text=True,
                       cwd=tmp_path, timeout=1800)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "run" / "series.pvd").exists()
    (table,) = blocks("toml")
    data = read_toml(REPO / "cases" / "cantilever.toml")
    data["run"] = tomllib.loads(table)["run"]
    if AVAILABLE >= 2:
        assert build_scene(data, "cantilever.toml").run.threads == 2
    else:
        with pytest.raises(ValueError, match=r"\[run\] threads: must be an integer from 1 to 1, got 2"):
            build_scene(data, "cantilever.toml")


# the code blocks of docs/threads.md run above, as written
