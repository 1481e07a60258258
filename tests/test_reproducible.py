"""Bit-identical results whether the kernels were compiled in the running process, loaded
from numba's cache, or compiled after a run was killed halfway through compiling them: a
net with contact on two threads, run in fresh processes sharing a cache directory, every
state array compared exactly. (Mostly compilation, in a cache of its own: the run killed
while compiling leaves some of the net's kernels cached; the rerun compiles the rest of them,
the threaded loops among them, and its step in-process; the warm run loads it all.)"""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from procs import spawn

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Runs the nets named by argv[3:] in turn and saves each one's state arrays (and the most
# contacts seen at its checks) to ARGV1.<net>.npz.
WORKER = r"""
import sys
import numpy as np
import cosnet

def run(case):
    # on past the first impacts, where cold and warm runs used to part (a run stopped soon
    # after the first touch showed no difference); on two threads, so that the threaded loops
    # are compiled cold in the rerun too
    scene = cosnet.load_scene(cases + f"/{case}.toml")
    sim = scene.simulation(threads=2)
    contact = next(e for e in scene.effects if isinstance(e, cosnet.Contact))
    most = 0
    for k in range(1, 8):
        sim.run(until=0.005 * k)
        most = max(most, contact.active_contacts(sim))
    return {**sim.state._asdict(), "contacts": np.array([most])}


out, cases = sys.argv[1:3]
for case in sys.argv[3:]:
    np.savez(f"{out}.{case}.npz", **run(case))
"""


def start(cache, out, cases):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="2")
    return spawn([sys.executable, "-c", WORKER, str(out), os.path.join(REPO, "cases"), *cases],
                 env=env, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def run(cache, out, cases):
    """{case: its state arrays} from one fresh process running the cases in turn."""
    proc = start(cache, out, cases)
    try:
        _, err = proc.communicate(timeout=3600)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    result = {}
    for case in cases:
        with np.load(f"{out}.{case}.npz") as f:
            result[case] = {k: f[k] for k in f.files}
    return result


def assert_identical(a, b):
    assert a.keys() == b.keys()
    differ = [k for k in a if not np.array_equal(a[k], b[k])]
    assert not differ, f"arrays differ: {differ}"


def step_cached(cache):
    return any(name.startswith("stepping.advance_verlet") and name.endswith(".nbi")
               for _, _, names in os.walk(cache) for name in names)


@pytest.mark.own_cache
def test_a_run_killed_while_compiling_then_rerun_equals_a_warm_one(tmp_path):
    """SIGKILL once some kernels are cached but not the step; the rerun compiles the step
    and the kernels not yet cached in-process, against the callees loaded from the cache
    (the threaded loops of two threads among them), and must compute what a run loading all
    of it does -- past the contact net's first impacts, so the contact forces take part."""
    cache = tmp_path / "cache"
    proc = start(cache, tmp_path / "killed", ["contact"])
    deadline = time.time() + 1800
    while time.time() < deadline and proc.poll() is None:
        if sum(name.endswith(".nbi") for _, _, names in os.walk(cache) for name in names) >= 12:
            break
        time.sleep(0.05)
    cached_step = step_cached(cache)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    assert proc.returncode == -signal.SIGKILL and not cached_step, "killed too late: nothing half-compiled"
    cases = ["contact"]
    rerun = run(cache, tmp_path / "rerun", cases)
    assert step_cached(cache)
    warm = run(cache, tmp_path / "warm", cases)
    assert rerun["contact"]["contacts"][0] > 0  # the sticks did land
    for case in cases:
        assert_identical(rerun[case], warm[case])


# Saves argv[2] entries (key (tag, i), data tag * 1000 + i) into one function's cache
# files in directory argv[1], as numba saves a compiled overload; both savers start saving
# once both have started (each waits for the other's file "ready.<tag>").
SAVER = r"""
import os, sys, time
import cosnet.kernels  # noqa: F401 -- installs the locked save
from numba.core.caching import IndexDataCacheFile
path, n, tag = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
cache = IndexDataCacheFile(path, "kernel-1.py311", ("stamp", 1))
open(os.path.join(path, f"ready.{tag}"), "w").close()
while not all(os.path.exists(os.path.join(path, f"ready.{t}")) for t in (1, 2)):
    time.sleep(0.01)
for i in range(n):
    cache.save((tag, i), tag * 1000 + i)
"""


def test_processes_saving_into_one_cache_at_once_keep_every_entry(tmp_path):
    """Numba's own save, run by two processes at once, drops entries or sends one key to
    another's data file (both start from their own copy of the index); with the save locked
    (kernels/compiler.py) every key of both finds its own data."""
    from numba.core.caching import IndexDataCacheFile
    n = 150
    procs = [spawn([sys.executable, "-c", SAVER, str(tmp_path), str(n), str(tag)],
                   cwd=REPO, stderr=subprocess.PIPE, text=True) for tag in (1, 2)]
    for proc in procs:
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
    cache = IndexDataCacheFile(str(tmp_path), "kernel-1.py311", ("stamp", 1))
    found = {(tag, i): cache.load((tag, i)) for tag in (1, 2) for i in range(n)}
    wrong = {k: v for k, v in found.items() if v != k[0] * 1000 + k[1]}
    assert not wrong, f"{len(wrong)} of {2 * n} entries lost or crossed, e.g. {next(iter(wrong.items()))}"


# A module of closures over jitted functions, cached; run as a script it prints each
# closure's value and whether it came from the cache.
CLOSURES = r"""
import sys
from numba import njit
from cosnet.kernels.compiler import stable_cache_key

@njit(cache=True)
def double(x):
    return 2 * x

@njit(cache=True)
def triple(x):
    return 3 * x

def plus_one(f, stable):
    def g(x):
        return f(x) + 1
    g = njit(cache=True)(g)
    return stable_cache_key(g) if stable else g

made = {"double": plus_one(double, True), "triple": plus_one(triple, True),
        "plain": plus_one(double, False)}
for name, g in made.items():
    print(name, g(5), sum(g.stats.cache_hits.values()))
"""


def test_a_closure_over_a_kernel_is_loaded_from_the_cache_by_the_next_process(tmp_path):
    """Numba keys a cached closure by the pickle of its cells, and a jitted function pickles
    with an id drawn anew in every process: such a closure (the serial and threaded loop
    runners of kernels/backend.py, motion.py, elastic.py) compiled again in every process.
    With stable_cache_key the next process loads it, and two closures of one source over
    different functions keep their own entries."""
    (tmp_path / "closures.py").write_text(CLOSURES)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    runs = []
    for _ in range(2):
        r = subprocess.run([sys.executable, "closures.py"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-2000:]
        runs.append({name: (int(value), int(hits)) for name, value, hits in
                     (line.split() for line in r.stdout.splitlines())})
    first, second = runs
    assert first == {"double": (11, 0), "triple": (16, 0), "plain": (11, 0)}
    # the stable ones come from the cache, each with its own code; the plain one compiles again
    assert second == {"double": (11, 1), "triple": (16, 1), "plain": (11, 0)}
