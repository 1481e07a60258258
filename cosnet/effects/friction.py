"""The keys of a penalty contact with Coulomb friction, declared alike by the contact between
lines, obstacles and bodies (their kernels share cosnet.kernels.friction): a normal spring k
and damper gamma, a tangential stick spring k_t, static and kinetic coefficients."""

from __future__ import annotations

import numpy as np

from ..core.units import DAMPING, STIFFNESS, nonnegative, positive
from ..engine.registry import Effect, Key


def friction_keys(coefficient=nonnegative, static: str = "static friction coefficient",
                  kinetic: str = "kinetic friction coefficient, at most mu_s",
                  normal: str = "normal penalty stiffness", damping: str = "normal damping",
                  k_required: bool = True) -> tuple:
    """(k, gamma, k_t, mu_s, mu_k) as Keys; ``coefficient`` converts mu_s and mu_k."""
    return (Key("k", positive, STIFFNESS, required=k_required, doc=normal),
            Key("gamma", nonnegative, DAMPING, doc=damping),
            Key("k_t", nonnegative, STIFFNESS, doc="tangential (stick) stiffness; default k"),
            Key("mu_s", coefficient, doc=static),
            Key("mu_k", coefficient, doc=kinetic))


class Frictional(Effect):
    """An effect of penalty contacts with Coulomb friction (between lines, with obstacles,
    with bodies): the reports they share, read from their records' counters."""

    def dissipated(self, sim) -> float:
        """Energy dissipated by friction and the dashpots so far (J): sim.energy() plus this
        is conserved."""
        return float(self.params(sim).dissipated[0])

    def active_contacts(self, sim) -> int:
        """Contacts touching at the last force evaluation (pairs of elements, vertices or
        elements on an obstacle, points of a body)."""
        return int(self.params(sim).active[0])

    def sliding(self, sim) -> int:
        """Of those, the ones sliding (the others stick)."""
        return sum(int(np.count_nonzero(flags)) for flags in self.sliding_flags(self.params(sim)))

    def sliding_flags(self, p) -> tuple:
        """Arrays whose true entries are the contacts of record p sliding now."""
        raise NotImplementedError
