"""The job behind ``railfem mesh``: a profile meshed, the mesh and its quality summary."""
from __future__ import annotations

import json
import logging
from pathlib import Path

from ..atomic import prepare_output_dir, write_text_atomic
from ..rail import meshing
from ..rail.quality import format_mesh_quality, mesh_quality
from .common import progress_logger, resolve_profile

log = logging.getLogger(__name__)

__all__ = ["run_mesh", "run_shipped_meshes"]


def run_mesh(profile, h: float, out_dir) -> dict:
    """Mesh ``profile`` at element size ``h`` (m); write <name>.npz, <name>_quality.json and
    <name>_quality.txt in ``out_dir``. Returns {'mesh', 'json', 'txt', 'quality'}."""
    prof = resolve_profile(profile)
    out = prepare_output_dir(out_dir, "mesh")
    mesh = meshing.mesh_profile(prof, h)
    npz = meshing.save_mesh(mesh, out / f"{mesh.name}.npz")
    q = mesh_quality(mesh)
    js = write_text_atomic(out / f"{mesh.name}_quality.json", json.dumps(q, indent=2) + "\n")
    txt = write_text_atomic(out / f"{mesh.name}_quality.txt", format_mesh_quality(q))
    log.info("wrote %s (%d vertices, %d triangles, %d DOFs)", npz, q["n_vertices"],
             q["n_triangles"], q["n_dofs"])
    return {"mesh": npz, "json": js, "txt": txt, "quality": q}


def run_shipped_meshes(out_dir=None, progress=None) -> list[dict]:
    """Regenerate the shipped meshes (60E1 at meshing.SHIPPED_H) in ``out_dir``
    (default: the package's railfem/data/meshes/ folder); progress is logged unless
    ``progress`` is given."""
    progress = progress or progress_logger("meshes")
    out_dir = meshing.MESH_DIR if out_dir is None else Path(out_dir)
    results = []
    for i, h in enumerate(meshing.SHIPPED_H):
        results.append(run_mesh(meshing.DEFAULT_PROFILE, h, out_dir))
        progress(i + 1, len(meshing.SHIPPED_H))
    return results
