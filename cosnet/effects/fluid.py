"""The fluid medium: lines in water or air feel drag, added mass, buoyancy and the inertia
force of an accelerating medium (Morison's equation), or the resistive forces of Stokes flow.
One declaration, ``Fluid``, scene kind "fluid"; its kernels are cosnet.kernels.fluid."""

from __future__ import annotations

import math

import numpy as np

from ..core import samples
from ..engine.bounds import index_error
from ..core import checks
from .contact import chosen_lines, chosen_parts
from .drives import driven_nodes
from .loads import Gravity, checked_table
from ..kernels.added_mass import TURNING_ROWS, threaded_blocks
from ..kernels.fluid import LINEAR, MORISON, SAMPLE_ROWS, FluidParams
from ..kernels.fluid_step import ENTRAINED, SAMPLE
from ..kernels.fluid_variants import VARIANTS, fluid_record
from ..kernels.layout import typed_call
from ..engine.registry import Binding, Effect, Key
from ..core.sea_state import jonswap_components
from ..core.turbulence import IEC_LENGTH, turbulent_series
from ..core.units import (LENGTH, TIME, VELOCITY, Unit, array, boolean, choice, floats, integer, nonnegative,
                          number, pair, positive, seed)

DENSITY = Unit("kg/m^3", -3, 1, 0)
RESISTANCE = Unit("N s/m^2", -1, 1, -1)   # force per length per velocity
VOLUME = Unit("m^3", 3)
AREA = Unit("m^2", 2)


def _finite(name: str, v) -> float:
    x = checks.number("Fluid", name, v)
    if not math.isfinite(x):
        raise ValueError(f"Fluid: {name} must be finite, got {v!r}")
    return x


def wave_number(omega: float, depth: float, g: float) -> float:
    """The wave number k of a linear wave of angular frequency omega over water of the given
    depth: the root of omega^2 = g k tanh(k depth) (Newton's method from the deep-water value)."""
    k = omega * omega / g
    if not math.isfinite(depth):
        return k
    k = max(k, omega / math.sqrt(g * depth))
    for _ in range(100):
        th = math.tanh(k * depth)
        f = g * k * th - omega * omega
        df = g * th + g * k * depth * (1.0 - th * th)
        step = f / df
        k -= step
        if abs(step) <= 1e-15 * k:
            break
    return k


def resistive_coefficients(viscosity: float, diameter: float, wavelength: float,
                           theory: str = "gray_hancock") -> tuple[float, float]:
    """(c_n, c_t), the drag per length per velocity of resistive-force theory for a filament
    of the given diameter bending in waves of the given wavelength in a fluid of the given
    dynamic viscosity: Gray & Hancock (1955), c_n = 4 pi mu / (ln(2 q / a) + 1/2),
    c_t = 2 pi mu / (ln(2 q / a) - 1/2), or Lighthill (1976), c_n = 4 pi mu / (ln(2 q / a) + 1/2),
    c_t = 2 pi mu / ln(2 q / a); a the radius and q = 0.09 wavelength."""
    for name, x in (("viscosity", viscosity), ("diameter", diameter), ("wavelength", wavelength)):
        checks.positive("resistive_coefficients", name, x)
    log = math.log(2.0 * 0.09 * wavelength / (0.5 * diameter))
    if theory == "gray_hancock":
        return 4 * math.pi * viscosity / (log + 0.5), 2 * math.pi * viscosity / (log - 0.5)
    if theory == "lighthill":
        return 4 * math.pi * viscosity / (log + 0.5), 2 * math.pi * viscosity / log
    raise ValueError(f"resistive_coefficients: theory must be 'gray_hancock' or 'lighthill', got {theory!r}")


def slender_body_coefficients(viscosity: float, diameter: float, length: float) -> tuple[float, float]:
    """(c_n, c_t) of local slender-body theory at leading order, as PyElastica has it (Gazzola
    et al. 2018, eq. 4.13: f = -4 pi mu / ln(L / a) (1 - t t^T / 2) v per length, a the radius
    and L the filament's length): c_n = 4 pi mu / ln(L / a), c_t = c_n / 2."""
    for name, x in (("viscosity", viscosity), ("diameter", diameter), ("length", length)):
        checks.positive("slender_body_coefficients", name, x)
    if length <= diameter:
        raise ValueError(f"slender_body_coefficients: length {length:g} must exceed the diameter {diameter:g} "
                         f"(the theory is for slender filaments)")
    cn = 4.0 * math.pi * viscosity / math.log(length / (0.5 * diameter))
    return cn, 0.5 * cn


