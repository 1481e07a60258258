"""A line's staggered grid before packing: vertices, element frames in the principal axes of
its cross-section, stiffnesses, rotary inertias, lumped masses and rest curvatures (§3).
cosnet.engine.flatten packs the grids of a net; cosnet.core.contract reads one line's."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .fast_modes import Factors
from .rotations import frame_from_tangent, matrix_from_rotvec, rotvec_from_matrix

if TYPE_CHECKING:
    from .net import Line


NODE_ROTARY_SHARE = 0.25


def _rz(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass
class LineGrid:
    """The staggered grid of one line before packing."""

    x: np.ndarray          # (n+1, 3)
    frames: np.ndarray     # (n, 3, 3) principal director frames
    rest_length: np.ndarray  # (n,)
    stiffness: np.ndarray  # (n, 3)
    inertia: np.ndarray    # (n, 3) rotary inertia per element
    mass: np.ndarray       # (n+1,) lumped vertex masses
    vor_length: np.ndarray  # (n+1,)
    bend: np.ndarray       # (n+1, 3)
    curvature: np.ndarray  # (n+1, 3) rest curvature, principal frame
    end_frames: tuple      # (D_start, D_end): line-end director frames in the lab (principal)
    element_mass: np.ndarray  # (n,) rho A l
    factors: Factors = field(default_factory=Factors)  # the line's fast-modes treatment
    held_bend: np.ndarray | None = None  # (2, 3) B at the boundary points of a jointed line (see flatten)


def _sections_at(line: Line, s: np.ndarray) -> tuple[list, np.ndarray]:
    """The cross-sections at arc fractions s and their principal (I1, I2, phi), (len(s), 3);
    a uniform line's section is evaluated once."""
    if not callable(line.section):
        return [line.section] * len(s), np.tile(np.array(line.section.principal()), (len(s), 1))
    secs = [line.section_at(float(x)) for x in s]
    return secs, np.array([sc.principal() for sc in secs])


def _principal_angle(line: Line) -> float:
    n = line.elements
    phis = _sections_at(line, np.linspace(0, 1, 2 * n + 1))[1][:, 2]
    if max(phis) - min(phis) > 1e-9:
        raise ValueError(f"line {line.name!r}: the principal axes of the cross-section (I12 != 0) "
                         f"must not turn along the line")
    return phis[0]


def element_frames(line: Line, phi: float) -> np.ndarray:
    """Director frames of the elements: d3 along each segment, d1 from the hint, transported
    along the polyline without twist, then turned by phi to the section's principal axes."""
    pts = line.points
    t = np.diff(pts, axis=0)
    frames = np.empty((line.elements, 3, 3))
    d1 = line.d1
    if d1 is None and line.start_frame is not None:
        d1 = (line.start.frame @ line.start_frame)[:, 0]
    frames[0] = frame_from_tangent(t[0], d1)
    # parallel transport of each frame onto the next tangent: the rotation taking unit tangent
    # a to b about a x b (the identity where they agree)
    u = t / np.linalg.norm(t, axis=1)[:, None]
    axis = np.cross(u[:-1], u[1:])
    sn = np.linalg.norm(axis, axis=1)
    cs = np.einsum("ij,ij->i", u[:-1], u[1:])
    turn = sn >= 1e-15
    rots = np.broadcast_to(np.eye(3), (len(sn), 3, 3)).copy()
    if turn.any():
        rv = axis[turn] / sn[turn, None] * np.arctan2(sn[turn], cs[turn])[:, None]
        rots[turn] = matrix_from_rotvec(rv)
    for k in range(1, line.elements):
        frames[k] = frames[k - 1] if not turn[k - 1] else rots[k - 1] @ frames[k - 1]
    return frames @ _rz(phi) if phi != 0.0 else frames


def build_line_grid(line: Line) -> LineGrid:
    n = line.elements
    mat = line.material
    phi = _principal_angle(line)
    frames = element_frames(line, phi)
    seg = np.linalg.norm(np.diff(line.points, axis=0), axis=1)
    s_vert = np.concatenate([[0.0], np.cumsum(seg)]) / seg.sum()
    s_mid = 0.5 * (s_vert[1:] + s_vert[:-1])
    secs, p_mid = _sections_at(line, s_mid)
    vsecs, p_v = _sections_at(line, s_vert)
    area = np.array([sc.A for sc in secs])
    kappa = np.array([sc.shear_coefficient for sc in secs])
    stiffness = np.column_stack([kappa * mat.G * area, kappa * mat.G * area, mat.E * area])
    inertia = seg[:, None] * _rotary_per_length(line, secs, p_mid)
    # rotations live at the element centres and at the nodes (s = 0, L): the dual cell of a
    # node is [0, l/4], so a node takes a quarter of its end element's rotary inertia
    inertia[0] *= 1.0 - NODE_ROTARY_SHARE
    inertia[-1] *= 1.0 - NODE_ROTARY_SHARE
    emass = mat.density * area * seg
    mass = np.zeros(n + 1)
    mass[:-1] += 0.5 * emass
    mass[1:] += 0.5 * emass
    vor = np.zeros(n + 1)
    vor[:-1] += 0.5 * seg
    vor[1:] += 0.5 * seg
    bend = np.column_stack([mat.E * p_v[:, 0], mat.E * p_v[:, 1], [mat.G * sc.J for sc in vsecs]])
    # line-end frames D(nu) X(nu, lambda); the default X makes the junction stress free (§2.3)
    ends = []
    for node, X, frame in ((line.start, line.start_frame, frames[0]), (line.end, line.end_frame, frames[-1])):
        ends.append(frame if X is None else node.frame @ X @ _rz(phi))
    curvature = np.zeros((n + 1, 3))
    if line.rest_curvature is not None:
        rz = _rz(phi)
        for k, s in enumerate(s_vert):
            curvature[k] = rz.T @ line.curvature_at(float(s))
    else:
        # rest shape = built polyline: interior Voronoi points are stress free
        if n > 1:
            rel = np.einsum("kji,kjl->kil", frames[:-1], frames[1:])
            curvature[1:n] = rotvec_from_matrix(rel) / vor[1:n, None]
    return LineGrid(line.points.copy(), frames, seg, stiffness, inertia, mass, vor, bend,
                    curvature, tuple(ends), emass)


def _rotary_per_length(line: Line, secs: list, principal: np.ndarray) -> np.ndarray:
    """(n, 3) rotary inertia per length about the principal axes: the line's own, else each
    section's own, else density times (I1, I2, I1 + I2) (3.4)."""
    rho = line.material.density
    derived = rho * np.column_stack([principal[:, 0], principal[:, 1], principal[:, 0] + principal[:, 1]])
    if line.rotary_inertia is not None:
        return np.tile(np.array(line.rotary_inertia), (len(secs), 1))
    own = [sc.rotary_inertia for sc in secs]
    if all(o is None for o in own):
        return derived
    return np.array([d if o is None else o for d, o in zip(derived, own)])
