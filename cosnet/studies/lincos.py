"""Analytic normal modes of a net of straight uniform lines (Gratus & Tucker §6, "LINCOS").

Each line is the linearised Kirchhoff-Cosserat rod about its stress-free straight state (6.13):
stretch, two shears, two bends and twist with rotary inertia, i.e. a 3D Timoshenko beam with
axial and torsional motion. For a mode ``sin(omega t)`` the state
``y = (u, theta, n, m)`` (displacement, small rotation, internal force, internal moment; all in
the line's director frame d1 d2 d3, SI) obeys the first-order linear ODE ``y' = A(omega) y``::

    u'     = K^-1 n - e3 x theta        (n = K (u' - theta x e3), the linearised (3.22))
    theta' = B^-1 m                     (m = B theta')
    n'     = -omega^2 rho A u           ((6.15), first line)
    m'     = -omega^2 rho I theta - e3 x n   ((6.15), second line)

Instead of the paper's closed forms (6.18)-(6.35) (with their case split at
``omega^2 I = kappa K``), the transfer matrix ``exp(A h)`` of a segment of length ``h`` is
computed in scaled variables (§5: every component divided by its natural scale on the segment,
so the exponent is O(1)) and turned into the segment's exact dynamic stiffness, which maps end
displacements/rotations to end loads. The junction conditions (6.36)-(6.38) -- end point =
node point + rotation x offset, one rotation per node, and the node's linearised balances
(4.3)/(4.4) with its mass, inertia and offsets -- are imposed by assembling the segments onto
node degrees of freedom (fixed nodes and locked inertia axes simply lose theirs). The result is
a symmetric global matrix ``T(omega)`` that is singular exactly at the natural frequencies.

Roots are found with the Wittrick-Williams count: segments are kept so short that none of
them has a clamped-clamped frequency below ``omega``, so the number of natural frequencies
below ``omega`` equals the number of negative eigenvalues of the (Jacobi-scaled) ``T(omega)``.
That count brackets every root with its exact multiplicity (a round section's two bending
modes are one double root) and bisection refines it; no root can be missed by a coarse scan.
Mode shapes are the null vectors of ``T(omega)``, mass-normalised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.net import Line, Net, node_groups
from ..core.rotations import frame_from_tangent, skew

_SAFETY = 0.4          # omega <= _SAFETY x (lower estimate of a segment's first clamped frequency)
_GAUSS = np.polynomial.legendre.leggauss(4)
CLAMPED_BETA_L2 = 22.37  # (beta L)^2 = 4.730^2 of a clamped-clamped beam's first mode


_E3X = skew((0.0, 0.0, 1.0))


def line_frame(line: Line) -> np.ndarray:
    """Director frame (columns d1 d2 d3, lab) of a straight line, as the engine builds it."""
    d1 = line.d1
    if d1 is None and line.start_frame is not None:
        d1 = (line.start.frame @ line.start_frame)[:, 0]
    return frame_from_tangent(line.points[-1] - line.points[0], d1)


class _LineData:
    """Constant properties of one straight uniform line (SI, director frame)."""

    def __init__(self, line: Line):
        who = f"line {line.name!r}"
        self.line = line
        p = line.points
        self.p0 = p[0].copy()
        chord = p[-1] - p[0]
        self.L = float(np.linalg.norm(chord))
        t = chord / self.L
        off = (p - p[0]) - np.outer((p - p[0]) @ t, t)
        if np.abs(off).max() > 1e-9 * self.L:
            raise ValueError(f"{who}: analytic modes need a straight line (its points leave the chord "
                             f"by {np.abs(off).max():.3g} m)")
        for s in np.linspace(0.0, 1.0, 5):
            if np.abs(line.curvature_at(float(s))).max() > 1e-12 / self.L:
                raise ValueError(f"{who}: analytic modes need zero rest curvature (a stress-free "
                                 f"straight state, §6)")
        sec = line.section_at(0.0)
        for s in np.linspace(0.0, 1.0, 9):
            if line.section_at(float(s)) != sec:
                raise ValueError(f"{who}: analytic modes need a uniform section along the line")
        self.C = line_frame(line)
        for node, X, end in ((line.start, line.start_frame, "start"), (line.end, line.end_frame, "end")):
            if X is not None and np.abs(node.frame @ X - self.C).max() > 1e-8:
                raise ValueError(f"{who}: its {end}_frame X does not match the line's director frame, "
                                 f"so the junction is pre-stressed; analytic modes need a "
                                 f"stress-free state (§6)")
        mat = line.material
        E, G, rho = mat.E, mat.G, mat.density
        assert G is not None   # Material fills it in from E and nu
        self.mu = rho * sec.A
        self.K = np.array([sec.shear_coefficient * G * sec.A] * 2 + [E * sec.A])
        self.B = np.array([[E * sec.I11, E * sec.I12, 0.0], [E * sec.I12, E * sec.I22, 0.0],
                           [0.0, 0.0, G * sec.J]])
        self.Binv = np.linalg.inv(self.B)
        self.Jr = rho * np.array([[sec.I11, sec.I12, 0.0], [sec.I12, sec.I22, 0.0],
                                  [0.0, 0.0, sec.I11 + sec.I22]])
        I1, I2, _ = sec.principal()
        self.Bb = E * math.sqrt(I1 * I2)          # bending stiffness scale
        # wave speeds for the segment rule
        self.c_ax = math.sqrt(E / rho)
        self.c_sh = math.sqrt(sec.shear_coefficient * G / rho)
        self.c_tor = math.sqrt(G * sec.J / (rho * (sec.I11 + sec.I22)))
        self.a_b = math.sqrt(E * min(I1, I2) / self.mu)

    def clamped_bound(self, h: float) -> float:
        """A lower estimate of the first clamped-clamped frequency of a segment of length h."""
        bend = 1.0 / math.sqrt((h * h / (CLAMPED_BETA_L2 * self.a_b)) ** 2 + (h / (math.pi * self.c_sh)) ** 2
                               + (h / (math.pi * self.c_ax)) ** 2)
        return min(math.pi * self.c_ax / h, math.pi * self.c_tor / h, bend)

    def segments(self, omega: float) -> int:
        n = 1
        while omega > _SAFETY * self.clamped_bound(self.L / n):
            n = n + 1 if n < 8 else int(n * 1.25) + 1
            if n > 20000:
                raise ValueError(f"line {self.line.name!r}: omega = {omega:g} rad/s needs too many segments")
        return n

    def A(self, omega: float) -> np.ndarray:
        """The 12 x 12 matrix of y' = A y, y = (u, theta, n, m) in the director frame (SI)."""
        a = np.zeros((12, 12))
        a[0:3, 6:9] = np.diag(1.0 / self.K)
        a[0:3, 3:6] = -_E3X
        a[3:6, 9:12] = self.Binv
        a[6:9, 0:3] = -omega**2 * self.mu * np.eye(3)
        a[9:12, 3:6] = -omega**2 * self.Jr
        a[9:12, 6:9] = -_E3X
        return a

    def scales(self, h: float) -> np.ndarray:
        """Natural scale of each component of y on a segment of length h (§5)."""
        ns = 1.0 / (h * h / self.Bb + 1.0 / self.K[0])
        return np.array([h, h, h, 1.0, 1.0, 1.0, ns, ns, self.K[2],
                         self.Bb / h, self.Bb / h, self.B[2, 2] / h])

    def propagator(self, omega: float, h: float) -> np.ndarray:
        """Transfer matrix exp(A h) over a length h, computed in scaled variables."""
        if h <= 0.0:
            return np.eye(12)
        from scipy.linalg import expm

        s = self.scales(h)
        return s[:, None] * expm(self.A(omega) * h * (1.0 / s)[:, None] * s[None, :]) / s[None, :]

    def stiffness(self, omega: float, h: float) -> np.ndarray:
        """12 x 12 dynamic stiffness of a segment: end loads on it from end (u, theta) at s = 0, h."""
        from scipy.linalg import expm

        s = self.scales(h)
        ph = expm(self.A(omega) * h * (1.0 / s)[:, None] * s[None, :])
        p11, p12, p21, p22 = ph[:6, :6], ph[:6, 6:], ph[6:, :6], ph[6:, 6:]
        g = np.linalg.solve(p12, np.hstack([p11, np.eye(6)]))
        g1, g2 = g[:, :6], g[:, 6:]
        k = np.block([[g1, -g2], [p21 - p22 @ g1, p22 @ g2]])
        sd, sf = np.tile(s[:6], 2), np.tile(s[6:], 2)
        return sf[:, None] * k / sd[None, :]


