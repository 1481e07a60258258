"""Two processes asking at once for a kernel that is in no cache compile it once: the second
waits for the first (kernels/compiler.py) and loads what it saved."""

import sys


from procs import started

KERNEL = """
from numba import njit
from cosnet.kernels.compiler import CACHED

@njit(**CACHED)
def spring_force(k, x):
    return -k * x
"""

# asks for spring_force(float64, float64), saying when it starts waiting for another process;
# prints its value and how many compilations it ran
CHILD = r"""
import sys
sys.path.insert(0, sys.argv[1])
from numba.core import event
from cosnet.kernels.compiler import WAIT_EVENT
import lockmod

class Tell(event.Listener):
    def on_start(self, ev):
        print("waiting", flush=True)
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
            first = child.stdout.readline().strip()   # the child's first word: it waits
            assert first == "waiting", (first, child.stderr.read() if first == "" else "")
            lockmod.spring_force.compile(sig)
        out, err = child.communicate(timeout=120)   # the lock is free: the child goes on
    assert child.returncode == 0, err
    _, force, _, compiled = out.split()
    assert float(force) == -0.5
    assert compiled == "0"   # loaded what this process saved, compiled nothing itself
