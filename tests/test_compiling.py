"""Compilation seen from outside: two processes asking at once for a kernel that is in no cache
compile it once (the second waits for the first, kernels/compiler.py, and loads what it
saved); the compile log (cosnet/compiling.py) times each kernel, learns what a step needs, and
the CLI's status line says how many kernels remain and how long they take here; the second
process compiling a step's kick alongside compiles the kick the step calls, and ends with its
block."""

import collections
import os
import re
import subprocess
import sys
import time

import numba
import numpy as np
import pytest
from numba import prange

from procs import started, wait_until

KERNEL = """
from numba import njit
from cosnet.kernels.compiler import CACHED

@njit(**CACHED)
def spring_force(k, x):
    return -k * x
"""

# asks for spring_force(float64, float64), saying when it starts waiting for another process and
# for which kernel;
# prints its value and how many compilations it ran
CHILD = r"""
import sys
sys.path.insert(0, sys.argv[1])
from numba.core import event
from cosnet.kernels.compiler import WAIT_EVENT
import lockmod

class Tell(event.Listener):
    def on_start(self, ev):
        print("waiting for", ev.data, flush=True)
    def on_end(self, ev):
        pass

compiled = []
class Count(event.Listener):
    def on_start(self, ev):
        compiled.append(ev.data["dispatcher"].py_func.__name__)
    def on_end(self, ev):
        pass

event.register(WAIT_EVENT, Tell())
event.register("numba:compile", Count())
print("force", lockmod.spring_force(2.0, 0.25), "compiled", len(compiled), flush=True)
"""


# Loads numba's numpy support as the first kernel a process compiles or loads does; prints
# whether scipy.linalg was imported by then, whether numba found BLAS, and whether a dot
# compiled afterwards imported it and computed the product.
BLAS = r"""
import sys
import numpy as np
from numba import njit
from numba.core.registry import cpu_target
import cosnet  # noqa: F401
cpu_target.target_context.refresh()
from numba.np import arraymath
before = "scipy.linalg" in sys.modules

@njit
def product(a, b):
    return np.dot(a, b)

a = np.arange(6.0).reshape(2, 3)
right = product(a, a.T).tolist() == (a @ a.T).tolist()
print(before, arraymath._HAVE_BLAS, right and "scipy.linalg" in sys.modules)
"""


def test_numpy_support_loads_without_scipy_linalg_and_blas_still_works():
    """Numba's numpy support, which every process loads with its first kernel, checks at
    import that BLAS is there: found without importing scipy.linalg (kernels/compiler.py), and
    a dot compiled later imports it and multiplies."""
    r = subprocess.run([sys.executable, "-c", BLAS], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["False", "True", "True"], r.stdout


def test_a_kernel_being_compiled_elsewhere_is_waited_for_and_loaded(tmp_path):
    from numba import float64

    from cosnet.kernels.compiler import compile_lock_path, compiling
    (tmp_path / "lockmod.py").write_text(KERNEL)
    sys.path.insert(0, str(tmp_path))
    try:
        import lockmod
    finally:
        sys.path.remove(str(tmp_path))
    sig = (float64, float64)
    path = compile_lock_path(lockmod.spring_force, sig)
    assert path is not None   # in no cache yet: compiling it takes the lock
    with started([sys.executable, "-c", CHILD, tmp_path], stdout=-1, stderr=-1, text=True) as child:
        with compiling(path):     # this process compiles it; the child asks meanwhile
            first = child.stdout.readline().strip()   # the child's first line: it waits, for what
            assert first == "waiting for lockmod.spring_force", (first, child.stderr.read() if first == "" else "")
            lockmod.spring_force.compile(sig)
        out, err = child.communicate(timeout=120)   # the lock is free: the child goes on
    assert child.returncode == 0, err
    _, force, _, compiled = out.split()
    assert float(force) == -0.5
    assert compiled == "0"   # loaded what this process saved, compiled nothing itself


# holds the lock of putoff.spring_force(float64, float64) until told (a line on stdin)
HOLDER = r"""
import sys
sys.path.insert(0, sys.argv[1])
from numba import float64
from cosnet.kernels.compiler import compile_lock_path, compiling
import putoff
with compiling(compile_lock_path(putoff.spring_force, (float64, float64))):
    print("holding", flush=True)
    sys.stdin.readline()
"""


# spring_force and a kernel calling it, and one calling neither
CALLERS = KERNEL + """

@njit(**CACHED)
def tension(k, x):
    return -spring_force(k, x)

@njit(**CACHED)
def stiffness(k, x):
    return k
"""


def test_a_kernel_another_process_compiles_is_seen_as_such(tmp_path):
    """compiling_elsewhere (by which bind_slots puts off a kernel the other process is
    compiling, to load it later) is true while another process holds the kernel's lock and
    false once it let go, or where this process holds it itself; a kernel calling it is seen
    to reach it (reaches_compiling_elsewhere: compiling that caller would wait for it), one
    calling neither is not."""
    from numba import float64

    from cosnet.kernels.compiler import compile_lock_path, compiling, compiling_elsewhere, reaches_compiling_elsewhere
    putoff = _fresh_module(tmp_path / "m", "putoff", CALLERS)
    sig = (float64, float64)
    assert not compiling_elsewhere(putoff.spring_force, sig)
    assert not reaches_compiling_elsewhere(putoff.tension)
    with started([sys.executable, "-c", HOLDER, tmp_path / "m"], stdin=-1, stdout=-1, stderr=-1,
                 text=True) as child:
        assert child.stdout.readline().strip() == "holding", child.stderr.read()
        assert compiling_elsewhere(putoff.spring_force, sig)
        assert not compiling_elsewhere(putoff.tension, sig)
        assert reaches_compiling_elsewhere(putoff.tension)
        assert reaches_compiling_elsewhere(putoff.spring_force)
        assert not reaches_compiling_elsewhere(putoff.stiffness)
        child.stdin.write("\n")
        child.stdin.flush()
        child.wait(timeout=60)
    assert not compiling_elsewhere(putoff.spring_force, sig)
    assert not reaches_compiling_elsewhere(putoff.tension)
    with compiling(compile_lock_path(putoff.spring_force, sig)):
        assert not compiling_elsewhere(putoff.spring_force, sig)
        assert not reaches_compiling_elsewhere(putoff.tension)


PAIR = """
from numba import njit
from cosnet.kernels.compiler import CACHED

@njit(**CACHED)
def inner(x):
    return x * x

@njit(**CACHED)
def outer(x):
    return inner(x) + 1.0
"""


def _fresh_module(folder, name, text):
    """Import ``text`` as module ``name`` from ``folder`` (a new file: in no cache)."""
    import importlib
    folder.mkdir()
    (folder / f"{name}.py").write_text(text)
    sys.path.insert(0, str(folder))
    try:
        sys.modules.pop(name, None)
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(folder))