class _Assembly:
    """Degrees of freedom of a net: free node (u lab, rotation about free body axes) and the
    interior segment points of every line (u, theta in the line's frame)."""

    def __init__(self, net: Net, datas: list[_LineData], omega: float):
        self.net, self.datas, self.omega = net, datas, omega
        self.node_dofs, nd = [], 0
        for node in net.nodes:
            nt = 0 if node.fixed_position else 3
            free = np.flatnonzero(~node.locked_axes)
            self.node_dofs.append((np.arange(nd, nd + nt + free.size), nt, free))
            nd += nt + free.size
        self.nseg, self.inner = [], []
        for d in datas:
            n = d.segments(omega)
            self.nseg.append(n)
            self.inner.append(nd + np.arange(6 * (n - 1)).reshape(max(n - 1, 0), 6))
            nd += 6 * (n - 1)
        self.size = nd
        self.ends = [(self._end_map(d, d.line.start, d.line.start_offset),
                      self._end_map(d, d.line.end, d.line.end_offset)) for d in datas]

    def _end_map(self, d: _LineData, node, xi):
        """(dof indices, 6 x k map) from node dofs to the line end's (u, theta), line frame:
        u_end = u_node + a x zeta with zeta = D xi (6.36), theta_end = a (rotation continuity)."""
        idx, nt, free = self.node_dofs[node.index]
        D, Ct = node.frame, d.C.T
        zeta = D @ xi
        full = np.zeros((6, 6))
        full[0:3, 0:3] = Ct
        full[0:3, 3:6] = -Ct @ skew(zeta) @ D
        full[3:6, 3:6] = Ct @ D
        cols = ([0, 1, 2] if nt else []) + [3 + k for k in free]
        return idx, full[:, cols]

    def endpoints(self, li: int):
        """Per segment boundary k = 0..n: (dof indices, 6 x k map)."""
        n, (e0, e1) = self.nseg[li], self.ends[li]
        return [e0] + [(self.inner[li][k], np.eye(6)) for k in range(n - 1)] + [e1]

    def matrix(self) -> np.ndarray:
        """T(omega): sum of segment dynamic stiffnesses minus omega^2 x node mass (symmetric)."""
        w2 = self.omega**2
        T = np.zeros((self.size, self.size))
        for node, (idx, nt, free) in zip(self.net.nodes, self.node_dofs):
            if nt:
                T[idx[:3], idx[:3]] -= w2 * node.mass
            r = idx[nt:]
            T[np.ix_(r, r)] -= w2 * node.inertia[np.ix_(free, free)]
        for li, d in enumerate(self.datas):
            n = self.nseg[li]
            k = d.stiffness(self.omega, d.L / n)
            pts = self.endpoints(li)
            for j in range(n):
                (i0, m0), (i1, m1) = pts[j], pts[j + 1]
                T[np.ix_(i0, i0)] += m0.T @ k[:6, :6] @ m0
                T[np.ix_(i0, i1)] += m0.T @ k[:6, 6:] @ m1
                T[np.ix_(i1, i0)] += m1.T @ k[6:, :6] @ m0
                T[np.ix_(i1, i1)] += m1.T @ k[6:, 6:] @ m1
        return 0.5 * (T + T.T)

    def scaled(self):
        """(Jacobi-scaled T, scale vector s) with T_scaled = diag(s) T diag(s)."""
        T = self.matrix()
        rn = np.sqrt(np.einsum("ij,ij->i", T, T))
        s = 1.0 / np.sqrt(np.where(rn > 0, rn, 1.0))
        return s[:, None] * T * s[None, :], s


