"""§5 nondimensionalisation: express a net in scaled units and back.

The paper's reference scales (Table 5.1) are a time T0, length L0, area A0, density rho0 and
torque G0, with E0 = L0^2 rho0 / T0^2 and kappa = E0 A0 L0 / G0 (Table 5.2). With kappa = 1
the scaled equations are the dimensional ones (5.2) written in the unit system
(length L0, time T0, mass rho0 A0 L0), so the engine runs a scaled net unchanged, and
mu = rho A / (rho0 A0), R_K = E A / (E0 A0) come out as in Table 5.2. A torque scale with
kappa != 1 would put kappa into (3.3) and (4.4); it is refused rather than silently ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from . import checks
from .materials import Material, Section
from .net import Net


@dataclass(frozen=True)
class Scale:
    """Reference scales of §5: time T0 (s), length L0 (m), area A0 (m^2), density rho0 (kg/m^3),
    optional torque G0 (N m) which must equal E0 A0 L0 (kappa = 1)."""

    time: float
    length: float
    area: float
    density: float
    torque: float | None = None

    def __post_init__(self):
        for name in ("time", "length", "area", "density"):
            v = getattr(self, name)
            if not checks.is_positive(v):
                raise ValueError(f"Scale: {name} must be a positive number, got {v!r}")
        if self.torque is not None and not math.isclose(self.torque, self.force * self.length, rel_tol=1e-12):
            raise ValueError(f"Scale: torque {self.torque} gives kappa = "
                             f"{self.force * self.length / self.torque:.6g}; only kappa = 1 "
                             f"(torque = E0 A0 L0 = {self.force * self.length:.6g}) is supported")

    # derived units (Table 5.2)
    @property
    def modulus(self) -> float:
        """E0 = L0^2 rho0 / T0^2."""
        return self.length**2 * self.density / self.time**2

    @property
    def mass(self) -> float:
        return self.density * self.area * self.length

    @property
    def force(self) -> float:
        return self.modulus * self.area

    @property
    def acceleration(self) -> float:
        return self.length / self.time**2

    def _units(self) -> tuple[float, float, float]:
        """Units of (length, mass, time) in which the scaled net is expressed."""
        return self.length, self.mass, self.time

    def scaled(self, net: Net) -> Net:
        """Return the same net in scaled (dimensionless) units."""
        return _convert(net, *self._units(), inverse=False)

    def physical(self, net: Net) -> Net:
        """Return a scaled net in physical (SI) units."""
        return _convert(net, *self._units(), inverse=True)


def _convert(net: Net, L: float, M: float, T: float, inverse: bool) -> Net:
    p = -1.0 if inverse else 1.0
    u = lambda dim_l, dim_m, dim_t: (L**dim_l * M**dim_m * T**dim_t) ** (-p)
    length, mass, inertia = u(1, 0, 0), u(0, 1, 0), u(2, 1, 0)
    modulus, density = u(-1, 1, -2), u(-3, 1, 0)
    rotary = u(1, 1, 0)   # rotary inertia per length
    torque, rotary_damping = u(2, 1, -2), u(2, 1, -1)
    joint = lambda j: None if j is None else j.scaled(torque, rotary_damping)
    per_length = lambda r: None if r is None else tuple(x * rotary for x in r)

    def section(s: Section) -> Section:
        return replace(s, A=s.A * length**2, I11=s.I11 * length**4, I22=s.I22 * length**4,
                       I12=s.I12 * length**4, J=s.J * length**4, radius=s.radius * length,
                       rotary_inertia=per_length(s.rotary_inertia))

    def material(m: Material) -> Material:
        return Material(E=m.E * modulus, G=m.G * modulus, density=m.density * density, name=m.name)

    out = Net()
    nodes = {}
    for n in net.nodes:
        nodes[n.index] = out.add_node(n.position * length, frame=n.frame, mass=n.mass * mass,
                                      inertia=n.inertia * inertia, name=n.name)
    mats: dict = {}
    for l in net.lines:
        m = mats.setdefault(id(l.material), material(l.material))
        sec = l.section
        sec = (lambda s, f=sec: section(f(s))) if callable(sec) else section(sec)
        u0 = l.rest_curvature
        if u0 is not None:
            u0 = (lambda s, f=u0: np.asarray(f(s)) / length) if callable(u0) else u0 / length
        out.add_line(nodes[l.start.index], nodes[l.end.index], material=m, section=sec,
                     elements=l.elements, start_offset=l.start_offset * length,
                     end_offset=l.end_offset * length, start_frame=l.start_frame,
                     end_frame=l.end_frame, rest_curvature=u0, points=l.points * length,
                     d1=l.d1, name=l.name, rotary_inertia=per_length(l.rotary_inertia),
                     rotary_inertia_scale=l.rotary_inertia_scale, fast_modes=l.fast_modes,
                     start_joint=joint(l.start_joint), end_joint=joint(l.end_joint))
    return out
