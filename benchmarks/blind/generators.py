"""Blind-test data: railfem's forward model (the door, railfem.models) with an effect
switched on, plus seeded noise. Nothing here imports railfem.diagnosis: the diagnosis is
never told which effect (if any) made the data.

Every generator returns a list of HammerMeasurement (or DecayRateMeasurement) objects; the
truth is returned separately for the test to compare with.

``form``: "own" (default) makes the data with railfem's default configuration, the one the
diagnosis estimates with; "cross" with a model that differs from it in model form, as an
independent implementation would (CROSS: a straight-sided P2 mesh of another size, the
published node springs in another count, another pad discretisation), so the estimator
never meets its own configuration.
"""
from __future__ import annotations

import math
import os
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

import railfem as rf
from railfem import models
from railfem.measurement import HammerMeasurement, Metadata, Sensor
from railfem.spec import SupportDeviation
from railfem.standards import en15461, iec61260
from railfem.diagnosis.effects.pad_length import ROWS as PAD_ROWS
from railfem.track.supports import FootDashpot, FractionalZener, RailAbsorber

TRUTH = dict(kp=400e6, eta_p=0.2, kb=60e6, eta_b=1.0, eta_r=0.02)
MODEL = "timoshenko-discrete"
NOISE = 0.05


FORMS = ("own", "cross")
#: the cross-model configuration: straight-sided P2 section mesh of CROSS["h"] m (the
#: estimator's shipped mesh is curved, 10 mm), CROSS["springs"] springs per support row at
#: the foot nodes (the published rule; the estimator: 4 midpoint springs), a pad of finite
#: length in CROSS["rows"] rows (the estimator's pad_length effect: PAD_ROWS)
CROSS = {"h": 0.0075, "curved": False, "foot_rule": "nodes", "springs": 8, "rows": 4}


def cross_mesh_file(h: float = CROSS["h"], curved: bool = CROSS["curved"],
                    profile: str = "60E1") -> str:
    """Path of the cross-model section mesh of ``profile`` (a RailSpec profile: '60E1' or a
    modified '60E1:foot=F'), written once to a per-user temporary folder."""
    from railfem.rail import meshing
    from railfem.rail.profiles import get_profile

    tag = "curved" if curved else "straight"
    folder = Path(os.environ.get("RAILFEM_BLIND_DIR", tempfile.gettempdir())) / \
        f"railfem-blind-{os.getuid() if hasattr(os, 'getuid') else 0}"
    path = folder / f"{profile.replace(':', '_')}_h{h * 1e3:g}mm_{tag}.npz"
    if not path.exists():
        folder.mkdir(parents=True, exist_ok=True)
        meshing.save_mesh(meshing.get_mesh(get_profile(profile), h, curved=curved), path)
    return str(path)


def cross_spec(spec):
    """``spec`` in the cross-model form (CROSS): another mesh, spring rule and count, and
    (for a pad of finite length) rows."""
    rail = replace(spec.rail, mesh_file=cross_mesh_file(profile=spec.rail.profile))
    num = replace(spec.numerics, foot_rule=CROSS["foot_rule"], n_foot_springs=CROSS["springs"])
    out = spec.replace(rail=rail, numerics=num)
    if spec.pad_length > 0 and spec.kind.is_discrete:
        out = out.replace(n_rows=CROSS["rows"])
    return out