def allowed_rigid_motions(C: np.ndarray) -> np.ndarray:
    """(6, r) orthonormal basis of the rigid motions (v, w) of one connected part that the
    clamps allow: the null space of C (m, 6), the clamped coordinates' rows of the 6 unit
    motions (r = 6 without clamps)."""
    if C.size and np.abs(C).max() > 0:
        _, s, vt = np.linalg.svd(C)
        rank = int(np.sum(s > 1e-9 * s[0]))
        return vt[rank:].T
    return np.eye(6)


def rigid_mode_count(net: Net) -> int:
    """Number of zero-frequency (rigid-body) modes: 6 per connected part, less those removed by
    fixed nodes and locked inertia axes."""
    root = node_groups(net, net.lines)
    total = 0
    for r in {root(i) for i in range(len(net.nodes))}:
        members = [n for n in net.nodes if root(n.index) == r]
        c = np.mean([n.position for n in members], axis=0)
        rows = [np.zeros((0, 6))]
        for n in members:
            if n.fixed_position:     # v + w x (x - c) = 0
                rows.append(np.hstack([np.eye(3), -skew(n.position - c)]))
            for k in np.flatnonzero(n.locked_axes):
                rows.append(np.hstack([np.zeros((1, 3)), n.frame[:, k][None, :]]))
        total += allowed_rigid_motions(np.vstack(rows)).shape[1]
    return total


