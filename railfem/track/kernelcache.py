"""Content-keyed store for parameter-free kernels, in memory and on disk.

A kernel (free-rail Green's functions between pad footprints, loads and responses on a
frequency grid) depends on the rail, the geometry and the grid, never on the support
parameters. ``content_key`` hashes exactly those inputs (arrays by dtype, shape and bytes),
so a changed mesh, material, location, position or frequency gives a new key and a stale
kernel is never used. Kernels are dicts of numpy arrays; on disk one ``.npz`` per key,
written atomically (``railfem.atomic``).

The disk folder is, in order: the ``directory`` given, ``$RAILFEM_CACHE``,
``$XDG_CACHE_HOME/railfem``, ``~/.cache/railfem``. ``KernelStore(directory=False)`` keeps
kernels in memory only.

The folder is kept under a size cap (``max_bytes``, default ``$RAILFEM_CACHE_MAX_MB`` MB or
2000 MB): after each write the least recently used kernel files are removed (reading a
kernel from disk marks it used). Only kernel files (``KIND-HASH.npz``) are counted and
removed; anything else in the folder is left alone.
"""
from __future__ import annotations

import hashlib
import io
import logging
import os
import re
from collections import OrderedDict
from pathlib import Path

import numpy as np

from ..atomic import write_bytes_atomic

log = logging.getLogger(__name__)

#: Bumped whenever a kernel's content or layout changes: old cache files are then ignored.
KERNEL_FORMAT = 4  # 4: the vertical pair differences carry their own code (PAD_ROLL)

#: Environment variable bounding the on-disk cache, in MB.
SIZE_VARIABLE = "RAILFEM_CACHE_MAX_MB"
DEFAULT_MAX_MB = 2000.0
#: Names of kernel files (what content_key gives, .npz): the only files counted and removed.
KERNEL_FILE = re.compile(r"^[\w.-]+-[0-9a-f]{40}\.npz$")


def default_directory() -> Path:
    """$RAILFEM_CACHE, else $XDG_CACHE_HOME/railfem, else ~/.cache/railfem."""
    env = os.environ.get("RAILFEM_CACHE")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "railfem"


def max_bytes() -> int:
    """The cap of the on-disk cache in bytes: $RAILFEM_CACHE_MAX_MB (MB), else 2000 MB."""
    value = os.environ.get(SIZE_VARIABLE, "").strip()
    if not value:
        return int(DEFAULT_MAX_MB * 1e6)
    try:
        mb = float(value)
        if not (mb > 0 and mb < float("inf")):
            raise ValueError
    except ValueError:
        raise ValueError(f"{SIZE_VARIABLE}={value!r}: give the largest size of the kernel "
                         f"cache in MB, a number > 0 (default {DEFAULT_MAX_MB:g})") from None
    return int(mb * 1e6)


def entries(directory) -> list[tuple[Path, int, float]]:
    """(path, bytes, last use as a time stamp) of each kernel file in ``directory``, least
    recently used first; [] for a missing folder."""
    out = []
    try:
        names = os.listdir(directory)
    except (FileNotFoundError, NotADirectoryError):
        return []
    for name in names:
        if not KERNEL_FILE.match(name):
            continue
        path = Path(directory) / name
        try:
            st = path.stat()
        except OSError:  # removed meanwhile by another process
            continue
        out.append((path, st.st_size, max(st.st_mtime, st.st_atime)))
    return sorted(out, key=lambda e: e[2])


def trim(directory, limit: int, keep=()) -> list[Path]:
    """Remove the least recently used kernel files until ``directory`` holds at most
    ``limit`` bytes of them; paths in ``keep`` stay. Returns the removed paths."""
    files = entries(directory)
    total = sum(size for _, size, _ in files)
    keep = {Path(k) for k in keep}
    removed = []
    for path, size, _ in files:
        if total <= limit:
            break
        if path in keep:
            continue
        try:
            path.unlink()
        except FileNotFoundError:
            pass
        except OSError as exc:
            log.warning("cannot remove kernel cache file %s (%s)", path, exc)
            continue
        total -= size
        removed.append(path)
    if removed:
        log.info("kernel cache %s: removed %d least recently used file(s) to stay under "
                 "%.0f MB", directory, len(removed), limit / 1e6)
    return removed


def clear(directory) -> tuple[int, int]:
    """Remove every kernel file of ``directory``: (files removed, bytes freed)."""
    n = freed = 0
    for path, size, _ in entries(directory):
        try:
            path.unlink()
        except FileNotFoundError:
            continue
        n, freed = n + 1, freed + size
    return n, freed


