"""Test processes share one compilation cache.

The suite is mostly compilation (each combination of effects, stepper and backend compiles
its own step), so it runs on every core (pytest-xdist, ``-n auto``), and every worker
compiles into and loads from the usual cache (a directory per kernel source under
NUMBA_CACHE_DIR, else under numba's user cache: kernels/rotations.py): a step one worker
compiled, the others load. Saving into one cache from several processes at once is safe
because kernels/rotations.py locks numba's saves (tests/test_reproducible.py checks it).
"""


def pytest_collection_modifyitems(items):
    """Tests that compile everything in a cache of their own (own_cache) run first: they are
    the longest, and started first they overlap the rest of the suite on the other workers
    instead of running alone at its end."""
    items.sort(key=lambda item: item.get_closest_marker("own_cache") is None)
