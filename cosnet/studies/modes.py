"""Normal modes of the discretised net about its stress-free state.

The discrete strain energy (kernels/elastic.py) is
    U = sum_e l_e/2 eps_e^T K_e eps_e + sum_k L_k/2 kap_k^T B_k kap_k,
    eps_e = D_e^T (x_{e+1} - x_e)/l_e - e3,   kap_k = log(D_a^T D_b)/L_k - u0_k.
At a stress-free state every eps and kap vanishes, so the terms of the Hessian holding second
derivatives of the strains multiply zero and the Hessian is exactly
    K = sum_e l_e G_e^T K_e G_e + sum_k G_k^T (B_k / L_k) G_k
with G_e = d eps_e / dq and G_k = d theta_k / dq:
    d eps_e   = D_e^T (dx_{e+1} - dx_e)/l_e + e3 x alpha_e
    d theta_k = J_r^-1(theta_k) beta_b - J_l^-1(theta_k) alpha_a
(alpha_a, beta_b the body rotations of the frames on either side of Voronoi point k).

Coordinates q (the reduced degrees of freedom, in this order):
    interior vertex displacements dx (lab, m)
    element rotations alpha_e (body frame, rad: D_e -> D_e exp(alpha_e))
    node centre-of-mass displacements dc (lab, m), nodes of finite mass only
    node rotations phi (principal body frame, rad: R -> R exp(phi)), unlocked axes only
A line-end vertex moves with its node, dx = dc + R (phi x rho) (rho = attach_offset, (1.1)),
and its frame D X' turns by X'^T phi (1.3). The kinetic energy of the stepper is
q'^T M q' / 2 with the diagonal M of vertex masses, element rotary inertias, node composite
masses and principal inertias, so the modes solve K u = omega^2 M u (shift-invert ARPACK).
Effects (gravity, loads, damping) are not part of the linearisation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..effects.articulations import condensed_bending
from ..engine.flatten import flatten
from .lincos import allowed_rigid_motions
from ..engine.measure import block_of, line_strains
from ..core.rotations import matrix_from_quat, rotvec_from_matrix, skew
from ..kernels.layout import Model, State
from ..kernels.motion import place_line_ends
from ..core.net import Line, Net, Node

if TYPE_CHECKING:
    import scipy.sparse as sp

STRESS_FREE_TOL = 1e-8   # largest strain |eps| and rotation misfit |theta - L u0| (rad) accepted
DENSE_LIMIT = 64         # below this many degrees of freedom the dense solver is used
REST_HINT = ("modes linearise about the stress-free state, so build the net in its rest shape "
             "(points consistent with rest_curvature, end frames consistent with the curvature "
             "at the line ends); a pre-stressed net has no such state")


def inverse_jacobians(theta: np.ndarray):
    """Return (J_l^-1, J_r^-1) (N, 3, 3) of rotation vectors theta (N, 3):
    I -/+ t^/2 + c t^2, c = 1/|t|^2 - (1 + cos|t|)/(2 |t| sin|t|)."""
    t2 = np.einsum("ni,ni->n", theta, theta)
    t = np.sqrt(t2)
    small = t < 1e-3
    ts = np.where(small, 1.0, t)
    c = np.where(small, 1.0 / 12.0 + t2 / 720.0,
                 1.0 / ts**2 - (1.0 + np.cos(ts)) / (2.0 * ts * np.sin(ts)))
    h = skew(theta)
    quad = np.eye(3) + c[:, None, None] * (h @ h)
    return quad - 0.5 * h, quad + 0.5 * h


def _blocks(row_block, col_block, mats):
    """COO triplets of 3x3 blocks mats (N, 3, 3) at block positions (row_block, col_block)."""
    i = 3 * row_block[:, None, None] + np.arange(3)[None, :, None]
    j = 3 * col_block[:, None, None] + np.arange(3)[None, None, :]
    i, j, v = np.broadcast_arrays(i, j, mats)
    return i.ravel(), j.ravel(), v.ravel()


def _matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of quaternions q (n, 4) (w, x, y, z); n may be 0."""
    return matrix_from_quat(q) if q.shape[0] else np.zeros((0, 3, 3))