def _feed(h, obj) -> None:
    if isinstance(obj, np.ndarray) or isinstance(obj, (np.floating, np.integer)):
        a = np.ascontiguousarray(obj)
        h.update(f"A{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    elif isinstance(obj, (tuple, list)):
        h.update(f"T{len(obj)}(".encode())
        for x in obj:
            _feed(h, x)
        h.update(b")")
    elif isinstance(obj, dict):
        _feed(h, sorted(obj.items()))
    elif obj is None or isinstance(obj, (bool, int, float, complex, str)):
        h.update(f"{type(obj).__name__}:{obj!r};".encode())
    else:
        raise TypeError(f"cannot hash {type(obj).__name__} into a kernel key")


def content_key(kind: str, *parts) -> str:
    """Hex SHA-256 of ``kind``, KERNEL_FORMAT and the parts (arrays, numbers, strings,
    nested tuples/lists/dicts)."""
    h = hashlib.sha256()
    _feed(h, (kind, KERNEL_FORMAT, parts))
    return f"{kind}-{h.hexdigest()[:40]}"


class KernelStore:
    """Kernels by key: an in-memory LRU of ``max_items`` and an optional disk folder.

    directory: a folder, None for ``default_directory()``, or False for memory only.
    max_bytes: cap of the disk folder's kernel files (bytes); None for ``max_bytes()``
    ($RAILFEM_CACHE_MAX_MB, read at each write).
    """

    def __init__(self, directory=None, max_items: int = 8, max_bytes: int | None = None):
        self.directory = None if directory is False else Path(directory or default_directory())
        self.max_items = int(max_items)
        if max_bytes is not None and not max_bytes > 0:
            raise ValueError(f"KernelStore.max_bytes = {max_bytes!r}: give a size in bytes > 0")
        self.max_bytes = max_bytes
        self._memory: OrderedDict[str, dict] = OrderedDict()

    def _path(self, key: str) -> Path:
        return self.directory / f"{key}.npz"

    def get(self, key: str) -> dict | None:
        if key in self._memory:
            self._memory.move_to_end(key)
            return self._memory[key]
        if self.directory is None:
            return None
        path = self._path(key)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except (OSError, ValueError, EOFError) as exc:  # a damaged file is recomputed
            log.warning("ignoring unreadable kernel cache file %s (%s)", path, exc)
            return None
        log.debug("kernel %s read from %s", key, path)
        try:
            os.utime(path)  # used now: the last to go when the folder is trimmed
        except OSError:
            pass
        self._remember(key, arrays)
        return arrays

    def put(self, key: str, arrays: dict) -> None:
        self._remember(key, arrays)
        if self.directory is None:
            return
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        try:
            write_bytes_atomic(self._path(key), buf.getvalue())
        except OSError as exc:  # a read-only cache folder costs speed, not results
            log.warning("cannot write kernel cache %s (%s); continuing without", self.directory,
                        exc)
            return
        limit = max_bytes() if self.max_bytes is None else self.max_bytes
        trim(self.directory, limit, keep=(self._path(key),))

    def _remember(self, key: str, arrays: dict) -> None:
        self._memory[key] = arrays
        self._memory.move_to_end(key)
        while len(self._memory) > self.max_items:
            self._memory.popitem(last=False)

    def cached(self, key: str, compute) -> dict:
        """The kernel stored under ``key``, or ``compute()`` stored and returned."""
        hit = self.get(key)
        if hit is not None:
            return hit
        arrays = compute()
        self.put(key, arrays)
        return arrays


def resolve(cache) -> KernelStore:
    """A KernelStore from a door's ``cache`` argument: a KernelStore; a folder (one shared
    store per folder); True or None for the default folder; False for the shared memory-only
    store (nothing read from or written to disk)."""
    if isinstance(cache, KernelStore):
        return cache
    if cache is False:
        return _MEMORY_ONLY
    directory = default_directory() if cache is None or cache is True else Path(cache)
    if directory not in _STORES:
        _STORES[directory] = KernelStore(directory=directory)
    return _STORES[directory]


_STORES: dict[Path, KernelStore] = {}  # one shared store (and memory) per folder
_MEMORY_ONLY = KernelStore(directory=False)


# ------------------------------------------------------------------ eigen-decompositions

#: Eigen-decompositions of a kernel's coupling kept in memory (bytes): the eigen form of
#: the coupling (railfem.identify.spectral) and the Woodbury form (railfem.track.woodbury)
#: of kernels with the same springs (a record's own kernel, the kernels of its shifted
#: geometries, the Woodbury form) decompose the same matrices.
EIGEN_BYTES = 320e6
_EIGEN: OrderedDict[str, list] = OrderedDict()  # key -> [hits, value, bytes]


def eigen_key(kernel, weight, parts) -> str:
    """Key of the matrices diag(w_R) (alpha_RR + c alpha_RJ) of ``kernel`` (its spring-spring
    receptances at every frequency) per part (R rows, J the mirror rows or None, c the
    mirror's coefficients or None), w = ``weight``: equal keys, equal matrices."""
    h = hashlib.sha256()
    _feed(h, ("eigen", KERNEL_FORMAT, np.asarray(kernel.frequency), kernel.ss,
              np.asarray(kernel.ss_index), np.asarray(weight, dtype=float),
              [(np.asarray(r), None if j is None else np.asarray(j),
                None if c is None else np.asarray(c, dtype=float)) for r, j, c in parts]))
    return h.hexdigest()[:40]


def eigen_get(key: str):
    """The value stored under ``key`` (marked used), or None."""
    hit = _EIGEN.get(key)
    if hit is None:
        return None
    hit[0] += 1
    _EIGEN.move_to_end(key)
    return hit[1]


def eigen_put(key: str, value: list) -> None:
    """Keep ``value`` ([per frequency [per part (eigenvalues, eigenvectors)]]) under
    ``key`` within EIGEN_BYTES: those never asked for again go first, then the least
    recently used."""
    size = sum(a.nbytes for per_f in value for pair in per_f for a in pair)
    if size > EIGEN_BYTES:
        return
    _EIGEN[key] = [0, value, size]
    total = sum(e[2] for e in _EIGEN.values())
    while total > EIGEN_BYTES:
        unused = [k for k, e in _EIGEN.items() if e[0] == 0 and k != key]
        drop = unused[0] if unused else next(iter(_EIGEN))
        total -= _EIGEN.pop(drop)[2]
