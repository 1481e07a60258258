"""Range and shape checks of the tables the kernels index by.

The kernels index the state by integers read from the model (CSR offsets, line ends, node
attachments) and from the effects' records (joined line ends, loaded nodes and lines, contact
segments, obstacle vertices and mesh grids, body vertices and target nodes, muscles' lines);
they do not check those on every access. These tables are built valid, but they are
writable arrays a user can reach (``sim.model``, ``sim.effect_params``), so ``table_error``
checks them, and every array's shape, before a run hands them to the kernels: a few
vectorised passes over the integer tables, nothing per step. Indices computed from
coordinates (the contact grid, an obstacle's mesh grid) are clamped or range-checked in their
kernel instead. ``table_seal`` is a key of everything ``table_error`` reads, far cheaper than
the check: a run checks again only when it changed.
"""

import numpy as np

from .kernels.checksum import weigh_words

from .kernels.bodies import BodyParams
from .kernels.contact import ContactParams
from .kernels.effects import GravityParams, LineLoadParams, NodeLoadParams
from .kernels.joints import FixedJointParams, HingeJointParams, SphericalJointParams
from .kernels.obstacles import ObstacleParams
from .kernels.active import MuscleTorqueParams
from .kernels.fluid import FluidParams
from .kernels.articulation import ArticulationParams
from .kernels.sliding import SlidingParams

QUATERNIONS = {"q", "node_q", "attach_frame", "node_principal", "rest_rotation"}
# what the rows of a model, state or loads array run over (by name or name prefix):
# 0 lines + 1, 1 vertices, 2 elements, 3 line ends, 4 nodes, 5 nodes + 1, 6 one row
ROWS = {"line_vertex_offsets": 0, "line_element_offsets": 0, "node_attach_offsets": 5, "clock": 6,
        "node_attach_list": 3, "x": 1, "v": 1, "f": 1, "q": 2, "w": 2, "tau": 2}
# arrays that may also have no rows at all (a net that does not use them)
MAY_BE_EMPTY = {"element_rest_strain"}
ROW_PREFIXES = (("vertex_", 1), ("voronoi_", 1), ("bend_", 1), ("element_", 2), ("elem_", 2),
                ("attach_", 3), ("end_", 3), ("node_", 4))


def _rows(name):
    """Return which count the rows of a model, state or loads array run over (see ROWS), or
    None for a name of unknown meaning (not checked)."""
    if name in ROWS:
        return ROWS[name]
    return next((n for prefix, n in ROW_PREFIXES if name.startswith(prefix)), None)


def _shape_error(what, record, counts):
    """Return a message if an array of record (model, state or loads) has the wrong number
    of rows, or of columns (3, or 4 for quaternions). A wrong number of dimensions or dtype
    cannot reach the memory: the kernels would not compile for it."""
    for name, a in zip(record._fields, record):
        which = _rows(name)
        if which is None:
            continue
        rows = counts[which]
        if name in MAY_BE_EMPTY and a.shape[0] == 0:
            continue
        if a.shape[0] != rows or (a.ndim == 2 and a.shape[1] != (4 if name in QUATERNIONS else 3)):
            return f"{what}.{name} has shape {a.shape}, the net needs {rows} rows"
    return None


def _index_error(where, a, n):
    """Return a message if some entry of the integer array a lies outside [0, n)."""
    if a.size and (a.min() < 0 or a.max() >= n):
        bad = a[(a < 0) | (a >= n)].flat[0]
        return f"{where} holds {bad}, outside [0, {n})"
    return None


def _offsets_error(where, o, total):
    if o[0] != 0 or o[-1] != total or np.any(np.diff(o) < 0):
        return f"{where} is not an offset table from 0 to {total}"
    return None