def _copy_state(state: State) -> State:
    return State(*(np.array(a, copy=True) for a in state))


@dataclass
class Linearisation:
    """K and M (reduced, CSR) of a flattened net and the map to its raw coordinates.

    Raw coordinates (length 3 nv + 3 ne + 6 nn): every vertex dx, every element alpha, every
    node dc and phi. ``T`` (raw x reduced) maps q to them; ``reduced`` (N,) lists the raw index
    of each reduced coordinate. ``x0, q0, node_x0, node_q0`` are the rest state. K equals
    jacobian^T diag(weights) jacobian."""

    K: sp.csr_matrix
    M: sp.csr_matrix
    T: sp.csr_matrix
    reduced: np.ndarray
    jacobian: sp.csr_matrix   # (3 ne + 3 nv, N): strain rows d eps_e (3 each), then d theta_k
    weights: np.ndarray       # (3 ne + 3 nv,): l_e K_e, then B_k / L_k
    model: Model
    x0: np.ndarray
    q0: np.ndarray
    node_x0: np.ndarray
    node_q0: np.ndarray

    @property
    def sizes(self):
        return self.x0.shape[0], self.q0.shape[0], self.node_x0.shape[0]

    def split(self, raw: np.ndarray):
        """Raw vector -> (dx (nv,3), alpha (ne,3), dc (nn,3), phi (nn,3))."""
        nv, ne, nn = self.sizes
        cut = np.cumsum([3 * nv, 3 * ne, 3 * nn])
        return tuple(p.reshape(-1, 3) for p in np.split(raw, cut))

    def raw_displacement(self, state: State) -> np.ndarray:
        """Raw coordinates of ``state`` relative to the rest state (finite rotations as
        rotation vectors, body frame)."""
        dx = state.x - self.x0
        rot = lambda q0, q: rotvec_from_matrix(np.einsum("nji,njk->nik", _matrices(q0), _matrices(q)))
        alpha = rot(self.q0, state.q)
        phi = rot(self.node_q0, state.node_q)
        return np.concatenate([dx.ravel(), alpha.ravel(), (state.node_x - self.node_x0).ravel(), phi.ravel()])


def _voronoi_sides(model):
    """Per Voronoi point k: (line, is_start, is_end, left element, right element)."""
    vo = model.line_vertex_offsets
    nv = model.vertex_mass.shape[0]
    line = np.repeat(np.arange(vo.shape[0] - 1), np.diff(vo))
    k = np.arange(nv)
    return line, k == vo[line], k == vo[line + 1] - 1, k - line - 1, k - line


@dataclass
class _Geometry:
    """A state's frames and strains: placed state st, element frames D (ne,3,3), node frames R
    (nn,3,3), line-end frames X' (na,3,3), element lines (ne,), Voronoi sides, element strains
    eps (ne,3) and Voronoi rotations theta (nv,3) = log(D_a^T D_b)."""

    st: State
    D: np.ndarray
    R: np.ndarray
    Xp: np.ndarray
    eline: np.ndarray
    sides: tuple
    eps: np.ndarray
    theta: np.ndarray


def _geometry(model, state: State) -> _Geometry:
    st = _copy_state(state)
    place_line_ends(model, st)
    D, R, Xp = _matrices(st.q), _matrices(st.node_q), _matrices(model.attach_frame)
    eo = model.line_element_offsets
    eline = np.repeat(np.arange(eo.shape[0] - 1), np.diff(eo))
    strains = line_strains(model, st, block_of(model))
    eps, theta = np.column_stack(strains.stretch), np.column_stack(strains.theta)
    return _Geometry(st, D, R, Xp, eline, _voronoi_sides(model), eps, theta)


def check_stress_free(model, geo: _Geometry, net: Net, hint: str):
    """Raise ValueError naming the first strained element or bent Voronoi point."""
    mis = geo.theta - model.voronoi_rest_length[:, None] * model.voronoi_rest_curvature
    for what, arr, offsets, unit in (("element", geo.eps, model.line_element_offsets, ""),
                                     ("Voronoi point", mis, model.line_vertex_offsets, " rad")):
        bad = np.flatnonzero(np.abs(arr).max(axis=1, initial=0.0) > STRESS_FREE_TOL)
        if bad.size:
            i = int(bad[0])
            l = int(np.searchsorted(offsets, i, side="right") - 1)
            qty = "strain |v - d3|" if what == "element" else "rotation misfit |theta - L u0|"
            raise ValueError(f"modes: line {net.lines[l].name!r} {what} {i - offsets[l]} is not stress "
                             f"free ({qty} = {np.abs(arr[i]).max():.3g}{unit}); {hint}")