def test_the_compile_log_times_each_kernel_and_learns_what_a_step_needs(tmp_path, monkeypatch):
    import cosnet.compiling as compiling
    monkeypatch.setattr(compiling, "learned_path", lambda: str(tmp_path / "learned.json"))
    first = _fresh_module(tmp_path / "a", "pairmod", PAIR)
    with compiling.CompileLog() as log:
        assert first.outer(3.0) == 10.0
    names = [k.name for k in log.kernels]
    assert names == ["pairmod.inner", "pairmod.outer"]   # callee finished first
    assert {k.root for k in log.kernels} == {"pairmod.outer"}
    assert all(0.0 < k.llvm < k.seconds for k in log.kernels)
    assert log.by_root() == {"pairmod.outer": (2, log.seconds)}
    # the same kernels, new to the cache (another file): the log now knows what is coming
    seen = []
    second = _fresh_module(tmp_path / "b", "pairmod", PAIR)
    with compiling.CompileLog(seen.append):
        assert second.outer(2.0) == 5.0
    start = seen[0]
    assert (start.kernel, start.done, start.expected) == ("outer", 0, 2)
    assert start.left == pytest.approx(sum(round(k.seconds, 4) for k in log.kernels), abs=1e-9)
    assert seen[1].kernel == "inner" and seen[1].left == start.left   # nothing finished yet


def test_the_status_line_says_how_many_kernels_and_how_long():
    import io

    from cosnet.cli import CompileStatus
    from cosnet.compiling import Status
    out = io.StringIO()
    status = CompileStatus(out, every=0.0)
    status(Status(done=30, expected=52, kernel="kick_loads", left=16.4))
    status(Status(done=3, expected=None, kernel="scan_words", left=None))
    status(Status(done=3, expected=None, kernel="advance_verlet", left=None, waiting=True))
    lines = [line.rstrip() for line in out.getvalue().split("\r") if line]
    assert lines == ["  compiling kernels: 30 of about 52 (kick_loads, about 16 s left)",
                     "  compiling kernels: 3 (scan_words)",
                     "  waiting for another process compiling advance_verlet"]
    status.clear()
    assert out.getvalue().endswith("\r" + " " * 78 + "\r")


@pytest.mark.parametrize("drive", [False, True])
def test_the_kick_compiled_alongside_is_the_one_the_step_calls(tmp_path, drive, monkeypatch):
    """compile_kick (what the second process runs) asks for the kick and the step with the very
    types the step calls them with, and, with a drive, for the loads with the types the drive's
    reaction evaluates them with: once the step has run and the reaction been read (compiling
    all into the cache), compile_kick finds them in the cache and compiles nothing (told the
    step is not cached, so that it asks for each)."""
    import cosnet
    from cosnet.compiling import CompileLog, compile_kick
    from cosnet.output import record
    from nets import write_sweep_scene
    path = write_sweep_scene(tmp_path / "scene.toml")
    if drive:   # the tip driven at a constant velocity
        text = path.read_text().replace("[initial.perturbation]", """[[effects]]
kind = "drive"
node = "tip"
position = { rate = [0.0, 0.0, -0.1] }
[initial.perturbation]""")
        path.write_text(text)
    scene = cosnet.load_scene(path)
    sim = scene.simulation(threads=1)
    sim.run(steps=1)
    if drive:
        sim.reaction(scene.net.node("tip"))
    monkeypatch.setattr(record, "kernels_compiled", lambda sim: False)
    with CompileLog() as log:
        compile_kick(path, 1)
    assert log.kernels == []


