"""Tests for railfem.plotting.render (off-screen PyVista renders of wave shapes)."""

import os

import numpy as np
import pytest

pytest.importorskip("pyvista")

from railfem.plotting import render as rendering


def rectangle_p2(width=0.07, height=0.17, nx=3, nz=6):
    """P2 triangle mesh of a rectangle: nodes (n, 2) as (y, z), elements (m, 6)."""
    gy = np.linspace(-width / 2, width / 2, 2 * nx + 1)
    gz = np.linspace(0.0, height, 2 * nz + 1)
    index = np.arange(gy.size * gz.size).reshape(gz.size, gy.size)  # [iz, iy]
    yy, zz = np.meshgrid(gy, gz)
    nodes = np.column_stack([yy.ravel(), zz.ravel()])
    elements = []
    for iz in range(0, 2 * nz, 2):
        for iy in range(0, 2 * nx, 2):
            a, b = index[iz, iy], index[iz, iy + 2]
            c, d = index[iz + 2, iy + 2], index[iz + 2, iy]
            centre = index[iz + 1, iy + 1]
            # two counter-clockwise triangles (a, b, c) and (a, c, d)
            elements.append([a, b, c, index[iz, iy + 1], index[iz + 1, iy + 2], centre])
            elements.append([a, c, d, centre, index[iz + 2, iy + 1], index[iz + 1, iy]])
    return nodes, np.array(elements)


def bending_shape(nodes):
    """Synthetic lateral bending + torsion-like wave shape (complex)."""
    y, z = nodes[:, 0], nodes[:, 1]
    u = np.zeros((len(nodes), 3), dtype=complex)
    u[:, 0] = 0.2 * y * 1j
    u[:, 1] = (z / z.max()) ** 2 * np.exp(0.3j)
    u[:, 2] = -0.5 * y / np.abs(y).max()
    return u


def read_png(path):
    import matplotlib.image as mpimg

    image = mpimg.imread(str(path))
    return image[..., :3]


def non_background_fraction(image):
    background = image[0, 0]
    differs = np.any(np.abs(image - background) > 1e-3, axis=-1)
    return differs.mean()


@pytest.fixture(scope="module")
def mesh():
    return rectangle_p2()


def test_p2_split_gives_four_ccw_triangles(mesh):
    nodes, elements = mesh
    tri = rendering.p2_to_linear_triangles(elements)
    assert tri.shape == (4 * len(elements), 3)
    p = nodes[tri]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    assert np.all(area > 0)
    assert np.isclose(area.sum(), 0.07 * 0.17)


def test_auto_scale_is_fifteen_percent_of_height(mesh):
    nodes, _ = mesh
    u = bending_shape(nodes)
    s = rendering.auto_scale(nodes, u)
    peak = np.max(np.hypot(np.abs(u[:, 1]), np.abs(u[:, 2])))
    assert np.isclose(s * peak, 0.15 * 0.17)
    assert rendering.auto_scale(nodes, np.zeros((len(nodes), 3))) == 0.0


def test_render_writes_non_blank_png(tmp_path, mesh):
    nodes, elements = mesh
    path = rendering.render_wave_shape(nodes, elements, bending_shape(nodes),
                                       tmp_path / "sub" / "shape.png",
                                       title="lateral bending", window_size=(400, 400))
    assert path == tmp_path / "sub" / "shape.png"
    assert path.exists()
    image = read_png(path)
    assert image.shape[:2] == (400, 400)
    assert image.std() > 0
    assert non_background_fraction(image) > 0.01
    # no temporary files left behind
    assert os.listdir(tmp_path / "sub") == ["shape.png"]


def test_deformed_differs_from_undeformed(tmp_path, mesh):
    nodes, elements = mesh
    u = bending_shape(nodes)
    kwargs = dict(window_size=(300, 300))
    flat = rendering.render_wave_shape(nodes, elements, u, tmp_path / "flat.png",
                                       scale=0.0, **kwargs)
    bent = rendering.render_wave_shape(nodes, elements, u, tmp_path / "bent.png", **kwargs)
    quarter = rendering.render_wave_shape(nodes, elements, u, tmp_path / "quarter.png",
                                          phase=np.pi / 2, **kwargs)
    a, b, c = read_png(flat), read_png(bent), read_png(quarter)
    assert np.mean(np.any(np.abs(a - b) > 1e-3, axis=-1)) > 0.01
    assert np.mean(np.any(np.abs(b - c) > 1e-3, axis=-1)) > 0.01


def test_render_wave_shapes_to_folder_and_paths(tmp_path, mesh):
    nodes, elements = mesh
    u = bending_shape(nodes)
    shapes = [u, u.conj(), np.roll(u, 1, axis=1)]
    paths = rendering.render_wave_shapes(nodes, elements, shapes, tmp_path / "modes",
                                         ["a", "b", "c"], window_size=(200, 200))
    assert [p.name for p in paths] == [f"wave_shape_{i:02d}.png" for i in range(3)]
    assert all(p.exists() for p in paths)
    explicit = [tmp_path / "x.png", tmp_path / "y.png"]
    out = rendering.render_wave_shapes(nodes, elements, shapes[:2], explicit, None,
                                       window_size=(200, 200))
    assert out == explicit and all(p.exists() for p in out)
    with pytest.raises(ValueError, match="output paths"):
        rendering.render_wave_shapes(nodes, elements, shapes, explicit, None)
    with pytest.raises(ValueError, match="titles"):
        rendering.render_wave_shapes(nodes, elements, shapes, tmp_path, ["only one"])


def test_bad_inputs_name_the_problem(tmp_path, mesh):
    nodes, elements = mesh
    u = bending_shape(nodes)
    with pytest.raises(ValueError, match=r"displacement must have shape \(n, 3\)"):
        rendering.render_wave_shape(nodes, elements, u[:-1], tmp_path / "x.png")
    with pytest.raises(ValueError, match="reshape"):
        rendering.render_wave_shape(nodes, elements, u.ravel(), tmp_path / "x.png")
    with pytest.raises(ValueError, match=r"nodes must have shape \(n, 2\)"):
        rendering.render_wave_shape(nodes.T, elements, u, tmp_path / "x.png")
    with pytest.raises(ValueError, match=r"elements must have shape \(m, 6\)"):
        rendering.render_wave_shape(nodes, elements[:, :3], u, tmp_path / "x.png")
    with pytest.raises(ValueError, match="same mesh"):
        rendering.render_wave_shape(nodes, elements + len(nodes), u, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
