"""Test processes share one compilation cache.

The suite is mostly compilation (each combination of effects, stepper and backend compiles
its own step), so it runs on every core (pytest-xdist, ``-n auto``), and every worker
compiles into and loads from the usual cache (a directory per kernel source under
NUMBA_CACHE_DIR, else under numba's user cache: kernels/compiler.py): a step one worker
compiled, the others load. Saving into one cache from several processes at once is safe
because kernels/compiler.py locks numba's saves (tests/test_reproducible.py checks it).
"""

import pytest


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
