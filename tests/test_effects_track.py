"""The diagnosis effects of the real track (sleeper_flexibility, two_rail, ballast_mass):
what they build, the evaluator against the door on the specs they make, and small blind
diagnoses (generator: benchmarks/blind/generators.py, the door with the effect switched
on behind the diagnosis's back, 5 % noise; more seeds with -m slow)."""
import math

import numpy as np
import pytest

from railfem.diagnosis import diagnose, effects, prepare
from railfem.diagnosis.evaluate import Evaluator, plain_support
from railfem.identify.forward import door_receptance
from railfem.track.sleeper import B90
from railfem.track.supports import (FootDashpot, RailAbsorber, SupportParameters,
                                    dynamic_stiffness)
from benchmarks.blind import generators as g

NEW = ("sleeper_flexibility", "two_rail", "ballast_mass")
SMALL_F = g.frequencies(low=50.0, high=4000.0)[::2]  # 1/4.5-octave: a cheap grid
EULER_FREE_FREE = 4.730040745  # beta_1 L of the free-free Euler-Bernoulli beam


def test_plain_support_keeps_the_track_options():
    """The kernel's canonical support drops only the diagnosis hooks (pad laws, absorber);
    the sleeper, the ballast mass and the horizontal chains stay (they were dropped)."""
    p = SupportParameters(kp=5e8, eta_p=0.2, ms=150.0, kb=5e7, eta_b=0.8, kp_lat=1e8,
                          kb_lat=3e7, mb=300.0, kf=9e7, eta_f=0.4, sleeper=B90,
                          pad_laws=(FootDashpot(eta_1k=0.3),),
                          absorber=RailAbsorber(mass=3.0, fa=800.0))
    q = plain_support(p)
    assert q.pad_laws == () and q.absorber is None
    assert (q.sleeper, q.mb, q.kf, q.eta_f, q.kp_lat, q.kb_lat) == (B90, 300.0, 9e7, 0.4,
                                                                   1e8, 3e7)
    assert (q.kp, q.eta_p, q.ms, q.kb, q.eta_b) == (5e8, 0.2, 150.0, 5e7, 0.8)


def test_sleeper_effect_has_the_base_mass_and_the_asked_first_mode():
    """The effect's sleeper weighs 2 ms, bends first at f1, and its EI is the one the
    free-free Euler-Bernoulli beam needs for f1 (shear lowers it by a few %)."""
    spec = g.truth_spec()
    out = effects.get("sleeper_flexibility").apply(spec, {"f1": 200.0, "eta_s": 0.05})
    sl = out.support.sleeper
    assert sl.mass == pytest.approx(2 * spec.support.ms, rel=1e-12)
    assert sl.free_frequencies(1)[0] == pytest.approx(200.0, rel=1e-8)
    assert sl.eta == 0.05 and sl.length == 2.6 and sl.seat_distance == 1.5
    w1 = 2 * math.pi * 200.0
    ei_euler = w1 ** 2 * sl.mass_per_length * sl.length ** 4 / EULER_FREE_FREE ** 4
    assert 1.0 < sl.EI / ei_euler < 1.08
    two = effects.get("two_rail").apply(spec, {"f1": 200.0, "eta_s": 0.05})
    assert two.rails == 2 and two.support.sleeper == sl


def test_a_stiff_sleeper_and_no_ballast_mass_are_the_base_support():
    """The effects nest the base model: a very stiff sleeper of mass 2 ms is the rigid
    mass ms (closed form of the published chain), a ballast mass 0 on a rigid subgrade
    is the massless ballast."""
    spec = g.truth_spec()
    p = spec.support
    w = 2 * np.pi * np.geomspace(20.0, 3000.0, 60)
    kp, kb = p.kp * (1 + 1j * p.eta_p), p.kb * (1 + 1j * p.eta_b)
    base = kp * (kb - w ** 2 * p.ms) / (kp + kb - w ** 2 * p.ms)
    stiff = effects.get("sleeper_flexibility").apply(spec, {"f1": 3e5, "eta_s": 0.02})
    assert np.abs(dynamic_stiffness(stiff.support, w) / base - 1).max() < 1e-4
    none = effects.get("ballast_mass").apply(spec, {"mb": 0.0, "kf": math.inf, "eta_f": 0.0})
    assert np.abs(dynamic_stiffness(none.support, w) / base - 1).max() < 1e-12


