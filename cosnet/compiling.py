"""What numba compiles in this process, how long each kernel takes, and how long is left.

A ``CompileLog`` listens to numba's compile events while it is open: for every kernel
compiled (a cache miss) it records its own time (the kernels compiled inside it and the waits
excluded), split into numba's part (type inference, lowering) and LLVM's (optimisation,
linking, machine code), and apart, the time spent waiting for another process compiling a
kernel this one needs (kernels/compiler.py). Loads from the cache fire no event: they are what is left of a phase.

What a step needs is learned per machine: closing a log stores, beside numba's cache, the
kernels compiled for each outermost one with their times, so the next compilation of that
kernel can say how many kernels remain and about how long they take on this machine.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass

from numba.core import event

from .kernels.compiler import WAIT_EVENT

LEARNED = "compile-times.cosnet.json"   # beside the cache directories, shared by them all


@dataclass
class Kernel:
    """One compilation: the kernel's name, its own seconds (total, of which LLVM), the
    outermost kernel it was compiled for."""
    name: str
    seconds: float = 0.0
    llvm: float = 0.0
    root: str = ""


@dataclass
class Status:
    """Where a compilation stands: kernels compiled so far, those expected in all (None when
    this machine has not compiled this step before), the kernel under way, and the seconds
    left by this machine's earlier times (None when unknown)."""
    done: int
    expected: int | None
    kernel: str
    left: float | None
    waiting: bool = False


def learned_path() -> str:
    """The file of this machine's compile times: beside the cache directories of every kernel
    source (kernels/compiler.py), so an edited kernel keeps its estimate."""
    from numba.core import config
    return os.path.join(os.path.dirname(config.CACHE_DIR), LEARNED)


def _read_learned() -> dict:
    try:
        with open(learned_path()) as f:
            data = json.load(f)
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