def linearise(model, state: State, net: Net, hint: str = REST_HINT, joints=()) -> Linearisation:
    """Exact stiffness K and mass M of the net linearised about ``state`` (stress free, else
    ValueError ending with ``hint``). ``joints``: [(point, S)], the condensed 3x3 bending
    stiffness of each articulated end's boundary point (cosnet.effects.articulations.condensed_bending),
    which the model does not hold; each enters factored, S = U diag(s) U^T, as three strain rows
    U^T d theta of weights s."""
    import scipy.sparse as sp

    geo = _geometry(model, state)
    check_stress_free(model, geo, net, hint)
    st, D, R, Xp, eline = geo.st, geo.D, geo.R, geo.Xp, geo.eline
    nv, ne, nn = st.x.shape[0], st.q.shape[0], st.node_x.shape[0]
    XA, AA, CA, PA = 0, nv, nv + ne, nv + ne + nn    # block offsets (units of 3)
    raw_n = 3 * (nv + ne + 2 * nn)
    e = np.arange(ne)
    # stretch and shear rows (block e): D^T (dx_{e+1} - dx_e)/l + e3 x alpha
    Dt = np.transpose(D, (0, 2, 1)) * model.element_inv_rest_length[:, None, None]
    trip = [_blocks(e, XA + e + eline + 1, Dt), _blocks(e, XA + e + eline, -Dt),
            _blocks(e, AA + e, np.broadcast_to(skew(np.array([0.0, 0.0, 1.0])), (ne, 3, 3)))]
    # bend and twist rows (block ne + k): J_r^-1 beta_b - J_l^-1 alpha_a
    line_v, start, end, e_left, e_right = geo.sides
    jl_inv, jr_inv = inverse_jacobians(geo.theta)
    a_start, a_end = 2 * line_v, 2 * line_v + 1
    col_a = np.where(start, PA + model.attach_node[a_start], AA + e_left)
    col_b = np.where(end, PA + model.attach_node[a_end], AA + e_right)
    eye = np.eye(3)
    map_a = np.where(start[:, None, None], np.transpose(Xp[a_start], (0, 2, 1)), eye)
    map_b = np.where(end[:, None, None], np.transpose(Xp[a_end], (0, 2, 1)), eye)
    k = np.arange(nv)
    trip += [_blocks(ne + k, col_a, -jl_inv @ map_a), _blocks(ne + k, col_b, jr_inv @ map_b)]
    rows, cols, vals = (np.concatenate(p) for p in zip(*trip))
    G = sp.coo_matrix((vals, (rows, cols)), shape=(3 * (ne + nv), raw_n)).tocsr()
    W = np.concatenate([(model.element_rest_length[:, None] * model.element_stiffness).ravel(),
                        (model.voronoi_stiffness * model.voronoi_inv_rest_length[:, None]).ravel()])

    # reduced coordinates and the map T: raw <- reduced
    free = np.ones(raw_n, dtype=bool)
    free[3 * model.attach_vertex[:, None] + np.arange(3)] = False
    free[3 * CA:3 * PA] = np.repeat(np.isfinite(model.node_mass), 3)
    free[3 * PA:] = (model.node_locked == 0).ravel()
    reduced = np.flatnonzero(free)
    to_red = np.full(raw_n, -1)
    to_red[reduced] = np.arange(reduced.size)
    na = model.attach_node.shape[0]
    ends = [_blocks(model.attach_vertex, CA + model.attach_node, np.broadcast_to(eye, (na, 3, 3))),
            _blocks(model.attach_vertex, PA + model.attach_node,
                    -R[model.attach_node] @ skew(model.attach_offset))]
    er, ec, ev = (np.concatenate(p) for p in zip(*ends))
    keep = to_red[ec] >= 0
    t_rows = np.concatenate([reduced, er[keep]])
    t_cols = np.concatenate([np.arange(reduced.size), to_red[ec[keep]]])
    T = sp.coo_matrix((np.concatenate([np.ones(reduced.size), ev[keep]]), (t_rows, t_cols)),
                      shape=(raw_n, reduced.size)).tocsr()
    A = (G @ T).tocsr()
    if joints:
        turn = sp.lil_matrix((A.shape[0], A.shape[0]))
        turn.setdiag(1.0)
        for point, stiff in joints:
            s, u = np.linalg.eigh(stiff)
            rows = 3 * (ne + point) + np.arange(3)
            turn[np.ix_(rows, rows)] = u.T
            W[rows] = np.maximum(s, 0.0)
        A = (turn.tocsr() @ A).tocsr()
    K = (A.T @ sp.diags(W) @ A).tocsr()
    K = (0.5 * (K + K.T)).tocsr()
    mass = np.concatenate([np.repeat(model.vertex_mass, 3), model.element_inertia.ravel(),
                           np.repeat(model.node_mass, 3), model.node_inertia.ravel()])
    M = sp.diags(mass[reduced]).tocsr()
    return Linearisation(K, M, T, reduced, A, W, model, st.x.copy(), st.q.copy(), st.node_x.copy(), st.node_q.copy())


