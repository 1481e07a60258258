"""Compilation cache of the test processes.

The suite is mostly compilation (each combination of effects, stepper and backend compiles
its own step), so it runs on every core (pytest-xdist, ``-n auto``). Numba's cache is not
safe for two processes saving overloads of one function at once (each rewrites the
function's index from its own copy), so each extra worker keeps its own cache directory:
the first worker, and a run without workers, use the usual cache (a directory per kernel
source under NUMBA_CACHE_DIR, else under numba's user cache: kernels/rotations.py), the
others a directory of their own (in NUMBA_CACHE_DIR, else in the temporary folder). This
runs before numba is imported.
"""

import os
import tempfile
from pathlib import Path

_worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
if _worker != "gw0":
    _base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(tempfile.gettempdir(), "cosnet-numba")
    os.environ["NUMBA_CACHE_DIR"] = str(Path(_base) / f"test-{_worker}")
