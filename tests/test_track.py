"""Supported WFE track (railfem.track.wfe) against independent answers: the Timoshenko beam
tracks of railfem.track.beams (a different model), the continuous support, truncation against
the infinite periodic solution, and the attenuation of the least-attenuated wave."""
from dataclasses import replace

import numpy as np
import pytest

from railfem.rail import meshing
from railfem.rail import mobility
from railfem.track import supports
from railfem.track import wfe as track
from railfem.rail import waveguide
from railfem.materials import Material
from railfem.standards import en15461
from railfem import models
from railfem.spec import RailSpec, preset
from railfem.rail.labels import label_waves
from railfem.rail.waves import waves_at

def track_receptance(model, tp, mesh, f, fx, rx, n_supports=131):
    """Receptance (nf, 2 [head, foot], n_rx, n_fx) through the model door (no disk cache)."""
    assert mesh.name == "60E1_h10mm"  # the presets' rail
    spec = preset(tp.name, model=model, n_supports=n_supports)
    return models.receptance(spec, f, fx, rx, cache=False)


def db(a):
    return 20 * np.log10(np.abs(a))


@pytest.fixture(scope="module")
def mesh():
    return meshing.get_mesh("60E1", 0.01)


@pytest.fixture(scope="module")
def rail(mesh):
    g = waveguide.assemble(mesh, Material.steel(0.02))
    return g, mobility.head_patch(g, 0.02), [mobility.point(g, "head_top", label="head"),
                                              mobility.point(g, "foot_sensor", label="foot")]


def test_wfe_discrete_matches_timoshenko_discrete_below_500hz(mesh):
    """Soft pads: the section's own flexibility (foot bending, web, local compliance under
    the springs) is small against the pad, so the beam and the WFE rail agree within 1 dB
    at every 1/9-octave point 50-500 Hz, over a support and at mid-span. (On stiff pads
    they do not near the rail-on-pad resonance: the WFE foot flexes; see the closing note
    of issue 4.)"""
    tp = preset("very_soft")
    f = 1000 * 10 ** (np.arange(-40, -9) / 30)
    fx, rx = np.array([0.0, 0.3]), np.array([0.0, 0.3])
    wfe = track_receptance("wfe-discrete", tp, mesh, f, fx, rx)[:, 0]
    beam = track_receptance("timoshenko-discrete", tp, mesh, f, fx, rx)[:, 0]
    assert np.abs(db(wfe / beam)).max() < 1.0


def test_discrete_tends_to_continuous_at_low_frequency(mesh):
    tp = preset("site")
    f = np.array([50.0, 63.0, 80.0])
    rx = np.array([0.3])
    disc = track_receptance("wfe-discrete", tp, mesh, f, [0.3], rx)[:, 0, 0, 0]
    cont = track_receptance("wfe-continuous", tp, mesh, f, [0.3], rx)[:, 0, 0, 0]
    assert np.abs(db(disc / cont)).max() < 0.5


def test_truncation_and_periodic_solution_agree(mesh):
    """131 supports against 261 and against infinitely many (Floquet): < 0.1 dB on the
    transfers within 30 dB of the point, < 1 % on the decay-rate sum of EN 15461 eq. (1)."""
    tp = preset("medium")
    f = np.array([100.0, 400.0, 1000.0, 2500.0])
    pos = en15461.hammer_positions(tp.spacing)
    fx, rx = 0.3 + np.where(pos == 0, 0.02, pos), np.array([0.3])
    a131 = track_receptance("wfe-discrete", tp, mesh, f, fx, rx)[:, 0, 0]
    a261 = track_receptance("wfe-discrete", tp, mesh, f, fx, rx, n_supports=261)[:, 0, 0]
    per = track_receptance("wfe-periodic", tp, mesh, f, fx, rx)[:, 0, 0]
    used = db(a261) > db(a261[:, :1]) - 30
    dx = en15461.weighted_intervals(pos)

    def decay(a):
        return 4.343 / ((np.abs(a / a[:, :1]) ** 2) @ dx)

    for model in (a131, per):
        assert np.abs(db(model / a261))[used].max() < 0.1
        assert np.abs(decay(model) / decay(a261) - 1).max() < 0.01


def test_periodic_converges_in_floquet_angles(rail):
    g, load, outs = rail
    p = preset("soft").support
    f = np.array([300.0, 1500.0])
    kw = dict(load=load, outputs=outs, force_x=[0.0, 0.3], response_x=[0.0, 3.0])
    coarse = track.periodic_receptance(g, p, 0.6, f, n_theta=128, **kw).receptance
    fine = track.periodic_receptance(g, p, 0.6, f, n_theta=1024, **kw).receptance
    mid = track.periodic_receptance(g, p, 0.6, f, n_theta=512, **kw).receptance
    assert np.abs(db(mid / fine)).max() < 0.01
    assert np.abs(db(mid / fine)).max() <= np.abs(db(coarse / fine)).max()