def rigid_basis(lin: Linearisation, net: Net) -> np.ndarray:
    """(N, r) basis of the rigid motions the clamps allow (6 per free connected component)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    model = lin.model
    nv, ne, nn = lin.sizes
    nl = len(net.lines)
    adj = sp.coo_matrix((np.ones(nl), ([l.start.index for l in net.lines], [l.end.index for l in net.lines])),
                        shape=(nn, nn))
    ncomp, comp = connected_components(adj, directed=False)
    vline = np.repeat(np.arange(nl), np.diff(model.line_vertex_offsets))
    eline = np.repeat(np.arange(nl), np.diff(model.line_element_offsets))
    line_comp = np.array([comp[l.start.index] for l in net.lines], dtype=int)
    D, R = _matrices(lin.q0), _matrices(lin.node_q0)
    clamped = np.zeros(3 * (nv + ne + 2 * nn), dtype=bool)
    clamped[3 * (nv + ne):] = True            # node coordinates not among the reduced ones
    clamped[lin.reduced] = False
    basis = []
    for c in range(ncomp):
        vm, em, nm = line_comp[vline] == c, line_comp[eline] == c, comp == c
        pts = np.concatenate([lin.x0[vm], lin.node_x0[nm]])
        p = pts.mean(axis=0)
        cols = []
        for j in range(6):
            a = np.eye(3)[j % 3]
            if j < 3:
                parts = (np.tile(a, (nv, 1)), np.zeros((ne, 3)), np.tile(a, (nn, 1)), np.zeros((nn, 3)))
            else:
                parts = (np.cross(a, lin.x0 - p), D.transpose(0, 2, 1) @ a, np.cross(a, lin.node_x0 - p),
                         R.transpose(0, 2, 1) @ a)
            masks = (vm, em, nm, nm)
            cols.append(np.concatenate([(q * m[:, None]).ravel() for q, m in zip(parts, masks)]))
        raw = np.column_stack(cols)
        null = allowed_rigid_motions(raw[clamped])
        if null.shape[1]:
            basis.append(raw[lin.reduced] @ null)
    return np.column_stack(basis) if basis else np.zeros((lin.reduced.size, 0))


class DiscreteModes:
    """Normal modes of a discretised net: ``omega`` (k,) rad/s ascending, ``frequency`` Hz,
    ``rigid_modes`` (zero-frequency rigid motions, not listed), ``vectors`` (N, k) mass-normalised
    reduced mode vectors (u^T M u = 1), ``lin`` the Linearisation, ``net``; ``analytic``: the
    exact modes main_modes set beside them, or None."""

    analytic = None   # cosnet.studies.lincos.Modes when main_modes computed them

    def __init__(self, net: Net, lin: Linearisation, omega, vectors, rigid_modes: int):
        self.net, self.lin = net, lin
        self.omega, self.vectors, self.rigid_modes = omega, vectors, rigid_modes

    def __len__(self):
        return self.omega.shape[0]

    @property
    def frequency(self) -> np.ndarray:
        return self.omega / (2.0 * math.pi)

    def raw(self, j: int):
        """Mode j as (dx (nv,3) lab, alpha (ne,3) body, dc (nn,3) lab, phi (nn,3) principal body)."""
        if not 0 <= j < len(self):
            raise ValueError(f"modes: mode index must be in [0, {len(self)}), got {j}")
        return self.lin.split(self.lin.T @ self.vectors[:, j])

    def line_displacement(self, j: int, line: Line) -> np.ndarray:
        """(n+1, 3) vertex displacements of line in mode j (lab, ends included)."""
        o = self.lin.model.line_vertex_offsets
        return self.raw(j)[0][o[line.index]:o[line.index + 1]]

    def line_rotation(self, j: int, line: Line) -> np.ndarray:
        """(n, 3) element rotations of line in mode j (each element's body frame)."""
        o = self.lin.model.line_element_offsets
        return self.raw(j)[1][o[line.index]:o[line.index + 1]]

    def node_displacement(self, j: int, node: Node) -> np.ndarray:
        """(3,) displacement of node's composite centre of mass in mode j (lab)."""
        return self.raw(j)[2][node.index]

    def node_rotation(self, j: int, node: Node) -> np.ndarray:
        """(3,) rotation of node in mode j, principal body frame (as sim.node_angular_velocity)."""
        return self.raw(j)[3][node.index]

    def peak_displacement(self, j: int) -> float:
        """Largest vertex or node translation of mode j (m per unit modal coordinate)."""
        dx, _, dc, _ = self.raw(j)
        return float(max(np.abs(dx).max(initial=0.0), np.abs(dc).max(initial=0.0)))

    def energy_shares(self, j: int) -> dict:
        """Fractions of mode j's strain energy in stretch, shear, bend and twist."""
        lin = self.lin
        ne = lin.sizes[1]
        parts = (lin.weights * (lin.jacobian @ self.vectors[:, j]) ** 2).reshape(-1, 3)
        st, bt = parts[:ne].sum(axis=0), parts[ne:].sum(axis=0)
        total = st.sum() + bt.sum()
        return {"stretch": st[2] / total, "shear": (st[0] + st[1]) / total,
                "bend": (bt[0] + bt[1]) / total, "twist": bt[2] / total}

    def _check_sim(self, sim):
        if sim.net is not self.net or sim.state.x.shape != self.lin.x0.shape:
            raise ValueError("modes: the simulation must be of the net these modes were computed for")

    def excite(self, sim, j: int, amplitude: float):
        """Set every velocity of sim (at rest) to that of mode j passing its rest position, scaled
        so that the largest translation reaches ``amplitude`` (m)."""
        self._check_sim(sim)
        dx, alpha, dc, phi = self.raw(j)
        s = self.omega[j] * amplitude / self.peak_displacement(j)
        st = sim.state
        st.v[:], st.w[:], st.node_v[:], st.node_w[:] = s * dx, s * alpha, s * dc, s * phi

    def coordinates(self, sim) -> np.ndarray:
        """(k,) modal coordinates u_j^T M q of sim's displacement q from the rest state."""
        self._check_sim(sim)
        place_line_ends(sim.model, sim.state)
        q = self.lin.raw_displacement(sim.state)[self.lin.reduced]
        return self.vectors.T @ (self.lin.M @ q)


def _solve(lin: Linearisation, rigid: np.ndarray, count: int, sigma: float):
    """Shift-invert Lanczos on K u = omega^2 M u, then a Rayleigh-Ritz step on the elastic
    vectors with the factored energy (J u)^T W (J u): assembled K carries the round-off of its
    large shear and stretch entries, the factored form does not, so slender rods keep full
    accuracy in their soft bending modes."""
    import scipy.linalg
    from scipy.sparse.linalg import eigsh

    K, M = lin.K, lin.M
    n, r = K.shape[0], rigid.shape[1]
    m = M.diagonal()
    # rigid modes and free joints' mechanisms make K singular: shift below zero by a tiny
    # fraction of the stiffest omega^2
    shift = sigma * sigma - 1e-9 * float(np.max(K.diagonal() / m))
    want = min(count + r, n)
    if n <= DENSE_LIMIT or want >= n - 1:
        vals, vecs = scipy.linalg.eigh(K.toarray(), np.diag(m))
    else:
        vals, vecs = eigsh(K.tocsc(), k=want, M=M.tocsc(), sigma=shift, which="LM")
    if r:
        vecs = vecs / np.sqrt(np.einsum("ij,i,ij->j", vecs, m, vecs))
        g = rigid.T @ (m[:, None] * rigid)
        # remove the rigid motions (the elastic modes are M-orthogonal to them); what is left of
        # a computed rigid mode is round-off
        vecs = vecs - rigid @ np.linalg.solve(g, rigid.T @ (m[:, None] * vecs))
        vecs = vecs[:, np.einsum("ij,i,ij->j", vecs, m, vecs) > 0.5]
    jv = lin.jacobian @ vecs
    vals, y = scipy.linalg.eigh(jv.T @ (lin.weights[:, None] * jv), vecs.T @ (m[:, None] * vecs))
    vecs = vecs @ y
    omega = np.sqrt(np.maximum(vals, 0.0))
    pick = np.sort(np.argsort(np.abs(omega - sigma), kind="stable")[:count])
    omega, vecs = omega[pick], vecs[:, pick]
    # deterministic sign: the largest mass-weighted component is positive
    big = np.argmax(np.abs(vecs) * np.sqrt(m)[:, None], axis=0)
    vecs = vecs * np.sign(vecs[big, np.arange(vecs.shape[1])])
    return omega, vecs


def modes(net_or_sim, count: int = 6, sigma: float = 0.0, method: str = "discrete"):
    """The ``count`` normal modes of the discretised net nearest to ``sigma`` (rad/s), about its
    stress-free state. ``net_or_sim``: a Net (flattened here) or a Simulation (its model and its
    current state, which must be at rest and stress free). Rigid motions of free parts are not
    listed; their number is ``rigid_modes``.

    method="analytic" returns instead the exact modes of the continuous net (§6, the LINCOS
    calculation of cosnet.studies.lincos.analytic_modes: straight uniform lines), lowest first."""
    from ..engine.simulation import Simulation
    if method == "analytic":
        if not isinstance(net_or_sim, Net):
            raise ValueError(f"modes: method='analytic' takes a cosnet.Net, got {net_or_sim!r}")
        if sigma != 0.0:
            raise ValueError("modes: sigma applies to the discrete method only")
        from .lincos import analytic_modes
        return analytic_modes(net_or_sim, count=count)
    if method != "discrete":
        raise ValueError(f"modes: method must be 'discrete' or 'analytic', got {method!r}")
    if isinstance(net_or_sim, Simulation):
        net, model, state, grids = net_or_sim.net, net_or_sim.model, net_or_sim.state, net_or_sim.grids
        hint = "a Simulation must be at its rest state (not yet run); " + REST_HINT
    elif isinstance(net_or_sim, Net):
        net = net_or_sim
        model, state, grids = flatten(net)
        hint = REST_HINT
    else:
        raise ValueError(f"modes: expected a cosnet.Net or Simulation, got {net_or_sim!r}")
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"modes: count must be a positive integer, got {count!r}")
    if not math.isfinite(sigma) or sigma < 0:
        raise ValueError(f"modes: sigma must be a frequency >= 0 (rad/s), got {sigma!r}")
    lin = linearise(model, state, net, hint, condensed_bending(net, model, state, grids))
    n = lin.K.shape[0]
    rigid = rigid_basis(lin, net)
    if count > n - rigid.shape[1]:
        raise ValueError(f"modes: count = {count} exceeds the {n - rigid.shape[1]} elastic modes of "
                         f"this discretisation ({n} degrees of freedom, {rigid.shape[1]} rigid)")
    omega, vecs = _solve(lin, rigid, int(count), float(sigma))
    return DiscreteModes(net, lin, omega, vecs, rigid.shape[1])


