"""Test processes share one compilation cache.

The suite is mostly compilation (each effect kind its kernels, each stepper and backend its
step), so it runs on every core (pytest-xdist, ``-n auto``), and every worker
compiles into and loads from the usual cache (a directory per kernel source under
NUMBA_CACHE_DIR, else under numba's user cache: kernels/compiler.py): a step one worker
compiled, the others load. Saving into one cache from several processes at once is safe
because kernels/compiler.py locks numba's saves (tests/test_reproducible.py checks it).
"""

import json
import os
import time

import pytest
from numba.core import event

pytest_plugins = ["ci_skips", "pytester"]


def pytest_collection_modifyitems(items):
    """Tests that compile everything in a cache of their own (own_cache) run first: they are
    the longest, and started first they overlap the rest of the suite on the other workers
    instead of running alone at its end."""
    items.sort(key=lambda item: item.get_closest_marker("own_cache") is None)


@pytest.fixture(scope="module")
def client():
    """A Dask LocalCluster of two single-threaded worker processes on 127.0.0.1, for the
    sweep tests of one module."""
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as c:
        yield c


class _CompileRecord(event.Listener):
    """A numba listener noting each outermost compilation: its function, seconds, and the
    effect types in its arguments (which combination of effects it compiled)."""

    def __init__(self):
        self.entries, self._depth, self._start = [], 0, 0.0

    def on_start(self, ev):
        if self._depth == 0:
            self._start = time.perf_counter()
        self._depth += 1

    def on_end(self, ev):
        self._depth -= 1
        if self._depth == 0:
            py = ev.data["dispatcher"].py_func
            self.entries.append([f"{py.__module__}.{py.__qualname__}", round(time.perf_counter() - self._start, 2),
                                 [str(a)[:300] for a in ev.data.get("args", ()) if "Tuple" in str(a)][:1]])


@pytest.fixture(autouse=True)
def _compile_log(request):
    """With COSNET_COMPILE_LOG=FILE, append a JSON line per test naming what it compiled (what
    a test pays for, to share compiled variants between tests): the suite's cache-hit log."""
    path = os.environ.get("COSNET_COMPILE_LOG")
    if not path:
        yield
        return
    record = _CompileRecord()
    event.register("numba:compile", record)
    try:
        yield
    finally:
        event.unregister("numba:compile", record)
        if record.entries:
            with open(path, "a", encoding="utf-8") as f:
                f.write(json.dumps({"test": request.node.nodeid, "compiled": record.entries}) + "\n")