class Fluid(Effect):
    """A fluid around the lines: water (with a free surface, waves, a current) or air (wind).

    Each wet vertex of a line (Voronoi length l, tangent t, diameter d, section area A; u its
    velocity relative to the medium's U, split into u_t along t and u_n across) feels
    - drag (Morison): -1/2 rho C_dn d l |u_n| u_n - 1/2 rho C_dt pi d l |u_t| u_t (the
      tangential part on the surface area, as MoorDyn), or with ``resistance = [c_n, c_t]``
      (Stokes flow) -c_n l u_n - c_t l u_t;
    - added mass: its mass becomes m + C_an rho A l (1 - t t^T) + C_at rho A l t t^T; with
      ``added_mass_law = "lagrange"`` (the default) the fluid it carries also pushes as it
      turns with the line (kernels/added_mass.py: Lagrange's equations for its kinetic
      energy; Munk's moment on a line moving obliquely), with "morison" it does not (Morison's
      equation, as MoorDyn);
    - the medium's inertia force rho A l ((1 + C_an) A_n + (1 + C_at) A_t) where the medium
      accelerates (waves, a current changing in time) - Froude-Krylov plus added mass;
    - buoyancy: rho g A times the submerged length of each element (cut at the still surface),
      shared by its vertices as the gradient of its potential.
    The current is ``velocity`` times a profile over height (a table, or a power law
    ((z - ground) / reference_height)^power_law) times a factor over time (a table, or a seeded
    turbulent series: ``turbulence_intensity`` and cosnet.core.turbulence); waves are
    linear (Airy) components over water of the given depth (given one by one, or drawn from
    a JONSWAP spectrum: ``wave_spectrum`` and cosnet.core.sea_state), their kinematics
    stretched to the instantaneous surface (Wheeler) or held above the still surface at its
    value ("none").
    Vertical is +z; above the free surface nothing acts. Drag and the added mass are solved
    exactly (or implicitly at nodes), so they never shorten the step. Energy: buoyancy and the
    entrained fluid's kinetic energy are in energy(); what drag takes (relative to the medium)
    is in dissipated(); what a moving medium gives is supplied().
    """

    kind = "fluid"
    keys = (Key("density", positive, DENSITY, required=True, doc="density of the medium"),
            Key("velocity", array((3,)), VELOCITY, doc="current (or wind) velocity"),
            Key("profile_heights", floats, LENGTH, doc="heights z of the current's profile table (increasing)"),
            Key("profile_factors", floats, doc="factors of the current at those heights"),
            Key("power_law", nonnegative, doc="exponent of a power-law profile ((z - ground)/reference_height)^a"),
            Key("reference_height", positive, LENGTH, doc="height above ground where the power law's factor is 1"),
            Key("ground", number, LENGTH, doc="z where the power-law profile is zero"),
            Key("times", floats, TIME, doc="times of the current's time factor (increasing)"),
            Key("values", floats, doc="the time factor at those times (a gust or tidal series)"),
            Key("turbulence_intensity", nonnegative,
                doc="a seeded turbulent time factor instead of times/values: sigma / |velocity| (Kaimal spectrum)"),
            Key("turbulence_length", positive, LENGTH, doc="its integral length scale (default 340.2 m, IEC 61400-1)"),
            Key("turbulence_duration", positive, TIME, doc="its record's length, repeated after (default 600 s)"),
            Key("turbulence_step", positive, TIME, doc="its sampling step (default 0.1 s)"),
            Key("turbulence_seed", seed, doc="its phases' seed (default 0)"),
            Key("drag", pair, doc="Morison drag coefficients [C_dn, C_dt]"),
            Key("resistance", pair, RESISTANCE, doc="Stokes-flow drag per length [c_n, c_t] (instead of drag)"),
            Key("diameter", positive, LENGTH, doc="hydrodynamic diameter (default: each line's section, 2 sqrt(A/pi))"),
            Key("added_mass", pair, doc="added-mass coefficients [C_an, C_at]"),
            Key("added_mass_law", choice("lagrange", "morison"),
                doc="lagrange: with the forces of the entrained fluid turning with the line (Munk's moment); "
                    "morison: without, as Morison's equation and MoorDyn"),
            Key("buoyancy", boolean, doc="whether the displaced medium lifts the lines"),
            Key("surface", number, LENGTH, doc="z of the still free surface (default: the medium fills space)"),
            Key("depth", positive, LENGTH, doc="water depth below the still surface (waves; default deep)"),
            Key("wave_amplitudes", floats, LENGTH, doc="amplitudes of the Airy wave components"),
            Key("wave_periods", floats, TIME, doc="their periods"),
            Key("wave_headings", floats, doc="their directions of travel, degrees from +x towards +y"),
            Key("wave_phases", floats, doc="their phases (rad)"),
            Key("wave_spectrum", choice("jonswap"),
                doc="components drawn from a spectrum instead of wave_amplitudes/periods/phases (seeded)"),
            Key("significant_height", positive, LENGTH, doc="its significant wave height Hs"),
            Key("peak_period", positive, TIME, doc="its peak period Tp"),
            Key("peak_enhancement", number, doc="its peak enhancement gamma (default 3.3; 1: Pierson-Moskowitz)"),
            Key("wave_components", integer, doc="how many components it is cut into (default 50)"),
            Key("wave_band", array((2,)),
                doc="their frequency band, multiples of the peak frequency (default [0.5, 3])"),
            Key("wave_seed", seed, doc="their phases' seed (default 0)"),
            Key("stretching", choice("wheeler", "none"), doc="wave kinematics above the still surface"),
            Key("lines", "lines", doc="the lines in the medium (default: all)"),
            Key("buoys", "nodes", doc="nodes with a volume of their own in the medium (buoys, floats)"),
            Key("buoy_volumes", floats, VOLUME, doc="their displaced volumes when submerged (spheres)"),
            Key("buoy_drag_areas", floats, AREA, doc="their drag areas C_d A (default 0)"),
            Key("buoy_added_mass", floats, doc="their added-mass coefficients C_a (default 0)"))
    record = FluidParams

    free_integers = ("turn",)            # which half of the kick is next, compared
    none_if_negative = ("line_row", "buoy")     # a line out of the fluid, a node without a buoy

    @classmethod
    def example(cls):
        net, _ = samples.rod(start=(0.0, 0.0, -0.02), end=(samples.LENGTH, 0.0, 0.01))
        # the end node a float of 1 cm radius, half out of the water
        return net, [Gravity(), cls(1025.0, velocity=(0.3, 0.0, 0.0), drag=(1.2, 0.008), added_mass=(1.0, 0.0),
                                    buoyancy=True, surface=0.0, buoys=[net.nodes[-1]], buoy_volumes=[4.19e-6],
                                    buoy_drag_areas=[3e-4], buoy_added_mass=[0.5])]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        nl, nn, nv = model.line_vertex_offsets.shape[0] - 1, model.node_mass.shape[0], model.vertex_mass.shape[0]
        k = p.lines.shape[0]
        rows = ("drag_n", "drag_t", "added_n", "added_t", "inertia_n", "inertia_t", "buoyancy")
        if any(getattr(p, name).shape != (k,) for name in rows):
            return f"fluid: {', '.join(rows)} need one entry per line of fluid.lines"
        if p.line_row.shape != (nl,) or p.node_skip.shape != (nn,) or p.sample.shape != (SAMPLE_ROWS, nv):
            return (f"fluid: line_row needs one entry per line, node_skip one per node, sample {SAMPLE_ROWS} rows "
                    f"of one per vertex")
        b = p.buoy_node.shape[0]
        if p.buoy.shape != (nn,) or p.buoy_sample.shape != (b, 7) or p.medium.shape != (2,) or any(
                getattr(p, name).shape != (b,) for name in ("buoy_volume", "buoy_radius", "buoy_drag", "buoy_added")):
            return "fluid: buoy needs one entry per node, the buoy rows one per buoy node, medium two"
        if p.wet_inverse.shape != (2, nv) or p.decay.shape != (2, nv) or p.decay_h.shape != (1,):
            return "fluid: wet_inverse and decay need two rows of one per vertex, decay_h one entry"
        nw = p.wave_a.shape[0]
        if any(getattr(p, name).shape != (nw,) for name in ("wave_w", "wave_k", "wave_cos", "wave_sin", "wave_phase",
                                                           "wave_now")) or p.wave_depth.shape != (nw, 2):
            return "fluid: the wave arrays need one entry per component of wave_a (wave_depth two)"
        if p.turning.shape not in ((TURNING_ROWS, nv), (TURNING_ROWS, 0)):
            return f"fluid: turning needs {TURNING_ROWS} rows of one per vertex, or none"
        return (index_error("fluid.lines", p.lines, nl) or index_error("fluid.line_row", p.line_row[p.line_row >= 0], k)
                or index_error("fluid.buoy_node", p.buoy_node, nn) or index_error("fluid.buoy", p.buoy[p.buoy >= 0], b))

    def __init__(self, density: float, velocity=(0.0, 0.0, 0.0), *, profile_heights=None, profile_factors=None,
                 power_law: float = 0.0, reference_height: float = 10.0, ground: float = 0.0, times=None,
                 values=None, turbulence_intensity=None, turbulence_length=IEC_LENGTH, turbulence_duration=600.0,
                 turbulence_step=0.1, turbulence_seed=0, drag=(0.0, 0.0), resistance=None,
                 diameter: float | None = None,
                 added_mass=(0.0, 0.0), added_mass_law: str = "lagrange", buoyancy: bool = False,
                 surface: float | None = None,
                 depth: float | None = None, wave_amplitudes=None, wave_periods=None, wave_headings=None,
                 wave_phases=None, wave_spectrum=None, significant_height=None, peak_period=None,
                 peak_enhancement=None, wave_components=None, wave_band=None, wave_seed=None,
                 stretching: str = "wheeler", lines=None, buoys=None, buoy_volumes=None,
                 buoy_drag_areas=None, buoy_added_mass=None):
        who = "Fluid"
        self.density = checks.positive(who, "density", density)
        self.velocity = checks.vec3(who, "velocity", velocity)
        self.profile = self._table(profile_heights, profile_factors, "profile_heights", "profile_factors")
        self.power = (checks.nonnegative(who, "power_law", power_law),
                      checks.positive(who, "reference_height", reference_height), _finite("ground", ground))
        self.time_table = self._table(times, values, "times", "values")
        if turbulence_intensity is not None:
            if times is not None or values is not None:
                raise ValueError("Fluid: give a time table (times, values) or turbulence_intensity, not both")
            speed = float(np.linalg.norm(self.velocity))
            if speed == 0.0:
                raise ValueError("Fluid: turbulence_intensity needs a velocity to fluctuate about")
            self.time_table = turbulent_series(speed, turbulence_intensity, turbulence_length, turbulence_duration,
                                               turbulence_step, turbulence_seed)
        self.drag = self._coefficients("drag", drag)
        self.resistance = None if resistance is None else self._coefficients("resistance", resistance)
        if self.resistance is not None and np.any(self.drag):
            raise ValueError("Fluid: give drag (Morison, turbulent) or resistance (Stokes flow), not both")
        self.diameter = None if diameter is None else checks.positive(who, "diameter", diameter)
        self.added_coefficients = self._coefficients("added_mass", added_mass)
        if added_mass_law not in ("lagrange", "morison"):
            raise ValueError(f"Fluid: added_mass_law must be 'lagrange' or 'morison', got {added_mass_law!r}")
        self.added_mass_law = added_mass_law
        if not isinstance(buoyancy, (bool, np.bool_)):
            raise ValueError(f"Fluid: buoyancy must be true or false, got {buoyancy!r}")
        self.buoyancy = bool(buoyancy)
        self.surface = math.inf if surface is None else _finite("surface", surface)
        self.depth = math.inf if depth is None else checks.positive(who, "depth", depth)
        if stretching not in ("wheeler", "none"):
            raise ValueError(f"Fluid: stretching must be 'wheeler' or 'none', got {stretching!r}")
        self.stretching = stretching
        spectrum = dict(significant_height=significant_height, peak_period=peak_period,
                        peak_enhancement=peak_enhancement, wave_components=wave_components, wave_band=wave_band,
                        wave_seed=wave_seed)
        if wave_spectrum is not None:
            wave_amplitudes, wave_periods, wave_headings, wave_phases = self._spectrum(
                wave_spectrum, spectrum, wave_amplitudes, wave_periods, wave_headings, wave_phases)
        elif any(v is not None for v in spectrum.values()):
            raise ValueError(f"Fluid: {', '.join(k for k, v in spectrum.items() if v is not None)} need "
                             f"wave_spectrum")
        self.waves = self._waves(wave_amplitudes, wave_periods, wave_headings, wave_phases)
        if self.waves[0].size and not math.isfinite(self.surface):
            raise ValueError("Fluid: waves need a free surface; give surface")
        if self.waves[0].size and math.isfinite(self.depth) and self.waves[0].max() >= self.depth:
            raise ValueError(f"Fluid: a wave amplitude ({self.waves[0].max():g} m) must be less than the "
                             f"depth ({self.depth:g} m)")
        if lines is not None:
            lines = list(lines)
        self.lines = lines
        self.buoys = self._buoys(buoys, buoy_volumes, buoy_drag_areas, buoy_added_mass)
        # a medium that moves or accelerates feeds energy in
        self.adds_energy = bool(np.any(self.velocity) or self.waves[0].size)

    def _buoys(self, nodes, volumes, areas, added):
        """(nodes, V, C_d A, C_a) of the buoys, checked."""
        if nodes is None:
            if any(x is not None for x in (volumes, areas, added)):
                raise ValueError("Fluid: buoy_volumes, buoy_drag_areas and buoy_added_mass need buoys")
            return [], np.zeros(0), np.zeros(0), np.zeros(0)
        nodes = list(nodes)
        n = len(nodes)
        if volumes is None:
            raise ValueError("Fluid: buoys need buoy_volumes, one per buoy")
        rows = []
        for name, x in (("buoy_volumes", volumes), ("buoy_drag_areas", areas), ("buoy_added_mass", added)):
            a = np.zeros(n) if x is None else np.atleast_1d(np.array(x, dtype=float))
            if a.shape != (n,) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"Fluid: {name} must be {n} finite numbers >= 0 (one per buoy), got {x!r}")
            rows.append(a)
        if np.any(rows[0] <= 0):
            raise ValueError(f"Fluid: buoy_volumes must be > 0, got {volumes!r}")
        if self.resistance is not None and np.any(rows[1]):
            raise ValueError("Fluid: a buoy's drag is Morison's (quadratic); in Stokes flow (resistance) give no "
                             "buoy_drag_areas")
        return nodes, *rows

    @staticmethod
    def _table(x, y, xname, yname):
        a, b = checked_table("Fluid", x, y, (xname, yname))
        if x is not None and not a.size:
            raise ValueError(f"Fluid: {xname} and {yname} must not be empty")
        return a, b

    @staticmethod
    def _coefficients(name, v):
        a = np.array(v, dtype=float)
        if a.shape != (2,) or not np.all(np.isfinite(a)) or np.any(a < 0):
            raise ValueError(f"Fluid: {name} must be two finite numbers >= 0 (normal, tangential), got {v!r}")
        return a

    @staticmethod
    def _spectrum(kind, keys: dict, amplitudes, periods, headings, phases):
        """(amplitudes, periods, headings, phases) of the components drawn from the spectrum
        (cosnet.core.sea_state), all along the one heading given (default 0)."""
        if kind != "jonswap":
            raise ValueError(f"Fluid: wave_spectrum must be 'jonswap', got {kind!r}")
        if amplitudes is not None or periods is not None or phases is not None:
            raise ValueError("Fluid: give wave_spectrum or wave_amplitudes/wave_periods/wave_phases, not both")
        if keys["significant_height"] is None or keys["peak_period"] is None:
            raise ValueError("Fluid: wave_spectrum needs significant_height and peak_period")
        heading = np.zeros(1) if headings is None else np.atleast_1d(np.array(headings, float))
        if heading.shape != (1,):
            raise ValueError(f"Fluid: a wave_spectrum's sea has one heading (wave_headings = [degrees]), got "
                             f"{headings!r}")
        # the keys given, by jonswap_components' names: its defaults are the only ones
        names = dict(peak_enhancement="gamma", wave_components="components", wave_band="band", wave_seed="seed")
        given = {names[k]: v for k, v in keys.items() if v is not None and k in names}
        a, T, ph = jonswap_components(keys["significant_height"], keys["peak_period"], **given)
        return a, T, np.full(a.size, heading[0]), ph

    def _waves(self, amplitudes, periods, headings, phases):
        if amplitudes is None and periods is None:
            if headings is not None or phases is not None:
                raise ValueError("Fluid: wave_headings and wave_phases need wave_amplitudes and wave_periods")
            return tuple(np.zeros(0) for _ in range(4))
        if amplitudes is None or periods is None:
            raise ValueError("Fluid: give both wave_amplitudes and wave_periods")
        a, T = np.atleast_1d(np.array(amplitudes, float)), np.atleast_1d(np.array(periods, float))
        n = a.size
        hd = np.zeros(n) if headings is None else np.atleast_1d(np.array(headings, float))
        ph = np.zeros(n) if phases is None else np.atleast_1d(np.array(phases, float))
        if any(x.shape != (n,) for x in (T, hd, ph)):
            raise ValueError("Fluid: wave_amplitudes, wave_periods, wave_headings and wave_phases must have "
                             "one entry per component")
        if not all(np.all(np.isfinite(x)) for x in (a, T, hd, ph)) or np.any(a < 0) or np.any(T <= 0):
            raise ValueError("Fluid: wave amplitudes must be finite and >= 0, periods > 0, headings and "
                             "phases finite")
        return a, T, hd, ph

    # ------------------------------------------------------------------ binding
    def _g(self, on: Binding) -> float:
        """|g| of the declared gravity (refused unless it points down, -z)."""
        grav = [e for e in on.effects if isinstance(e, Gravity)]
        if not grav:
            if self.buoyancy:
                raise ValueError("Fluid: buoyancy needs a gravity effect")
            return 9.81
        g = grav[0].g
        if not np.any(g) and not (self.buoyancy or self.waves[0].size):
            return 9.81
        if abs(g[0]) > 1e-12 * abs(g[2]) or abs(g[1]) > 1e-12 * abs(g[2]) or g[2] >= 0:
            raise ValueError(f"Fluid: the free surface is horizontal (z up); gravity must point along -z, "
                             f"got {g.tolist()}")
        return float(-g[2])

    def bind(self, on: Binding) -> FluidParams:
        lines = chosen_lines(on, self.lines, "Fluid")
        g = self._g(on)
        rho = self.density
        nl, nn = len(on.net.lines), len(on.net.nodes)
        nv = on.model.vertex_mass.shape[0]
        k = len(lines)
        rows = {name: np.zeros(k) for name in ("drag_n", "drag_t", "added_n", "added_t", "inertia_n",
                                               "inertia_t", "buoyancy")}
        line_row = np.full(nl, -1, dtype=np.int64)
        for j, line in enumerate(lines):
            line_row[line.index] = j
            # the section at mid-length stands for the line's (a tapered line: its mean)
            area = float(np.mean([line.section_at((i + 0.5) / line.elements).A for i in range(line.elements)]))
            d = 2.0 * math.sqrt(area / math.pi) if self.diameter is None else self.diameter
            if self.resistance is not None:
                rows["drag_n"][j], rows["drag_t"][j] = self.resistance
            else:
                rows["drag_n"][j] = 0.5 * rho * self.drag[0] * d
                rows["drag_t"][j] = 0.5 * rho * self.drag[1] * math.pi * d
            vol = math.pi * d * d / 4.0     # displaced area per length
            rows["added_n"][j], rows["added_t"][j] = rho * vol * self.added_coefficients
            if self.waves[0].size or self.time_table[0].size:
                rows["inertia_n"][j], rows["inertia_t"][j] = rho * vol * (1.0 + self.added_coefficients)
            if self.buoyancy:
                rows["buoyancy"][j] = rho * g * vol
        # the nodes the medium leaves alone: a drive's, and the fixed ones (a variant compiles no
        # pass over the nodes where that is all of them: kernels/fluid.py, NODES)
        skip = (driven_nodes(on.effects, nn) | (on.model.node_inv_mass == 0.0)).astype(float)
        a, T, hd, ph = self.waves
        omega = 2.0 * math.pi / T if T.size else np.zeros(0)
        kw = np.array([wave_number(w, self.depth, g) for w in omega])
        e2 = np.exp(-2.0 * kw * self.depth) if math.isfinite(self.depth) else np.zeros(kw.size)
        heading = np.radians(hd)
        zp, fp = self.profile
        tt, tv = self.time_table
        p = FluidParams(LINEAR if self.resistance is not None else MORISON,
                           np.array([ln.index for ln in lines], dtype=np.int64), line_row, **rows,
                           surface=self.surface, depth=self.depth, stretch=int(self.stretching == "wheeler"),
                           current=self.velocity.copy(), profile_z=zp.copy(), profile_f=fp.copy(),
                           power=np.array(self.power), times=tt.copy(), values=tv.copy(), wave_a=a.copy(),
                           wave_w=omega, wave_k=kw, wave_cos=np.cos(heading), wave_sin=np.sin(heading),
                           wave_phase=ph.copy(), wave_depth=np.column_stack([e2, 1.0 / (1.0 - e2)]),
                           wave_now=np.zeros(a.size), node_skip=skip,
                           sample=np.zeros((SAMPLE_ROWS, nv)),
                           wet_inverse=self._wet_inverse(on.model, lines, rows),
                           decay=np.zeros((2, nv)), decay_h=np.full(1, np.nan),
                           turn=np.zeros(1, dtype=np.int64),
                           dissipated=np.zeros(1), supplied=np.zeros(1), **self._buoy_rows(on, rho, g, nn),
                           turning=np.zeros((TURNING_ROWS, nv if self._turns(rows) else 0)),
                           node_mass=np.zeros((nn, 6)),
                           chord_inverse=np.zeros(nv), node_rate=np.zeros((nn, 3)),
                           block_sums=np.zeros((threaded_blocks(len(lines), nn), 3)))
        p = fluid_record(p, on.model, on.threads)   # of the variant that compiles only the parts its data can use
        # the entrained fluid's energy from the start
        if np.any(rows["added_n"]) or np.any(rows["added_t"]) or np.any(p.buoy_added):
            typed_call(VARIANTS.of(p).kernel("fluid_entry"), p, on.model, on.state, SAMPLE)
        return p

    @staticmethod
    def _wet_inverse(m, lines, rows: dict) -> np.ndarray:
        """1 / (m + l a_n) and 1 / (m + l a_t) at each interior vertex of the lines in the
        medium (FluidParams.wet_inverse)."""
        inv = np.zeros((2, m.vertex_mass.shape[0]))
        for j, line in enumerate(lines):
            lo, hi = m.line_vertex_offsets[line.index] + 1, m.line_vertex_offsets[line.index + 1] - 1
            mass, vlen = m.vertex_mass[lo:hi], m.voronoi_rest_length[lo:hi]
            for r, added in enumerate((rows["added_n"][j], rows["added_t"][j])):
                total = mass + vlen * added
                np.divide(1.0, total, out=inv[r, lo:hi], where=total > 0)   # (a massless vertex: 0, as dry)
        return inv

    def _turns(self, rows: dict) -> bool:
        """Whether the entrained fluid's turning forces act (kernels/added_mass.py): Lagrange's
        law, and some line's added mass differs across and along it."""
        return self.added_mass_law == "lagrange" and bool(np.any(rows["added_n"] != rows["added_t"]))

    def _buoy_rows(self, on: Binding, rho: float, g: float, nn: int) -> dict:
        nodes, volume, area, added = self.buoys
        found = [nd.index for nd in chosen_parts(on, nodes, "node", "Fluid")]
        if len(set(found)) != len(found):
            raise ValueError("Fluid: a node is named twice in buoys")
        buoy = np.full(nn, -1, dtype=np.int64)
        buoy[found] = np.arange(len(found))
        return dict(buoy=buoy, buoy_node=np.array(found, dtype=np.int64), buoy_volume=volume.copy(),
                    buoy_radius=np.cbrt(3.0 * volume / (4.0 * math.pi)), buoy_drag=0.5 * rho * area,
                    buoy_added=rho * volume * added, buoy_sample=np.zeros((len(found), 7)),
                    medium=np.array([rho, g if self.buoyancy else 0.0]))

    # ------------------------------------------------------------------ energy
    def potential(self, p, on: Binding) -> float:
        """Buoyancy's potential, -rho g A times the integral of min(z, surface) over each line's
        elements and the buoys' upthrust potential, plus the kinetic energy of the entrained
        fluid (kernels/fluid_step.entrained_energy: 1/2 v^T M_a v, M_a the added mass of the present
        positions; see entrained)."""
        m, x = on.model, on.state.x
        e = 0.0
        for j, l in enumerate(p.lines):
            if p.buoyancy[j]:
                lo, hi = m.line_vertex_offsets[l], m.line_vertex_offsets[l + 1]
                e0 = m.line_element_offsets[l]
                za, zb = x[lo:hi - 1, 2], x[lo + 1:hi, 2]
                e -= p.buoyancy[j] * float(np.sum(m.element_rest_length[e0:e0 + hi - lo - 1]
                                                  * _mean_min(za, zb, p.surface)))
        for b, nd in enumerate(p.buoy_node):
            e += p.medium[0] * p.medium[1] * _cap_integral(p.surface - on.state.node_x[nd, 2], p.buoy_radius[b])
        return e + self.entrained(p, on, held=False)

    @staticmethod
    def entrained(p, on: Binding, held: bool) -> float:
        """The kinetic energy of the fluid the lines carry: with ``held`` with the added mass
        the step holds (sampled at the last kick's positions, half a step before the present
        ones), which the accounts use, else with the added mass of the present positions,
        which the energy uses so that it is the same function of the state whatever the step
        (0 without added mass)."""
        if not (np.any(p.added_n) or np.any(p.added_t) or np.any(p.buoy_added)):
            return 0.0
        kernels = VARIANTS.of(p)
        if held:
            return typed_call(kernels.kernel("fluid_entry"), p, on.model, on.state, ENTRAINED)
        # sampled in place and put back: the step's own record keeps typed_call's held entry
        kept = p.sample.copy(), p.buoy_sample.copy()
        try:
            typed_call(kernels.kernel("fluid_entry"), p, on.model, on.state, SAMPLE)
            return typed_call(kernels.kernel("fluid_entry"), p, on.model, on.state, ENTRAINED)
        finally:
            p.sample[...], p.buoy_sample[...] = kept

    def exchange(self, p, on: Binding) -> float:
        """Upthrust of the lines in the medium times the diagonal of the net's bounding box."""
        x = on.state.x
        size = float(np.linalg.norm(x.max(axis=0) - x.min(axis=0))) if x.size else 0.0
        total = 0.0
        for j, l in enumerate(p.lines):
            e0, e1 = on.model.line_element_offsets[l], on.model.line_element_offsets[l + 1]
            total += p.buoyancy[j] * float(np.sum(on.model.element_rest_length[e0:e1]))
        return total * size

    def added_mass(self, p, on: Binding):
        """The least added mass, min(C_an, C_at) rho A l, of each vertex below the free
        surface by more than the waves' height as built (and of the free nodes' such line
        ends): a line that rises out of the water meets its dry step, which the watch
        guards."""
        m, x = on.model, on.state.x
        vertex, node = np.zeros(m.vertex_mass.shape[0]), np.zeros(m.node_mass.shape[0])
        deep = x[:, 2] < p.surface - float(np.sum(p.wave_a))
        for j, l in enumerate(p.lines):
            lo, hi = m.line_vertex_offsets[l], m.line_vertex_offsets[l + 1]
            a = min(p.added_n[j], p.added_t[j]) * m.voronoi_rest_length[lo:hi] * deep[lo:hi]
            vertex[lo + 1:hi - 1] += a[1:-1]
            for end, i in ((0, 0), (1, -1)):
                nd = m.attach_node[2 * l + end]
                if m.node_inv_mass[nd] > 0 and p.node_skip[nd] == 0:
                    node[nd] += a[i]
        return (vertex, node) if np.any(vertex) or np.any(node) else None

    def adds_mass(self) -> bool:
        return bool(np.any(self.added_coefficients)) or bool(np.any(self.buoys[3]))

    def carried_mass(self, p, on: Binding):
        """The vertices of the lines that carry an added mass across or along them, the free
        nodes at their ends, and the nodes of buoys with an added mass."""
        m = on.model
        vertex, node = np.zeros(m.vertex_mass.shape[0], bool), np.zeros(m.node_mass.shape[0], bool)
        for j, l in enumerate(p.lines):
            if p.added_n[j] != 0.0 or p.added_t[j] != 0.0:
                vertex[m.line_vertex_offsets[l]:m.line_vertex_offsets[l + 1]] = True
                for end in (0, 1):
                    nd = m.attach_node[2 * l + end]
                    node[nd] |= m.node_inv_mass[nd] > 0 and p.node_skip[nd] == 0
        node[p.buoy_node[p.buoy_added != 0.0]] = True
        return (vertex, node) if vertex.any() or node.any() else None

    def dissipated(self, sim) -> float:
        """Energy drag has taken so far (J), measured in the frame of the medium."""
        return float(self.params(sim).dissipated[0])

    def supplied(self, sim) -> float:
        """Work a moving or accelerating medium has done on the net so far (J): drag's share
        from the medium's motion, the inertia force's, and the change of the entrained fluid's
        kinetic energy as the added mass changes plus the work of the forces of that fluid
        turning with the lines (kernels/added_mass.py): in still water the two cancel to the
        step's order, and what is left is the fluid a line takes along or leaves behind as it
        enters or leaves the water, which Morison's M v' = f leaves out of its forces."""
        p, on = self.params(sim), Binding(sim.net, sim.model, sim.state)
        # the held added mass catches up with the present positions, as at the next kick
        return float(p.supplied[0]) + self.entrained(p, on, held=False) - self.entrained(p, on, held=True)

    def start(self, sim):
        """Sample the medium at the positions a run starts from (kernels/fluid_step.fluid_entry):
        the added mass the first kick's account starts from."""
        p = self.params(sim)
        typed_call(VARIANTS.of(p).kernel("fluid_entry"), p, sim.model, sim.state, SAMPLE)

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        # the sample: the added mass the step holds (the entrained fluid's energy and its account;
        # the nodes' mass matrices, which rings and eyelets move them by before the next sample)
        # and the turning fluid's forces of the last kick, the next one's predictor (kernels/added_mass.py)
        return {"turn": p.turn, "dissipated": p.dissipated, "supplied": p.supplied, "sample": p.sample,
                "node_mass": p.node_mass, "turning": p.turning}

    def describe(self):
        law = f"resistance={self.resistance.tolist()}" if self.resistance is not None else f"drag={self.drag.tolist()}"
        return f"Fluid(density={self.density:g}, velocity={self.velocity.tolist()}, {law})"


def _cap_integral(depth: float, radius: float) -> float:
    """The integral of a sphere's submerged volume over its centre's depth below the still
    surface, from fully out of the water: the buoy's upthrust potential per rho g (kernels/
    fluid.submerged_fraction is its derivative over the volume)."""
    if depth <= -radius:
        return 0.0
    if depth >= radius:
        return 4.0 / 3.0 * math.pi * radius ** 3 * depth
    u = radius + depth
    return math.pi * (radius * u ** 3 / 3.0 - u ** 4 / 12.0)


def _mean_min(za, zb, s):
    """The mean over each element of min(z, s), z linear from za to zb."""
    lo, hi = np.minimum(za, zb), np.maximum(za, zb)
    out = 0.5 * (za + zb)
    dry = lo >= s
    out = np.where(dry, s, out)
    cut = (lo < s) & (hi > s)
    span = np.where(cut, hi - lo, 1.0)
    f = np.where(cut, (s - lo) / span, 0.0)           # wet fraction
    wet_mean = np.where(cut, f * 0.5 * (lo + s) + (1 - f) * s, 0.0)
    return np.where(cut, wet_mean, out)