def test_the_queue_two_processes_share_takes_the_longest_kernels_first():
    """The run and the second process compile a step's slot kernels in one order, each every
    kernel once, the drift's first for the run (frame 0 needs it) and last for the other; the
    rest by their bytecode, the longest first: a line-obstacle contact with friction (6.6 s
    to compile here) before the kick's own kernels and gravity (0.4 s), so that neither ends
    waiting for the other to finish a long kernel taken last."""
    import cosnet
    from cosnet.kernels.compiler import code_weight
    from cosnet.kernels.compose import step_kernels
    from cosnet.kernels.stepping import compile_orders, drift_positions_at, start_loads_at
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 1.0)), net.add_node((1.0, 0.0, 1.0))
    rubber = cosnet.Material(E=1e7, poisson=0.3, density=1000.0)
    net.add_line(a, b, material=rubber, section=cosnet.Circle(0.01), elements=4)
    drum = cosnet.Obstacle("capsule", start=(0.5, -0.1, 0.0), end=(0.5, 0.1, 0.0), radius=0.1, k=1e6, gamma=24.0,
                           mu_s=0.3, mu_k=0.3)
    sim = cosnet.Simulation(net, [cosnet.Gravity(), drum])
    kernels = step_kernels(sim.step_groups)
    run, other = compile_orders(kernels)
    drift = kernels.index(drift_positions_at)
    assert sorted(run) == sorted(other) == list(range(len(kernels)))
    assert run[0] == other[-1] == drift and run[1:] == other[:-1]
    weights = [code_weight(kernels[r]) for r in other[:-1]]
    assert weights == sorted(weights, reverse=True)
    names = [getattr(kernels[r], "slot_name", "") for r in other]
    contact = next(i for i, n in enumerate(names) if n.endswith("add_line_obstacle"))
    gravity = next(i for i, n in enumerate(names) if n.endswith("add_gravity"))
    assert contact < other.index(kernels.index(start_loads_at)) and contact < gravity


# a kernel whose call of another sits in a branch an option of its module decides
OPTIONED = """
from numba import njit
from cosnet.kernels.compiler import CACHED
PART = {part}

@njit(**CACHED)
def series(x):
    y = 0.0
    for k in range(10):
        y += x ** k / (k + 1.0)
    return y

@njit(**CACHED)
def value(x):
    if PART:
        return series(x)
    if not PART:
        return x
    return 2.0 * x
"""


def test_a_kernels_weight_leaves_out_what_its_options_prune(tmp_path):
    """code_weight, which orders the queue, counts what numba compiles: a call in a branch a
    boolean constant of the module never enters (a variant's option off) is pruned before
    typing, so neither it nor its callee is counted, and the callee is not among what the
    kernel reaches (whose locks put it off: reaches_compiling_elsewhere); with the option on,
    both are, and the branch ``if not PART`` is what is pruned."""
    from cosnet.kernels.compiler import _reach, code_weight
    off = _fresh_module(tmp_path / "off", "optioned_off", OPTIONED.format(part=False))
    on = _fresh_module(tmp_path / "on", "optioned_on", OPTIONED.format(part=True))
    assert off.value.compile("float64(float64)") is not None
    assert off.series.overloads == {}   # numba did prune it: the call was never typed
    assert off.series not in _reach(off.value)[1] and on.series in _reach(on.value)[1]
    callee = code_weight(on.series)
    assert code_weight(on.value) > callee > code_weight(off.value)
    assert code_weight(on.value) < callee + len(on.value.py_func.__code__.co_code)


def test_the_process_compiling_alongside_ends_with_the_block(tmp_path, monkeypatch):
    """The second process is started only for a step not cached yet, and is gone when the
    block ends, finished or not."""
    import cosnet
    from cosnet import compiling
    from cosnet.output import record
    from nets import write_sweep_scene
    sim = cosnet.load_scene(write_sweep_scene(tmp_path / "scene.toml")).simulation(threads=1)
    marker = tmp_path / "helper.pid"
    monkeypatch.setattr(compiling, "_HELPER", f"import os, time; open({str(marker)!r}, 'w').write(str(os.getpid())); "
                                              "time.sleep(600)")
    monkeypatch.setattr(record, "kernels_compiled", lambda sim: True)
    with compiling.compiling_alongside("scene.toml", sim):
        time.sleep(0.5)
    assert not marker.exists()             # cached: nothing started
    monkeypatch.setattr(record, "kernels_compiled", lambda sim: False)
    with compiling.compiling_alongside("scene.toml", sim):
        assert wait_until(lambda: marker.exists() and marker.read_text(), 60)
        pid = int(marker.read_text())
        assert os.path.exists(f"/proc/{pid}")
    assert not os.path.exists(f"/proc/{pid}")   # killed and reaped as the block ended


