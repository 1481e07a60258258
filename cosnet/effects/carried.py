"""The masses an effect's impulses move a wet net by: where a fluid bound before adds mass to
the lines or nodes a ring, eyelet, sheave or dashpot acts on, the kick divides by that mass,
and the effect's record shares the fluid's sampled arrays so that its impulses are the ones
that mass takes (kernels/sliding.py, kernels/sheaves.py, kernels/strain_damping.py)."""

from __future__ import annotations

import numpy as np

from ..engine.registry import Binding, carried_by
from ..kernels.fluid import INVERSE_ROW, TANGENT_ROW
from ..kernels.fluid_step import SAMPLE_NODES
from ..kernels.fluid_variants import VARIANTS
from ..kernels.layout import typed_call


def carried_rows(on: Binding, who: str, lines, nodes, weight) -> dict:
    """A constraint record's carried_* rows for ``lines`` and ``nodes`` (weight: the inverse
    mass that moves each node there, 0 where nothing does): the flags of the vertices and
    nodes a fluid bound before adds mass to, and that fluid's own sampled arrays (shared);
    empty rows where none does."""
    m = on.model
    nv, nn = m.vertex_mass.shape[0], m.node_mass.shape[0]
    found = carried_by(on, who, lines, nodes)
    if found is None:
        return dict(carried_vertex=np.zeros(nv, dtype=np.int64), carried_node=np.zeros(nn, dtype=np.int64),
                    carried=np.zeros((0, 0)), carried_node_mass=np.zeros((0, 6)))
    _, fluid, vertex, node = found
    if node.any():   # the nodes' mass matrices as the first kick will hold them (the catch and first drift read them)
        typed_call(VARIANTS.of(fluid).kernel("fluid_entry"), fluid, m, on.state, SAMPLE_NODES)
    return dict(carried_vertex=vertex.astype(np.int64), carried_node=(node & (weight > 0)).astype(np.int64),
                carried=fluid.sample, carried_node_mass=fluid.node_mass)


def node_tensor(p, nd) -> np.ndarray:
    """The inverse mass tensor (3, 3) that moves node nd by record ``p``'s impulses."""
    if p.node_weight[nd] > 0.0 and p.carried_node[nd]:
        a = p.carried_node_mass[nd]
        return np.linalg.inv(np.array([[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]]))
    return p.node_weight[nd] * np.eye(3)


def vertex_tensor(p, model, v) -> np.ndarray:
    """The inverse mass tensor (3, 3) that moves interior vertex v by record ``p``'s impulses."""
    if not p.carried_vertex[v]:
        return model.vertex_inv_mass[v] * np.eye(3)
    wn, wt = p.carried[INVERSE_ROW, v], p.carried[INVERSE_ROW + 1, v]
    t = p.carried[TANGENT_ROW:TANGENT_ROW + 3, v]
    return wn * np.eye(3) + (wt - wn) * np.outer(t, t)


def table_error(p, model, who: str) -> str | None:
    """What is wrong with record ``p``'s carried rows for ``model``, or None."""
    nv, nn = model.vertex_mass.shape[0], model.node_mass.shape[0]
    if p.carried_vertex.shape != (nv,) or p.carried_node.shape != (nn,):
        return f"{who}: carried_vertex needs one entry per vertex, carried_node one per node"
    if (p.carried_vertex.any() and (p.carried.shape[1] != nv or p.carried.shape[0] < INVERSE_ROW + 2)) or (
            p.carried_node.any() and p.carried_node_mass.shape != (nn, 6)):
        return f"{who}: carried needs the fluid's sample rows of one entry per vertex, carried_node_mass (nodes, 6)"
    return None