class CompileLog(event.Listener):
    """Records compilations while open (``with CompileLog(report) as log``): ``kernels`` (a
    Kernel each, in the order they finished), ``waited`` (seconds). ``report``, if given,
    receives a Status as each kernel starts compiling or a wait begins. ``llvm``: time LLVM's
    share too (numba fires an event at every hold of its LLVM lock: some overhead)."""

    def __init__(self, report=None, llvm: bool = True):
        self.report = report
        self._kinds = ("numba:compile", WAIT_EVENT) + (("numba:llvm_lock",) if llvm else ())
        self.kernels: list[Kernel] = []
        self.waited = 0.0
        self._stack: list = []   # [Kernel, start, seconds of the kernels compiled inside it]
        self._llvm_depth = 0
        self._wait_start = self._llvm_start = 0.0
        self._plans = _read_learned().get("plans", {})

    # numba's listener interface, one object for several event kinds
    def on_start(self, ev):
        self._dispatch(ev)

    def on_end(self, ev):
        self._dispatch(ev)

    def _dispatch(self, ev):
        if ev.kind == "numba:compile":
            self._compile(ev)
        elif ev.kind == "numba:llvm_lock":
            self._llvm(ev)
        elif ev.kind == WAIT_EVENT:
            self._wait(ev)

    def _compile(self, ev):
        now = time.perf_counter()
        if ev.is_start:
            dispatcher = ev.data["dispatcher"]
            py = dispatcher.py_func
            # an effect's slot wrappers share one function (compose.slot_wrapper): each is named
            # by its hook and kernel, so that its time and its plan are that kernel's
            name = getattr(dispatcher, "slot_name", None) or f"{py.__module__}.{py.__qualname__}"
            root = self._stack[0][0].name if self._stack else name
            self._stack.append([Kernel(name, root=root), now, 0.0])
            self._tell(name)
            return
        kernel, start, nested = self._stack.pop()
        kernel.seconds = now - start - nested
        self.kernels.append(kernel)
        if self._stack:
            self._stack[-1][2] += now - start

    def _llvm(self, ev):
        # LLVM's lock is taken re-entrantly: time the outermost hold, for the kernel on top
        if ev.is_start:
            self._llvm_depth += 1
            if self._llvm_depth == 1:
                self._llvm_start = time.perf_counter()
            return
        self._llvm_depth -= 1
        if self._llvm_depth == 0 and self._stack:
            self._stack[-1][0].llvm += time.perf_counter() - self._llvm_start

    def _wait(self, ev):
        if ev.is_start:
            self._wait_start = time.perf_counter()
            self._tell(str(ev.data), waiting=True)
            return
        took = time.perf_counter() - self._wait_start
        self.waited += took
        if self._stack:   # a wait inside a compilation is not that kernel's own time
            self._stack[-1][2] += took

    def _tell(self, name, waiting=False):
        if self.report is None:
            return
        root = self._stack[0][0].name if self._stack else name
        plan = self._plans.get(root)
        expected = left = None
        if plan:
            # the plan's kernels not yet finished here (names repeat: closures made by one
            # factory share theirs), the ones under way included: their own time lies ahead
            finished = Counter(k.name for k in self.kernels if k.root == root)
            unfinished = []
            for entry_name, seconds in plan:
                if finished[entry_name] > 0:
                    finished[entry_name] -= 1
                else:
                    unfinished.append(seconds)
            others = sum(1 for k in self.kernels if k.root != root)
            expected = others + len(plan)
            left = float(sum(unfinished))
        self.report(Status(len(self.kernels), expected, name.rsplit(".", 1)[-1], left, waiting))

    def __enter__(self):
        for kind in self._kinds:
            event.register(kind, self)
        return self

    def __exit__(self, *exc):
        for kind in self._kinds:
            event.unregister(kind, self)
        if self.kernels and exc[0] is None:
            self._learn()

    @property
    def seconds(self) -> float:
        return sum(k.seconds for k in self.kernels)

    @property
    def llvm(self) -> float:
        return sum(k.llvm for k in self.kernels)

    def by_root(self) -> dict:
        """{outermost kernel: (kernels compiled for it, seconds)}."""
        out: dict = {}
        for k in self.kernels:
            n, s = out.get(k.root, (0, 0.0))
            out[k.root] = (n + 1, s + k.seconds)
        return out

    def _learn(self):
        """Store each outermost kernel's plan on this machine: the kernels compiled for it, in
        order, with their own seconds (a best effort: a cache folder we cannot write only loses
        the estimates)."""
        learned = _read_learned()
        plans = learned.setdefault("plans", {})
        for root in {k.root for k in self.kernels}:
            plan = [[k.name, round(k.seconds, 4)] for k in self.kernels if k.root == root]
            # a step compiled over a partly warm cache compiles fewer kernels than it needs:
            # it does not replace a fuller plan
            if len(plan) >= len(plans.get(root, ())):
                plans[root] = plan
        path = learned_path()
        try:
            tmp = f"{path}.{os.getpid()}.tmp"
            with open(tmp, "w") as f:
                json.dump(learned, f, indent=0, sort_keys=True)
            os.replace(tmp, path)
        except OSError:
            pass


def compile_scene(path, alongside: bool = True) -> dict:
    """Update numba's cache given a scene file: build it as `cosnet run` does and compile (or
    load) every kernel its first frames and its steps need, on a simulation thrown away after
    one step (``alongside``: with a second process compiling the kick, compiling_alongside).
    Returns {"scene", "kernels" (compiled in this process), "seconds" (compiling)}."""
    from .scene.loader import load_scene
    scene = load_scene(path)
    helper = compiling_alongside(path) if alongside else contextlib.nullcontext()
    with CompileLog(llvm=False) as log, helper:
        sim = scene.simulation()
        sim.check()
        sim.run(steps=1)
        sim.energy()
    return {"scene": str(path), "kernels": len(log.kernels), "seconds": log.seconds}


# What the second process runs: argv = scene file, threads ("" for the scene's own).
_HELPER = ("import sys; from cosnet.compiling import compile_kick; "
           "compile_kick(sys.argv[1], int(sys.argv[2]) if sys.argv[2] else None)")


