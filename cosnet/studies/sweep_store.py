"""The store of a sweep, ``OUT/NAME.zarr``: a Zarr (format 2) directory that xarray opens,
kept whole by a manifest that only cosnet writes.

A flush of finished variants must land whole or not at all, and a store damaged from outside
(a chunk truncated or deleted) must be found and its variants run again. Zarr rewrites a
chunk in place, one file at a time, so neither holds by itself. Here every file a flush
changes is encoded (with the codecs its array's ``.zarray`` names) into a new file beside
it, ``KEY.gN``; then the manifest ``cosnet-sweep.json`` -- the sweep's variants and scene
digests, the cosnet version and creation time, which variants are written, the size and
sha256 of every file of the store, the generation N and the files of its commit -- replaces
the old one in one rename: that rename is the commit. Only then are the new files renamed
over the old. A store opened again after a crash rolls a committed generation forward (its
``KEY.gN`` still there are renamed in) and removes the new files of one never committed; a
new store is built in a hidden folder beside its place and renamed into it whole.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MANIFEST = "cosnet-sweep.json"
FORMAT = 1
PENDING = "pending"
# per-variant numbers: (variable, key of a finished variant's record, value until it has one)
SCALARS = (("steps", "steps", 0), ("dt", "dt", np.nan), ("wall_time", "wall", np.nan),
           ("compiled", "compiled", -1))
# the variables a finished variant writes besides its probes (the rest is the plan's)
RESULTS = ("frame_time", "status", "worker", *(v for v, _, _ in SCALARS))
_NEW = re.compile(r"\.g(\d+)$")


def package_version() -> str:
    """The installed cosnet's version, stamped on a store so that a resumed sweep computes
    every variant alike."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("cosnet")
    except PackageNotFoundError:    # a source tree that was never installed
        return "unknown (not installed)"