THETA = {"sleeper_flexibility": {"f1": 160.0, "eta_s": 0.03},
         "two_rail": {"f1": 160.0, "eta_s": 0.03},
         "ballast_mass": {"mb": 400.0, "kf": 8e7, "eta_f": 0.5}}


@pytest.mark.parametrize("name", NEW)
def test_evaluator_agrees_with_the_door(name):
    """The diagnosis's fast path (eigen form of the coupling; two rails as the mean of the
    two load cases) gives what railfem.models gives for the spec the effect makes."""
    rec = prepare(g.dataset("none", 0, f=SMALL_F)).records[0]
    t = rec.fit
    spec = effects.get(name).apply(g.truth_spec(), THETA[name])
    got = Evaluator().receptance(spec, rec)
    ref = door_receptance(spec, t.frequency, t.sensor_x, t.force_x, t.outputs, cache=False)
    scale = np.abs(ref).max(axis=(1, 2), keepdims=True)
    assert np.all(np.abs(got - ref) <= 1e-6 * scale)
    base = Evaluator().receptance(g.truth_spec(), rec)
    assert np.abs(20 * np.log10(np.abs(got[:, :, 0] / base[:, :, 0]))).max() > 1.0


def test_two_rail_is_not_the_one_rail_flexible_sleeper():
    """The anti-phase track adds the sleeper's antisymmetric modes: the hammer rail's
    response on two rails differs from the one-rail (in-phase) flexible sleeper."""
    rec = prepare(g.dataset("none", 0, f=SMALL_F)).records[0]
    one = effects.get("sleeper_flexibility").apply(g.truth_spec(), THETA["two_rail"])
    two = effects.get("two_rail").apply(g.truth_spec(), THETA["two_rail"])
    a1, a2 = (Evaluator().receptance(s, rec) for s in (one, two))
    assert np.abs(20 * np.log10(np.abs(a2[:, 0, 0] / a1[:, 0, 0]))).max() > 2.0


# ------------------------------------------------------------------ blind

# the default suite keeps clean data and the cheapest effect (ballast_mass), with the rail
# loss factor of the base (no rail-loss profile per candidate and for the chosen one:
# ~4 s of CPU each instead of ~7-10 s); the same with the profiles, sleeper_flexibility and
# two_rail (two_rail needs the profile), ten seeds each, run with -m slow
FAST = [(c, 3, False) for c in ("none", "ballast_mass")]
SLOW = [pytest.param(c, s, True, marks=pytest.mark.slow) for c in ("none",) + NEW
        for s in range(3, 13)]  # ten seeds per case


@pytest.mark.parametrize("case, seed, profile", FAST + SLOW)
def test_blind_real_track(case, seed, profile):
    """Hammer data (cross-model form, 5 % noise, coarse grid) of the truth track with the
    case's effect on: the diagnosis among the three real-track effects names and keeps
    it; on clean data (case none) it claims nothing."""
    d = diagnose(g.dataset(case, seed, f=SMALL_F, form="cross"), model="timoshenko-discrete",
                 effects=NEW, n_starts=2, pairs=False, profile_final=profile)
    if case == "none":
        assert d.chosen is None, d.statement
        return
    assert d.chosen is not None and d.chosen.name == case, d.statement
    assert d.verdict in ("explained", "partly explained"), d.statement
    assert d.chosen_row["final_held_out"]["reduction"] >= 0.5
    truth = g.CASES[case]
    got = {p["name"].split(".")[-1]: p["value"] for p in d.chosen.parameters()}
    key = "f1" if "f1" in truth else "mb"
    assert got[key] == pytest.approx(truth[key], rel=0.1 if key == "f1" else 0.5), got