def frequencies(n_per_octave: int = 9, low: float = 50.0, high: float = 5000.0):
    if n_per_octave == 9:
        return iec61260.ninth_octave_grid(low, high)
    return iec61260.ninth_octave_grid(low, high)[::9 // n_per_octave]


def truth_spec(model=MODEL, **changes):
    # point-like supports, as the diagnosis's base: the finite pad is an effect of its own
    return rf.preset("site", model=model, pad_length=0.0).replace(**{**TRUTH, **changes})


def clean(spec, f, *, outputs=("head",), sensor_shift=0.0, hammer_offset=0.0, form="own",
          cache=False):
    """Mobilities (nf, n_out, n_pos) of an EN 15461 test on spec (in ``form``: FORMS): the
    sensor at mid-span (+ sensor_shift), positions of the standard, the point 20 mm away,
    every other hammer position moved by hammer_offset. ``cache``: the door's kernel cache
    (railfem.models; False: memory only); the kernel is content-keyed, so a cached one
    gives the same data (tests share the data's kernels through the test cache)."""
    if form not in FORMS:
        raise ValueError(f"form {form!r}: give one of {FORMS}")
    spec = cross_spec(spec) if form == "cross" else spec
    pos = en15461.hammer_positions(spec.spacing).astype(float)
    pos[0] = models.POINT_OFFSET
    xs = spec.spacing / 2 + sensor_shift
    hx = xs + pos + np.where(np.arange(len(pos)) > 0, hammer_offset, 0.0)
    if spec.deviations:
        spec = spec.replace(n_supports=2 * math.ceil((hx.max() + 20) / spec.spacing) + 1)
    a = models.receptance(spec, f, hx, [xs], outputs=outputs, cache=cache)[:, :, 0, :]
    return 2j * np.pi * f[:, None, None] * a, pos


def noisy(Y, seed, level=NOISE, floor_db=None):
    """Multiplicative complex Gaussian scatter of RMS ``level`` per FRF point; optionally an
    additive floor (complex Gaussian, RMS 10^(floor_db/20) |Y_point|)."""
    rng = np.random.default_rng(seed)
    e = (rng.standard_normal(Y.shape) + 1j * rng.standard_normal(Y.shape)) / np.sqrt(2)
    out = Y * (1 + level * e)
    if floor_db is not None:
        g = (rng.standard_normal(Y.shape) + 1j * rng.standard_normal(Y.shape)) / np.sqrt(2)
        out = out + 10 ** (floor_db / 20) * np.abs(Y[:, :, :1]) * g
    return out


def measurement(Y, pos, f, outputs=("head",), metadata=None, stated_sensor_x=0.3):
    frf = rf.FRF(frequency=f, values=Y, quantity="mobility", response=tuple(outputs),
                 force=tuple(f"x{p:.3f}" for p in pos))
    return HammerMeasurement(frf=frf, positions=pos, sleeper_spacing=0.6,
                             sensors=tuple(Sensor(name=o) for o in outputs),
                             sensor_x=stated_sensor_x, metadata=metadata or Metadata())


def mount(f, fs, eta):
    """Transmissibility of a sensor on a compliant mount (base-excited oscillator)."""
    r = f / fs
    return (1 + 1j * eta * r) / (1 - r ** 2 + 1j * eta * r)


def _support(spec, **changes):
    return spec.replace(support=replace(spec.support, **changes))


#: effect name -> (truth parameters, spec change or None)
CASES = {
    "none": {},
    "pad_frequency": {"ratio": 3.0, "fc": 400.0},
    "foot_damping": {"eta_1k": 0.4},
    "rail_damper": {"mass": 4.0, "fa": 900.0, "eta_a": 0.3},
    "pad_length": {"pad_length": 0.16},
    "voided_sleeper": {"index": 2, "kb_factor": 0.05},
    "sensor_resonance": {"fs": 3200.0, "eta_s": 0.15},
    "sensor_position": {"sensor_shift": 0.1},
    "hammer_position": {"hammer_offset": 0.05},
    "noise_floor": {"floor_db": -40.0},
    "temperature": {"a": 0.03},
    "preload": {"n_p": 0.8, "n_b": 0.5},
    "rail_stiffness": {"E": 1.75e11},  # outside the library: a softer rail
    "section_geometry": {"foot_thickness": 0.0025},  # m; a WFE model's case (a 60E1 foot)
    # every support's pad and ballast stiffness scattered (lognormal, SD of ln)
    "random_support": {"sd_kp": 0.15, "sd_kb": 0.3},
    # real track: a flexible sleeper of the truth's mass (2 ms), B90 shape, first free-free
    # bending mode at f1; the same on both rails (the hammer rail's response); a ballast
    # mass on a damped subgrade
    "sleeper_flexibility": {"f1": 160.0, "eta_s": 0.03},
    "two_rail": {"f1": 160.0, "eta_s": 0.03},
    "ballast_mass": {"mb": 400.0, "kf": 80e6, "eta_f": 0.5},
}
RANDOM_SPAN = range(-65, 66)  # supports scattered by random_support (the default 131)
SCORED_SPAN = range(-8, 25)  # the supports random_support fits


def random_factors(seed: int, p=CASES["random_support"]) -> dict:
    """{support index: (kp factor, kb factor)} of the random_support case, seed-drawn from
    a stream of its own (not the noise's)."""
    rng = np.random.default_rng(10_000 + seed)
    z = rng.standard_normal((len(RANDOM_SPAN), 2))
    return {i: (float(np.exp(p["sd_kp"] * a)), float(np.exp(p["sd_kb"] * b)))
            for i, (a, b) in zip(RANDOM_SPAN, z)}


def truth(case: str, seed: int) -> dict:
    """The parameters of the case the diagnosis should recover (named as its effect names
    them); for random_support the realised factors of the supports the effect fits
    (SCORED_SPAN)."""
    if case != "random_support":
        return dict(CASES[case])
    out = dict(CASES[case])
    for i, (kp, kb) in random_factors(seed).items():
        if i in SCORED_SPAN:
            tag = f"{'m' if i < 0 else ''}{abs(i)}"
            out[f"kp_{tag}"], out[f"kb_{tag}"] = kp, kb
    return out


def truth_sleeper(ms: float, f1: float, eta: float):
    """The default (B90-type) sleeper with mass 2 ms (kg) and its bending and shear
    stiffness scaled so that its first free-free bending mode is at f1 (Hz)."""
    from railfem.track.sleeper import B90

    m = 2 * ms / B90.mass
    k = m * (f1 / float(B90.free_frequencies(1)[0])) ** 2
    return replace(B90, EI=B90.EI * k, kGA=B90.kGA * k, eta=eta,
                   mass_per_length=B90.mass_per_length * m,
                   rotary_inertia=B90.rotary_inertia * m)


def effect_spec(case: str, seed: int = 0, model=MODEL):
    """The truth TrackSpec of a case whose effect is in the track (None for the others:
    measurement, geometry and campaign effects)."""
    p = CASES[case]
    spec = truth_spec(model)
    if case == "none":
        return spec
    if case == "pad_frequency":
        return _support(spec, pad_laws=(FractionalZener(ratio=p["ratio"], fc=p["fc"],
                                                        alpha=0.5),))
    if case == "foot_damping":
        return _support(spec, pad_laws=(FootDashpot(eta_1k=p["eta_1k"]),))
    if case == "rail_damper":
        return _support(spec, absorber=RailAbsorber(mass=p["mass"], fa=p["fa"],
                                                    eta=p["eta_a"]))
    if case == "pad_length":  # in the estimator's own rows (cross_spec: CROSS["rows"])
        return spec.replace(pad_length=p["pad_length"], n_rows=PAD_ROWS)
    if case == "voided_sleeper":
        return spec.replace(deviations=(SupportDeviation(index=p["index"],
                                                         kb=p["kb_factor"]),))
    if case == "random_support":
        return spec.replace(deviations=tuple(
            SupportDeviation(index=i, kp=kp, kb=kb)
            for i, (kp, kb) in random_factors(seed, p).items()))
    if case in ("sleeper_flexibility", "two_rail"):
        spec = spec.replace(sleeper=truth_sleeper(spec.support.ms, p["f1"], p["eta_s"]))
        return spec.replace(rails=2) if case == "two_rail" else spec
    if case == "ballast_mass":
        return _support(spec, mb=p["mb"], kf=p["kf"], eta_f=p["eta_f"])
    if case == "rail_stiffness":
        return spec.replace(rail=replace(spec.rail, E=p["E"]))
    if case == "section_geometry":  # the modified outline, meshed by Gmsh
        from railfem.rail.profiles import modified_name
        prof = modified_name(foot=p["foot_thickness"] * 1e3)
        return spec.replace(rail=replace(spec.rail, profile=prof))
    return None


def dataset(case: str, seed: int, f=None, outputs=("head",), model=MODEL, form="own",
            level=NOISE, cache=False):
    """A list of measurements with ``case`` switched on (CASES), noise (RMS ``level``)
    seeded by ``seed``, made by the model in ``form`` (FORMS: 'own' or 'cross');
    ``cache``: the kernel cache of the model (clean)."""
    f = frequencies() if f is None else f
    p = CASES[case]
    if case in ("temperature", "preload"):
        return _campaign(case, p, truth_spec(model), f, seed, outputs, form, cache)
    spec = effect_spec(case, seed, model) or truth_spec(model)
    kw = {}
    if case == "sensor_position":
        kw["sensor_shift"] = p["sensor_shift"]
    elif case == "hammer_position":
        kw["hammer_offset"] = p["hammer_offset"]
    Y, pos = clean(spec, f, outputs=outputs, form=form, cache=cache, **kw)
    if case == "sensor_resonance":
        Y = Y * mount(f, p["fs"], p["eta_s"])[:, None, None]
    floor = p["floor_db"] if case == "noise_floor" else None
    return [measurement(noisy(Y, seed, level=level, floor_db=floor), pos, f, outputs)]



def thinned(meas: list, every: int = 1) -> list:
    """A one-record dataset with every ``every``-th transfer position kept (the point
    mobility always): the same data on fewer positions, for fast tests."""
    if every == 1:
        return meas
    m = meas[0]
    keep = np.r_[0, np.arange(1, len(m.positions))[::every]]
    return [measurement(m.frf.values[:, :, keep], np.asarray(m.positions)[keep], m.frequency)]

#: pass-by generator: train speeds (m/s), sample rate, signal noise, wheel detector
PASSBY_SPEEDS = (30.0, 40.0, 50.0)
PASSBY_FS = 25600.0
PASSBY_NOISE = 0.05
PASSBY_DETECT = {"lowpass_hz": 50.0, "snr_db": 12.0}


def passby_recordings(case: str, seed: int, model=MODEL, speeds=PASSBY_SPEEDS):
    """Pass-by recordings (foot sensor at mid-span, rigid wheels with interaction, 24
    wheels, a known roughness, seeded noise) of the truth track of ``case`` (a track
    effect: effect_spec), as railfem.recording.Recording objects that know nothing of the
    truth."""
    from railfem.wheelrail import contact
    from railfem.wheelrail import roughness as R
    from railfem.wheelrail import wheels
    from railfem.simulate import passby as P, signals
    from railfem.simulate.train import default_train

    spec = effect_spec(case, seed, model)
    if spec is None or spec.deviations:
        raise ValueError(f"case {case!r} has no periodic track effect for a pass-by")
    f = iec61260.ninth_octave_grid(80.0, 6300.0)
    tables = P.rail_tables(spec, f, cache=False)
    hz, wheel, train = contact.hertz(), wheels.RigidWheel(mass=600.0), default_train()
    rough = R.sloped_spectrum(0.0, 10.0, lambda_min=0.002, lambda_max=1.0)
    out = []
    for k, v in enumerate(speeds):
        r = R.amplitude_at(rough, f, v) * np.sqrt(contact.filter_power("analytical", f, v, hz))
        res = P.simulate_passby(tables, train, wheel.receptance(f),
                                contact.contact_receptance(hz, f), r, before=20.0,
                                after=20.0)
        sig, truth = signals.synthesise(res, train, v, sample_rate=PASSBY_FS,
                                        noise_fraction=PASSBY_NOISE, seed=1000 * seed + k)
        out.append(signals.passby_recording(sig, truth, spacing=spec.spacing,
                                            location="foot"))
    return out


def _campaign(case, p, spec, f, seed, outputs, form="own", cache=False):
    out = []
    if case == "temperature":
        temps = (0.0, 15.0, 30.0)
        for i, T in enumerate(temps):
            s = spec.replace(kp=spec.support.kp * math.exp(-p["a"] * (T - np.mean(temps))))
            Y, pos = clean(s, f, outputs=outputs, form=form, cache=cache)
            out.append(measurement(noisy(Y, seed * 7 + i), pos, f, outputs,
                                   Metadata(date=f"2020-0{i + 1}-01", temperature_c=T)))
    else:
        loads = (0.0, 40.0, 80.0)
        ref = float(np.mean(loads))
        for i, P in enumerate(loads):
            fac = lambda n: ((1 + P / 20) / (1 + ref / 20)) ** n  # noqa: E731
            s = spec.replace(kp=spec.support.kp * fac(p["n_p"]),
                             kb=spec.support.kb * fac(p["n_b"]))
            Y, pos = clean(s, f, outputs=outputs, form=form, cache=cache)
            out.append(measurement(noisy(Y, seed * 7 + i), pos, f, outputs,
                                   Metadata(date=f"2020-0{i + 1}-01",
                                            notes={"static_load_kn": P})))
    return out


def decay_rate_campaign(seed: int, a: float = 0.03, temps=(0.0, 15.0, 30.0), level=0.03,
                        model=MODEL):
    """Decay rates per band (100 Hz - 5 kHz) of the truth at three temperatures with the pad
    following kp exp(-a (T - mean T)); multiplicative scatter ``level`` per band."""
    from railfem.measurement import DecayRateMeasurement

    rng = np.random.default_rng(seed)
    f = iec61260.ninth_octave_grid(100.0, 5000.0)
    out = []
    for i, T in enumerate(temps):
        spec = truth_spec(model)
        spec = spec.replace(kp=spec.support.kp * math.exp(-a * (T - float(np.mean(temps)))))
        r = models.decay_rate(spec, f, cache=False)
        d = np.asarray(r.decay_rate) * (1 + level * rng.standard_normal(len(r.decay_rate)))
        out.append(DecayRateMeasurement(frequency=np.asarray(r.frequency), decay_rate=d,
                                        metadata=Metadata(date=f"2020-0{i + 1}-01",
                                                          temperature_c=T, section="S1")))
    return out


# ------------------------------------------------------------------ lateral decay rates

#: lateral cases: the fastening's roll restraint (N m/rad, -) switched on in the truth;
#: 'roll_restraint' about the truth pad's own roll stiffness on the rigid rail seat
#: (400 MN/m x 0.15^2 / 12 = 7.5e5 N m/rad), 'guide_plate' several times beyond it, as the
#: foot edge bearing on stiff guide plates would give (assumed; on the old per-spring seat
#: the SBB lateral rows asked for 2e6-9e6)
LATERAL_CASES = {"none": {}, "roll_restraint": {"k_roll": 1e6, "eta_roll": 0.3},
                 "guide_plate": {"k_roll": 5e6, "eta_roll": 0.3}}
LATERAL_MODEL = "wfe-periodic"
LATERAL_BANDS = (100.0, 630.0)  # Hz: the band centres of the small blind test


def lateral_truth_spec(case: str = "none", model: str = LATERAL_MODEL):
    """The truth track of a lateral case: truth_spec on supports acting vertically and
    laterally, its lateral chain from TRUTH by the presets' rule
    (railfem.track.supports.horizontal_support), the case's grip switched on."""
    from railfem.track.supports import horizontal_support

    spec = truth_spec(model)
    s = spec.support
    spec = spec.replace(support_directions="zy",
                        **horizontal_support(s.kp, s.eta_p, s.kb, s.eta_b, s.ms))
    return spec.replace(**LATERAL_CASES[case]) if LATERAL_CASES[case] else spec


def decay_rates(case: str, seed: int, *, bands=LATERAL_BANDS, directions: str = "zy",
                form: str = "cross", level: float = NOISE, model: str = LATERAL_MODEL,
                rails=("li", "re"), cache=False) -> list:
    """EN 15461 decay rates per one-third-octave band (``bands``: lowest and highest centre,
    Hz) of the lateral case's truth (lateral_truth_spec) in ``form`` ('cross': CROSS), one
    row per direction ('z' vertical hammer and sensor on the head top, 'y' lateral on the
    side of the head) and rail (repeats: same section and date, independent noise), each
    band scattered by a seeded multiplicative Gaussian of RMS ``level``; ``cache``: the
    kernel cache of the model (as clean)."""
    from railfem.measurement import DecayRateMeasurement

    spec = lateral_truth_spec(case, model)
    spec = cross_spec(spec) if form == "cross" else spec
    f = iec61260.ninth_octave_grid(*bands)
    rng = np.random.default_rng(20_000 + seed)
    out = []
    for d in directions:
        r = models.decay_rate(spec, f, output="head_lateral" if d == "y" else "head",
                              cache=cache)
        for side in rails:
            dr = np.asarray(r.decay_rate) * (1 + level * rng.standard_normal(len(r.frequency)))
            out.append(DecayRateMeasurement(
                frequency=np.asarray(r.frequency), decay_rate=dr, direction=d, sensor="head",
                metadata=Metadata(section="S1", date="2020-01-01", rail_side=side)))
    return out