def test_the_process_alongside_a_build_starts_at_the_first_compilation(tmp_path, monkeypatch):
    """Given no simulation (the block builds it), the second process starts as the block
    first compiles a kernel, not before: a warm start, which compiles nothing, starts none."""
    from numba import njit

    from cosnet import compiling
    marker = tmp_path / "helper.pid"
    monkeypatch.setattr(compiling, "_HELPER", f"import os, time; open({str(marker)!r}, 'w').write(str(os.getpid())); "
                                              "time.sleep(600)")
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    with compiling.compiling_alongside("scene.toml", threads=1):
        time.sleep(0.5)
    assert not marker.exists()             # nothing compiled: nothing started
    with compiling.compiling_alongside("scene.toml", threads=1):
        time.sleep(0.5)
        assert not marker.exists()
        njit(lambda x: x + 1)(1)           # a compilation: the helper starts
        assert wait_until(lambda: marker.exists() and marker.read_text(), 60)
        pid = int(marker.read_text())
    assert not os.path.exists(f"/proc/{pid}")


def test_nets_of_one_element_lines_or_none_share_the_step_of_longer_lines():
    """A net of bodies alone, one of a one-element line and one of a four-element line step
    with one compiled step (their column-major arrays of one row or none are typed as longer
    ones are, kernels.layout.record_type); each falls freely, z = -g t^2 / 2 exactly under
    Verlet (an unstressed straight line carries no internal load). Numba's own dispatch still
    types by the arrays' flags: a kernel called from Python with row-major copies of a
    one-element net's state computes what it does with the state itself."""
    import numpy as np

    import cosnet
    from cosnet.engine.measure import energies
    steel = cosnet.Material(E=2e11, G=8e10, density=7850.0)
    sims = []
    for elements in (0, 1, 4):
        net = cosnet.Net()
        a = net.add_node((0.0, 0.0, 0.0), mass=1.0, inertia=(1.0, 1.0, 1.0))
        if elements:
            net.add_line(a, net.add_node((0.5, 0.0, 0.0)), material=steel, section=cosnet.Circle(0.01),
                         elements=elements)
        sims.append(cosnet.Simulation(net, effects=[cosnet.Gravity()], dt=1e-6))
    assert len({s.step_signature() for s in sims}) == 1
    compiled = len(sims[0].advance_kernel.overloads)   # what other tests in this process compiled
    for sim in sims:
        sim.run(steps=40)
        fall = -0.5 * 9.81 * sim.time ** 2
        np.testing.assert_allclose(sim.state.node_x[:, 2], fall, rtol=1e-12, atol=0)
        np.testing.assert_allclose(sim.state.x[:, 2], fall, rtol=1e-12, atol=0)
    assert len(sims[0].advance_kernel.overloads) <= compiled + 1
    # row-major copies of the one-element net's records have the flags, not the shapes, of
    # the records of the net without lines, whose arrays have no rows
    energies(sims[0].model, sims[0].state)
    one = sims[1]
    one.state.v[:] = [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]]
    model, state = (type(r)(*(np.ascontiguousarray(a) for a in r)) for r in (one.model, one.state))
    assert energies(model, state) == energies(one.model, one.state)


def test_kernels_called_from_python_are_typed_as_the_step_types_the_records():
    """A line in water whose model has no active lines holds an empty rest-strain array, which
    numba's own dispatch types row-major and the stepper column-major (record_type). The
    fluid's sample and entrained energy, run from Python when the simulation is built and its
    energy measured, go through kernels.layout.typed_call: the overloads they are called with
    (compiled here or loaded from the cache) have the step's record types, so every kernel they
    call is the one the step calls. The energy they give is the one of the state: the kinetic
    energy of the entrained water, 1/2 C_a rho A l v^2 for a line moving across itself."""
    import math

    import cosnet
    from cosnet.kernels import fluid_variants
    from cosnet.kernels.layout import record_type
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, -1.0)), net.add_node((1.0, 0.0, -1.0))
    net.add_line(a, b, material=cosnet.Material(E=1e8, G=4e7, density=400.0), section=cosnet.Circle(0.01),
                 elements=4)
    water = cosnet.Fluid(1000.0, added_mass=(1.0, 0.0))
    sim = cosnet.Simulation(net, [cosnet.Gravity((0.0, 0.0, 0.0)), water])
    assert sim.model.element_rest_strain.shape[0] == 0 and sim.model.element_rest_strain.flags.c_contiguous
    sim.state.v[:] = (0.0, 0.0, 0.5)
    sim.state.node_v[:] = (0.0, 0.0, 0.5)
    entrained = sim.energy() - 0.5 * net.total_mass() * 0.25
    assert entrained == pytest.approx(0.5 * 1000.0 * math.pi * 1e-4 * 1.0 * 0.25, rel=1e-12)
    model, state = record_type(sim.model), record_type(sim.state)
    variant = fluid_variants.VARIANTS.of(water.params(sim))
    kernel = variant.kernel("fluid_entry")
    assert kernel.overloads and all(sig[1:3] == (model, state) for sig in kernel.overloads), kernel