# ---------------------------------------------------------------------- output
def _mode_mesh_parts(res: DiscreteModes):
    """Static parts of a mode's VTK mesh: segments (one per element) and node vertex cells."""
    model = res.lin.model
    nv, ne, nn = res.lin.sizes
    eline = np.repeat(np.arange(len(res.net.lines)), np.diff(model.line_element_offsets))
    left = np.arange(ne) + eline
    segs = np.column_stack([left, left + 1]).astype(np.int64)
    local = np.arange(ne) - model.line_element_offsets[eline]
    vline = np.repeat(np.arange(len(res.net.lines)), np.diff(model.line_vertex_offsets))
    return segs, eline, local, vline


def write_mode_series(res: DiscreteModes, j: int, out_dir, frames: int = 16, amplitude: float | None = None):
    """Write mode j as an animated oscillation over one period: ``mode_JJ_FFF.vtu`` (lines as
    2-point segments, one per element, plus node reference points as vertex cells; point data
    "displacement" (lab, m), "line_id" (-1 on nodes); cell data "line_id", "element" (element
    index in its line, node index on node cells), "rotation" (lab rotation vector, rad)) and the
    collection ``mode_JJ.pvd``; point data "radius" (the section's, 0 on nodes) lets pictures
    draw the lines at their size. amplitude: peak translation (default 5 % of the net's size)."""
    import meshio

    from ..output.io import write_collection
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    lin = res.lin
    dx, alpha, dc, phi = res.raw(j)
    refs = np.array([n.position for n in res.net.nodes])
    R = _matrices(lin.node_q0)
    # reference point displacement: dc + (R phi) x (r - c)
    node_dx = dc + np.cross(np.einsum("nij,nj->ni", R, phi), refs - lin.node_x0)
    pts0 = np.concatenate([lin.x0, refs])
    if amplitude is None:
        amplitude = 0.05 * float(np.linalg.norm(np.ptp(pts0, axis=0)) or 1.0)
    scale = amplitude / max(res.peak_displacement(j), 1e-300)
    disp = np.concatenate([dx, node_dx]) * scale
    rot_el = np.einsum("eij,ej->ei", _matrices(lin.q0), alpha) * scale
    rot_nd = np.einsum("nij,nj->ni", R, phi) * scale
    segs, eline, local, vline = _mode_mesh_parts(res)
    nv, nn = lin.x0.shape[0], refs.shape[0]
    radius = np.concatenate([np.array([l.section_at(u).radius for u in np.linspace(0, 1, l.elements + 1)],
                                      dtype=float) for l in res.net.lines] + [np.zeros(nn)])
    verts = (nv + np.arange(nn))[:, None].astype(np.int64)
    period = 2 * math.pi / float(res.omega[j]) if res.omega[j] > 0 else 1.0
    entries = []
    for f in range(frames):
        t = period * f / frames
        s = math.sin(2 * math.pi * f / frames)
        mesh = meshio.Mesh(pts0 + s * disp, [("line", segs), ("vertex", verts)],
                           point_data={"displacement": s * disp, "radius": radius,
                                       "line_id": np.concatenate([vline, -np.ones(nn, int)]).astype(np.int32)},
                           cell_data={"line_id": [eline.astype(np.int32), -np.ones(nn, np.int32)],
                                      "element": [local.astype(np.int32), np.arange(nn, dtype=np.int32)],
                                      "rotation": [s * rot_el, s * rot_nd]})
        name = f"mode_{j:02d}_{f:03d}.vtu"
        mesh.write(out / name, file_format="vtu", binary=True)
        entries.append((t, 0, name))
    write_collection(out / f"mode_{j:02d}.pvd", entries)
    return out / f"mode_{j:02d}.pvd"


