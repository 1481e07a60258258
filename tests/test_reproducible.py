"""Bit-identical results whether the kernels were compiled in the running process, loaded
from numba's cache, or compiled after a run was killed halfway through compiling them: a
net with contact, one with joints and a long rod on two threads, each run in fresh
processes sharing one cache directory, every state array compared exactly. (Mostly
compilation: each net compiles its own step in a cache of its own.)"""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Runs one of the nets (argv[3]) and saves every state array (and, for the contact net, the
# most contacts seen at its checks) to the .npz file named by argv[1].
WORKER = r"""
import sys
import numpy as np
import cosnet

out, cases, case = sys.argv[1:4]
extra = {}
if case == "contact":
    # on past the first impacts, where cold and warm runs used to part (a run stopped soon
    # after the first touch showed no difference)
    scene = cosnet.load_scene(cases + "/contact.toml")
    sim = scene.simulation()
    contact = next(e for e in scene.effects if isinstance(e, cosnet.Contact))
    most = 0
    for k in range(1, 8):
        sim.run(until=0.005 * k)
        most = max(most, contact.active_contacts(sim))
    extra["contacts"] = np.array([most])
elif case == "joints":
    sim = cosnet.load_scene(cases + "/elastica_joints.toml").simulation()
    sim.run(steps=3000)
else:
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    tip = net.add_node((1.0, 0.0, 0.0), name="tip")
    net.add_line(root, tip, material=cosnet.Material(E=2e9, G=8e8, density=1000.0),
                 section=cosnet.Circle(0.01), elements=6000, name="rod")
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()], threads=2)
    sim.run(steps=300)
np.savez(out, **sim.state._asdict(), **extra)
"""


def start(cache, out, case):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="2")
    return subprocess.Popen([sys.executable, "-c", WORKER, str(out), os.path.join(REPO, "cases"), case],
                            env=env, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def run(cache, out, case):
    proc = start(cache, out, case)
    try:
        _, err = proc.communicate(timeout=3600)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


def assert_identical(a, b):
    assert a.keys() == b.keys()
    differ = [k for k in a if not np.array_equal(a[k], b[k])]
    assert not differ, f"arrays differ: {differ}"


def step_cached(cache):
    return any(name.startswith("stepping.advance_verlet") and name.endswith(".nbi")
               for _, _, names in os.walk(cache) for name in names)


@pytest.mark.parametrize("case", ["contact", "joints", "rod"])
def test_a_cold_run_equals_a_warm_one_bit_for_bit(case, tmp_path):
    cache = tmp_path / "cache"
    cold = run(cache, tmp_path / "cold.npz", case)
    assert step_cached(cache)
    warm = run(cache, tmp_path / "warm.npz", case)
    if case == "contact":
        assert cold["contacts"][0] > 0  # the sticks did land: the contact forces took part
    assert_identical(cold, warm)


def test_a_run_killed_while_compiling_then_rerun_equals_a_warm_one(tmp_path):
    """SIGKILL once some kernels are cached but not the step; the rerun compiles the step
    against the callees loaded from the cache, and must compute what a run loading all of
    it does."""
    cache = tmp_path / "cache"
    proc = start(cache, tmp_path / "killed.npz", "contact")
    deadline = time.time() + 1800
    while time.time() < deadline and proc.poll() is None:
        if sum(name.endswith(".nbi") for _, _, names in os.walk(cache) for name in names) >= 12:
            break
        time.sleep(0.05)
    cached_step = step_cached(cache)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    assert proc.returncode == -signal.SIGKILL and not cached_step, "killed too late: nothing half-compiled"
    rerun = run(cache, tmp_path / "rerun.npz", "contact")
    warm = run(cache, tmp_path / "warm.npz", "contact")
    assert_identical(rerun, warm)
