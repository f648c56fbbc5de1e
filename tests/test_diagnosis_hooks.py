"""The support hooks the effect library uses (railfem.track.supports): a fractional Zener pad,
a dashpot at the rail foot and a rail absorber, each against its closed form; the two
coupling paths (eigen form and direct solve) agree with the hooks on; deviations keep the
laws; specs with laws write to JSON."""
import json
import math

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.diagnosis.evaluate import Evaluator
from railfem.diagnosis.data import prepare
from railfem.measurement import HammerMeasurement, Sensor
from railfem.spec import SupportDeviation, spec_to_dict
from railfem.track.supports import (
    FootDashpot, FractionalZener, RailAbsorber, SupportParameters, dynamic_stiffness,
)

W = 2 * np.pi * np.array([1.0, 30.0, 100.0, 400.0, 1000.0, 3000.0])
RIGID_BALLAST = dict(ms=0.0, kb=math.inf)


def test_zener_alpha_one_is_the_standard_linear_solid():
    """alpha = 1: a spring k0 in parallel with a Maxwell arm (k1 = (r-1) k0 in series with a
    dashpot of time constant tau = 1/(2 pi fc))."""
    k0, r, fc = 3e8, 4.0, 500.0
    p = SupportParameters(kp=k0, pad_laws=(FractionalZener(ratio=r, fc=fc, alpha=1.0),),
                          **RIGID_BALLAST)
    tau = 1 / (2 * np.pi * fc)
    k1 = (r - 1) * k0
    expected = k0 + k1 * 1j * W * tau / (1 + 1j * W * tau)
    assert np.allclose(dynamic_stiffness(p, W), expected, rtol=1e-12)


def test_zener_limits():
    base = SupportParameters(kp=2e8, eta_p=0.1, **RIGID_BALLAST)
    one = SupportParameters(kp=2e8, eta_p=0.1, pad_laws=(FractionalZener(ratio=1.0, fc=50.0),),
                            **RIGID_BALLAST)
    assert np.allclose(dynamic_stiffness(one, W), dynamic_stiffness(base, W), rtol=1e-14)
    z = SupportParameters(kp=2e8, eta_p=0.1, pad_laws=(FractionalZener(ratio=5.0, fc=1.0,
                                                                       alpha=0.5),),
                          **RIGID_BALLAST)
    high = dynamic_stiffness(z, np.array([2 * np.pi * 1e9]))[0]
    assert high == pytest.approx(5.0 * 2e8 * (1 + 0.1j), rel=1e-3)


def test_foot_dashpot_is_a_viscous_term():
    kp, eta, e1k = 5e8, 0.2, 0.3
    p = SupportParameters(kp=kp, eta_p=eta, pad_laws=(FootDashpot(eta_1k=e1k),),
                          **RIGID_BALLAST)
    c = kp * e1k / (2 * np.pi * 1000.0)
    assert np.allclose(dynamic_stiffness(p, W), kp * (1 + 1j * eta) + 1j * W * c, rtol=1e-12)


def test_rail_absorber_is_a_mass_on_a_spring():
    """Alone (no pad contact): 1/K = 1/k* + 1/(-omega^2 m), a spring and a mass in series."""
    m, fa, eta = 3.0, 700.0, 0.25
    p = SupportParameters(kp=0.0, kb=0.0, ms=0.0, absorber=RailAbsorber(mass=m, fa=fa, eta=eta))
    k = m * (2 * np.pi * fa) ** 2 * (1 + 1j * eta)
    expected = 1 / (1 / k + 1 / (-W ** 2 * m))
    assert np.allclose(dynamic_stiffness(p, W), expected, rtol=1e-12)
    half = p.scaled(0.5)
    assert half.absorber.mass == pytest.approx(1.5)