def compile_kick(path, threads: int | None):
    """Compile (into numba's cache) a scene's step (which a scene with drives needs at frame 0
    already: its drives' reactions evaluate the loads through it), then the kernels it calls
    through its slots (kernels/slots.py): the kick's own (internal loads, node balances,
    velocity update), the effects', the drift's, for the types the step will call them with.
    PEFRL's kick, a kernel of its own, is compiled as well. The simulation is built
    for its types alone: the kernels building it runs from Python (the fluid's sample, a
    drive's pose) are left to the parent, which needs them first. Returns at once where the
    step is cached already (the parent may start this before it knows)."""
    from numba import types

    from .kernels import layout
    from .kernels.compose import bind_slots, step_kernels
    from .kernels.slots import pin_record, pointers_type
    from .kernels.stepping import compile_orders, kick_loads
    from .output.record import kernels_compiled
    from .scene.loader import load_scene
    layout.TYPING_ONLY[0] = True   # the parent compiles what building the simulation runs
    sim = load_scene(path).simulation(**({} if threads is None else {"threads": threads}))
    layout.TYPING_ONLY[0] = False
    if kernels_compiled(sim):
        return
    model, state, loads, table, _, _, backend = sim.step_signature()
    # the step first (compiled once for every combination of effects: at once where cached),
    # the parent reaches it last, or at frame 0 where drives need it (their reactions evaluate
    # the loads through it), and the kernels after it are a queue the parent shares at the end
    sim.advance_kernel.compile(sim.step_signature())
    if sim.stepper == "pefrl":   # its kick is a kernel of its own (the Verlet step inlines it)
        kick_loads.compile((pointers_type(model, state, loads, table, backend), types.float64))
    for sig in sim._pins.signatures():   # the records' pins: small, and the parent's first step needs them
        pin_record.compile(sig)
    bind_slots(sim.step_table, sim.step_groups, model, state, loads, backend, sim.advance_kernel,
               compile_orders(step_kernels(sim.step_groups))[1])


@contextlib.contextmanager
def compiling_alongside(path, sim=None, cached: bool | None = None, threads: int | None = None):
    """Run the block (which compiles ``sim``'s step) with a second process compiling the
    step's kernels meanwhile (compile_kick), where the step is not cached and there is a
    second core: the two share the list of slot kernels as one queue (bind_slots), each
    loading what the other compiled, while the frame-0 kernels were compiled here. The
    process dies with this one and is stopped when the block ends. ``cached``: whether the
    step is cached, when the caller knows (record.kernels_compiled). Without ``sim`` the block
    builds the simulation itself (with ``threads``, None for the scene's), so that building
    it (the fluid's sample, the drives' poses: seconds of compiling) overlaps the kick's
    compilation; the second process then starts as this one first compiles anything (a warm
    start compiles nothing and starts none) and ends at once where the step is cached."""
    from .output.record import kernels_compiled
    if sim is not None:
        threads = sim.threads
        if cached is None:
            cached = kernels_compiled(sim)
    if (os.cpu_count() or 1) < 2 or cached:
        yield
        return
    helper = []
    argv = [sys.executable, "-c", _HELPER, str(path), "" if threads is None else str(threads)]

    def start():
        helper.append(subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                       preexec_fn=die_with_parent))
    trigger = None
    if sim is None:
        trigger = _FirstCompile(start)
        event.register("numba:compile", trigger)
    else:
        start()
    try:
        yield
    finally:
        if trigger is not None:
            event.unregister("numba:compile", trigger)
        for process in helper:
            if process.poll() is None:
                process.kill()
            process.wait()


class _FirstCompile(event.Listener):
    """Calls ``start`` as the first compilation begins while installed."""

    def __init__(self, start):
        self.start = start

    def on_start(self, ev):
        start, self.start = self.start, None
        if start is not None:
            start()

    def on_end(self, ev):
        pass


def die_with_parent():
    """Have the kernel kill this process when its parent dies (Linux; elsewhere nothing)."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)   # 1: PR_SET_PDEATHSIG