def spectrum_table(res: DiscreteModes) -> str:
    """The spectrum as text: index, omega (rad/s), frequency (Hz), strain energy shares."""
    lines = [f"{res.lin.K.shape[0]} degrees of freedom, {res.rigid_modes} rigid-body modes (not listed)",
             f"{'mode':>4} {'omega [rad/s]':>14} {'f [Hz]':>12}  stretch  shear   bend  twist"]
    for j in range(len(res)):
        sh = res.energy_shares(j)
        lines.append(f"{j:4d} {res.omega[j]:14.6g} {res.frequency[j]:12.6g}  " +
                     "  ".join(f"{sh[k]:5.3f}" for k in ("stretch", "shear", "bend", "twist")))
    return "\n".join(lines)


def main_modes(scene_or_net, count: int = 6, sigma: float = 0.0, analytic: bool = False) -> DiscreteModes:
    """The ``count`` modes of a scene (path to a TOML file, or a Scene) or a Net nearest to
    ``sigma``, as ``cosnet modes`` lists them. ``analytic``: also the exact modes of the
    continuous net (§6, straight uniform lines), kept as ``result.analytic`` (mode j of each,
    in ascending order). ``spectrum_table``, ``comparison_table`` and ``write_modes`` show
    and write the result."""
    net = scene_or_net
    if isinstance(net, (str, Path)):
        from ..scene.loader import load_scene
        net = load_scene(net)
    net = getattr(net, "net", net)          # a Scene carries its net
    res = modes(net, count=count, sigma=sigma)
    res.analytic = None
    if analytic:
        from .lincos import analytic_modes
        res.analytic = analytic_modes(net, count=len(res))
    return res


