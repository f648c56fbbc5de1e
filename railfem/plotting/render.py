"""Off-screen PyVista rendering of cross-section wave shapes.

The rail cross-section lies in the (y, z) plane: y lateral, z vertical (see
:mod:`railfem.conventions`). A wave shape is a complex per-node displacement
``(u_x, u_y, u_z)``; the picture shows the undeformed section in grey and the
section deformed by ``Re(u e^{i phase})`` in the plane, coloured by the
displacement magnitude ``|u| = sqrt(|u_x|^2 + |u_y|^2 + |u_z|^2)`` (so a
mainly axial wave still shows up in the colours).

PyVista (and VTK) are imported inside the functions so ``import railfem`` stays
fast. Without a ``DISPLAY`` the EGL render window is selected
(``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow``; needs Debian's ``libegl1``,
which ``scripts/setup.sh`` installs).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from ..atomic import atomic_path

log = logging.getLogger(__name__)

#: Target of the automatic scale: largest in-plane displacement / section height.
AUTO_SCALE_FRACTION = 0.15

# Split of a 6-node triangle (vertices 0,1,2; midside 3 on 0-1, 4 on 1-2, 5 on 2-0)
# into 4 counter-clockwise linear triangles.
_P2_SPLIT = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])
#: Colour-bar title of a wave shape: a mode shape has an arbitrary scale (railfem scales
#: them to unit norm), so its magnitude has no physical unit.
SHAPE_COLORBAR_TITLE = "amplitude (arb. units)"
_SCALAR_BAR = {"title": SHAPE_COLORBAR_TITLE, "color": "black", "fmt": "%.2g", "vertical": True,
               "position_x": 0.83, "position_y": 0.1, "width": 0.06, "height": 0.5,
               "title_font_size": 16, "label_font_size": 14}
# Permissions of written files: what open() would give (0666 minus the umask).
# Each edge of a 6-node triangle as (start vertex, midside node, end vertex).
_P2_EDGES = np.array([[0, 3, 1], [1, 4, 2], [2, 5, 0]])


# --------------------------------------------------------------------------- inputs
def _check_inputs(nodes, elements, displacement):
    """Validate and convert the mesh and wave shape; raise ValueError naming the fix."""
    nodes = np.asarray(nodes, dtype=float)
    if nodes.ndim != 2 or nodes.shape[1] != 2:
        raise ValueError(
            f"nodes must have shape (n, 2) holding (y, z) in metres, got {nodes.shape}; "
            "pass mesh points transposed to one row per node"
        )
    elements = np.asarray(elements)
    if elements.ndim != 2 or elements.shape[1] != 6:
        raise ValueError(
            f"elements must have shape (m, 6) (P2 triangles: 3 vertices then midside "
            f"nodes of edges 0-1, 1-2, 2-0), got {elements.shape}"
        )
    if not np.issubdtype(elements.dtype, np.integer):
        if not np.all(np.equal(np.mod(elements, 1), 0)):
            raise ValueError("elements must hold integer node indices")
        elements = elements.astype(np.int64)
    if elements.size and (elements.min() < 0 or elements.max() >= len(nodes)):
        raise ValueError(
            f"elements index nodes 0..{len(nodes) - 1} but hold values "
            f"{elements.min()}..{elements.max()}; check that nodes and elements come "
            "from the same mesh"
        )
    displacement = np.asarray(displacement)
    if displacement.shape != (len(nodes), 3):
        raise ValueError(
            f"displacement must have shape (n, 3) = ({len(nodes)}, 3) per node "
            f"(u_x, u_y, u_z), got {displacement.shape}; reshape a flat DOF vector "
            "with .reshape(-1, 3) and check it belongs to this mesh"
        )
    if not np.all(np.isfinite(displacement)):
        raise ValueError("displacement contains NaN or inf values")
    return nodes, elements.astype(np.int64, copy=False), displacement.astype(complex)


def p2_to_linear_triangles(elements: np.ndarray) -> np.ndarray:
    """Split each 6-node triangle into 4 linear triangles; returns (4m, 3) indices."""
    elements = np.asarray(elements)
    return elements[:, _P2_SPLIT].reshape(-1, 3)


def _edge_segments(elements: np.ndarray, boundary_only: bool) -> np.ndarray:
    """Segments (k, 2) along the P2 element edges (each curved edge as 2 segments)."""
    edges = elements[:, _P2_EDGES].reshape(-1, 3)  # (3m, 3): start, mid, end
    if boundary_only:
        key = np.sort(edges[:, [0, 2]], axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        edges = edges[counts[inverse.ravel()] == 1]
    else:
        key = np.sort(edges[:, [0, 2]], axis=1)
        _, first = np.unique(key, axis=0, return_index=True)
        edges = edges[np.sort(first)]
    return np.concatenate([edges[:, [0, 1]], edges[:, [1, 2]]])


def section_height(nodes: np.ndarray) -> float:
    """Vertical extent of the section (falls back to the width for a flat one)."""
    nodes = np.asarray(nodes, dtype=float)
    extent = np.ptp(nodes, axis=0)
    height = float(extent[1]) if extent[1] > 0 else float(extent.max())
    return height if height > 0 else 1.0


def auto_scale(nodes: np.ndarray, displacement: np.ndarray,
               fraction: float = AUTO_SCALE_FRACTION) -> float:
    """Scale making the largest in-plane amplitude ``fraction`` of the section height.

    The amplitude is ``sqrt(|u_y|^2 + |u_z|^2)`` (phase independent, so frames of
    an animation share one scale). Returns 0 for a purely axial shape.
    """
    displacement = np.asarray(displacement)
    amplitude = np.sqrt(np.abs(displacement[:, 1]) ** 2 + np.abs(displacement[:, 2]) ** 2)
    peak = float(amplitude.max()) if amplitude.size else 0.0
    if peak == 0.0:
        log.info("wave shape has no in-plane displacement; drawing it undeformed")
        return 0.0
    return fraction * section_height(nodes) / peak


# ------------------------------------------------------------------------- pyvista
def _import_pyvista():
    """Import pyvista set up for off-screen rendering (EGL when there is no display)."""
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import pyvista as pv
    except ImportError as exc:  # pragma: no cover - depends on the machine
        raise ImportError(
            "railfem.plotting.render needs pyvista (and libegl1 for headless use); "
            "run `bash scripts/setup.sh`"
        ) from exc
    pv.OFF_SCREEN = True
    return pv


def _points3d(y: np.ndarray, z: np.ndarray, x: float = 0.0) -> np.ndarray:
    """Place the section in the plane ``x`` of the 3D scene (camera on +x)."""
    return np.column_stack([np.full_like(y, x), y, z])


def _line_mesh(pv, points: np.ndarray, segments: np.ndarray):
    lines = np.column_stack([np.full(len(segments), 2), segments]).ravel()
    return pv.PolyData(points, lines=lines)


def _surface_mesh(pv, points: np.ndarray, triangles: np.ndarray):
    faces = np.column_stack([np.full(len(triangles), 3), triangles]).ravel()
    return pv.PolyData(points, faces=faces)


def _write_atomic(plotter, path: Path) -> None:
    """Screenshot to a temporary file beside ``path``, then move it into place."""
    with atomic_path(path) as tmp:
        plotter.screenshot(str(tmp))


def render_wave_shape(nodes, elements, displacement, path, *, title=None, scale=None,
                      phase=0.0, window_size=(800, 800),
                      colorbar_title: str = SHAPE_COLORBAR_TITLE) -> Path:
    """Render one cross-section wave shape off-screen to a PNG.

    Parameters
    ----------
    nodes : (n, 2) array
        (y, z) coordinates of the P2 nodes in metres.
    elements : (m, 6) int array
        6-node triangles: 3 vertices counter-clockwise, then the midside nodes
        of edges (0-1), (1-2), (2-0).
    displacement : (n, 3) complex array
        Per-node wave shape (u_x, u_y, u_z).
    path : str or Path
        PNG file to write (parent folders are created; written atomically).
    title : str, optional
        Text drawn at the top of the picture.
    scale : float, optional
        Deformation scale factor; by default the largest in-plane amplitude is
        drawn as 15 % of the section height.
    phase : float
        Phase (rad) of the snapshot: the drawn displacement is Re(u e^{i phase}).
    window_size : (int, int)
        Image size in pixels.
    colorbar_title : str
        Title of the colour bar of |u|, with its unit (e.g. "amplitude (m)" for a
        forced response; a mode shape has arbitrary units, the default). VTK's font has
        no '|' glyph.

    Returns
    -------
    Path of the written PNG.
    """
    nodes, elements, displacement = _check_inputs(nodes, elements, displacement)
    path = Path(path)
    if scale is None:
        scale = auto_scale(nodes, displacement)
    snapshot = np.real(displacement * np.exp(1j * phase))
    y, z = nodes[:, 0], nodes[:, 1]
    deformed = _points3d(y + scale * snapshot[:, 1], z + scale * snapshot[:, 2])
    magnitude = np.sqrt(np.sum(np.abs(displacement) ** 2, axis=1))
    log.debug("rendering %s: scale %.3g, phase %.3g, max |u| %.3g", path, scale, phase,
              magnitude.max(initial=0.0))

    pv = _import_pyvista()
    plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
    try:
        plotter.set_background("white")
        # depth layers along x (camera on +x, parallel projection): undeformed fill
        # and mesh lines behind, the coloured deformed section, then both outlines
        eps = 1e-3 * section_height(nodes)
        behind, front = _points3d(y, z, -2 * eps), _points3d(y, z, eps)
        plotter.add_mesh(_surface_mesh(pv, behind, p2_to_linear_triangles(elements)),
                         color="whitesmoke", lighting=False)
        plotter.add_mesh(_line_mesh(pv, _points3d(y, z, -eps),
                                    _edge_segments(elements, False)),
                         color="silver", line_width=1, lighting=False)
        surface = _surface_mesh(pv, deformed, p2_to_linear_triangles(elements))
        surface.point_data["|u|"] = magnitude
        plotter.add_mesh(surface, scalars="|u|", cmap="viridis", lighting=False,
                         scalar_bar_args={**_SCALAR_BAR, "title": str(colorbar_title)})
        plotter.add_mesh(_line_mesh(pv, front, _edge_segments(elements, True)),
                         color="grey", line_width=2, lighting=False)
        outline = deformed.copy()  # PolyData shares memory with `deformed`
        outline[:, 0] = 2 * eps
        plotter.add_mesh(_line_mesh(pv, outline, _edge_segments(elements, True)),
                         color="black", line_width=1, lighting=False)
        if title:
            plotter.add_text(str(title), position="upper_edge", font_size=12,
                             color="black")
        plotter.view_yz()
        plotter.enable_parallel_projection()
        plotter.reset_camera()
        plotter.camera.zoom(0.85)  # margin for the title and the colour bar
        _write_atomic(plotter, path)
    finally:
        plotter.close()
    log.info("wrote wave shape %s", path)
    return path


def _output_paths(paths_or_dir, count: int) -> list[Path]:
    if isinstance(paths_or_dir, (str, os.PathLike)):
        folder = Path(paths_or_dir)
        if folder.suffix.lower() == ".png":
            raise ValueError(
                f"paths_or_dir {folder} looks like one PNG file but {count} shapes were "
                "given; pass a folder or a list with one path per shape"
            )
        return [folder / f"wave_shape_{i:02d}.png" for i in range(count)]
    paths = [Path(p) for p in paths_or_dir]
    if len(paths) != count:
        raise ValueError(
            f"got {len(paths)} output paths for {count} shapes; pass one path per shape "
            "or a folder"
        )
    return paths


def render_wave_shapes(nodes, elements, shapes, paths_or_dir,
                       titles: Sequence[str] | None = None, **kwargs) -> list[Path]:
    """Render several wave shapes; returns the written paths.

    ``shapes`` is a sequence of (n, 3) arrays (or an (s, n, 3) array);
    ``paths_or_dir`` is a folder (files ``wave_shape_00.png``, ...) or one path
    per shape; ``titles`` gives one title per shape. Other keyword arguments go to
    :func:`render_wave_shape`.
    """
    shapes = list(shapes)
    paths = _output_paths(paths_or_dir, len(shapes))
    if titles is None:
        titles = [None] * len(shapes)
    titles = list(titles)
    if len(titles) != len(shapes):
        raise ValueError(f"got {len(titles)} titles for {len(shapes)} shapes; "
                         "pass one title per shape or titles=None")
    return [render_wave_shape(nodes, elements, shape, path, title=title, **kwargs)
            for shape, path, title in zip(shapes, paths, titles)]


# ------------------------------------------------------------------ wheel modes (3-D)
def revolve_mode(nodes, elements, shape, n: int, *, n_theta: int = 96, scale=None):
    """Points and quads of the wheel surface swept around the axle, deformed by harmonic n.

    nodes: (N, 2) (r, z) of the section's P2 nodes; elements: (m, 6) P2 triangles;
    shape: (N, 3) real (U_r, U_z, U_theta) with u_r = U_r cos(n theta), u_z = U_z cos(n
    theta), u_theta = U_theta sin(n theta). Returns (points (k, 3), quads (q, 4),
    magnitude (k,)) with x, y in the wheel plane and z along the axle; the largest
    displacement is drawn as 8 % of the wheel radius unless ``scale`` is given."""
    nodes = np.asarray(nodes, dtype=float)
    shape = np.real(np.asarray(shape))
    if shape.shape != (len(nodes), 3):
        raise ValueError(f"shape must be (n_nodes, 3) = ({len(nodes)}, 3), got {shape.shape}")
    seg = _edge_segments(np.asarray(elements, dtype=np.int64), True)  # boundary segments
    ring = np.unique(seg)
    local = {int(v): i for i, v in enumerate(ring)}
    theta = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    c, s = np.cos(n * theta), np.sin(n * theta)
    u = shape[ring]
    peak = float(np.abs(shape).max()) or 1.0
    if scale is None:
        scale = 0.08 * float(nodes[:, 0].max()) / peak
    r = nodes[ring, 0][None, :] + scale * u[None, :, 0] * c[:, None]
    z = nodes[ring, 1][None, :] + scale * u[None, :, 1] * c[:, None]
    ut = scale * u[None, :, 2] * s[:, None]
    ct, st = np.cos(theta)[:, None], np.sin(theta)[:, None]
    pts = np.stack([r * ct - ut * st, r * st + ut * ct, z], axis=-1).reshape(-1, 3)
    mag = np.sqrt((u[None, :, 0] * c[:, None]) ** 2 + (u[None, :, 1] * c[:, None]) ** 2
                  + (u[None, :, 2] * s[:, None]) ** 2).ravel()
    nr = len(ring)
    a = np.array([local[int(v)] for v in seg[:, 0]])
    b = np.array([local[int(v)] for v in seg[:, 1]])
    j = np.arange(n_theta)[:, None]
    jn = (j + 1) % n_theta
    quads = np.stack([j * nr + a, j * nr + b, jn * nr + b, jn * nr + a], axis=-1).reshape(-1, 4)
    return pts, quads, mag


def render_wheel_mode(nodes, elements, shape, n: int, path, *, title=None,
                      window_size=(800, 800), n_theta: int = 96) -> Path:
    """Render a wheel mode of harmonic n (see :func:`revolve_mode`) off-screen to a PNG."""
    pts, quads, mag = revolve_mode(nodes, elements, shape, n, n_theta=n_theta)
    path = Path(path)
    pv = _import_pyvista()
    faces = np.column_stack([np.full(len(quads), 4), quads]).ravel()
    surf = pv.PolyData(pts, faces=faces)
    surf.point_data["|u|"] = mag
    plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
    try:
        plotter.set_background("white")
        plotter.add_mesh(surf, scalars="|u|", cmap="viridis", smooth_shading=True,
                         scalar_bar_args=_SCALAR_BAR)
        if title:
            plotter.add_text(str(title), position="upper_edge", font_size=12, color="black")
        plotter.camera_position = [(1.6, -1.2, 1.4), (0.0, 0.0, 0.05), (0.0, 0.0, 1.0)]
        plotter.reset_camera()
        _write_atomic(plotter, path)
    finally:
        plotter.close()
    log.info("wrote wheel mode %s", path)
    return path
