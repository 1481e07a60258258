"""The flattened net: static model, time-varying state and per-step load accumulators.

Packing convention: every ``*_offsets`` array is a CSR offset of length n + 1 whose last entry
is the sentinel total. Per line l (n_l elements):
  vertices  line_vertex_offsets[l]  .. line_vertex_offsets[l+1]   (n_l + 1 of them)
  elements  line_element_offsets[l] .. line_element_offsets[l+1]  (n_l)
  Voronoi points share the vertex numbering: Voronoi point k of a line sits at vertex k; the
  interior ones (0 < k < n_l) join elements k-1 and k, the two boundary ones (k = 0, n_l) join
  the end element to the node's frame D(nu) X(nu, lambda) over half an element (1.3).
Each line end is an *attachment*: attachment 2 l is the start (Omega = -1), 2 l + 1 the end
(Omega = +1) (2.3). node_attach_offsets / node_attach_list give each node its attachments.

Frames: element and node quaternions rotate principal body axes to the lab. A node's state is
that of its composite rigid body (its own mass plus the lumped masses of its line ends), whose
centre of mass sits at node_com_offset from the node's reference point.

Memory order: every 2-D array (n, k) over vertices, elements or Voronoi points is stored
column-major (Fortran order), so each component runs contiguously over the items; arrays
over nodes and line ends stay row-major (their loops are not vectorised, and a node's
values then share a cache line). Kernels index [item, component] as usual; the
hot per-element loops read the transposed view [component, item], which LLVM vectorises
(SIMD over consecutive elements). ``column_major`` converts a record; the loads' scratch
arrays (elem_force, bend_left, bend_right) hold intermediate results of the internal-force
passes.
"""

import weakref
from typing import NamedTuple

import numpy as np
from numba import njit, typeof
from numba.core import types

from .compiler import CACHED_INLINE


class Model(NamedTuple):
    """Static constants of a flattened net (nl lines, nv vertices, ne elements, na = 2 nl
    attachments, nn nodes)."""

    line_vertex_offsets: np.ndarray   # (nl+1,) int64
    line_element_offsets: np.ndarray  # (nl+1,) int64
    vertex_mass: np.ndarray           # (nv,) lumped mass (end vertices: their share, carried by the node)
    vertex_inv_mass: np.ndarray       # (nv,) 1/mass, 0 for end vertices (moved by their node)
    vertex_inv_mass3: np.ndarray      # (nv, 3) the same repeated per component (uniform kick kernel)
    element_rest_length: np.ndarray   # (ne,)
    element_inv_rest_length: np.ndarray  # (ne,) 1 / rest length
    element_stiffness: np.ndarray     # (ne, 3) K = (k G A, k G A, E A), principal frame (3.23)
    element_rest_strain: np.ndarray   # (ne, 3) rest strain v0, principal frame (3.22), (0, 3) when v0 = d3
                                      # = (0, 0, 1) everywhere and stays so (no active line changes it)
    element_inertia: np.ndarray       # (ne, 3) rotary inertia rho l (I1, I2, I1 + I2) (3.4)
    element_inv_inertia: np.ndarray   # (ne, 3)
    voronoi_rest_length: np.ndarray   # (nv,) Voronoi length (half an element at the line ends)
    voronoi_inv_rest_length: np.ndarray  # (nv,) 1 / Voronoi length
    voronoi_stiffness: np.ndarray     # (nv, 3) B = (E I1, E I2, G J), principal frame (3.23)
    voronoi_rest_curvature: np.ndarray  # (nv, 3) u0, principal frame (2.27)
    attach_node: np.ndarray           # (na,) int64 node of each line end
    attach_vertex: np.ndarray         # (na,) int64 global vertex index of the line end
    attach_element: np.ndarray        # (na,) int64 global index of the end element
    attach_offset: np.ndarray         # (na, 3) line end relative to the node's centre of mass, node principal frame
    attach_frame: np.ndarray          # (na, 4) quaternion X'(nu, lambda): line-end frame in the node principal frame
    node_attach_offsets: np.ndarray   # (nn+1,) int64
    node_attach_list: np.ndarray      # (na,) int64 attachment ids grouped by node
    node_mass: np.ndarray             # (nn,) composite mass (inf: fixed position)
    node_inv_mass: np.ndarray         # (nn,)
    node_own_mass: np.ndarray         # (nn,) the node's own finite mass (0 if infinite), at its reference point
    node_inertia: np.ndarray          # (nn, 3) composite principal inertia about the centre of mass (inf: locked)
    node_inv_inertia: np.ndarray      # (nn, 3)
    node_locked: np.ndarray           # (nn, 3) 1.0 on locked (infinite-inertia) principal axes
    node_com_offset: np.ndarray       # (nn, 3) centre of mass minus reference point, node principal frame
    node_principal: np.ndarray        # (nn, 4) quaternion P: user body frame -> principal frame (D_user = D P^T)


