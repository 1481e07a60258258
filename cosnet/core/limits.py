"""Resource limits checked before a scene is built or a run starts, so that a typo (one zero
too many in ``elements``, a joint stiffness of 1e300, ``dt = 1e-30``) is refused in a line
with its numbers instead of running for hours or exhausting memory.

    elements  at most MAX_ELEMENTS in the net, and an estimated memory (BYTES_PER_ELEMENT
              each) of at most half the machine's physical memory
    steps     at most MAX_STEPS time steps in one run
    frames    at most MAX_FRAMES output frames in one run
    variants  at most MAX_VARIANTS variants in one sweep, counted before any is built

Each is lifted by ``[run] limits = false`` in the scene or ``cosnet run --no-limits``; the
variants by ``cosnet sweep --no-limits`` (``sweep(..., limits=False)``).
"""

from __future__ import annotations

import os

MAX_ELEMENTS = 5_000_000
MAX_STEPS = 1_000_000_000
MAX_FRAMES = 100_000
# a --vary typo (linspace(0, 1, 10000) twice) must not plan and validate 10^8 scenes
MAX_VARIANTS = 10_000
# Peak resident memory per element of loading a scene and building its Simulation is about
# 1,000 bytes (measured on straight rods of 10^5 and 10^6 elements: the flattened model, state,
# loads and grids); doubled for the frame writer and the temporaries of a run.
BYTES_PER_ELEMENT = 2_000
OVERRIDE = "set [run] limits = false in the scene or pass --no-limits to go ahead"


def physical_memory() -> int:
    """Bytes of physical memory (0 when the platform does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


def _gb(n: float) -> str:
    return f"{n / 1e9:.3g} GB"


def check_elements(total: int, where: str):
    """Refuse a net of ``total`` elements above MAX_ELEMENTS or half the physical memory."""
    need = total * BYTES_PER_ELEMENT
    have = physical_memory()
    if total > MAX_ELEMENTS or (have and need > have / 2):
        raise ValueError(f"{where}: {total:,} elements in the net need about {_gb(need)} of memory "
                         f"({BYTES_PER_ELEMENT:,} bytes each); the limits are {MAX_ELEMENTS:,} "
                         f"elements and half the physical memory ({_gb(have / 2)}); {OVERRIDE}")


def check_run(steps: float, frames: float, step: str, where: str):
    """Refuse a run of more than MAX_STEPS steps (``step`` says what dt is and what set it)
    or MAX_FRAMES frames."""
    if steps > MAX_STEPS:
        raise ValueError(f"{where}: {steps:,.4g} steps of {step} exceed the limit of "
                         f"{MAX_STEPS:,} steps; {OVERRIDE}")
    if frames > MAX_FRAMES:
        raise ValueError(f"{where}: {frames:,.4g} output frames exceed the limit of {MAX_FRAMES:,}; "
                         f"{OVERRIDE}")


def check_variants(n: int, where: str):
    """Refuse a sweep of more than MAX_VARIANTS variants."""
    if n > MAX_VARIANTS:
        raise ValueError(f"{where}: the variations give {n:,} variants, above the limit of "
                         f"{MAX_VARIANTS:,}; pass --no-limits to go ahead")