def test_a_fluid_compiles_only_the_parts_its_data_can_use():
    """A fluid's record is of the variant its data needs (kernels/specialise.py): the kernels of
    a Stokes-flow fluid in a still medium, without added mass or buoys, leave out the parts
    that cannot act, so they are never typed. Typed afresh here (not from the cache), its flow
    and inertia kernels reach the drag (the free ends' inside the kick) and none of the added
    mass, its turning fluid, the buoys, the moving medium or the pass over nodes whose line ends
    have arms (their compiled code names nothing of those). A variant record pickles by name,
    as a sweep's worker or a step's cache index reads it."""
    import pickle

    from numba import typeof

    import cosnet
    from cosnet.kernels import fluid
    from cosnet.kernels.compose import FLOW_KERNELS, INERTIAS
    from cosnet.kernels.layout import empty_loads, record_type
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, -1.0)), net.add_node((1.0, 0.0, -1.0))
    net.add_line(a, b, material=cosnet.Material(E=1e8, G=4e7, density=400.0), section=cosnet.Circle(0.01),
                 elements=4)
    stokes = cosnet.Fluid(1000.0, resistance=(2.0, 1.0))
    sim = cosnet.Simulation(net, [stokes])
    p = stokes.params(sim)
    cls = type(p)
    assert cls is not fluid.FluidParams and isinstance(p, fluid.FluidParams)
    assert pickle.loads(pickle.dumps(p)).__class__ is cls
    model, state, h = record_type(sim.model), record_type(sim.state), typeof(0.5)
    kick = typeof((empty_loads(sim.model), 0.5))
    ir = (_reached(FLOW_KERNELS[cls], typeof(p), model, state, h)
          + _reached(INERTIAS[cls], typeof(p), model, state, kick))
    named = set(re.findall(r"\d+([a-z_]+)B", ir))   # (numba's mangled names: length, name, its suffix)
    assert {"sample_medium", "kick_drag_vertices", "kick_drag_nodes"} <= named
    assert not named & {"sample_buoys", "push_vertices", "sample_node_masses", "node_mass_matrix", "entrained_energy",
                        "nodes_entrained", "buoys_entrained", "add_turning_forces", "drag_nodes"}


def _reached(kernel, *argtypes) -> str:
    """The LLVM IR of ``kernel``'s Python function compiled afresh for ``argtypes`` (not loaded
    from the cache): every function it reaches, inlined or linked, is named in it."""
    from numba import njit
    options = {k: v for k, v in kernel.targetoptions.items() if k not in ("nopython", "cache")}
    fresh = njit(**options)(kernel.py_func)
    fresh.compile(argtypes)
    return fresh.inspect_llvm(argtypes)