@pytest.mark.parametrize("hook", ["zener", "dashpot", "absorber"])
def test_eigen_form_and_direct_coupling_agree_with_hooks(hook):
    """Two code paths: the diagnosis evaluator (eigen form of the coupling) and the door's
    direct solve of the discrete track (each spring's K from the layout)."""
    extra = {"zener": dict(pad_laws=(FractionalZener(ratio=3.0, fc=300.0),)),
             "dashpot": dict(pad_laws=(FootDashpot(eta_1k=0.5),)),
             "absorber": dict(absorber=RailAbsorber(mass=5.0, fa=800.0, eta=0.3))}[hook]
    from dataclasses import replace

    spec = rf.preset("site", model="timoshenko-discrete")
    spec = spec.replace(support=replace(spec.support, **extra))
    f = np.geomspace(60, 3000, 12)
    xs, pos, hx = models.hammer_x(spec)
    Y = 2j * np.pi * f[:, None, None] * models.receptance(spec, f, hx, [xs], outputs=("head",),
                                                          cache=False)[:, :, 0, :]
    frf = rf.FRF(frequency=f, values=Y, quantity="mobility", response=("head",),
                 force=tuple(f"x{p:g}" for p in pos))
    pos = pos.copy()
    pos[0] = models.POINT_OFFSET
    meas = HammerMeasurement(frf=frf, positions=pos, sensors=(Sensor(name="head"),),
                                sleeper_spacing=0.6, sensor_x=0.3)
    rec = prepare(meas).records[0]
    a = Evaluator().receptance(spec, rec)
    direct = models.receptance(spec, f, rec.fit.force_x, [xs], outputs=("head",),
                               cache=False)[:, :, 0, :]
    near = np.abs(direct) > 1e-4 * np.abs(direct[:, :, :1])  # within 80 dB of the point
    assert np.abs(a - direct)[near].max() <= 1e-6 * np.abs(direct).max()
    plain = models.receptance(rf.preset("site", model="timoshenko-discrete"), f, rec.fit.force_x,
                              [xs], outputs=("head",), cache=False)[:, :, 0, :]
    assert np.abs(direct - plain).max() > 1e-3 * np.abs(plain).max()  # the hook acts


def test_deviation_keeps_laws_and_spec_writes_json():
    law = FractionalZener(ratio=2.0, fc=100.0)
    spec = rf.preset("site", model="timoshenko-discrete")
    from dataclasses import replace

    spec = spec.replace(support=replace(spec.support, pad_laws=(law,),
                                        absorber=RailAbsorber(mass=1.0, fa=500.0)),
                        deviations=(SupportDeviation(index=1, kb=0.1),))
    lay = spec.layout()
    centre = (spec.n_supports - 1) // 2
    assert lay.params[centre + 1].pad_laws == (law,)
    assert lay.params[centre + 1].kb == pytest.approx(0.1 * spec.support.kb)
    d = spec_to_dict(spec)
    text = json.dumps(d)
    assert "FractionalZener" in text and "RailAbsorber" in text
    assert "pad_laws" not in json.dumps(spec_to_dict(rf.preset("site")))


def test_bad_hook_values_are_named():
    with pytest.raises(ValueError, match="ratio"):
        FractionalZener(ratio=0.5, fc=100.0)
    with pytest.raises(ValueError, match="alpha"):
        FractionalZener(ratio=2.0, fc=100.0, alpha=1.5)
    with pytest.raises(ValueError, match="mass"):
        RailAbsorber(mass=-1.0, fa=100.0)
    with pytest.raises(TypeError, match="pad_laws"):
        SupportParameters(kp=1e8, kb=1e8, pad_laws=("soft",))


def test_deviating_supports_woodbury_update_against_the_door():
    """The evaluator's Woodbury update for deviating beam supports (one, or eleven at
    random) against the door's direct solve of the track with them (301 supports at absolute
    positions). Near the sensor the two differ only by where the supported stretch ends:
    the door's own uniform paths (re-centred vs absolute) differ by ~1e-4 there."""
    import benchmarks.blind.generators as g

    f = np.geomspace(60, 3000, 10)
    data = prepare(g.dataset("none", 0, f=f))
    rec = data.records[0]
    near = rec.fit.positions <= 3.0
    ev = Evaluator()
    rng = np.random.default_rng(3)
    many = tuple(SupportDeviation(index=i, kb=float(np.exp(0.4 * rng.standard_normal())),
                                  kp=float(np.exp(0.2 * rng.standard_normal())))
                 for i in range(-2, 9))
    cases = [(SupportDeviation(index=2, kb=0.05),), (SupportDeviation(index=-1, kp=0.3, kb=2.0),),
             (SupportDeviation(index=0, ms=0.5),), many]
    for devs in cases:
        spec = g.truth_spec().replace(deviations=devs)
        a = ev.receptance(spec, rec)
        ref = models.receptance(spec.replace(n_supports=301), f, rec.fit.force_x,
                                [rec.fit.sensor_x], outputs=("head",), cache=False)[:, :, 0, :]
        err = np.abs(a[:, :, near] / ref[:, :, near] - 1).max()
        assert err < 1e-3, (devs, err)
        uni = models.receptance(g.truth_spec(), f, rec.fit.force_x, [rec.fit.sensor_x],
                                outputs=("head",), cache=False)[:, :, 0, :]
        assert np.abs(uni[:, :, near] / ref[:, :, near] - 1).max() > 1e-2  # it matters
