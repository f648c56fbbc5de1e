"""The job behind ``railfem cache``: what the on-disk kernel cache holds, and emptying it.

The kernel cache (railfem.track.kernelcache) keeps the parameter-free kernels of the
discrete and periodic track models, one ``.npz`` file each, in ``$RAILFEM_CACHE`` (default
``~/.cache/railfem``), under a cap of ``$RAILFEM_CACHE_MAX_MB`` MB (default 2000).
"""
from __future__ import annotations

import logging
from pathlib import Path

from ..track import kernelcache

log = logging.getLogger(__name__)


def _folder(directory) -> Path:
    return Path(directory) if directory is not None else kernelcache.default_directory()


def cache_info(directory=None) -> dict:
    """{'directory', 'entries', 'bytes', 'max_bytes', 'oldest', 'newest'} of the kernel
    cache in ``directory`` (default: the one the models use); a missing folder is empty."""
    folder = _folder(directory)
    files = kernelcache.entries(folder)
    return {"directory": str(folder), "entries": len(files),
            "bytes": sum(size for _, size, _ in files), "max_bytes": kernelcache.max_bytes(),
            "size_variable": kernelcache.SIZE_VARIABLE,
            "oldest": files[0][2] if files else None, "newest": files[-1][2] if files else None}


def clear_cache(directory=None) -> dict:
    """Remove every kernel file of the cache in ``directory``: {'directory', 'removed',
    'bytes'}. Other files in the folder are left alone."""
    folder = _folder(directory)
    n, freed = kernelcache.clear(folder)
    log.info("kernel cache %s: removed %d file(s), %.1f MB", folder, n, freed / 1e6)
    return {"directory": str(folder), "removed": n, "bytes": freed}
