"""The one atomic writer: every file railfem writes goes through here.

A file is written to a temporary name in its target folder and moved over the target with
``os.replace`` only when complete, so an interrupted run never leaves a truncated output.
Temporary names carry the writer's process id (``.NAME.PID.tmpSUFFIX``): a run killed
outright (SIGKILL, power loss) can leave one behind, and the next run into that folder
removes those whose process no longer exists (:func:`remove_stale_temporaries`).

:func:`prepare_output_dir` is what a job calls before computing anything: it creates the
folder, proves it is a writable folder (not a file, not read-only) and refuses to mix the
outputs of two different commands, whose ``run.json`` records would replace each other.

Inside :func:`output_scope` (the ``railfem`` command runs every job in one) a prepared
folder holds a file ``INCOMPLETE`` until the job ends: removed when it succeeds, kept when
it fails or is interrupted after writing something; a job that fails before writing
anything leaves no marker, and no folder if it created it.
"""
from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import re
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

# Permissions of written files: what open() would give (0666 minus the umask).
_UMASK = os.umask(0)
os.umask(_UMASK)
FILE_MODE = 0o666 & ~_UMASK

RUN_RECORD = "run.json"
INCOMPLETE = "INCOMPLETE"  # marker of a folder whose job has not finished (output_scope)
_SCOPES: list[dict] = []  # the active output_scope blocks: {folder: created by the job}
_TEMP = re.compile(r"^\..+\.(\d+)\.tmp[^/]*$")


def _temp_path(path: Path) -> Path:
    # the suffix is kept last so that writers choosing a format by extension still work
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


@contextlib.contextmanager
def atomic_path(path, *, mode: int | None = None):
    """Yield a temporary path next to ``path``; on success move it over ``path``.

    The caller writes the temporary file by any means (numpy, matplotlib, VTK...). If the
    block raises (or is interrupted), the temporary file is removed and ``path`` is left
    as it was. The file gets the usual permissions (0666 minus the umask) unless ``mode``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temp_path(path)
    try:
        yield tmp
        if not tmp.exists():
            raise OSError(f"nothing was written for {path}")
        os.chmod(tmp, FILE_MODE if mode is None else mode)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (parent folders are created)."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            fh.write(text)
    return Path(path)


def write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (parent folders are created)."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_atomic(path, write, *, binary: bool = False) -> Path:
    """Call ``write(fh)`` on a temporary file next to ``path`` and move it into place."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") if binary else open(tmp, "w", newline="",
                                                   encoding="utf-8") as fh:
            write(fh)
    return Path(path)


# the names the job layer has always used
write_text_atomic = write_text
write_bytes_atomic = write_bytes


def json_safe(obj):
    """A strict-JSON copy of nested dicts/lists/tuples/arrays: NaN and inf -> None, numpy
    scalars and arrays -> Python numbers and lists, dict keys -> str."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, belongs to someone else
        return True
    return True


def remove_stale_temporaries(folder) -> list[Path]:
    """Remove temporary files left in ``folder`` by railfem runs that no longer exist."""
    removed = []
    folder = Path(folder)
    if not folder.is_dir():
        return removed
    for p in folder.iterdir():
        m = _TEMP.match(p.name)
        if m and p.is_file() and not _alive(int(m.group(1))):
            p.unlink(missing_ok=True)
            removed.append(p)
    if removed:
        log.info("removed %d temporary file(s) of interrupted runs in %s", len(removed), folder)
    return removed


def prepare_output_dir(folder, command: str) -> Path:
    """Make ``folder`` ready for the outputs of ``command``, before any computing.

    Raises ValueError (naming the folder and the fix) when it is a file, cannot be written,
    or already holds the ``run.json`` of a different command.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"output folder {folder} is a file; give --out a folder path")
    created = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".railfem-write-test.{os.getpid()}.tmp"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise ValueError(f"cannot write to output folder {folder} ({exc.strerror or exc}); "
                         "give --out a folder you can write to") from None
    remove_stale_temporaries(folder)
    record = folder / RUN_RECORD
    if record.is_file():
        try:
            previous = json.loads(record.read_text(encoding="utf-8")).get("command")
        except (OSError, ValueError, AttributeError):
            previous = None
        if previous is not None and previous != command:
            raise ValueError(
                f"output folder {folder} holds the results of 'railfem {previous}' "
                f"({record}); writing 'railfem {command}' there would replace that record. "
                "Give --out another folder")
    if _SCOPES and folder.resolve() not in _SCOPES[-1]:
        write_text(folder / INCOMPLETE, f"'railfem {command}' is writing here or was "
                   "interrupted: the outputs of this folder may be partial. This file is "
                   "removed when the command finishes.\n")
        _SCOPES[-1][folder.resolve()] = created
    return folder


@contextlib.contextmanager
def output_scope():
    """Mark the output folders prepared inside the block (prepare_output_dir) with an
    ``INCOMPLETE`` file until the block ends. On success the markers go. On an exception
    (bad input, Ctrl-C, kill) a folder where the job wrote something keeps its marker; one
    where it wrote nothing loses it again, and is removed if the job created it."""
    prepared: dict[Path, bool] = {}
    _SCOPES.append(prepared)
    try:
        yield prepared
    except BaseException:
        for folder, created in prepared.items():
            _abandon(folder, created)
        raise
    else:
        for folder in prepared:
            (folder / INCOMPLETE).unlink(missing_ok=True)
    finally:
        _SCOPES.remove(prepared)


def _abandon(folder: Path, created: bool) -> None:
    """After a failed job: keep the INCOMPLETE marker if anything was written after it."""
    marker = folder / INCOMPLETE
    try:
        since = marker.stat().st_mtime_ns
        written = [p for p in folder.rglob("*") if p.is_file() and p != marker
                   and p.stat().st_mtime_ns >= since]
        if written:
            return
        marker.unlink()
        if created:
            for d in sorted((p for p in folder.rglob("*") if p.is_dir()), reverse=True):
                d.rmdir()  # only empty sub-folders; any file stops the clean-up
            folder.rmdir()
    except OSError as exc:  # leave whatever cannot be checked or removed
        log.debug("output folder %s not cleaned up: %s", folder, exc)