def model_error(model, state, loads):
    """Return what is wrong with the model's index tables or the shapes of the model, state
    and loads arrays, or None."""
    voff, eoff = model.line_vertex_offsets, model.line_element_offsets
    nl, nv, ne = voff.shape[0] - 1, model.vertex_mass.shape[0], model.element_rest_length.shape[0]
    na, nn = model.attach_node.shape[0], model.node_mass.shape[0]
    counts = (nl + 1, nv, ne, na, nn, nn + 1, 1)
    for what, record in (("model", model), ("state", state), ("loads", loads)):
        problem = _shape_error(what, record, counts)
        if problem:
            return problem
    problem = (_offsets_error("model.line_vertex_offsets", voff, nv)
               or _offsets_error("model.line_element_offsets", eoff, ne)
               or _offsets_error("model.node_attach_offsets", model.node_attach_offsets, na))
    if problem:
        return problem
    if na != 2 * nl or np.any(np.diff(voff) != np.diff(eoff) + 1) or np.any(np.diff(eoff) < 1):
        return "model: every line needs one element or more and one vertex more than elements"
    if (np.any(model.attach_vertex[0::2] != voff[:-1]) or np.any(model.attach_vertex[1::2] != voff[1:] - 1)
            or np.any(model.attach_element[0::2] != eoff[:-1]) or np.any(model.attach_element[1::2] != eoff[1:] - 1)):
        return "model: attach_vertex / attach_element do not name the lines' end vertices / elements"
    return (_index_error("model.attach_node", model.attach_node, nn)
            or _index_error("model.node_attach_list", model.node_attach_list, na))


def _joint_error(what, p, model):
    k = p.k.shape[0]
    for name, a in zip(p._fields, p):
        if a.shape[0] != k:
            return f"{what}.{name} has {a.shape[0]} rows for {k} joints"
    na = model.attach_node.shape[0]
    return _index_error(f"{what}.attach_a", p.attach_a, na) or _index_error(f"{what}.attach_b", p.attach_b, na)


def _load_error(what, p, field, table, size):
    k = table.shape[0]
    if p.force.shape != (k, 3) or p.torque.shape != (k, 3):
        return f"{what}: force and torque need one row of 3 per entry"
    if p.omega.shape != (k,) or p.phase.shape != (k,):
        return f"{what}: omega and phase need one entry per row"
    if p.values.shape != p.times.shape:
        return f"{what}: the amplitude table's times and values differ in length"
    o, m = p.table, p.times.shape[0]
    if o.shape != (k + 1,) or o[0] < 0 or o[-1] > m or np.any(np.diff(o) < 0):
        return f"{what}.table is not an offset table of {k} rows into {m} table entries"
    return _index_error(f"{what}.{field}", table, size)


def _contact_error(p, model):
    ne, nl, nn = model.element_rest_length.shape[0], model.line_vertex_offsets.shape[0] - 1, model.node_mass.shape[0]
    m, size = p.elements.shape[0], p.cursor.shape[0]
    if size < 1 or size & (size - 1) or p.bucket_start.shape != (size + 1,):
        return "contact: bucket tables must hold a power of two of buckets (and one offset more)"
    for name in ("slot_bucket", "slot_mid", "slot_reach", "slot_cell", "sorted_elem", "sorted_cell",
                 "sorted_mid", "sorted_reach"):
        if getattr(p, name).shape[0] != m:
            return f"contact.{name} has {getattr(p, name).shape[0]} rows for {m} segments"
    if p.elem_index.shape != (ne, 2) or p.elem_geom.shape != (ne, 4) or p.node_gap.shape != (nn,):
        return "contact: elem_index, elem_geom or node_gap do not match the net"
    pairs = p.pair_key.shape[1] if p.pair_key.ndim == 3 else -1
    if (p.pair_key.shape != (2, pairs, 3) or p.pair_data.shape != (2, pairs, 8)
            or p.pair_used.shape != (2, pairs) or pairs & (pairs - 1) or p.pair_state.shape != (3,)
            or p.mu_s.shape != (3,) or p.mu_k.shape != (3,) or p.dissipated.shape != (1,)):
        return "contact: the friction pair tables do not have the shapes bind gives them"
    if pairs and (p.pair_state[0] not in (0, 1) or np.any(p.pair_state[1:] < 0)
                  or np.any(2 * p.pair_state[1:] > pairs)):
        return "contact.pair_state: side must be 0 or 1 and each side hold at most half the table"
    if pairs and any(_index_error("contact.pair_used", p.pair_used[side, :p.pair_state[1 + side]], pairs)
                     for side in (0, 1)):
        return "contact.pair_used names a slot outside the pair table"
    if p.damp.shape != ((model.vertex_mass.shape[0] if p.gamma > 0 else 0), 3):
        return "contact.damp needs one row of 3 per vertex when gamma > 0"
    first = np.repeat(model.line_vertex_offsets[:-1] - model.line_element_offsets[:-1],
                      np.diff(model.line_element_offsets)) + np.arange(ne)
    if np.any(p.elem_index[:, 0] != first):
        return "contact.elem_index does not name the elements' first vertices"
    return (_index_error("contact.elements", p.elements, ne)
            or _index_error("contact.elem_index (line)", p.elem_index[:, 1], nl))


