"""Atomic file writes: a temporary file in the target folder, then ``os.replace``.

An interrupted write never leaves a truncated file under the final name, and readers never
see a half-written one. Used for job outputs (text) and for the kernel cache (binary).
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

# Permissions of written files: what open() would give (0666 minus the umask).
_UMASK = os.umask(0)
os.umask(_UMASK)
FILE_MODE = 0o666 & ~_UMASK


def write_atomic(path, write, *, binary: bool = False) -> Path:
    """Call ``write(fh)`` on a temporary file next to ``path`` and move it into place
    (parent folders are created). ``binary`` opens the file in binary mode."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}-", dir=path.parent)
    try:
        os.chmod(tmp, FILE_MODE)  # mkstemp gives 0600; outputs get the usual mode
        with (os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", newline="")) as fh:
            write(fh)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_text_atomic(path, text: str) -> Path:
    """Write text to ``path`` atomically (parent folders are created)."""
    return write_atomic(path, lambda fh: fh.write(text))


def write_bytes_atomic(path, data: bytes) -> Path:
    """Write bytes to ``path`` atomically (parent folders are created)."""
    return write_atomic(path, lambda fh: fh.write(data), binary=True)
