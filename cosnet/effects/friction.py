"""The keys of a penalty contact with Coulomb friction, declared alike by the contact between
lines, obstacles and bodies (their kernels share cosnet.kernels.friction): a normal spring k
and damper gamma, a tangential stick spring k_t, static and kinetic coefficients."""

from __future__ import annotations

from ..core.units import DAMPING, STIFFNESS, nonnegative, positive
from ..engine.registry import Key


def friction_keys(coefficient=nonnegative, static: str = "static friction coefficient",
                  kinetic: str = "kinetic friction coefficient, at most mu_s",
                  normal: str = "normal penalty stiffness", damping: str = "normal damping") -> tuple:
    """(k, gamma, k_t, mu_s, mu_k) as Keys; ``coefficient`` converts mu_s and mu_k."""
    return (Key("k", positive, STIFFNESS, required=True, doc=normal),
            Key("gamma", nonnegative, DAMPING, doc=damping),
            Key("k_t", nonnegative, STIFFNESS, doc="tangential (stick) stiffness; default k"),
            Key("mu_s", coefficient, doc=static),
            Key("mu_k", coefficient, doc=kinetic))