def _obstacle_error(p, model):
    nv, m, nt = model.vertex_mass.shape[0], p.verts.shape[0], p.tri.shape[0]
    shapes = {"origin": (3,), "axis": (3,), "size": (3,), "rot": (3, 3), "mu_s": (3,), "mu_k": (3,),
              "vprev": (m,), "vnext": (m,), "radius": (m,), "anchor": (m, 3), "mode": (m,),
              "dissipated": (1,), "deepest": (1,), "active": (1,), "tri": (nt, 3, 3), "tri_normal": (nt, 3),
              "grid_origin": (3,), "grid_dims": (3,), "damp": (m, 3)}
    ne = p.elems.shape[0]
    shapes.update({"elems": (ne, 2), "edata": (ne, 7), "emode": (ne,), "edamp": (ne, 2, 3)})
    for name, shape in shapes.items():
        if getattr(p, name).shape != shape:
            return f"obstacle.{name} has shape {getattr(p, name).shape}, needs {shape}"
    dims = p.grid_dims
    if np.any(dims < 0) or p.cell_start.shape != (int(np.prod(dims)) + 1,):
        return "obstacle: the triangle grid's cell_start does not have one offset per cell and one more"
    return (_index_error("obstacle.verts", p.verts, nv) or _index_error("obstacle.vprev", p.vprev, nv)
            or _index_error("obstacle.elems", p.elems.ravel(), m)
            or _index_error("obstacle.vnext", p.vnext, nv)
            or _offsets_error("obstacle.cell_start", p.cell_start, p.cell_tri.shape[0])
            or _index_error("obstacle.cell_tri", p.cell_tri, nt))


def _body_error(p, model):
    nv, nn = model.vertex_mass.shape[0], model.node_mass.shape[0]
    nl, ns, nt, ne = p.verts.shape[0], p.samples.shape[0], p.tnode.shape[0], p.elems.shape[0]
    m = nl + ns * nt + ne
    shapes = {"vrad": (nl,), "samples": (ns, 3), "srad": (ns,), "tshape": (nt,), "torigin": (nt, 3),
              "taxis": (nt, 3), "tsize": (nt, 3), "trot": (nt, 3, 3), "tbound": (nt,), "delta": (m, 3),
              "mode": (m,), "last": (1,), "dissipated": (1,), "deepest": (1,), "active": (1,), "damp": (m, 6),
              "elems": (ne, 2), "eparam": (ne, 8)}
    for name, shape in shapes.items():
        if getattr(p, name).shape != shape:
            return f"body.{name} has shape {getattr(p, name).shape}, needs {shape}"
    if not 0 <= p.node < nn:
        return f"body.node is {p.node}, outside [0, {nn})"
    bad = p.tnode[(p.tnode < -1) | (p.tnode >= nn)]
    if bad.size:
        return f"body.tnode holds {bad[0]}, outside [-1, {nn}) (-1: a static obstacle)"
    return _index_error("body.verts", p.verts, nv) or _index_error("body.elems", p.elems.ravel(), nl)
def _muscle_error(p, nl):
    m = p.lines.shape[0]
    if p.offsets.shape != (m + 1,) or p.s.shape != p.amplitude.shape:
        return "muscle torque: offsets need one entry per line and one more, s one per amplitude"
    return _index_error("muscle_torque.lines", p.lines, nl) or _offsets_error("muscle_torque.offsets", p.offsets,
                                                                              p.amplitude.shape[0])


def _fluid_error(p, model):
    nl, nn, nv = model.line_vertex_offsets.shape[0] - 1, model.node_mass.shape[0], model.vertex_mass.shape[0]
    k = p.lines.shape[0]
    rows = ("drag_n", "drag_t", "added_n", "added_t", "inertia_n", "inertia_t", "buoyancy")
    if any(getattr(p, name).shape != (k,) for name in rows):
        return f"fluid: {', '.join(rows)} need one entry per line of fluid.lines"
    if p.line_row.shape != (nl,) or p.node_skip.shape != (nn,) or p.sample.shape != (14, nv):
        return "fluid: line_row needs one entry per line, node_skip one per node, sample 14 rows of one per vertex"
    return _index_error("fluid.lines", p.lines, nl) or _index_error("fluid.line_row", p.line_row[p.line_row >= 0], k)


