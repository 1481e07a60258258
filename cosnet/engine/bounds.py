"""Range and shape checks of the tables the kernels index by.

The kernels index the state by integers read from the model (CSR offsets, line ends, node
attachments) and from the effects' records (each effect checks its own: Effect.table_error);
they do not check those on every access. These tables are built valid, but they are
writable arrays a user can reach (``sim.model``, ``sim.effect_params``), so ``table_error``
checks them, and every array's shape, before a run hands them to the kernels: a few
vectorised passes over the integer tables, nothing per step. Indices computed from
coordinates (the contact grid, an obstacle's mesh grid) are clamped or range-checked in their
kernel instead. ``table_seal`` is a key of everything ``table_error`` reads, far cheaper than
the check: a run checks again only when it changed.
"""

import numpy as np

from ..kernels.checksum import weigh_words


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


def index_error(where, a, n):
    """Return a message if some entry of the integer array a lies outside [0, n)."""
    if a.size and (a.min() < 0 or a.max() >= n):
        bad = a[(a < 0) | (a >= n)].flat[0]
        return f"{where} holds {bad}, outside [0, {n})"
    return None


def offsets_error(where, o, total):
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
    problem = (offsets_error("model.line_vertex_offsets", voff, nv)
               or offsets_error("model.line_element_offsets", eoff, ne)
               or offsets_error("model.node_attach_offsets", model.node_attach_offsets, na))
    if problem:
        return problem
    if na != 2 * nl or np.any(np.diff(voff) != np.diff(eoff) + 1) or np.any(np.diff(eoff) < 1):
        return "model: every line needs one element or more and one vertex more than elements"
    if (np.any(model.attach_vertex[0::2] != voff[:-1]) or np.any(model.attach_vertex[1::2] != voff[1:] - 1)
            or np.any(model.attach_element[0::2] != eoff[:-1]) or np.any(model.attach_element[1::2] != eoff[1:] - 1)):
        return "model: attach_vertex / attach_element do not name the lines' end vertices / elements"
    return (index_error("model.attach_node", model.attach_node, nn)
            or index_error("model.node_attach_list", model.node_attach_list, na))


def params_error(params, model, classes):
    """Return what is wrong with the tables of the effects' records, or None: each record
    ``params[i]`` is checked by its effect's declaration ``classes[i].table_error``."""
    for cls, p in zip(classes, params):
        problem = cls.table_error(p, model)
        if problem:
            return problem
    return None

def table_error(model, state, loads, params, classes):
    """Return the first problem of model_error and params_error, or None."""
    return model_error(model, state, loads) or params_error(params, model, classes)


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