def test_far_field_decay_equals_least_attenuated_wave(rail):
    """Far from the load on a continuous support one wave remains: the transfer level falls
    by 20 log10(e) |Im k| = 8.686 |Im k| dB/m, with k from the supported section's own
    eigenproblem (not from the response)."""
    g, load, outs = rail
    p = preset("soft").support
    f = 800.0
    x = np.linspace(4.0, 8.0, 9)
    r = track.continuous_receptance(g, p, 0.6, [f], load=load, outputs=outs[:1], x=x)
    slope = np.polyfit(x, db(r.receptance[0, 0, :, 0]), 1)[0]
    ops = track.supported_operators(g, p, 0.6)
    w = waves_at(ops, 2 * np.pi * f, method="shift-invert", n_waves=10)
    labels = np.array(label_waves(g, ops, w))
    k = w.k[labels == "vertical bending"]
    # the longitudinal wave is even less attenuated but barely moves the head vertically
    assert -slope == pytest.approx(8.686 * np.abs(k.imag).min(), rel=0.02)


def test_head_and_foot_sensors_differ_only_at_high_frequency(mesh):
    tp = preset("site")
    f = np.array([100.0, 250.0, 500.0, 2000.0, 3150.0, 5000.0])
    a = track_receptance("wfe-discrete", tp, mesh, f, [0.32, 1.2], [0.3])[:, :, 0]
    diff = np.abs(db(a[:, 0] / a[:, 1]))
    assert diff[f <= 500].max() < 1.0
    assert diff[f >= 2000].max() > 2.0


def test_inhomogeneous_track_void_support(rail):
    """One support with almost no ballast (a hanging sleeper) needs no new code and makes
    the track softer over it at low frequency, not far away."""
    g, load, outs = rail
    p = preset("medium").support
    lay = supports.uniform_layout(p, 0.6, 41)
    void = supports.with_support(lay, 20, replace(p, kb=1e3))
    f = np.array([60.0])
    kw = dict(load=load, outputs=outs[:1], force_x=[0.0], response_x=[0.0, 9.0])
    a = track.discrete_receptance(g, lay, f, **kw).receptance[0, 0, :, 0]
    b = track.discrete_receptance(g, void, f, **kw).receptance[0, 0, :, 0]
    assert db(b[0] / a[0]) > 3.0


def test_reciprocity_of_the_supported_track(rail):
    g, load, outs = rail
    lay = supports.uniform_layout(preset("site").support, 0.6, 41)
    f = np.array([400.0, 1200.0])
    r = track.discrete_receptance(g, lay, f, load=load, outputs=[load], force_x=[0.1, 0.9],
                                  response_x=[0.1, 0.9], response_length=0.02).receptance[:, 0]
    assert np.allclose(r[:, 0, 1], r[:, 1, 0], rtol=1e-8, atol=0)


def test_point_mobility_is_passive(mesh):
    tp = preset("stiff")
    f = np.geomspace(50, 5000, 12)
    a = track_receptance("wfe-discrete", tp, mesh, f, [0.3], [0.3])[:, 0, 0, 0]
    assert np.all((1j * 2 * np.pi * f * a).real > 0)


def test_beam_section_uses_mesh_constants(mesh):
    bs = models.beam_section(RailSpec())
    assert bs.area == pytest.approx(76.70e-4, rel=5e-3)
    assert bs.I == pytest.approx(3038.3e-8, rel=5e-3)
    cat = models.beam_section(RailSpec(beam_constants="catalogue", E=2.0e11, eta=0.03))
    assert (cat.area, cat.I, cat.kappa, cat.E, cat.eta) == (76.70e-4, 3038.3e-8, 0.4, 2.0e11,
                                                            0.03)


def test_model_kinds_say_what_each_model_is_made_of():
    from railfem.spec import MODEL_KINDS, MODELS, ModelKind, model_kind

    table = {"wfe-discrete": ("wfe", "discrete"), "wfe-periodic": ("wfe", "periodic"),
             "wfe-continuous": ("wfe", "continuous"),
             "timoshenko-discrete": ("timoshenko", "discrete"),
             "timoshenko-continuous": ("timoshenko", "continuous")}
    assert MODELS == tuple(table) and set(MODEL_KINDS) == set(table)
    for name, (rail, sup) in table.items():
        k = model_kind(name)
        assert (k.name, k.rail, k.supports) == (name, rail, sup)
        assert (k.is_wfe, k.is_beam) == (rail == "wfe", rail == "timoshenko")
        assert (k.is_discrete, k.is_periodic, k.is_continuous) == (
            sup == "discrete", sup == "periodic", sup == "continuous")
        assert k.continuous.name == f"{rail}-continuous"
    spec = preset("site", model="timoshenko-discrete")
    assert spec.kind is MODEL_KINDS["timoshenko-discrete"] and spec.is_beam and not spec.is_wfe
    assert preset("site").is_wfe and not preset("site").is_beam
    with pytest.raises(ValueError, match="model = 'beam'"):
        model_kind("beam")
    with pytest.raises(ValueError, match="name"):
        ModelKind(name="wfe-discrete", rail="timoshenko", supports="discrete")
    with pytest.raises(ValueError, match="supports"):
        ModelKind(name="wfe-floating", rail="wfe", supports="floating")