def _articulation_error(p, model):
    k, na = p.attach.shape[0], model.attach_node.shape[0]
    rows = [a for name, a in zip(p._fields, p) if name not in ("attach", "table_offsets", "table_angle",
                                                                  "table_torque", "last", "dissipated")]
    if any(a.shape[0] != k for a in rows) or p.last.shape != (1,) or p.dissipated.shape != (1,):
        return "joints: every table needs one row per articulated line end"
    if np.any((p.dofs < 1) | (p.dofs > 3)):
        return "joints: dofs must be 1 (hinge), 2 (universal) or 3 (ball)"
    m = p.table_angle.shape[0]
    if p.table_offsets.shape != (3 * k + 1,) or p.table_torque.shape != (m,):
        return "joints: table_offsets needs 3 entries per joint and one, table_torque one per angle"
    problem = _offsets_error("joints.table_offsets", p.table_offsets, m)
    if problem:
        return problem
    return _index_error("joints.attach", p.attach, na)


def _sliding_error(p, model):
    k, nv, nn = p.node.shape[0], model.vertex_mass.shape[0], model.node_mass.shape[0]
    vo = model.line_vertex_offsets
    if any(a.shape[0] != k for a in (p.link, p.mu_s, p.mu_k, p.damping, p.at, p.s, p.push, p.sliding)):
        return "sliders: every table needs one row per ring or eyelet"
    if p.arc.shape != (nv,) or p.node_weight.shape != (nn,) or p.dissipated.shape != (1,):
        return "sliders: arc needs one entry per vertex, node_weight one per node"
    m = p.path_lines.shape[0]
    if p.path_arc.shape != (m,) or p.path_offsets.shape != (k + 1,):
        return "sliders: path_arc needs one entry per path line, path_offsets one per slider and one"
    problem = (_index_error("sliders.node", p.node, nn) or _offsets_error("sliders.path_offsets", p.path_offsets, m)
               or _index_error("sliders.path_lines", p.path_lines, vo.shape[0] - 1))
    if problem:
        return problem
    out = (p.link < p.path_offsets[:-1]) | (p.link >= p.path_offsets[1:])
    if np.any(out):
        return f"sliders.link holds {p.link[out][0]}, outside its slider's path"
    line = p.path_lines[p.link]
    bad = (p.at < vo[line]) | (p.at > vo[line + 1] - 2)
    if np.any(bad):
        return f"sliders.at holds {p.at[bad][0]}, outside the elements of its line"
    return None


def params_error(params, model):
    """Return what is wrong with the tables of the built-in effects' records, or None
    (records of other effects are their own kernels' business)."""
    nl, nn = model.line_vertex_offsets.shape[0] - 1, model.node_mass.shape[0]
    for p in params:
        problem = None
        if isinstance(p, (SphericalJointParams, HingeJointParams, FixedJointParams)):
            problem = _joint_error(type(p).__name__, p, model)
        elif isinstance(p, NodeLoadParams):
            problem = _load_error("node load", p, "nodes", p.nodes, nn)
        elif isinstance(p, LineLoadParams):
            problem = _load_error("line load", p, "lines", p.lines, nl)
        elif isinstance(p, GravityParams) and p.g.shape != (3,):
            problem = "gravity: g needs 3 components"
        elif isinstance(p, ContactParams):
            problem = _contact_error(p, model)
        elif isinstance(p, ObstacleParams):
            problem = _obstacle_error(p, model)
        elif isinstance(p, BodyParams):
            problem = _body_error(p, model)
        elif isinstance(p, MuscleTorqueParams):
            problem = _muscle_error(p, nl)
        elif isinstance(p, FluidParams):
            problem = _fluid_error(p, model)
        elif isinstance(p, ArticulationParams):
            problem = _articulation_error(p, model)
        elif isinstance(p, SlidingParams):
            problem = _sliding_error(p, model)
        if problem:
            return problem
    return None


def table_error(model, state, loads, params):
    """Return the first problem of model_error and params_error, or None."""
    return model_error(model, state, loads) or params_error(params, model)


def table_seal(model, state, loads, params) -> tuple:
    """Return a key that changes whenever what table_error reads may have changed: the shape
    of every array of the records and a weighted sum of the entries of every integer array
    (the index tables, whatever effect declares them), which any change of one entry changes
    (kernels.checksum.weigh_words)."""
    shapes, h = [], np.uint64(0)
    for record in (model, state, loads, *params):
        for a in record:
            if not isinstance(a, np.ndarray):
                continue
            shapes.append(a.shape)
            if a.dtype.kind in "iu":
                words = a if a.dtype.itemsize == 8 else a.astype(np.int64)
                h = np.uint64(weigh_words(np.ravel(words, order="K").view(np.uint64), h))
    return int(h), tuple(shapes)