@dataclass
class Mode:
    """One normal mode: angular frequency ``omega`` (rad/s), displacement of each node's
    reference point and its small rotation vector, both (n_nodes, 3) in the lab frame. Shapes
    are mass-normalised: int (rho A |u|^2 + theta . rho I theta) ds over the lines plus
    sum (M |u|^2 + a . I a) over the nodes = 1 (so u is in m / sqrt(kg)); a degenerate
    frequency's shapes are mass-orthonormal. Along a line, ``line_shape(line, s)`` takes s as
    the fraction of its length (as ``Line.section_at``)."""

    omega: float
    node_displacement: np.ndarray
    node_rotation: np.ndarray
    _asm: _Assembly
    _x: np.ndarray

    @property
    def frequency(self) -> float:
        """Frequency in Hz."""
        return self.omega / (2.0 * math.pi)

    def _segment_states(self, li: int):
        asm, d = self._asm, self._asm.datas[li]
        n = asm.nseg[li]
        h = d.L / n
        k = d.stiffness(self.omega, h)
        pts = asm.endpoints(li)
        disp = [m @ self._x[i] for i, m in pts]
        # internal loads at the start of each segment: n(s_j) = -(load on the segment there)
        return [np.concatenate([disp[j], -(k[:6, :6] @ disp[j] + k[:6, 6:] @ disp[j + 1])])
                for j in range(n)], h

    def line_state(self, line: Line, s) -> np.ndarray:
        """(k, 12) state (u, theta, n, m) in the line's director frame at fractions s in [0, 1]."""
        li = line.index
        states, h = self._segment_states(li)
        d = self._asm.datas[li]
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if np.any((s < 0) | (s > 1)):
            raise ValueError(f"line {line.name!r}: s must lie in [0, 1] (fraction of its length)")
        out = np.empty((s.size, 12))
        for i, si in enumerate(s * d.L):
            j = min(int(si / h), len(states) - 1)
            out[i] = d.propagator(self.omega, si - j * h) @ states[j]
        return out

    def line_shape(self, line: Line, s):
        """(displacement (k, 3), rotation (k, 3)), lab frame, at fractions s in [0, 1] of the line."""
        y = self.line_state(line, s)
        C = self._asm.datas[line.index].C
        return y[:, 0:3] @ C.T, y[:, 3:6] @ C.T

    def line_loads(self, line: Line, s):
        """(internal force n (k, 3) N, internal moment m (k, 3) N m), lab frame, per unit amplitude."""
        y = self.line_state(line, s)
        C = self._asm.datas[line.index].C
        return y[:, 6:9] @ C.T, y[:, 9:12] @ C.T


def _gram(asm: _Assembly, omega: float, X: np.ndarray) -> np.ndarray:
    """Kinetic (mass) Gram matrix of the columns of X: lines by Gauss quadrature, plus nodes."""
    G = np.zeros((X.shape[1], X.shape[1]))
    for node, (idx, nt, free) in zip(asm.net.nodes, asm.node_dofs):
        xs = X[idx]
        if nt:
            G += node.mass * xs[:3].T @ xs[:3]
        G += xs[nt:].T @ node.inertia[np.ix_(free, free)] @ xs[nt:]
    for li, d in enumerate(asm.datas):
        h = d.L / asm.nseg[li]
        props = np.array([d.propagator(omega, 0.5 * h * (1 + g)) for g in _GAUSS[0]])
        W = np.zeros((12, 12))
        W[0:3, 0:3] = d.mu * np.eye(3)
        W[3:6, 3:6] = d.Jr
        # Y[c, j, q]: state of column c in segment j at Gauss point q
        none = np.zeros((0, 3))
        Y = np.array([[props @ y for y in Mode(omega, none, none, asm, X[:, c])._segment_states(li)[0]]
                      for c in range(X.shape[1])])
        G += 0.5 * h * np.einsum("q,cjqa,ab,djqb->cd", _GAUSS[1], Y, W, Y)
    return G


