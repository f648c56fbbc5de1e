"""The per-track computations of the pass-by error study (``railfem study passby``,
railfem.jobs.study; docs/roughness.md): model decay rates and far-field attenuation,
simulated pass-bys written as recordings and read back, the pass-by decay-rate estimators,
the roughness by the full and the simplified method and, on one track, the sensitivity
to a wrong track model and the causes of the simplified method's error.

Everything of one track is :func:`track_study` (it runs in a worker process of the job and
returns plain arrays); the recordings go under ``out/recordings`` so that the estimators
see files only (the truth in separate files, railfem.io.recording).
"""
from __future__ import annotations

import logging
import time
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

__all__ = ["far_field_decay", "track_study", "sensitivity", "tdr_causes", "causes",
           "warm_cache", "STUDY_TRACKS", "SPEEDS_KMH", "TDR_SOURCES", "A_SOURCES", "DETECT"]

STUDY_TRACKS = ("stiff", "medium", "soft", "very_soft", "site")
SPEEDS_KMH = (212.0, 214.0, 216.0, 218.0)
TDR_SOURCES = ("hammer", "energy", "slope")
A_SOURCES = ("model", "default")
# wheel detector: a 6-car train fills most of a short record (the detector's background is
# the record's median) and band content from 89 Hz rings through a 100 Hz low-pass at
# 60 m/s: threshold 12 dB, low-pass 50 Hz (the quasi-static pulses lie below ~20 Hz)
DETECT = {"snr_db": 12.0, "lowpass_hz": 50.0}


def far_field_decay(tables, bands, sensor_x: float, output: str = "foot",
                    start: float = 1.0, drop_db: float = 40.0) -> np.ndarray:
    """(nb,) far-field attenuation (dB/m): minus the slope of the band level of the
    transfer receptance (force on the head at the sensor, response at ``output``) vs
    distance, fitted from ``start`` m until the level has dropped ``drop_db`` below its value
    there (or the tables end); NaN with fewer than 5 points."""
    from ..simulate.passby import OUTPUTS
    from ..standards.iec61260 import band_average

    step = tables.step
    j = int(round(sensor_x / step)) % len(tables.force_x)
    x = tables.response_x - tables.force_x[j]
    a = tables.receptance[:, OUTPUTS.index(output), :, j]
    keep = x >= start - 1e-9
    lev = 20 * np.log10(band_average(tables.frequency, a[:, keep], bands))
    xs = x[keep]
    out = np.full(len(bands), np.nan)
    for b in range(len(bands)):
        use = lev[b] >= lev[b, 0] - drop_db
        use &= np.cumprod(use).astype(bool)  # up to the first drop below
        if use.sum() >= 5:
            out[b] = -np.polyfit(xs[use], lev[b, use], 1)[0]
    return out