def test_obstacles_and_drives_compile_only_the_parts_their_data_can_use():
    """As a fluid's (above), an obstacle's and a drive's records are of the variant their data
    needs: a plane's load kernel, compiled afresh, reaches the vertex contacts and none of the
    element contacts or the other shapes (the deepest point of a capsule in a half-space is an
    end sphere, which the vertex contact is); a capsule's reaches the element contacts and
    none of the mesh, nor does a body's shape (never a mesh); a drive that leaves the rotation
    free compiles none of the turning (the prescribed angle's rotation, the exponential's
    rates). Every variant pickles by name."""
    import pickle

    from numba import typeof

    import cosnet
    from cosnet.kernels.compose import DRIFT_CONSTRAINTS, KICK_CONSTRAINTS, LOAD_KERNELS
    from cosnet.kernels import segments
    from cosnet.kernels.bodies import BodyParams
    from cosnet.kernels.drives import DriveParams
    from cosnet.kernels.layout import empty_loads, record_type
    from cosnet.kernels.obstacles import ObstacleParams
    net = cosnet.Net()
    a, b = net.add_node((0.0, 0.0, 0.01)), net.add_node((1.0, 0.0, 0.01))
    net.add_line(a, b, material=cosnet.Material(E=1e8, G=4e7, density=400.0), section=cosnet.Circle(0.01),
                 elements=4)
    plane = cosnet.Obstacle("plane", point=(0, 0, 0), normal=(0, 0, 1), k=1e3, name="floor")
    capsule = cosnet.Obstacle("capsule", start=(0.5, -1, -0.5), end=(0.5, 1, -0.5), radius=0.5, k=1e3)
    ball = net.add_node((0.5, 0.0, 0.5), mass=1.0, inertia=(1e-2, 1e-2, 1e-2))
    body = cosnet.Body(ball, "sphere", radius=0.1, k=1e3, obstacles=["floor"])
    shaken = cosnet.Drive(a, position=dict(amplitude=[0.0, 0.0, 0.01], omega=3.0))
    turned = cosnet.Drive(b, position=dict(amplitude=[0.0, 0.0, 0.01], omega=3.0),
                          rotation=dict(amplitude=[0.1], omega=3.0), axis=(1.0, 0.0, 0.0))
    sim = cosnet.Simulation(net, [plane, capsule, shaken, turned, body])
    model, state = record_type(sim.model), record_type(sim.state)
    loads = typeof(empty_loads(sim.model))
    records = [x.params(sim) for x in (plane, capsule, shaken, turned)]
    for p in records:
        assert type(p) not in (ObstacleParams, DriveParams) and isinstance(p, (ObstacleParams, DriveParams))
        assert pickle.loads(pickle.dumps(p)).__class__ is type(p)
    on_plane, on_capsule = (_reached(LOAD_KERNELS[type(p)], typeof(p), model, state, loads) for p in records[:2])
    assert "obstacle_distance" in on_plane and "add_obstacle" in on_plane
    for p in records[:2]:   # the elements' energy: nothing for a plane
        energy = segments.VARIANTS.of(p).kernel("element_energy")
        assert ("element_overlap" in _reached(energy, typeof(p), state)) is (p.shape != segments.PLANE)
    for name in ("add_element_contacts", "deepest_point", "_mesh_distance", "mesh_segment", "_box_deepest"):
        assert name not in on_plane, name
    assert "add_element_contacts" in on_capsule and "deepest_point" in on_capsule
    on_body = _reached(LOAD_KERNELS[BodyParams], typeof(body.params(sim)), model, state, loads)
    for name in ("_mesh_distance", "mesh_segment"):
        assert name not in on_capsule, name
        assert name not in on_body, name   # a body's shape and targets are never meshes
    assert "deepest_point" in on_body
    for p, turns in zip(records[2:], (False, True)):
        kick = typeof((empty_loads(sim.model), 0.5))
        ir = _reached(DRIFT_CONSTRAINTS[type(p)], typeof(p), model, state, typeof(0.5)) + \
            _reached(KICK_CONSTRAINTS[type(p)], typeof(p), model, state, kick)
        assert ("quat_exp" in ir and "exp_rates" in ir) is turns, ir.count("quat")


def test_joints_compile_only_what_the_nets_joints_have():
    """The articulated ends' record is of the variant its joints need: a net of free universal
    joints compiles neither the ball joints' coordinates and friction nor the sticking of
    coordinates that no joint of it has; one with a ball joint with friction compiles both."""
    from numba import typeof

    import cosnet
    from cosnet.kernels.compose import LOAD_KERNELS
    from cosnet.kernels.layout import empty_loads, record_type
    reached = []
    for joint in (cosnet.Universal(), cosnet.Ball(friction=(0.1, 0.05))):
        net = cosnet.Net()
        a, b = net.add_node((0.0, 0.0, 0.0), mass=1.0), net.add_node((1.0, 0.0, 0.0))
        net.add_line(a, b, material=cosnet.Material(E=1e8, G=4e7, density=400.0), section=cosnet.Circle(0.01),
                     elements=4, start_joint=joint)
        sim = cosnet.Simulation(net, [cosnet.Gravity()])
        p = next(r for group in sim.step_groups for r in group if hasattr(r, "dofs"))
        reached.append(_reached(LOAD_KERNELS[type(p)], typeof(p), record_type(sim.model), record_type(sim.state),
                                typeof(empty_loads(sim.model))))
    free_universal, ball = reached
    # a universal joint settles by its exact step (settle_universal), a ball by the iteration (settle_ball),
    # a loose one in closed form (loose_turn)
    assert "settle_universal" in free_universal and "settle_ball" not in free_universal
    assert "settle_ball" in ball and "joint_turn" in ball
    for name in ("start_turning", "ball_axes", "loose_turn"):
        assert name not in free_universal, name
        assert name in ball, name