@dataclass
class Modes:
    """Result of ``analytic_modes``: ``omega`` (k,) rad/s ascending (a degenerate frequency is
    repeated with its multiplicity), ``shapes`` (k Mode), ``rigid_modes`` (skipped zero modes).
    Unpacks as ``omega, shapes = analytic_modes(...)``."""

    omega: np.ndarray
    shapes: list
    rigid_modes: int

    @property
    def frequency(self) -> np.ndarray:
        return self.omega / (2.0 * math.pi)

    def __iter__(self):
        return iter((self.omega, self.shapes))

    def __len__(self):
        return len(self.omega)


def analytic_modes(net: Net, count: int | None = None, omega_max: float | None = None, *,
                   rtol: float = 1e-11, shapes: bool = True) -> Modes:
    """Normal modes of a net of straight, uniform, stress-free lines (§6), lowest first.

    count: how many elastic modes (degenerate ones counted with their multiplicity);
    omega_max: only modes with omega <= omega_max (rad/s). Either or both may be given
    (neither: the lowest 10).
    rtol: relative accuracy of each frequency. shapes: also compute mass-normalised shapes.
    Rigid-body (zero-frequency) modes are skipped; their number is ``result.rigid_modes``.
    """
    net.validate()
    if count is None and omega_max is None:
        count = 10
    if count is not None and (isinstance(count, bool) or int(count) != count or count < 1):
        raise ValueError(f"analytic_modes: count must be a positive integer, got {count!r}")
    if omega_max is not None and not (math.isfinite(omega_max) and omega_max > 0):
        raise ValueError(f"analytic_modes: omega_max must be a positive number, got {omega_max!r}")
    if not net.lines:
        raise ValueError("analytic_modes: the net has no lines (nothing elastic to vibrate)")
    datas = [_LineData(l) for l in net.lines]
    rigid = rigid_mode_count(net)
    want = math.inf if count is None else int(count)

    def below(omega):          # Wittrick-Williams: number of elastic frequencies below omega
        T, _ = _Assembly(net, datas, omega).scaled()
        return int(np.sum(np.linalg.eigvalsh(T) < 0.0)) - rigid

    if omega_max is not None:
        hi = float(omega_max)
    else:
        hi = min(d.a_b / d.L**2 for d in datas)
        while below(hi) < want:
            hi *= 2.0
    found = []

    def isolate(lo, hi, nlo, nhi):
        while nhi > nlo and nlo < want:
            if hi - lo <= rtol * hi:
                found.extend([0.5 * (lo + hi)] * (nhi - nlo))
                return
            mid = 0.5 * (lo + hi)
            nm = min(max(below(mid), nlo), nhi)     # monotone by theory; guard round-off
            isolate(lo, mid, nlo, nm)
            lo, nlo = mid, nm

    isolate(0.0, hi, 0, below(hi))
    omegas = np.array(sorted(found)[: None if count is None else int(count)])
    modes = []
    if shapes:
        i = 0
        while i < len(omegas):
            m = int(np.sum(np.abs(omegas - omegas[i]) <= 2 * rtol * omegas[i]))
            modes.extend(_shapes(net, datas, float(omegas[i]), m))
            i += m
    return Modes(omegas, modes, rigid)


def _shapes(net, datas, omega, m):
    asm = _Assembly(net, datas, omega)
    T, s = asm.scaled()
    vals, vecs = np.linalg.eigh(T)
    X = s[:, None] * vecs[:, np.argsort(np.abs(vals))[:m]]
    G = _gram(asm, omega, X)
    w, V = np.linalg.eigh(G)
    X = X @ V / np.sqrt(w)[None, :]
    out = []
    for c in range(m):
        x = X[:, c]
        u = np.zeros((len(net.nodes), 3))
        a = np.zeros((len(net.nodes), 3))
        for node, (idx, nt, free) in zip(net.nodes, asm.node_dofs):
            if nt:
                u[node.index] = x[idx[:3]]
            a[node.index] = node.frame[:, free] @ x[idx[nt:]]
        out.append(Mode(omega, u, a, asm, x))
    return out
