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
from pathlib import Path

import numpy as np

from ..effects.articulations import condensed_bending
from ..effects.sliders import places
from ..engine.flatten import flatten
from .lincos import allowed_rigid_motions
from ..engine.linearised import REST_HINT, Linearisation, frame_matrices, linearise
from ..kernels.motion import place_line_ends
from ..core.net import Line, Net, Node

DENSE_LIMIT = 64         # below this many degrees of freedom the dense solver is used


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
    D, R = frame_matrices(lin.q0), frame_matrices(lin.node_q0)
    clamped = np.zeros(3 * (nv + ne + 2 * nn), dtype=bool)
    clamped[3 * (nv + ne):] = True            # node coordinates not among the reduced ones
    clamped[lin.reduced[lin.reduced >= 0]] = False
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
            basis.append(lin.restrict(raw) @ null)
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
        q = self.lin.restrict(self.lin.raw_displacement(sim.state))
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
    m = M.diagonal()   # M is diagonal but for sliders' couplings (engine/linearised._slide)
    # rigid modes and free joints' mechanisms make K singular: shift below zero by a tiny
    # fraction of the stiffest omega^2
    shift = sigma * sigma - 1e-9 * float(np.max(K.diagonal() / m))
    want = min(count + r, n)
    if n <= DENSE_LIMIT or want >= n - 1:
        vals, vecs = scipy.linalg.eigh(K.toarray(), M.toarray())
    else:
        vals, vecs = eigsh(K.tocsc(), k=want, M=M.tocsc(), sigma=shift, which="LM")
    if r:
        vecs = vecs / np.sqrt(np.einsum("ij,ij->j", vecs, M @ vecs))
        g = rigid.T @ (M @ rigid)
        # remove the rigid motions (the elastic modes are M-orthogonal to them); what is left of
        # a computed rigid mode is round-off
        vecs = vecs - rigid @ np.linalg.solve(g, rigid.T @ (M @ vecs))
        vecs = vecs[:, np.einsum("ij,ij->j", vecs, M @ vecs) > 0.5]
    jv = lin.jacobian @ vecs
    vals, y = scipy.linalg.eigh(jv.T @ (lin.weights[:, None] * jv), vecs.T @ (M @ vecs))
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
    if net.sheaves:   # the rim holds a vertex only while it presses there: not a linear constraint
        raise ValueError(f"modes: a net with sheaves has no linear modes (a line leaves the rim where its "
                         f"tension stops pressing it there); sheave on node {net.sheaves[0].node.name!r}")
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"modes: count must be a positive integer, got {count!r}")
    if not math.isfinite(sigma) or sigma < 0:
        raise ValueError(f"modes: sigma must be a frequency >= 0 (rad/s), got {sigma!r}")
    lin = linearise(model, state, net, hint, condensed_bending(net, model, state, grids),
                    sliders=places(net, model, state))
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
    R = frame_matrices(lin.node_q0)
    # reference point displacement: dc + (R phi) x (r - c)
    node_dx = dc + np.cross(np.einsum("nij,nj->ni", R, phi), refs - lin.node_x0)
    pts0 = np.concatenate([lin.x0, refs])
    if amplitude is None:
        amplitude = 0.05 * float(np.linalg.norm(np.ptp(pts0, axis=0)) or 1.0)
    scale = amplitude / max(res.peak_displacement(j), 1e-300)
    disp = np.concatenate([dx, node_dx]) * scale
    rot_el = np.einsum("eij,ej->ei", frame_matrices(lin.q0), alpha) * scale
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
