"""The net linearised about a stress-free state: the exact stiffness K and mass M of the
discrete strain energy (kernels/elastic.py), from which the normal modes (cosnet.studies.modes)
and the stable step (Simulation.stable_dt(tight=True)) are found.

    U = sum_e l_e/2 eps_e^T K_e eps_e + sum_k L_k/2 kap_k^T B_k kap_k,
    eps_e = D_e^T (x_{e+1} - x_e)/l_e - e3,   kap_k = log(D_a^T D_b)/L_k - u0_k.
At a stress-free state every eps and kap vanishes, so the terms of the Hessian holding second
derivatives of the strains multiply zero and the Hessian is exactly
    K = sum_e l_e G_e^T K_e G_e + sum_k G_k^T (B_k / L_k) G_k
with G_e = d eps_e / dq and G_k = d theta_k / dq (cosnet.studies.modes lists the coordinates).
About a strained state the same K leaves out those terms (the geometric stiffness of tension,
of the order of the strain against one).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core.net import Net
from ..core.rotations import matrix_from_quat, rotvec_from_matrix, skew
from ..kernels.layout import Model, State
from ..kernels.motion import place_line_ends
from .measure import block_of, line_strains

if TYPE_CHECKING:
    import scipy.sparse as sp

STRESS_FREE_TOL = 1e-8   # largest strain |eps| and rotation misfit |theta - L u0| (rad) accepted
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


def frame_matrices(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of quaternions q (n, 4) (w, x, y, z); n may be 0."""
    return matrix_from_quat(q) if q.shape[0] else np.zeros((0, 3, 3))


def _copy_state(state: State) -> State:
    return State(*(np.array(a, copy=True) for a in state))


@dataclass
class Linearisation:
    """K and M (reduced, CSR) of a flattened net and the map to its raw coordinates.

    Raw coordinates (length 3 nv + 3 ne + 6 nn): every vertex dx, every element alpha, every
    node dc and phi. ``T`` (raw x reduced) maps q to them; ``reduced`` (N,) lists the raw index
    of each reduced coordinate (-1: a slider's material coordinate, which has none). ``x0,
    q0, node_x0, node_q0`` are the rest state. K equals jacobian^T diag(weights) jacobian; M
    is diagonal unless the net has sliders."""

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

    def restrict(self, raw: np.ndarray) -> np.ndarray:
        """The reduced coordinates of raw vectors (rows; columns for several) whose sliders
        keep their material coordinates (rigid motions): their raw entries, 0 for s."""
        out = raw[np.maximum(self.reduced, 0)]
        out[self.reduced < 0] = 0.0
        return out

    def raw_displacement(self, state: State) -> np.ndarray:
        """Raw coordinates of ``state`` relative to the rest state (finite rotations as
        rotation vectors, body frame)."""
        dx = state.x - self.x0
        rot = lambda q0, q: rotvec_from_matrix(np.einsum("nji,njk->nik", frame_matrices(q0), frame_matrices(q)))
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
    D, R, Xp = frame_matrices(st.q), frame_matrices(st.node_q), frame_matrices(model.attach_frame)
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