def test_bad_inputs(rail):
    g, load, outs = rail
    p = preset("site").support
    lay = supports.uniform_layout(p, 0.6, 5)
    no_foot = replace(g, node_sets={**g.node_sets, "foot_underside": np.array([], int)})
    with pytest.raises(ValueError, match="rail-foot"):
        track.discrete_receptance(no_foot, lay, [100.0], load=load, outputs=outs,
                                  force_x=[0.0], response_x=[0.0])
    with pytest.raises(ValueError, match="directions = 'zq'"):  # lateral loads: test_lateral
        track.discrete_receptance(g, lay, [100.0], load=load, outputs=outs,
                                  force_x=[0.0], response_x=[0.0], directions="zq")
    with pytest.raises(ValueError, match="force_x"):
        track.discrete_receptance(g, lay, [100.0], load=load, outputs=outs,
                                  force_x=[np.nan], response_x=[0.0])
    with pytest.raises(ValueError, match="model = 'winkler'"):
        preset("site", model="winkler")


def test_track_command_writes_readable_outputs(tmp_path):
    """`railfem track` end to end on a short band range: the transfer CSV reads back as
    mobility with the 29 EN positions, and its point value equals the model's own."""
    import json

    from railfem import cli
    from railfem.io.frf_csv import read_frf_csv

    out = tmp_path / "site"
    assert cli.main(["-q", "track", "--preset", "site", "--model", "timoshenko-discrete",
                     "--f-low", "100", "--f-high", "200", "--no-cache", "--out", str(out)]) == 0
    frf = read_frf_csv(out / "transfer_mobility.csv")
    assert frf.quantity == "mobility" and frf.values.shape[1:] == (2, 29)
    tp = preset("site")
    a = track_receptance("timoshenko-discrete", tp, meshing.get_mesh("60E1", 0.01),
                         frf.frequency, [0.32], [0.3])[:, 0, 0, 0]
    assert np.allclose(frf.values[:, 0, 0], 2j * np.pi * frf.frequency * a, rtol=1e-6)
    decay = np.loadtxt(out / "decay_rate.csv", delimiter=",", skiprows=2)
    assert decay.shape == (4, 5) and np.all(decay[:, 1] > 0)
    run = json.loads((out / "run.json").read_text())
    assert run["name"] == "site" and set(run["files"]) >= {"transfer_csv", "decay_png"}
    assert cli.main(["-q", "track", "--preset", "site", "--pad-length", "0", "--n-rows", "3",
                     "--out", str(tmp_path / "bad")]) == 2  # rows need a pad length
    assert not (tmp_path / "bad").exists()  # refused before any computing


def test_requests_outside_a_models_range_are_flagged(caplog):
    """Issue 10: a beam far above its range, a discrete track asked 1000 km away and a
    section mesh too coarse for the frequency run, but say so."""
    import logging

    import railfem as rf

    spec = rf.preset("site", model="timoshenko-discrete")
    with caplog.at_level(logging.WARNING, logger="railfem.models"):
        rf.receptance(spec, [100.0, 5000.0], [0.3], [0.3], cache=False)
    assert "beam has no cross-section deformation" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="railfem.models"):
        rf.receptance(spec, [100.0], [0.3], [1.0e6], cache=False)
    assert "beyond the supported stretch" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="railfem.models"):
        rf.receptance(spec, [100.0, 1000.0], [0.3], [5.0], cache=False)
    assert caplog.text == ""  # inside every range: nothing said
    from railfem.rail import waveguide

    guide = waveguide.assemble(meshing.get_mesh("60E1", 0.02))
    with caplog.at_level(logging.WARNING, logger="railfem.rail.waveguide"):
        waveguide.check_resolution(guide, 1.0e6)
    assert "elements per shortest" in caplog.text


def test_out_of_range_warning_is_said_once(caplog):
    """A fitter repeats the same request thousands of times: the validity warning is logged
    once per distinct text, not per call."""
    import logging

    spec = preset("site", model="timoshenko-continuous")
    f = np.array([100.0, 3000.0])
    with caplog.at_level(logging.WARNING, logger="railfem.models"):
        for _ in range(3):
            models.receptance(spec, f, [0.0], [0.0])
    assert caplog.text.count("beam has no cross-section deformation") == 1