def comparison_table(res: DiscreteModes) -> str:
    """The discrete and analytic frequencies side by side, one mode a line ("" without
    analytic modes)."""
    if res.analytic is None:
        return ""
    rows = ["mode  discrete (rad/s)  analytic (rad/s)  relative difference"]
    for j, (w, we) in enumerate(zip(res.omega, res.analytic.omega)):
        rows.append(f"{j:4d}  {w:16.8g}  {we:16.8g}  {(w - we) / we:+.2e}")
    return "\n".join(rows)


def spectrum_csv(res: DiscreteModes) -> str:
    """``spectrum.csv``: mode, omega_rad_s, frequency_hz, the energy shares stretch, shear,
    bend, twist, and with analytic modes analytic_omega_rad_s, analytic_frequency_hz,
    relative_difference."""
    head = "mode,omega_rad_s,frequency_hz,stretch,shear,bend,twist"
    rows = [head + (",analytic_omega_rad_s,analytic_frequency_hz,relative_difference"
                    if res.analytic is not None else "")]
    for j in range(len(res)):
        sh = res.energy_shares(j)
        row = f"{j},{float(res.omega[j])!r},{float(res.frequency[j])!r}," + \
            ",".join(f"{sh[k]:.6g}" for k in ("stretch", "shear", "bend", "twist"))
        if res.analytic is not None:
            we = float(res.analytic.omega[j])
            row += f",{we!r},{we / (2 * math.pi)!r},{(float(res.omega[j]) - we) / we:.6e}"
        rows.append(row)
    return "\n".join(rows) + "\n"