def test_rings_compile_the_fluid_s_masses_only_where_a_fluid_adds_some():
    """The sliders' record is of the variant its net needs: a ring on a dry line moves it by
    scalar inverse masses, and its drift's projection, compiled afresh, reaches none of the
    inverse mass tensors; on a line that carries a fluid's added mass, it reaches them. A
    sheave's record is of its variant likewise. Every variant pickles by name."""
    import pickle

    from numba import typeof

    import cosnet
    from cosnet.kernels.compose import DRIFT_CONSTRAINTS
    from cosnet.kernels.layout import record_type
    from cosnet.kernels.sliding import SlidingParams
    reached = []
    for effects in ([], [cosnet.Fluid(1025.0, added_mass=(1.0, 0.0))]):
        net = cosnet.Net()
        a, b = net.add_node((0.0, 0.0, 0.0), mass=1.0), net.add_node((1.0, 0.0, 0.0), mass=1.0)
        line = net.add_line(a, b, material=cosnet.Material(E=1e8, G=4e7, density=400.0),
                            section=cosnet.Circle(0.01), elements=4)
        net.add_ring(line, s=0.5, mass=0.1)
        sim = cosnet.Simulation(net, effects)
        p = next(r for r in sim.step_groups[2] if isinstance(r, SlidingParams))
        assert type(p) is not SlidingParams and pickle.loads(pickle.dumps(p)).__class__ is type(p)
        reached.append(_reached(DRIFT_CONSTRAINTS[type(p)], typeof(p), record_type(sim.model),
                                record_type(sim.state), typeof(0.5)))
    dry, wet = reached
    assert "nearest_on_path" in dry and "nearest_on_path" in wet
    for name in ("drift_impulse", "slider_tensor"):
        assert name not in dry, name
        assert name in wet, name
    from cosnet.effects.sheaves import Sheaves, over_a_sheave   # a sheave's record likewise
    for effects, bits in (([], "0"), ([cosnet.Fluid(1025.0, added_mass=(1.0, 0.0))], "1")):
        net, _ = over_a_sheave(radius=0.05, drop=0.2, masses=(0.3, 0.2))
        sim = cosnet.Simulation(net, effects)
        p = next(e for e in sim.effects if isinstance(e, Sheaves)).params(sim)
        assert type(p).__name__ == "SheaveParams_" + bits and pickle.loads(pickle.dumps(p)).__class__ is type(p)


def test_every_kernel_sets_what_numba_would_take_from_its_first_caller():
    """Numba compiles a kernel whose options leave fast-math, the error model or reference
    counting unset with its first caller's, and keys neither its overloads nor its cache by
    them: a contact kernel first called from Python took python's error model and a step
    compiled after it raised ZeroDivisionError where the same step compiled first gave a
    finite result. Every kernel of cosnet.kernels sets all three, so its code is the same
    whoever calls it first, and the error model is numpy's (a zero divisor gives inf or NaN,
    which the watch sees)."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    from cosnet import kernels
    unset, python_model = [], []
    for info in pkgutil.iter_modules(kernels.__path__):
        module = importlib.import_module(f"{kernels.__name__}.{info.name}")
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module.__name__:
                options = obj.targetoptions
                unset += [f"{info.name}.{name}: {k}" for k in ("fastmath", "error_model", "_nrt")
                          if k not in options]
                if options.get("error_model") == "python":
                    python_model.append(f"{info.name}.{name}")
    assert not unset and not python_model, unset + python_model


# Runs a wire in water (drag, added mass turning with it, upthrust) for 300 steps and prints
# a digest of its state arrays, after whether numba's typing remembers (kernels/typing_memo.py).
WET_WIRE_BUILT = r"""
import hashlib
import cosnet
from numba.core.types.functions import BaseFunction
remembers = getattr(BaseFunction.get_call_type, "remembers", False)
net = cosnet.Net()
a = net.add_node((0.0, 0.0, -2.0), fixed=True)
b = net.add_node((3.0, 0.0, -1.0), mass=5.0, inertia=(0.1, 0.1, 0.1))
net.add_line(a, b, material=cosnet.Material(E=1e9, poisson=0.3, density=7850.0),
             section=cosnet.Circle(0.02), elements=12)
fluid = cosnet.Fluid(1025.0, velocity=(0.4, 0.1, 0.0), drag=(1.2, 0.008), added_mass=(1.0, 0.2),
                     buoyancy=True, surface=0.0)
sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid], threads=1)
"""
WET_WIRE_RUN = r"""
sim.run(steps=300)
digest = hashlib.sha256()
for name, array in sim.state._asdict().items():
    digest.update(name.encode())
    digest.update(array.tobytes())
print(remembers, digest.hexdigest(), flush=True)
"""
WET_WIRE = WET_WIRE_BUILT + WET_WIRE_RUN

# After the wet wire: whether the fluid's sample_medium (linked into the sample called from
# Python and into the step's flow) has machine code of its own, how often it came from the
# cache, and how many libraries were compiled for their address late (kernels/linking.py).
LINKED = r"""
from cosnet.kernels import fluid_variants, linking
kernel = fluid_variants.VARIANTS.of(fluid.params(sim)).family["sample_medium"]
(cres,) = kernel.overloads.values()
print(not getattr(cres.library, "_cosnet_linked_only", False), sum(kernel.stats.cache_hits.values()),
      linking.promoted[0], flush=True)
"""


def _output(script: str, env: dict, meanwhile=None) -> str:
    """The output of a Python process running ``script`` in ``env``, ``meanwhile`` called here
    while it runs; the process killed if either fails or it runs over ten minutes (started),
    its exit code asserted 0."""
    with started([sys.executable, "-c", script], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                 text=True) as proc:
        if meanwhile is not None:
            meanwhile()
        stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 0, stderr[-2000:]
    return stdout


def test_remembered_typing_compiles_the_same_code(tmp_path):
    """kernels/typing_memo.py changes how long numba types, not what it compiles: a wire in
    water compiled cold with numba's typing as it is (a process with an empty cache of its
    own, so it compiles everything) runs to the same state, bit for bit, as this process,
    whose typing remembers (its step compiled here or loaded from the suite's cache, which
    the memo compiled: a second cold compile with it would show nothing more)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache0"), COSNET_TYPING_MEMO="0")
    here: dict = {}
    remembers, digest = _output(WET_WIRE, env, lambda: exec(WET_WIRE, here)).split()[-2:]
    assert (remembers, here["remembers"]) == ("False", True)
    from numba.core.inline_closurecall import InlineWorker   # and the inliner copies once here
    assert getattr(InlineWorker.inline_ir, "copies_once", False)
    assert len(digest) == 64 and digest == here["digest"].hexdigest()