class State(NamedTuple):
    """Time-varying state; a checkpoint is a dump of these arrays."""

    x: np.ndarray        # (nv, 3) vertex positions (line ends follow their node exactly)
    v: np.ndarray        # (nv, 3) vertex velocities
    q: np.ndarray        # (ne, 4) element director quaternions
    w: np.ndarray        # (ne, 3) element angular velocities, body (principal) frame
    node_x: np.ndarray   # (nn, 3) composite centre of mass
    node_v: np.ndarray   # (nn, 3)
    node_q: np.ndarray   # (nn, 4) node principal frame
    node_w: np.ndarray   # (nn, 3) body-frame angular velocity (0 on locked axes)
    node_hold: np.ndarray  # (nn, 3) body-frame angular momentum on locked axes (their reaction)
    clock: np.ndarray    # (1,) simulated time


class Loads(NamedTuple):
    """Per-step accumulators written by the internal-force kernel and the declared effects."""

    f: np.ndarray        # (nv, 3) vertex forces, lab frame
    tau: np.ndarray      # (ne, 3) element torques, body frame
    end_tau: np.ndarray  # (na, 3) torques on the nodes through the boundary Voronoi points, line-end frame
    node_f: np.ndarray   # (nn, 3) node forces, lab frame
    node_tau: np.ndarray  # (nn, 3) node torques about the centre of mass, lab frame
    elem_force: np.ndarray  # (ne, 3) scratch: internal force n of each element, lab frame
    bend_left: np.ndarray   # (nv, 3) scratch: torque of Voronoi point k on its left frame, body frame
    bend_right: np.ndarray  # (nv, 3) scratch: torque of Voronoi point k on its right frame, body frame


@njit(**CACHED_INLINE)
def columns(a, start=0, stop=-1):
    """Return the three component columns of rows start .. stop (default: all) of a
    column-major (n, 3) array as contiguous 1-D views, indexed from 0. LLVM vectorises loops
    over such views when they are indexed by a loop counter
    or an unsigned offset plus one (``uint``); a signed offset index does not vectorise (numba
    wraps a possibly negative index, which hides the stride from LLVM)."""
    stop = a.shape[0] if stop < 0 else stop
    return a[start:stop, 0], a[start:stop, 1], a[start:stop, 2]


@njit(**CACHED_INLINE)
def quat_columns(a, start=0, stop=-1):
    """Return the four component columns of rows start .. stop of a column-major (n, 4)
    array of quaternions, as ``columns``."""
    stop = a.shape[0] if stop < 0 else stop
    return a[start:stop, 0], a[start:stop, 1], a[start:stop, 2], a[start:stop, 3]


@njit(**CACHED_INLINE)
def uint(i):
    """Return i as an unsigned index (see ``columns``)."""
    return np.uint64(i)


ROW_MAJOR = ("node_", "attach_", "end_")   # the fields kept row-major


def column_major(record):
    """Return the record with every 2-D array over vertices, elements or Voronoi points in
    Fortran order (a copy only where needed); node and line-end arrays stay row-major."""
    def order(name, a):
        if np.ndim(a) != 2:
            return a
        if name.startswith(ROW_MAJOR):
            return np.ascontiguousarray(a)
        return np.asfortranarray(a)
    return type(record)(*(order(n, a) for n, a in zip(record._fields, record)))


def record_type(record):
    """The numba type of a Model, State or Loads record, its column-major arrays typed
    Fortran-ordered whatever their number of rows. An array of one row or none is both C- and
    F-contiguous, and numba types it C: a net whose lines have one element each, or that has no
    lines, would compile a step and every kernel in it of its own, the same code for other
    types. Only the caller that chose the type may call with it (Simulation's stepper): numba's
    dispatcher maps arguments to types by a fingerprint that sees an array's flags, not its
    shape, so this typing cannot be numba's own for these records."""
    fields = []
    for name, a in zip(record._fields, record):
        t = typeof(a)
        if (isinstance(a, np.ndarray) and a.ndim == 2 and a.flags.f_contiguous and t.layout == "C"
                and not name.startswith(ROW_MAJOR)):
            t = t.copy(layout="F")
        fields.append(t)
    return types.NamedTuple(fields, type(record))