def write_modes(res: DiscreteModes, out_dir, frames: int = 16, amplitude: float | None = None) -> Path:
    """Write ``spectrum.csv`` and each mode as a VTK series (``mode_JJ.pvd``, ``frames``
    frames over one period, see write_mode_series) into out_dir; return out_dir."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "spectrum.csv").write_text(spectrum_csv(res))
    for j in range(len(res)):
        write_mode_series(res, j, out, frames=frames, amplitude=amplitude)
    return out


def bending_omegas(sim, count: int) -> np.ndarray:
    """The lowest ``count`` bending frequencies (rad/s) of sim's nets of straight lines along
    the lab x axis: the modes whose kinetic energy is mostly sideways vertex motion (stretch
    and twist left out), one of each equal pair of a round section."""
    res = modes(sim, count=4 * count + 6)
    m, J = sim.model.vertex_mass, sim.model.element_inertia
    out: list = []
    for j, w in enumerate(res.omega):
        dx, alpha, _, _ = res.lin.split(res.lin.T @ res.vectors[:, j])
        side = float(np.sum(m[:, None] * dx[:, 1:] ** 2))
        total = float(np.sum(m[:, None] * dx ** 2) + np.sum(J * alpha ** 2))
        if side > 0.5 * total and not (out and abs(w - out[-1]) < 1e-5 * w):
            out.append(w)
    return np.array(out[:count])
