"""Any section mesh in: mesh files read with meshio (railfem.rail.meshing.read_mesh).

The files are written here by other tools than railfem's mesher: the Gmsh API directly
(a 6-node mesh of an asymmetric 60E1, metres, x lateral / y vertical, .msh 2.2 and 4.1) and
meshio (railfem's own shipped mesh exported in mm with other axes). Independent answers: the
exact polygon properties of the outline, and the cut-on frequencies of the same mesh before
export (a round trip must not change them).
"""
import json

import numpy as np
import pytest

from railfem import cli
from railfem.rail import meshing
from railfem.rail import profiles
from railfem.rail import section
from railfem.rail import waveguide
from railfem.rail import waves
from railfem.io.frf_csv import read_frf_csv

SHIFT = 0.3e-3  # m: the right half of the head is widened by 0.3 mm


def asymmetric_outline():
    p = profiles.uic60().outline.copy()
    p[(p[:, 1] > 0.14) & (p[:, 0] > 0.005), 0] += SHIFT
    return p


def write_gmsh_p2(path, outline, h, version):
    """Mesh a closed outline with the Gmsh API (one spline per quarter of the points,
    second order) and write it: no railfem code involved."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("user")
        tags = [gmsh.model.geo.addPoint(x, y, 0.0, h) for x, y in outline]
        n = len(tags)
        cuts = [0, n // 4, n // 2, 3 * n // 4, n]
        curves = [gmsh.model.geo.addSpline([tags[j % n] for j in range(a, b + 1)])
                  for a, b in zip(cuts[:-1], cuts[1:])]
        gmsh.model.geo.addPlaneSurface([gmsh.model.geo.addCurveLoop(curves)])
        gmsh.model.geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [1], name="rail")
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


@pytest.fixture(scope="module")
def asym_msh(tmp_path_factory):
    return write_gmsh_p2(tmp_path_factory.mktemp("msh") / "asym.msh", asymmetric_outline(),
                         0.006, 4.1)


@pytest.mark.parametrize("version", [2.2, 4.1])
def test_gmsh_file_of_an_asymmetric_rail_is_read_as_one_family(tmp_path, version):
    path = write_gmsh_p2(tmp_path / f"asym{version}.msh", asymmetric_outline(), 0.006, version)
    mesh = meshing.read_mesh(path, units="m", axes="xy")
    assert mesh.curved and mesh.elements.shape[1] == 6
    poly = profiles.polygon_properties(asymmetric_outline())
    A, cz, Iy, Iz = section.moments(mesh)
    assert A == pytest.approx(poly.area, rel=1e-3)
    assert Iy == pytest.approx(poly.I_y, rel=2e-3)
    # the frame: lateral centre of the extent at y = 0, underside at z = 0; origin kept
    out = asymmetric_outline()
    assert mesh.origin[0] == pytest.approx(0.5 * (out[:, 0].min() + out[:, 0].max()), abs=1e-6)
    assert mesh.nodes[:, 1].min() == 0.0
    g = waveguide.assemble(mesh)
    assert list(g.families) == ["full"]
    assert {"head_top", "foot_underside", "foot_sensor"} <= set(g.node_sets)
    assert g.nodes[g.node("head_top"), 1] == pytest.approx(0.172, abs=1e-3)
    # the same rail meshed by railfem (symmetric, two families) has nearly the same cut-ons:
    # the asymmetry is 0.3 mm and the meshes differ
    ref = waves.cut_on_frequencies(waveguide.assemble(meshing.get_mesh("60E1", 0.01)), 4)
    got = waves.cut_on_frequencies(g, 4)
    assert np.all(np.abs(got / ref - 1) < 0.01), (got, ref)


def test_round_trip_through_msh_in_mm_with_other_axes(tmp_path):
    """railfem's shipped mesh exported by meshio as a 6-node .msh in mm, lateral = file -y,
    vertical = file z, x = 0.5: read back, it is the same mesh (symmetry detected again) and
    gives the same cut-on frequencies."""
    import meshio

    mesh = meshing.get_mesh("60E1", 0.02)
    pts = np.column_stack([np.full(len(mesh.nodes), 500.0), -mesh.nodes[:, 0] * 1e3,
                           mesh.nodes[:, 1] * 1e3 + 7.0])
    path = tmp_path / "rail_mm.msh"
    meshio.write(path, meshio.Mesh(pts, [("triangle6", mesh.elements)]), file_format="gmsh22")
    back = meshing.read_mesh(path, units="mm", axes="-y,z")
    assert back.origin == pytest.approx((0.0, 7e-3))
    np.testing.assert_allclose(back.nodes, mesh.nodes, atol=1e-12)
    g0, g1 = waveguide.assemble(mesh), waveguide.assemble(back)
    assert set(g1.families) == {"symmetric", "antisymmetric"}
    np.testing.assert_allclose(waves.cut_on_frequencies(g1, 6),
                               waves.cut_on_frequencies(g0, 6), rtol=1e-9)


def test_linear_triangles_give_a_straight_sided_mesh(tmp_path):
    import meshio

    mesh = meshing.get_mesh("60E1", 0.02)
    path = tmp_path / "lin.msh"
    meshio.write(path, meshio.Mesh(np.column_stack([mesh.vertices, np.zeros(mesh.n_vertices)]),
                                   [("triangle", mesh.triangles)]), file_format="gmsh")
    back = meshing.read_mesh(path, units="m")
    assert not back.curved
    assert section.moments(back) == pytest.approx(section.moments(mesh.straight()), rel=1e-12)


def test_mesh_file_errors(tmp_path, asym_msh):
    with pytest.raises(FileNotFoundError, match="not found"):
        meshing.read_mesh(tmp_path / "none.msh", units="m")
    with pytest.raises(ValueError, match="units"):
        meshing.read_mesh(asym_msh, units="cm")
    with pytest.raises(ValueError, match="axes"):
        meshing.read_mesh(asym_msh, units="m", axes="xx")
    with pytest.raises(ValueError, match="not flat"):
        meshing.read_mesh(asym_msh, units="m", axes="xz")
    with pytest.raises(ValueError, match="coordinates in m\\?"):
        meshing.read_mesh(asym_msh, units="mm")  # metres read as mm: 0.17 mm high
    assert cli.main(["-q", "dispersion", "--mesh", str(asym_msh), "--frequencies", "500",
                     "--no-render", "--out", str(tmp_path / "d")]) == 2


@pytest.fixture(scope="module")
def asym_msh_coarse(tmp_path_factory):
    """The asymmetric rail at 10 mm (the commands' own test: a full-family solve costs a
    third of the 6 mm one)."""
    return write_gmsh_p2(tmp_path_factory.mktemp("msh") / "asym10.msh", asymmetric_outline(),
                         0.010, 4.1)


def test_dispersion_and_mobility_commands_on_a_user_mesh(tmp_path, asym_msh_coarse, capsys):
    asym_msh = asym_msh_coarse
    out = tmp_path / "disp"
    assert cli.main(["-q", "dispersion", "--mesh", str(asym_msh), "--mesh-units", "m",
                     "--mesh-axes", "xy", "--frequencies", "300", "2000", "--no-render",
                     "--out", str(out)]) == 0
    rows = [r for r in (out / "dispersion.csv").read_text().splitlines()
            if r and not r.startswith("#")][1:]
    fams = {r.split(",")[2] for r in rows}
    labels = {r.split(",")[3] for r in rows if r.endswith(",1") and r.startswith("300,")}
    assert fams == {"full"}
    assert {"vertical bending", "lateral bending", "torsion", "longitudinal"} <= labels
    meta = json.loads((out / "run.json").read_text())
    assert meta["families"] == ["full"] and meta["curved"]
    mob = tmp_path / "mob"
    assert cli.main(["-q", "mobility", "--free", "--mesh", str(asym_msh), "--mesh-units", "m",
                     "--freq", "100", "1000", "--x", "0", "0.6", "--out", str(mob)]) == 0
    frf = read_frf_csv(mob / "mobility.csv")
    assert np.all(np.isfinite(frf.values)) and np.all(frf.values[:, 0, 0].real > 0)  # passive


def test_node_sets_found_or_given_and_a_missing_one_is_named():
    """A round bar has no flat foot: foot_underside has a single node, foot_sensor cannot be
    found and asking for it names it and the fix; a user-given set takes its place."""
    a = -np.pi / 2 + 2 * np.pi * np.arange(400) / 400
    disc = profiles.RailProfile(name="disc", outline=np.column_stack(
        [0.03 * np.cos(a), 0.03 * (1 + np.sin(a))]))
    mesh = meshing.mesh_profile(disc, 0.01)
    g = waveguide.assemble(mesh)
    assert "foot_sensor" not in g.node_sets
    with pytest.raises(KeyError, match="'foot_sensor'.*was not found.*node_sets"):
        g.node("foot_sensor")
    g2 = waveguide.assemble(mesh, node_sets={"foot_sensor": (0.02, 0.01), "probe": [0, 1]})
    s = g2.node("foot_sensor")
    assert s in g2.node_sets["boundary"]
    assert np.hypot(*(g2.nodes[s] - [0.02, 0.01])) < 0.01
    assert list(g2.node_set("probe")) == [0, 1]
    with pytest.raises(ValueError, match="node set 'bad'"):
        waveguide.assemble(mesh, node_sets={"bad": [10**9]})