# ---------------------------------------------------------------------- files
def digest(path: Path) -> list:
    """[size, sha256] of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return [path.stat().st_size, h.hexdigest()]


def _write_file(path: Path, data: bytes):
    """Write ``data`` to ``path`` and flush it to the disk (a commit may rename it in); an
    OSError names the file (a full disk: the store's path in the one-line error)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as e:
        raise OSError(e.errno, e.strerror, str(path)) from None


def _sync_dir(path: Path):
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _write_json(path: Path, doc: dict):
    """Replace ``path`` by ``doc`` in one rename (a reader sees the old file or the new)."""
    from ..output.io import replace_atomically
    replace_atomically(path, lambda tmp: _write_file(tmp, json.dumps(doc, separators=(",", ":")).encode()))
    try:   # the rename has happened: a failed flush of the folder does not undo it
        _sync_dir(path.parent)
    except OSError:
        pass


def store_files(root: Path) -> list[str]:
    """The files of a store, as keys relative to it (the manifest and new files left out)."""
    out = []
    for dirpath, _, names in os.walk(root):
        for n in names:
            key = os.path.relpath(os.path.join(dirpath, n), root)
            if key not in (MANIFEST, MANIFEST + ".tmp") and not _NEW.search(key):
                out.append(key)
    return sorted(out)


# ---------------------------------------------------------------------- chunks
class _Array:
    """One array of the store as its ``.zarray`` describes it: where its chunks are, and
    how their bytes encode (filters, then compressor) and decode."""

    def __init__(self, root: Path, name: str):
        import numcodecs
        meta = json.loads((root / name / ".zarray").read_text())
        self.name, self.shape, self.chunks = name, tuple(meta["shape"]), tuple(meta["chunks"])
        self.dtype = np.dtype(meta["dtype"])
        self.sep = meta.get("dimension_separator") or "."
        self.filters = [numcodecs.get_codec(f) for f in meta.get("filters") or []]
        self.compressor = numcodecs.get_codec(meta["compressor"]) if meta.get("compressor") else None
        fill = meta.get("fill_value")
        self.fill = ("" if self.dtype.kind == "O" else np.nan if fill == "NaN"
                     else 0 if fill is None else fill)

    @property
    def rows(self) -> int:
        return self.chunks[0]

    def key(self, c: int) -> str:
        return f"{self.name}/" + self.sep.join([str(c)] + ["0"] * (len(self.chunks) - 1))

    def blank(self) -> np.ndarray:
        return np.full(self.chunks, self.fill, dtype=self.dtype)

    def encode(self, block: np.ndarray) -> bytes:
        data = np.ascontiguousarray(block, dtype=self.dtype)
        for f in self.filters:
            data = f.encode(data)
        if self.compressor is not None:
            data = self.compressor.encode(data)
        return bytes(data)

    def decode(self, raw: bytes) -> np.ndarray:
        data = raw
        if self.compressor is not None:
            data = self.compressor.decode(data)
        for f in reversed(self.filters):
            data = f.decode(data)
        flat = (np.asarray(data, dtype=object) if self.dtype.kind == "O"
                else np.frombuffer(data, dtype=self.dtype))
        block = self.blank()
        part = flat.reshape((-1,) + self.chunks[1:])   # an edge chunk may hold its rows only
        block[:len(part)] = part[:self.rows]
        return block

    def read(self, root: Path, c: int) -> np.ndarray:
        """Chunk ``c`` as a writable block (blank where no file was written)."""
        path = root / self.key(c)
        return self.decode(path.read_bytes()) if path.exists() else self.blank()


# ---------------------------------------------------------------------- the manifest and its checks
@dataclass
class Damage:
    """What a check found: files ({key: "missing" | "truncated" | "changed"}) and the
    written variants whose rows lie in a damaged chunk of a result variable."""

    files: dict = field(default_factory=dict)
    variants: list = field(default_factory=list)

    def __bool__(self):
        return bool(self.files)

    def line(self) -> str:
        names = ", ".join(f"{k} {why}" for k, why in sorted(self.files.items())[:4])
        more = f" and {len(self.files) - 4} more files" if len(self.files) > 4 else ""
        which = (f"variant{'s' if len(self.variants) > 1 else ''} "
                 f"{', '.join(map(str, self.variants))}" if self.variants else "no written variant")
        return f"damaged: {which} ({names}{more})"


class Store:
    """An open store (the caller holds its directory's lock). ``write`` commits finished
    variants; ``check`` compares every file against the manifest."""

    def __init__(self, root: Path, probes: list[str] | None = None):
        self.root = Path(root)
        path = self.root / MANIFEST
        try:
            self.man = json.loads(path.read_text())
            if self.man.get("format") != FORMAT:
                raise ValueError
        except (OSError, ValueError, AttributeError):
            raise ValueError(f"{self.root}: no readable {MANIFEST}: not a sweep store of this cosnet "
                             f"(or its manifest was damaged), so which variants are whole cannot be "
                             f"told; pass --overwrite to replace it") from None
        self.probes = list(self.man["probes"]) if probes is None else probes
        self.recover()
        self._arrays: dict[str, _Array] = {}

    @property
    def n(self) -> int:
        return len(self.man["variants"])

    @property
    def done(self) -> list[int]:
        return list(self.man["done"])

    def array(self, name: str) -> _Array:
        if name not in self._arrays:
            self._arrays[name] = _Array(self.root, name)
        return self._arrays[name]

    # -- crash recovery
    def recover(self):
        """Finish the manifest's commit (rename its new files in) and remove new files of a
        generation that was never committed: what a crash may have left (on opening)."""
        self._roll_forward()
        for dirpath, _, names in os.walk(self.root):
            for n in names:
                if _NEW.search(n) or n == MANIFEST + ".tmp":
                    os.unlink(os.path.join(dirpath, n))

    def _roll_forward(self):
        """Rename the new files of the manifest's commit over the old ones."""
        g = self.man["generation"]
        for key in self.man.get("commit", []):
            new = self.root / f"{key}.g{g}"
            if new.exists():
                os.replace(new, self.root / key)

    # -- writing
    def commit(self, files: dict[str, bytes], done=(), undone=()):
        """Replace the store's ``files`` {key: bytes} and mark variants ``done`` (written)
        or ``undone`` (to run again) as one commit: all of it lands or none."""
        g = self.man["generation"] + 1
        chunks = dict(self.man["chunks"])
        chunks.update({key: [len(data), hashlib.sha256(data).hexdigest()] for key, data in files.items()})
        written = (set(self.man["done"]) | set(done)) - set(undone)
        man = dict(self.man, generation=g, done=sorted(written), chunks=chunks, commit=sorted(files))
        made = []
        try:
            for key, data in files.items():
                made.append(self.root / f"{key}.g{g}")
                _write_file(made[-1], data)
            for d in {p.parent for p in made}:
                _sync_dir(d)
            _write_json(self.root / MANIFEST, man)
        except BaseException:   # a full disk, an interrupt: the commit landed whole or not at all
            if self._generation_on_disk() == g:
                self.man = man
                self._roll_forward()
            else:
                for p in made:
                    p.unlink(missing_ok=True)
            raise
        self.man = man
        self._roll_forward()   # its own files only: no walk over the whole store per flush

    def _generation_on_disk(self) -> int | None:
        try:
            return json.loads((self.root / MANIFEST).read_text()).get("generation")
        except (OSError, ValueError, AttributeError):
            return None

    def write(self, results: list):
        """Commit finished variants [(index, record)] (records of sweep.run_batch)."""
        run = sorted(dict(results).items())
        if not run:
            return
        rows = np.array([i for i, _ in run])
        nt = self.array("frame_time").shape[1]
        values: dict = {"frame_time": np.full((len(run), nt), np.nan)}
        values.update({p: np.full((len(run), nt, 3), np.nan) for p in self.probes})
        values.update({v: [] for v in RESULTS[1:]})
        for j, (_, rec) in enumerate(run):
            if "times" in rec:
                values["frame_time"][j, :len(rec["times"])] = rec["times"][:nt]
                for name, arr in rec["probes"].items():
                    values[name][j, :len(arr)] = arr[:nt]
            for var, key, blank in SCALARS:
                values[var].append(rec.get(key, blank) if "times" in rec else blank)
            values["status"].append(rec["status"])
            values["worker"].append(rec.get("worker", ""))
        self.commit(self.blocks(rows, values), done=rows.tolist())

    def blocks(self, rows: np.ndarray, values: dict) -> dict[str, bytes]:
        """The encoded chunks {key: bytes} of the variables ``values`` {name: rows' values}
        with ``rows`` replaced (the other rows of each chunk as the store holds them)."""
        files = {}
        for name, vals in values.items():
            arr = self.array(name)
            vals = np.asarray(vals, dtype=arr.dtype) if arr.dtype.kind != "O" else np.array(vals, dtype=object)
            for c in np.unique(rows // arr.rows):
                block = arr.read(self.root, int(c))
                sel = rows // arr.rows == c
                block[rows[sel] - c * arr.rows] = vals[sel]
                files[arr.key(int(c))] = arr.encode(block)
        return files

    # -- checking
    def chunk(self, key: str) -> tuple[str, int] | None:
        """(variable, chunk index) of a result variable's chunk file; None for anything else
        (metadata, coordinates, the plan's keys)."""
        name, _, last = key.rpartition("/")
        if not (name in self.probes or name in RESULTS) or last.startswith("."):
            return None
        return name, int(last.split(self.array(name).sep)[0])

    def check(self) -> Damage:
        """Every file against its size and sha256 in the manifest."""
        found = Damage()
        for key, (size, sha) in self.man["chunks"].items():
            path = self.root / key
            if not path.exists():
                found.files[key] = "missing"
                continue
            have = digest(path)
            if have != [size, sha]:
                found.files[key] = "truncated" if have[0] < size else "changed"
        found.variants = sorted(set(self._rows(found.files)) & set(self.man["done"]))
        return found

    def _rows(self, keys) -> list[int]:
        """The variants whose rows lie in the result chunks among ``keys``."""
        rows: set = set()
        for key in keys:
            if (nc := self.chunk(key)) is not None:
                r = self.array(nc[0]).rows
                rows.update(range(nc[1] * r, min((nc[1] + 1) * r, self.n)))
        return sorted(rows)

    def status(self) -> list[str]:
        """Each variant's status as the store holds it."""
        arr = self.array("status")
        out: list[str] = []
        for c in range(-(-self.n // arr.rows)):
            out += [str(s) for s in arr.read(self.root, c)]
        return out[:self.n]

    def repair(self, damage: Damage, reference: dict[str, bytes]):
        """One commit that makes the store whole again: damaged files that the plan alone
        makes (metadata, coordinates, keys) taken from ``reference`` {key: bytes} (a new
        store's files), every row of a damaged result chunk pending, and the damaged
        variants pending in every result variable, so that they run again."""
        files = {k: reference[k] for k in damage.files if self.chunk(k) is None and k in reference}
        lost = [k for k in damage.files if self.chunk(k) is not None]
        for key in lost:   # nothing of a damaged chunk is read back
            (self.root / key).unlink(missing_ok=True)
        self.forget(sorted(set(damage.variants) | set(self._rows(lost))), files)

    def forget(self, rows, files=None):
        """Commit the variants ``rows`` as pending (their results blank), with ``files``."""
        rows = np.asarray(rows, dtype=int)
        m, nt = len(rows), self.array("frame_time").shape[1]
        blank: dict = {p: np.full((m, nt, 3), np.nan) for p in self.probes}
        blank.update(frame_time=np.full((m, nt), np.nan), status=[PENDING] * m, worker=[""] * m)
        blank.update({var: [value] * m for var, _, value in SCALARS})
        self.commit({**(files or {}), **(self.blocks(rows, blank) if m else {})}, undone=rows.tolist())


# ---------------------------------------------------------------------- making and replacing stores
def hidden(store: Path, what: str) -> Path:
    """A folder beside ``store`` for a new or an old copy of it (same disk: renames are
    atomic), named after this process."""
    return store.parent / f".{store.name}.{what}-{os.getpid()}"


def tidy(store: Path):
    """Undo what a crash left beside ``store``: a new copy never renamed in is removed; an
    old copy is put back when the store itself is missing (a crash between the two renames
    of a replacement), else removed."""
    for p in sorted(store.parent.glob(f".{store.name}.new-*")):
        shutil.rmtree(p, ignore_errors=True)
    for p in sorted(store.parent.glob(f".{store.name}.old-*")):
        if not store.exists():
            os.replace(p, store)
        else:
            shutil.rmtree(p, ignore_errors=True)


def write_manifest(meta: dict, root: Path):
    """Write the first manifest of a store built at ``root``: ``meta`` (variants, probes,
    scene digests) with the cosnet version, the creation time and every file's digest."""
    _write_json(root / MANIFEST, dict(format=FORMAT, cosnet=package_version(),
                                      created=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), **meta,
                                      generation=0, done=[], commit=[],
                                      chunks={k: digest(root / k) for k in store_files(root)}))


def install(new: Path, store: Path):
    """Rename the finished store ``new`` into ``store``; an existing store is moved aside
    first and removed only once the new one is in place."""
    old = hidden(store, "old")
    if store.exists():
        os.replace(store, old)
    os.replace(new, store)
    _sync_dir(store.parent)
    shutil.rmtree(old, ignore_errors=True)


def is_store(path: Path) -> bool:
    """Whether ``path`` looks like a sweep store (its manifest, or at least a Zarr group)."""
    return (path / MANIFEST).exists() or (path / ".zgroup").exists()