def _slide(T, M, reduced, sliders, node_block):
    """(T, M, reduced) with each slider's node held on its line: the node's translation equals
    its element's, (1 - t) dx_i + t dx_{i+1}, plus the line's tangent times ds, ds a reduced
    coordinate of its own (appended). Three coordinates leave per slider, solved from those
    three equations: the node's own translation where it is free (a ring), else those of the
    element's vertex nearer it (an eyelet fixed in space: the line is held at its point).
    ``sliders``: [(node, i, t, dx/ds (3,))]; M then couples them (no longer diagonal)."""
    import scipy.sparse as sp

    for nd, i, t, dxds in sliders:
        n = T.shape[1] + 1
        T = sp.hstack([T, sp.csr_matrix((T.shape[0], 1))]).tocsr()
        M = sp.block_diag([M, sp.csr_matrix((1, 1))]).tocsr()
        node, near, far = (T[r:r + 3].toarray() for r in (3 * (node_block + nd), 3 * i, 3 * i + 3))
        c = (1.0 - t) * near + t * far - node
        c[:, n - 1] = dxds
        # the three coordinates to solve for: the node's translation, else a vertex's (its own,
        # or its node's at a line end), the nearer first; each a block of the identity in T
        own = [np.flatnonzero(np.isclose(np.abs(b).max(axis=0), 1.0)) for b in (node, near, far)]
        groups = [own[0]] + (own[1:] if t < 0.5 else own[:0:-1])
        pick = next((g for g in groups if g.size == 3 and np.linalg.cond(c[:, g]) < 1e8), None)
        if pick is None:
            raise ValueError("modes: a slider whose node and element are both held in space is not in the modes")
        rest = np.setdiff1d(np.arange(n), pick)
        Z = sp.lil_matrix((n, rest.size))
        Z[rest, np.arange(rest.size)] = 1.0
        Z[pick] = -np.linalg.solve(c[:, pick], c[:, rest])
        Z = Z.tocsr()
        T, M = (T @ Z).tocsr(), (Z.T @ M @ Z).tocsr()
        reduced = np.concatenate([reduced, [-1]])[rest]
    return T, M, reduced


def linearise(model, state: State, net: Net, hint: str = REST_HINT, joints=(),
              strained: bool = False, sliders=()) -> Linearisation:
    """Exact stiffness K and mass M of the net linearised about ``state`` (stress free, else
    ValueError ending with ``hint``; with ``strained`` any state, K then without the geometric
    stiffness of its strains). ``joints``: [(point, S)], the condensed 3x3 bending
    stiffness of each articulated end's boundary point (cosnet.effects.articulations.condensed_bending),
    which the model does not hold; each enters factored, S = U diag(s) U^T, as three strain rows
    U^T d theta of weights s. ``sliders``: [(node, i, t, dx/ds)] (cosnet.effects.sliders.places):
    each slider's node held on its line, its material coordinate a reduced coordinate (_slide)."""
    import scipy.sparse as sp

    geo = _geometry(model, state)
    if not strained:
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
    mass = np.concatenate([np.repeat(model.vertex_mass, 3), model.element_inertia.ravel(),
                           np.repeat(model.node_mass, 3), model.node_inertia.ravel()])
    M = sp.diags(mass[reduced]).tocsr()
    if sliders:
        T, M, reduced = _slide(T, M, reduced, sliders, CA)
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
    return Linearisation(K, M, T, reduced, A, W, model, st.x.copy(), st.q.copy(), st.node_x.copy(), st.node_q.copy())


DENSE_SIZE = 400   # up to this many degrees of freedom a dense solve is quicker than Lanczos


def highest_omega2(model: Model, state: State, net: Net) -> float:
    """omega^2 of the highest mode of the net linearised about ``state`` with the masses of
    ``model``: the largest eigenvalue of M^-1/2 K M^-1/2 (0 for a net with nothing to
    deform). Lanczos' Ritz value approaches it from below, so its residual bound is added:
    the value returned is not below the eigenvalue it stands for."""
    import scipy.linalg
    import scipy.sparse as sp
    from scipy.sparse.linalg import eigsh

    lin = linearise(model, state, net, strained=True)
    n = lin.K.shape[0]
    if n == 0:
        return 0.0
    s = 1.0 / np.sqrt(lin.M.diagonal())
    A = (sp.diags(s) @ lin.K @ sp.diags(s)).tocsr()
    if n <= DENSE_SIZE:
        return max(float(scipy.linalg.eigvalsh(A.toarray())[-1]), 0.0)
    start = np.random.default_rng(0).standard_normal(n)   # a fixed start: the same net, the same step
    vals, vecs = eigsh(A, k=1, which="LA", tol=1e-3, ncv=min(n, 32), v0=start)
    residual = float(np.linalg.norm(A @ vecs[:, 0] - vals[0] * vecs[:, 0]))
    return max(float(vals[0]) + residual, 0.0)
