"""Numba kernels of cosnet (installed as cosnet.kernels).

The per-element loops read several component columns of a few arrays; LLVM proves them
disjoint with a runtime check per pair of columns before it runs the vectorised loop. Its
default budget (8 checks) is too small for them, so it is raised here, before anything is
compiled (the option is process-wide; it only lets LLVM vectorise more loops).
"""

import llvmlite.binding as _llvm

for _opt in ("--runtime-memory-check-threshold=256", "--vectorize-memory-check-threshold=256"):
    _llvm.set_option("cosnet", _opt)
