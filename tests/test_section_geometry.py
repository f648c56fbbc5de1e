"""The 60E1 section as built (railfem.rail.profiles.uic60_modified) and the diagnosis effect
section_geometry: the outline's changes against the area and second moment a strip of the
changed thickness adds (bounds from the nominal outline's own dimensions), the
foot-flapping cut-on against a plate-strip cantilever of the foot (its own small beam model
here), the effect's contract, and (slow) a blind diagnosis of a rail with a thicker foot."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse.linalg as spl

from railfem.diagnosis import effects
from railfem.rail import meshing, profiles, waveguide, waves
from railfem.spec import RailSpec

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "blind"))
import generators as g  # noqa: E402

MM = 1e-3


def props(**kw):
    return profiles.polygon_properties(profiles.uic60_modified(**kw).outline)


def surface_z(outline_mm, y, below):
    """Heights (mm) where the vertical line at lateral position y crosses the outline's
    edges below z = ``below`` mm, ascending."""
    a, b = outline_mm, np.roll(outline_mm, -1, axis=0)
    hit = (np.minimum(a[:, 0], b[:, 0]) <= y) & (np.maximum(a[:, 0], b[:, 0]) > y)
    t = (y - a[hit, 0]) / (b[hit, 0] - a[hit, 0])
    z = a[hit, 1] + t * (b[hit, 1] - a[hit, 1])
    return np.sort(z[z < below])


# ------------------------------------------------------------------ (a) the outline


def test_nominal_and_named_outlines():
    nom = profiles.uic60()
    np.testing.assert_array_equal(profiles.uic60_modified().outline, nom.outline)
    name = profiles.modified_name(foot=2, web=-1.5)
    assert name == "60E1:foot=+2,web=-1.5,head=+0"
    np.testing.assert_array_equal(profiles.get_profile(name).outline,
                                  profiles.uic60_modified(foot=2, web=-1.5).outline)
    assert profiles.get_profile("60e1:head=1").meta == {"foot": 0.0, "web": 0.0, "head": 1.0}
    with pytest.raises(ValueError, match="foot=F,web=W,head=H"):
        profiles.get_profile("60E1:flange=2")
    with pytest.raises(ValueError, match="web change"):
        profiles.uic60_modified(web=-5)


@pytest.mark.parametrize("kw", [{"foot": -4, "web": -3, "head": 20},
                                {"foot": 10, "web": 6, "head": -10},
                                {"foot": 2, "web": 1.5, "head": 3}])
def test_outline_stays_a_valid_symmetric_section(kw):
    """At the limits the outline is still simple (RailProfile checks it) and mirror-
    symmetric; the rail is taller by the foot change and lower by the head loss."""
    pr = profiles.uic60_modified(**kw)
    assert pr.symmetric
    assert pr.height == pytest.approx(profiles.uic60().height + (kw["foot"] - kw["head"]) * MM,
                                      abs=1e-9)
    assert np.all(np.diff(profiles.half_outline(pr)[:, 1]) > -0.2)  # no fold on the half


def test_web_thickening_adds_a_strip_of_the_web_height():
    """A web thicker by dw adds dw x (height between the foot's upper surface and the
    head's underside) of area: that height, measured on the nominal outline, is 91.1 mm at
    |y| = 12 mm (where the full shift ends) and 102.6 mm at |y| = 18 mm (where the taper
    over the fillets ends): the area change must lie between dw times each (to first order
    in dw), and the second moment change between those of strips over the two spans about
    the centroid (the centroid moves by < 0.1 mm: its parallel-axis term is of second
    order)."""
    out = profiles.uic60().outline * 1e3
    p0 = props()
    dw = 1.5
    p1 = props(web=dw)
    zc = p0.centroid_z * 1e3
    bounds_a, bounds_i = [], []
    for y in (12.0, 18.0):
        z1, z2 = surface_z(out, y, 60.0)[-1], surface_z(out, y, 150.0)[-1]
        bounds_a.append(dw * (z2 - z1))
        bounds_i.append(dw * ((z2 - zc) ** 3 - (z1 - zc) ** 3) / 3)
    assert bounds_a[0] == pytest.approx(dw * 91.1, rel=0.01)
    assert bounds_a[1] == pytest.approx(dw * 102.6, rel=0.01)
    dA = (p1.area - p0.area) * 1e6
    dI = (p1.I_y - p0.I_y) * 1e12
    assert min(bounds_a) < dA < max(bounds_a)
    assert min(bounds_i) < dI < max(bounds_i)
    assert abs(p1.centroid_z - p0.centroid_z) < 0.1 * MM


def test_foot_thickening_adds_a_strip_of_the_foot_width():
    """A foot thicker by dt adds dt x its width (150 mm) of area, less the rounded tip
    corners (within 2 %); the head loss removes dh x the head's width (74.0 mm, its
    widest), less the rounding of its crown (within 10 %)."""
    p0 = props()
    width = np.ptp(profiles.uic60().outline[:, 0]) * 1e3
    assert width == pytest.approx(150.0, abs=0.01)
    dA = (props(foot=2).area - p0.area) * 1e6
    assert dA == pytest.approx(2 * width, rel=0.02)
    out = profiles.uic60().outline * 1e3
    head_width = 2 * out[out[:, 1] > profiles.UIC60_HEAD_BASE, 0].max()
    assert head_width == pytest.approx(74.0, abs=0.1)
    dA_head = (props(head=2).area - p0.area) * 1e6
    assert dA_head == pytest.approx(-2 * head_width, rel=0.10)


# ------------------------------------------------------------------ (b) the cut-on


def flapping_cut_on(foot_mm=0.0, web_mm=0.0, head_mm=0.0, h=0.01):
    """The in-plane foot-flapping cut-on (Hz): the lowest symmetric k = 0 mode with no
    axial motion (an axial, warping mode of the foot lies within 100 Hz of it) and above
    1 kHz (the rigid motions are at 0 Hz)."""
    mesh = meshing.mesh_profile(profiles.uic60_modified(foot=foot_mm, web=web_mm,
                                                        head=head_mm), h)
    guide = waveguide.assemble(mesh, RailSpec().material())
    K, M, ops = waves.real_k_mode_matrices(guide, "symmetric", 0.0)
    w2, vec = spl.eigsh(K, k=8, M=M, sigma=-(2 * np.pi * 100.0) ** 2, which="LM")
    for j in np.argsort(w2):
        f = np.sqrt(max(w2[j], 0.0)) / (2 * np.pi)
        axial = np.sum(vec[:ops.na, j] ** 2) / np.sum(vec[:, j] ** 2)
        if f > 1000.0 and axial < 0.5:
            return f
    raise AssertionError("no in-plane symmetric mode")


def cantilever_frequency(dt_mm, n=120):
    """First frequency (Hz) of the foot as a plate strip (plane strain) clamped at the
    symmetry axis (the symmetric mode has zero slope there), its thickness the nominal
    outline's foot (the part below z = 40 mm, where the web's root fillets join the
    straight web) plus dt_mm."""
    out = profiles.uic60().outline * 1e3
    E, nu, rho = 2.1e11, 0.3, 7850.0
    y = np.linspace(0.0, 75.0, n + 1)
    ym = 0.5 * (y[1:] + y[:-1])
    t = []
    for v in ym:  # the underside, then the foot's top (or the web's face, or the head)
        z = surface_z(out, v, 1e9)
        t.append(min(40.0, z[1]) - z[0])
    t = np.array(t)
    K = np.zeros((2 * n + 2,) * 2)
    M = np.zeros_like(K)
    for e in range(n):
        L = (y[e + 1] - y[e]) * MM
        th = (t[e] + dt_mm) * MM
        EI, m = E * th ** 3 / (12 * (1 - nu ** 2)), rho * th
        k = EI / L ** 3 * np.array([[12, 6 * L, -12, 6 * L],
                                    [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                                    [-12, -6 * L, 12, -6 * L],
                                    [6 * L, 2 * L * L, -6 * L, 4 * L * L]])
        mm = m * L / 420 * np.array([[156, 22 * L, 54, -13 * L],
                                     [22 * L, 4 * L * L, 13 * L, -3 * L * L],
                                     [54, 13 * L, 156, -22 * L],
                                     [-13 * L, -3 * L * L, -22 * L, 4 * L * L]])
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += k
        M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += mm
    w2 = sl.eigh(K[2:, 2:], M[2:, 2:], eigvals_only=True)
    return np.sqrt(w2[0]) / (2 * np.pi)


def test_foot_flapping_cut_on_rises_with_foot_thickness_as_a_plate():
    """A thicker foot is a stiffer flapping plate: the cut-on rises monotonically with the
    foot's thickness. Plate bending: f ~ t / L^2 for a uniform strip; for the tapered 60E1
    foot the plate-strip cantilever gives d ln f / dt = 3.0 %/mm; the WFE section's
    relative shift per mm must be within 30 % of it (it is 2.4 %/mm: the foot's root is
    not clamped, the web and the foot under it give)."""
    dts = (-2.0, 0.0, 2.0)
    f = np.array([flapping_cut_on(d) for d in dts])
    assert 4800 < f[1] < 5400  # about 5.1 kHz on 60E1
    assert np.all(np.diff(f) > 0), f
    rel = (f[2] - f[0]) / (dts[2] - dts[0]) / f[1]
    fc = [cantilever_frequency(d) for d in dts]
    rel_plate = (fc[2] - fc[0]) / (dts[2] - dts[0]) / fc[1]
    assert rel_plate == pytest.approx(0.030, abs=0.002)
    assert rel == pytest.approx(rel_plate, rel=0.3), (rel, rel_plate)
    # the web and the head move it far less per mm: the foot is the parameter to fit
    f_web = flapping_cut_on(web_mm=1.5) - flapping_cut_on(web_mm=-1.5)
    f_head = flapping_cut_on(head_mm=2.0) - flapping_cut_on(head_mm=-2.0)
    per_mm = (f[2] - f[0]) / 4
    assert abs(f_web / 3) < 0.4 * per_mm and abs(f_head / 4) < 0.2 * per_mm


# ------------------------------------------------------------------ the effect


def test_effect_contract_and_where_it_applies():
    from railfem.diagnosis.data import prepare
    from railfem.diagnosis.loop import applicable

    e = effects.get("section_geometry")
    d = e.describe()
    json.dumps(d)
    assert d["kind"] == "spec" and d["parameters"][0]["unit"] == "m"
    assert 0.0 in e.grid["foot_thickness"] and len(e.grid["foot_thickness"]) >= 3
    spec = g.truth_spec("wfe-discrete")
    out = e.apply(spec, {"foot_thickness": 0.0015})
    assert out.rail.profile == profiles.modified_name(foot=1.5)
    assert out.support == spec.support and out.rail.h == spec.rail.h
    from dataclasses import replace
    with pytest.raises(ValueError, match="60E1 outline"):
        e.apply(spec.replace(rail=replace(spec.rail, profile="rect:20x50")),
                {"foot_thickness": 0.001})
    data = prepare(g.dataset("none", 0, f=np.array([200.0, 400.0, 800.0])))
    ok, why = applicable(e, data, "timoshenko-discrete")
    assert not ok and "cross-section" in why and "WFE" in why
    assert applicable(e, data, "wfe-discrete")[0]


def test_the_effect_moves_the_wfe_prediction_near_the_cut_on():
    """The WFE model with the foot 1.5 mm thicker differs from the nominal one near the
    foot-flapping cut-on by more than 5 dB somewhere, and by less than 1 dB below 1 kHz
    (there the rail is a beam whose mass and bending stiffness grow by 3 and 5 %)."""
    from railfem import models

    e = effects.get("section_geometry")
    spec = g.truth_spec("wfe-discrete")
    f = np.array([300.0, 800.0, 5000.0, 5400.0, 5800.0])
    kw = dict(outputs=("foot",), cache=False)
    a0 = models.receptance(spec, f, [0.32], [0.3], **kw)[:, 0, 0, 0]
    a1 = models.receptance(e.apply(spec, {"foot_thickness": 0.0015}), f, [0.32], [0.3],
                           **kw)[:, 0, 0, 0]
    d = np.abs(20 * np.log10(np.abs(a1 / a0)))
    assert d[:2].max() < 1.0 and d[2:].max() > 5.0, d


# ------------------------------------------------------------------ (c) blind diagnosis


@pytest.mark.slow
def test_a_thicker_foot_is_diagnosed_as_section_geometry():
    """Data of a WFE track whose 60E1 foot is 2.5 mm thicker (the generator meshes the
    modified outline; 5 % noise), third-octave lines below 2.9 kHz and ninth-octave lines
    to 5.8 kHz (the cut-on's peak is about 100 Hz wide: third-octave lines miss it): the
    diagnosis with section_geometry and pad_frequency on wfe-discrete names
    section_geometry, with the foot change within one grid step (2 mm) of the truth and
    its 95 % interval holding it. About 2 min on one core."""
    from railfem.diagnosis.loop import diagnose
    from railfem.standards import iec61260

    f9 = iec61260.ninth_octave_grid(100.0, 6300.0)
    f = np.concatenate([f9[f9 < 2900][::3], f9[f9 >= 2900]])
    data = g.dataset("section_geometry", 0, f=f, model="wfe-discrete")
    d = diagnose(data, model="wfe-discrete", effects=("section_geometry", "pad_frequency"),
                 pairs=False, n_starts=2)
    assert d.verdict in ("explained", "partly explained")
    assert d.chosen.name == "section_geometry"
    key = ("section_geometry", "foot_thickness")
    truth = g.CASES["section_geometry"]["foot_thickness"]
    assert abs(d.chosen.grid[key] - truth) <= 0.002
    lo, hi = d.chosen.grid_profiles[key]["ci95"]
    assert lo <= truth <= hi