# Set by a process that builds a simulation only to type its step (cosnet.compiling.compile_kick):
# typed_call then neither compiles nor runs anything, so that process does not wait for the
# kernels its parent compiles while building the same simulation.
TYPING_ONLY = [False]


# typed_call's entry points by (kernel, the identities of its record and array arguments),
# each with weak references to the arrays that typed it. Typing a record costs a typeof per
# array (a fluid's energy took 1.4 ms in typing, called at every test of the watch: a
# microsecond a step); a record's arrays cannot be replaced and an array's type does not
# change, so the same arrays type the same. Weak: a held entry keeps no simulation alive (a
# sweep's discarded nets are freed), and one whose arrays died no longer matches.
_ENTRIES: dict = {}
_ENTRIES_HELD = 32
_SCALARS = (bool, int, float, np.bool_, np.integer, np.floating)


def typed_call(kernel, *args):
    """Call the njit function ``kernel`` with ``args`` through its overload for the types the
    stepper gives the same records (typed_entry). Returns None without calling where
    TYPING_ONLY is set."""
    if TYPING_ONLY[0]:
        return None
    return typed_entry(kernel, *args)(*args)


def typed_entry(kernel, *args):
    """The entry point of the njit function ``kernel``'s overload for ``args`` as the stepper
    types the same records (record_type for a Model, State or Loads, numba's typeof
    otherwise), compiled or loaded if need be. Called through numba's own dispatch, a kernel
    taking a model with an empty or one-row array (a net without active lines, a single node)
    types it row-major, and every kernel it calls is compiled a second time for the step."""
    key = _identity_key(kernel, args)
    held = _ENTRIES.get(key) if key is not None else None
    if held is not None and _still(held[0], args):
        return held[1]
    sig = tuple(record_type(a) if isinstance(a, (Model, State, Loads)) else typeof(a) for a in args)
    kernel.compile(sig)
    entry = kernel.overloads[sig].entry_point
    if key is not None:
        for k in [k for k, (refs, _) in _ENTRIES.items() if not _alive(refs)]:
            del _ENTRIES[k]
        if len(_ENTRIES) >= _ENTRIES_HELD:
            del _ENTRIES[next(iter(_ENTRIES))]
        _ENTRIES[key] = (_references(args), entry)
    return entry


def _identity_key(kernel, args):
    """The key of typed_call's held entries: arrays and records (tuples of arrays and scalars)
    by identity, scalars by type (which alone decides theirs); None for anything else (typed
    at every call)."""
    key = [id(kernel)]
    for a in args:
        if isinstance(a, np.ndarray) or (isinstance(a, tuple) and
                                         all(isinstance(f, (np.ndarray, *_SCALARS)) for f in a)):
            key.append(id(a))
        elif isinstance(a, _SCALARS):
            key.append(type(a))
        else:
            return None
    return tuple(key)


def _references(args):
    """Per array argument a weak reference to it, per record one to each array field and the
    type of each other field."""
    return tuple(weakref.ref(a) if isinstance(a, np.ndarray) else
                 tuple(weakref.ref(f) if isinstance(f, np.ndarray) else type(f) for f in a)
                 for a in args if isinstance(a, (np.ndarray, tuple)))


def _still(refs, args):
    """Whether the arrays of ``args`` are the very ones ``refs`` was taken of (an identity in
    the key may have passed to a new record whose arrays are others)."""
    held = [a for a in args if isinstance(a, (np.ndarray, tuple))]
    for r, a in zip(refs, held):
        if isinstance(a, np.ndarray):
            if r() is not a:
                return False
        elif len(r) != len(a) or any((f is not x()) if isinstance(x, weakref.ref) else (type(f) is not x)
                                     for x, f in zip(r, a)):
            return False
    return True


def _alive(refs):
    return all(x() is not None for r in refs for x in (r if isinstance(r, tuple) else (r,))
               if isinstance(x, weakref.ref))


def empty_loads(model: Model) -> Loads:
    nv = model.vertex_mass.shape[0]
    ne = model.element_rest_length.shape[0]
    na = model.attach_node.shape[0]
    nn = model.node_mass.shape[0]
    def z(n):
        return np.zeros((n, 3))
    return column_major(Loads(z(nv), z(ne), z(na), z(nn), z(nn), z(ne), z(nv), z(nv)))