# ------------------------------------------------------------------------- one track
def track_study(spec, cfg: dict, out: Path) -> dict:
    """Everything of one track (a railfem.spec.TrackSpec named after one of STUDY_TRACKS,
    which seeds its signals); cfg: the job's settings; returns plain arrays (runs in a
    worker process)."""
    from ..wheelrail import contact as C
    from ..wheelrail import roughness as R
    from ..estimators.passby import PassbyOptions, passby_decay_rate
    from ..estimators.passby_level import passby_level
    from ..identify import roughness as RM
    from ..io.recording import read_recording, write_recording
    from ..models import decay_rate
    from ..simulate import passby as P, signals
    from ..simulate.chain import effective_roughness, make_wheel
    from ..simulate.train import default_train
    from ..standards.iec61260 import ninth_octave_grid, third_octave_bands

    t0 = time.perf_counter()
    timing = {}
    name = spec.name
    f = ninth_octave_grid(cfg["f_low"], cfg["f_high"])
    bands = third_octave_bands(cfg["f_low"], cfg["f_high"])
    tables = P.rail_tables(spec, f, cache=cfg["cache"])
    hammer = decay_rate(spec, f, output="foot", cache=cfg["cache"])
    sensor_x = round(spec.spacing / 2 / tables.step) * tables.step
    far = far_field_decay(tables, bands, sensor_x)
    timing["model_s"] = time.perf_counter() - t0
    # ---- simulated recordings: written, then read back as files
    train = default_train()
    hz = C.hertz()
    aw_rigid = make_wheel("rigid").receptance(f)
    ac = C.contact_receptance(hz, f)
    truth_spec = R.sloped_spectrum(0.0, 10.0, name="known: 0 dB re 1 um at 10 mm, "
                                                    "+10 dB/decade")
    quasi = signals.quasi_static(spec, hz.load)
    paths, ideal = [], []
    t1 = time.perf_counter()
    for k, kmh in enumerate(cfg["speeds_kmh"]):
        v = kmh / 3.6
        r = effective_roughness(truth_spec, f, v, hz)
        res = P.simulate_passby(tables, train, aw_rigid, ac, r, sensor_x=sensor_x)
        ideal.append((res, v))
        sig, truth = signals.synthesise(res, train, v, quasi=quasi,
                                        noise_fraction=cfg["noise_fraction"],
                                        position_error=cfg["position_error"],
                                        seed=cfg["seed"] + 1000 * k + STUDY_TRACKS.index(name))
        truth["roughness"] = {"name": truth_spec.name,
                              "wavelength_m": truth_spec.wavelength.tolist(),
                              "level_db_re_1um": truth_spec.level.tolist()}
        rec = signals.passby_recording(sig, truth, spacing=spec.spacing, location="foot")
        stem = out / "recordings" / name.replace(" ", "_") / f"passby_{k + 1}"
        paths.append(write_recording(stem, rec, data_format="wav", truth=truth)["data"])
    timing["simulate_s"] = time.perf_counter() - t1
    # ---- the estimators read the files (never the truth)
    t2 = time.perf_counter()
    recs = [read_recording(p).select() for p in paths]
    est = passby_decay_rate(recs, PassbyOptions(f_low=cfg["f_low"], f_high=cfg["f_high"]),
                            detect=DETECT)
    timing["tdr_estimators_s"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    levels = [passby_level(rec, cfg["f_low"], cfg["f_high"], wheels=w)
              for rec, w in zip(recs, est.wheels)]
    tdr = {"hammer": hammer.decay_rate, "energy": est.energy.decay_rate,
           "slope": est.slope.decay_rate}
    a_terms = {"model": RM.a_terms_model(tables, bands, wheel_receptance=aw_rigid,
                                         contact_receptance=ac, sensor_x=sensor_x),
               "default": RM.a_terms_default(spec, bands, f, contact=hz,
                                             wheel_receptance=cfg["flexible_receptance"],
                                             cache=cfg["cache"])}
    wl = R.wavelength_bands(0.01, 0.5)

    def combined(method, **kw):
        return RM.combine([method(lev, **kw) for lev in levels], wl).level

    rough = {"full": combined(RM.full_method, tables=tables, wheel_receptance=aw_rigid,
                              contact=hz, sensor_x=sensor_x)}
    for ts in TDR_SOURCES:
        for asrc in A_SOURCES:
            rough[f"simplified_{asrc}_{ts}"] = combined(
                lambda lev, ts=ts, asrc=asrc: RM.simplified_method(
                    lev, tdr[ts], a_terms[asrc], contact=hz))
    true_level = np.interp(np.log(wl), np.log(truth_spec.wavelength[::-1]),
                           truth_spec.level[::-1])
    timing["roughness_s"] = time.perf_counter() - t3
    result = {
        "track": name, "bands_hz": bands.nominal, "hammer": hammer.decay_rate, "far": far,
        "energy": est.energy.decay_rate, "energy_raw": est.energy.raw,
        "energy_status": list(est.energy.status), "energy_std": est.energy.std_passbys,
        "slope": est.slope.decay_rate, "slope_raw": est.slope.raw,
        "slope_status": list(est.slope.status), "slope_std": est.slope.std_passbys,
        "wheels": [w.count for w in est.wheels],
        "wavelength_m": wl, "true_level": true_level, "roughness": rough,
        "a1_model": a_terms["model"].a1, "a2_model": a_terms["model"].a2,
        "a2_default": a_terms["default"].a2,
    }
    if name == cfg["sensitivity_track"]:
        t4 = time.perf_counter()
        result["sensitivity"] = sensitivity(spec, f, bands, levels, tdr["hammer"], wl, hz,
                                            aw_rigid, ac, sensor_x, cfg)
        result["causes"] = causes(spec, tables, bands, ideal, train, hz, aw_rigid, ac,
                                  sensor_x, tdr, a_terms, wl, truth_spec, cfg)
        result["tdr_causes"] = tdr_causes(name, tables, train, hz, aw_rigid, ac, sensor_x,
                                          truth_spec, quasi, out, cfg)
        timing["sensitivity_and_causes_s"] = time.perf_counter() - t4
    timing["total_s"] = time.perf_counter() - t0
    result["timing"] = timing
    log.info("study: %s track done in %.0f s", name, timing["total_s"])
    return result


def sensitivity(spec, f, bands, levels, tdr, wl, hz, aw, ac, sensor_x, cfg) -> dict:
    """Full method and simplified method (model A terms, hammer TDR of the true track) with
    the track model's pad or ballast stiffness off by the given factors."""
    from ..identify import roughness as RM
    from ..simulate import passby as P

    out = {}
    for par in ("kp", "kb"):
        for factor in cfg["sensitivity_factors"]:
            wrong = spec.replace(**{par: getattr(spec.support, par) * factor})
            tab = P.rail_tables(wrong, f, cache=cfg["cache"])
            terms = RM.a_terms_model(tab, bands, wheel_receptance=aw, contact_receptance=ac,
                                     sensor_x=sensor_x)
            key = f"{par} x{factor:g}"
            out[key] = {
                "full": RM.combine([RM.full_method(lv, tab, wheel_receptance=aw, contact=hz,
                                                   sensor_x=sensor_x) for lv in levels],
                                   wl).level,
                "simplified_model_hammer": RM.combine(
                    [RM.simplified_method(lv, tdr, terms, contact=hz) for lv in levels],
                    wl).level}
    return out


def tdr_causes(name, tables, train, hz, aw, ac, sensor_x, truth_spec, quasi, out,
               cfg) -> dict:
    """The pass-by TDR estimators on the same track with one cause removed at a time:
    noise-free recordings, then also without interaction between wheels, then also at
    72 km/h (less filter smear, bandwidth-time products above 1 from 1 kHz)."""
    from ..estimators.passby import PassbyOptions, passby_decay_rate
    from ..io.recording import read_recording, write_recording
    from ..simulate import passby as P, signals
    from ..simulate.chain import effective_roughness

    f = tables.frequency
    cases = {"noise-free": (cfg["speeds_kmh"], True),
             "noise-free, no interaction": (cfg["speeds_kmh"], False),
             "noise-free, no interaction, 72 km/h": ((72.0,) * len(cfg["speeds_kmh"]), False)}
    results = {}
    for c, (label, (speeds, interaction)) in enumerate(cases.items()):
        paths = []
        for k, kmh in enumerate(speeds):
            v = kmh / 3.6
            r = effective_roughness(truth_spec, f, v, hz)
            res = P.simulate_passby(tables, train, aw, ac, r, sensor_x=sensor_x,
                                    interaction=interaction)
            sig, truth = signals.synthesise(res, train, v, quasi=quasi, seed=cfg["seed"] + k)
            rec = signals.passby_recording(sig, truth, spacing=0.6, location="foot")
            stem = out / "recordings" / f"{name}_causes" / f"case{c + 1}_passby_{k + 1}"
            paths.append(write_recording(stem, rec, truth=truth)["data"])
        est = passby_decay_rate([read_recording(p).select() for p in paths],
                                PassbyOptions(f_low=cfg["f_low"], f_high=cfg["f_high"]),
                                detect=DETECT)
        results[label] = {"energy": est.energy.decay_rate, "slope": est.slope.decay_rate,
                          "energy_status": list(est.energy.status),
                          "slope_status": list(est.slope.status)}
    return results


def causes(spec, base, bands, ideal, train, hz, aw, ac, sensor_x, tdr, a_terms, wl,
           truth_spec, cfg) -> dict:
    """Error of the simplified method on noise-free band values (a perfect measurement):
    the full conditions, then with one violated assumption removed at a time."""
    from ..identify import roughness as RM
    from ..models import decay_rate
    from ..simulate import passby as P
    from ..simulate.chain import effective_roughness

    f = base.frequency
    true_level = np.interp(np.log(wl), np.log(truth_spec.wavelength[::-1]),
                           truth_spec.level[::-1])

    def error(tables, hammer, terms, **sim):
        """Simplified estimate - truth on noise-free band values; the study's own
        simulations unless other tables or switches are given."""
        ests = []
        for res0, v in ideal:
            if tables is base and not sim:
                res = res0
            else:
                r = effective_roughness(truth_spec, f, v, hz)
                res = P.simulate_passby(tables, train, aw, ac, r, sensor_x=sensor_x,
                                        before=0.0, after=0.0, **sim)
            lev = RM.ideal_level(res, train, v)
            ests.append(RM.simplified_method(lev, hammer, terms, contact=hz))
        return RM.combine(ests, wl).level - true_level

    out = {}
    for ts in TDR_SOURCES:
        for asrc in A_SOURCES:
            out[f"all effects, A {asrc}, TDR {ts}"] = error(base, tdr[ts], a_terms[asrc])
    out["no interaction (A model, TDR hammer)"] = error(base, tdr["hammer"], a_terms["model"],
                                                        interaction=False)
    out["paper's form (A model, TDR hammer)"] = error(base, tdr["hammer"], a_terms["model"],
                                                      form="paper")
    cont = P.rail_tables(spec, f, continuous=True, cache=cfg["cache"])
    cont_spec = spec.replace(model=spec.kind.continuous.name)
    terms_c = RM.a_terms_model(cont, bands, wheel_receptance=aw, contact_receptance=ac,
                               sensor_x=0.0)
    hammer_c = decay_rate(cont_spec, f, output="foot", cache=cfg["cache"]).decay_rate
    out["continuous support, no interaction (A, TDR of that model)"] = error(
        cont, hammer_c, terms_c, interaction=False)
    return out


def warm_cache(spec, f, cache) -> None:
    """Compute the parameter-free kernels of the track ``spec`` once (rail tables and the
    EN 15461 positions)."""
    from ..models import decay_rate
    from ..simulate import passby as P

    P.rail_tables(spec, f, cache=cache)
    decay_rate(spec, f, output="foot", cache=cache)
