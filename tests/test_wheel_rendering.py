"""Wheel-mode renders: the revolved surface is where the harmonic says, and a PNG is made."""
import numpy as np
import pytest

from railfem.plotting import render as rendering
from railfem.wheelrail import wheelfe


def _ring():
    mesh = wheelfe.rectangle_mesh(0.40, 0.46, 0.0, 0.05, 2, 2)
    w = wheelfe.assemble(mesh)
    return w.nodes, w.elements


def test_revolved_points_follow_the_harmonic():
    nodes, elements = _ring()
    shape = np.zeros((len(nodes), 3))
    shape[:, 0] = 1.0  # U_r = 1: u_r = cos(2 theta)
    pts, quads, mag = rendering.revolve_mode(nodes, elements, shape, 2, n_theta=8, scale=0.01)
    r = np.hypot(pts[:, 0], pts[:, 1])
    theta = np.arctan2(pts[:, 1], pts[:, 0])
    base = np.tile(r.reshape(8, -1)[1], 8)  # theta = pi/4: cos(2 theta) = 0, undeformed
    assert np.allclose(r - base, 0.01 * np.cos(2 * theta), atol=1e-12)
    assert quads.shape[1] == 4 and quads.max() < len(pts)
    assert np.allclose(mag, np.abs(np.cos(2 * theta)))


def test_render_wheel_mode_writes_png(tmp_path):
    pytest.importorskip("pyvista")
    nodes, elements = _ring()
    shape = np.zeros((len(nodes), 3))
    shape[:, 1] = nodes[:, 0]
    path = rendering.render_wheel_mode(nodes, elements, shape, 3, tmp_path / "m.png",
                                       title="n = 3", window_size=(300, 300))
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