def test_a_kernel_only_linked_is_cached_as_ir_and_links_as_compiled(tmp_path):
    """kernels/linking.py: a kernel only ever linked into others gets no machine code of its
    own and is cached as its LLVM IR, and a step that links it from the cache runs as one that
    compiled it. A process builds the wet wire, which compiles the fluid's sample (called from
    Python) and with it sample_medium into an empty cache; a second runs the wire from that
    cache, sample_medium read back as IR and linked into the step's flow, compiled there: its
    state after 300 steps is this process's, bit for bit. In neither has sample_medium
    machine code, and no kernel the step calls through its address was left without it and
    compiled late (linking.promoted)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    runs = [_output(script, env).split() for script in (WET_WIRE_BUILT + LINKED, WET_WIRE + LINKED)]
    here: dict = {}
    exec(WET_WIRE, here)
    assert runs[0][-3:] == ["False", "0", "0"]          # compiled: IR only
    assert runs[1][-3:] == ["False", "1", "0"]          # read back from the cache: IR only
    assert runs[1][-4] == here["digest"].hexdigest()


def test_numba_linking_keeps_its_own_cache(tmp_path):
    """COSNET_LINK_ONLY=0 leaves numba's code generation as it is (kernels/linking.py), whose
    steps differ in their last bits: its kernels go to a cache directory of their own, and
    this process's kernels, linked as IR, to another."""
    script = ("import numba; from cosnet.kernels import compiler; "
              "from numba.core.typed_passes import BaseNativeLowering; "
              "print(getattr(BaseNativeLowering.run_pass, 'links_only', False), numba.config.CACHE_DIR)")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), COSNET_LINK_ONLY="0")
    links_only, cache = _output(script, env).split()[-2:]
    import numba
    assert links_only == "False" and cache.endswith("-numba-linking")
    assert cache[:-len("-numba-linking")] == os.path.join(str(tmp_path), os.path.basename(numba.config.CACHE_DIR))


RECORD = collections.namedtuple("RECORD", [f"a{i}" for i in range(12)])


@numba.njit
def _add_block(p, i0, i1):
    for i in range(i0, i1):
        p.a0[i] += p.a11[i] * p.a5[i]


def _add_blocks(p, n):   # (as the fluid's threaded kick: a block function called in the loop)
    for b in prange(n):
        _add_block(p, 4 * b, 4 * b + 4)


def test_a_threaded_loop_reads_its_record_once_and_compiles_the_same_code(monkeypatch):
    """kernels/parfor_loads.py: where a prange loop that reads a record of 12 arrays is called,
    the record is loaded from its variable once, not once per array (the twelve loads that
    made LLVM's time grow as the square of a record's size are one), and the machine code and
    the results are numba's own: the same loop compiled with numba's lowering as it is
    computes the same values, bit for bit, with the same instructions."""
    from numba.core import codegen

    from cosnet.kernels import parfor_loads
    optimise = codegen.CPUCodeLibrary._optimize_functions

    def compiled(active, p):
        modules: list = []

        def seen(library, module):
            modules.append(str(module))
            return optimise(library, module)
        monkeypatch.setattr(parfor_loads, "ACTIVE", active)
        monkeypatch.setattr(codegen.CPUCodeLibrary, "_optimize_functions", seen)
        kernel = numba.njit(parallel=True)(_add_blocks)
        kernel(p, 3)
        monkeypatch.undo()
        caller = [m for m in modules if "_add_blocks" in m and "parfor_gufunc" in m and "@cfunc" not in m]
        assert len(caller) == 1
        return kernel, len(re.findall(r"= load \[12 x", caller[0]))

    def asm(kernel):   # (less the names: a function's unique id, the loop's address)
        return re.sub(r"0x[0-9a-f]+|B\d+v\d+|_\d+\b", "", kernel.inspect_asm(kernel.signatures[0]))

    rng = np.random.default_rng(1)
    ours = RECORD(*[rng.random(12) for _ in range(12)])
    numbas = RECORD(*[a.copy() for a in ours])
    sums = ours.a0 + ours.a11 * ours.a5
    (kernel, loads), (numba_kernel, numba_loads) = compiled(True, ours), compiled(False, numbas)
    assert loads == numba_loads - 11
    assert np.array_equal(ours.a0, sums) and np.array_equal(numbas.a0, sums)
    assert asm(kernel) == asm(numba_kernel)
