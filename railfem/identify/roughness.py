"""Combined wheel-rail roughness from pass-by rail vibration (METHOD.md section 8).

The measured side is model-free (:mod:`railfem.estimators.passby_level`): the band mean
square of the recorded rail vibration from the first to the last wheel over the sensor,
``L = V (t_N - t_1)`` of train. Both methods turn it into a roughness level per band and
map band centre f_m to the wavelength ``lambda = V / f_m``. docs/roughness.md derives the
formulas and reports their errors.

**Full method** (:func:`full_method`): simulate the same pass-by (detected axle layout,
speed, sensor position, the same averaging window) on the track model with a known
reference roughness r_s (1 um in every band, contact filter applied), then

    L_r = 20 lg(r_s / r0) + L_m - L_s        (m: measured, s: simulated, same quantity)

exact when the roughness is the same at every wheel, incoherent between wheels and
smooth within a band, whatever the track (discrete supports, interaction between wheels).

**Simplified method** (:func:`simplified_method`): incoherent wheels, a position-independent
rail, no interaction, exponential decay ``|Y_s(x)|^2 = |Y_s(0)|^2 exp(-2 beta |x|)`` with
beta = D / 8.686 from a measured decay rate D (dB/m). Averaged over the window of the N
wheels at positions a_n (0 = first, L = last):

    v^2 = omega^2 |r H|^2 |Y_s(0) / (Y_rh + Y_w + Y_c)|^2 N_eff / (beta L),
    N_eff = sum_n [1 - (exp(-2 beta a_n) + exp(-2 beta (L - a_n))) / 2]

(N_eff -> N when the window is long against 1/beta on both sides, the constant
sqrt(N/(beta L)) of docs/passby.md; with the window ending at the first and last wheels,
those two lose half their decay tail: N_eff ~ N - 1 for beta L >> 1). Inverted:

    L_r = L_v - 10 lg(N_eff/(beta L)) - 20 lg(omega) - A1 - A2 - A3 + 20 lg(v0/r0)

A1 = 20 lg|Y_s(0)/Y_rh|, A2 = 20 lg|Y_rh/(Y_rh + Y_w + Y_c)|, A3 = 20 lg|H| (band
energy averages), v0 = 1e-9 m/s, r0 = 1e-6 m, so 20 lg(v0/r0) = -60 dB. A1, A2 come from
the model (:func:`a_terms_model`: the track's rail tables, A2 averaged over the wheel
positions in a span) or from the original method's defaults (:func:`a_terms_default`:
A1 = 0 dB up to 4 kHz, A2 from the continuously supported Timoshenko track with a flexible
wheel).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from railfem.wheelrail import contact as contact_mod
from railfem.conventions import R_REF
from railfem.wheelrail.roughness import wavelength_bands
from railfem.estimators.passby_level import V_REF, PassbyLevel
from railfem.simulate import passby as P
from railfem.simulate.train import TrainLayout
from railfem.standards.iec61260 import ThirdOctaveBands, band_average

log = logging.getLogger(__name__)

__all__ = ["RoughnessEstimate", "ATerms", "full_method", "simplified_method", "ideal_level",
           "band_leakage",
           "a_terms_model", "a_terms_default", "effective_wheel_count", "combine",
           "DB_PER_NEPER", "A1_DEFAULT_MAX_HZ"]

DB_PER_NEPER = 20 * math.log10(math.e)  # D = 8.686 beta
A1_DEFAULT_MAX_HZ = 4000.0  # the original method's A1 = 0 dB holds up to 4 kHz
REF_DB = 20 * math.log10(V_REF / R_REF)  # -60 dB


@dataclass(frozen=True, kw_only=True, eq=False)
class RoughnessEstimate:
    """Roughness level per band of one pass-by (or combined on wavelength bands).

    wavelength: (nb,) band centre wavelength, m. level: (nb,) dB re 1 um (NaN where not
    estimated, see status). method: 'full', 'simplified' or 'combined ...'. speed: m/s
    (NaN for a combination). frequency: (nb,) exact band centres (Hz; NaN for a
    combination). terms: the intermediate quantities per band (dB or SI, named by key).
    status: per band, 'ok' or why not."""

    method: str
    wavelength: np.ndarray
    level: np.ndarray
    speed: float
    frequency: np.ndarray
    status: tuple[str, ...]
    name: str = ""
    terms: dict = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True, eq=False)
class ATerms:
    """A1, A2 per one-third-octave band (dB) and where they came from."""

    bands: ThirdOctaveBands
    a1: np.ndarray
    a2: np.ndarray
    source: str


def ideal_level(result: P.PassbyResult, train: TrainLayout, speed: float,
                name: str = "simulated") -> PassbyLevel:
    """The pass-by level a perfect measurement would give: the simulated band velocity
    mean square over the train positions from the first to the last wheel over the sensor
    (ideal bands, no filters, no noise), for studies of the methods' own errors."""
    from railfem.estimators.wheels import WheelPassage

    x_s = result.settings["sensor_x_m"]
    sel = (result.position >= x_s - 1e-9) & (result.position <= x_s + train.length + 1e-9)
    if sel.sum() < 2:
        raise ValueError("the simulation does not cover the train passage: simulate with "
                         "before >= 0 and after >= 0")
    offsets = np.asarray(train.offsets, dtype=float) - train.offsets[0]
    wheels = WheelPassage(times=offsets / speed, speed=float(speed), speed_source="given",
                          speed_scatter=0.0, positions=offsets)
    return PassbyLevel(name=name, bands=result.bands, quantity="velocity",
                       mean_square=np.mean(result.band_velocity[:, sel] ** 2, axis=1),
                       wheels=wheels, window=(0.0, float(offsets[-1] / speed)), fs=None)


def effective_wheel_count(beta, positions) -> np.ndarray:
    """N_eff of the module docstring for amplitude decay constants ``beta`` (1/m, array)
    and wheel positions (m, first wheel 0, last = L, the window)."""
    a = np.asarray(positions, dtype=float)
    a = a - a[0]
    L = a[-1]
    b = np.asarray(beta, dtype=float)[..., None]
    return np.sum(1 - (np.exp(-2 * b * a) + np.exp(-2 * b * (L - a))) / 2, axis=-1)


def _check_level(level: PassbyLevel, frequency) -> None:
    f = np.asarray(frequency)
    if f.min() > level.bands.centre[0] * 1.001 or f.max() < level.bands.centre[-1] / 1.001:
        raise ValueError(f"the model's frequencies {f.min():.0f}-{f.max():.0f} Hz do not "
                         f"cover the measured bands {level.bands.nominal[0]:g}-"
                         f"{level.bands.nominal[-1]:g} Hz; compute the rail tables on "
                         "iec61260.ninth_octave_grid(f_low, f_high) of the measurement")


def _sensor_output(level_location: str) -> str:
    if level_location not in P.OUTPUTS:
        raise ValueError(f"the sensor location is {level_location!r}; the track model has "
                         f"sensors on the rail {' or '.join(P.OUTPUTS)}: say where the sensor "
                         "was (channel location, or --sensor)")
    return level_location


def full_method(level: PassbyLevel, tables: P.RailTables, *, wheel_receptance,
                contact: contact_mod.HertzContact, sensor_x: float, output: str = "foot",
                contact_filter: str = "analytical", interaction: bool = True,
                form: str = "exact") -> RoughnessEstimate:
    """Full method on one pass-by: simulate it with 1 um roughness in every band on
    ``tables`` (railfem.simulate.passby.rail_tables of the track) with the detected axle
    layout, speed and window, and compare band by band.

    wheel_receptance: (nf,) on tables.frequency (m/N). contact: HertzContact. sensor_x:
    sensor position from a support (m, on the tables' grid). output: 'foot' or 'head'."""
    _check_level(level, tables.frequency)
    _sensor_output(output)
    f = tables.frequency
    V = level.speed
    step = tables.step
    offsets = np.round(level.wheels.positions / step) * step
    if np.any(np.diff(offsets) <= 0):
        raise ValueError(f"{level.name}: wheels closer than the {step} m grid of the tables")
    train = TrainLayout(axle_offsets=tuple(offsets), name="detected")
    x_s = round(sensor_x / step) * step
    r = R_REF * np.sqrt(contact_mod.filter_power(contact_filter, f, V, contact))
    ac = contact_mod.contact_receptance(contact, f)
    sim = P.simulate_passby(tables, train, wheel_receptance, ac, r, sensor_x=x_s,
                            output=output, form=form, interaction=interaction,
                            before=0.0, after=0.0)
    v2 = sim.velocity_sq.mean(axis=1)  # (nf,) over the window: first to last wheel
    q2 = v2 * (2 * np.pi * f) ** 2 if level.quantity == "acceleration" else v2
    ms_s = band_average(f, np.sqrt(q2), level.bands) ** 2
    if level.fs is not None:  # band values as the measurement's filters give them
        ms_s = band_leakage(level.bands, level.fs) @ ms_s
    with np.errstate(divide="ignore", invalid="ignore"):
        l_m = 10 * np.log10(level.mean_square)
        l_s = 10 * np.log10(ms_s)
    lr = 0.0 + l_m - l_s  # 20 lg(r_s/r0) = 0 dB
    ok = np.isfinite(lr)
    return RoughnessEstimate(
        method="full", wavelength=V / level.bands.centre, level=np.where(ok, lr, np.nan),
        speed=V, frequency=level.bands.centre, name=level.name,
        status=tuple("ok" if o else "no_level" for o in ok),
        terms={"L_measured_db": l_m, "L_simulated_db": l_s, "n_wheels": train.n_wheels,
               "window_m": level.length})


def band_leakage(bands: ThirdOctaveBands, fs: float, per_band: int = 64) -> np.ndarray:
    """(nb, nb) matrix C: the band mean squares that the measurement's IEC 61260 filters
    (zero phase, power response |H|^4; railfem.estimators.bands) give are C @ P for a
    spectrum whose power P_b' is spread evenly (flat density) over each band b':
    C_bb' = (1/B_b') int_b' |H_b(f)|^4 df. The diagonal is ~1 (0.7 % short of it: the
    skirts' share), the off-diagonals let a strong neighbour band into a weak one (up to
    ~1 dB next to high-decay bands, docs/roughness.md)."""
    from scipy import signal

    from railfem.standards.iec61260 import band_filter_sos

    u = (np.arange(per_band) + 0.5) / per_band
    c = np.empty((len(bands), len(bands)))
    for j, (lo, hi) in enumerate(zip(bands.lower, bands.upper)):
        f = lo * (hi / lo) ** u                       # log-uniform points, weight f df
        wgt = f * math.log(hi / lo) / per_band / (hi - lo)
        for b, centre in enumerate(bands.centre):
            _, h = signal.sosfreqz(band_filter_sos(float(centre), fs), worN=f, fs=fs)
            c[b, j] = np.sum(np.abs(h) ** 4 * wgt)
    return c


def a_terms_model(tables: P.RailTables, bands: ThirdOctaveBands, *, wheel_receptance,
                  contact_receptance, sensor_x: float, output: str = "foot") -> ATerms:
    """A1, A2 from the track model's rail tables: A1 = 10 lg <|a_s(x_s; x_s)/a_rh(x_s;
    x_s)|^2> (sensor over the wheel), A2 = 10 lg <|a_rh/(a_rh + a_w + a_c)|^2> averaged
    over the band and the wheel positions of one track period."""
    out = P.OUTPUTS.index(_sensor_output(output))
    f = tables.frequency
    x = tables.force_x
    a_rh = P.table_receptance(tables, 0, x, x)          # (nf, n_p)
    x_s = round(sensor_x / tables.step) * tables.step
    a_s = P.table_receptance(tables, out, [x_s], [x_s])[:, 0]
    a_h = P.table_receptance(tables, 0, [x_s], [x_s])[:, 0]
    tot = a_rh + (np.asarray(wheel_receptance) + np.asarray(contact_receptance))[:, None]
    a1 = 20 * np.log10(band_average(f, a_s / a_h, bands))
    # band RMS over the band's points and the wheel positions of one period
    a2 = 20 * np.log10(np.sqrt(np.mean(band_average(f, a_rh / tot, bands) ** 2, axis=1)))
    return ATerms(bands=bands, a1=a1, a2=a2, source=f"model ({tables.description})")


def a_terms_default(spec, bands: ThirdOctaveBands, frequency, *, wheel_receptance=None,
                    contact: contact_mod.HertzContact, cache=None) -> ATerms:
    """The original method's A1, A2: A1 = 0 dB (held above 4 kHz, where it no longer
    applies: a warning), A2 from the continuously supported Timoshenko track of ``spec``
    (railfem.spec.TrackSpec) with a flexible wheel: ``wheel_receptance`` (nf,) on
    ``frequency``, default railfem.wheelrail.wheels.flexible_wheel() (the 920 mm wheel)."""
    from railfem.wheelrail import wheels as W
    from railfem.models import receptance

    f = np.asarray(frequency, dtype=float)
    aw = (W.flexible_wheel(f_max=float(f.max())).receptance(f) if wheel_receptance is None
          else np.asarray(wheel_receptance))
    cont = spec.replace(model="timoshenko-continuous", pad_length=0.0, n_rows=1,
                        deviations=())
    a_rh = receptance(cont, f, [0.0], [0.0], outputs=("head",), cache=cache)[:, 0, 0, 0]
    tot = a_rh + aw + contact_mod.contact_receptance(contact, f)
    a2 = 20 * np.log10(band_average(f, a_rh / tot, bands))
    if bands.centre[-1] > A1_DEFAULT_MAX_HZ * 10 ** 0.05:
        log.warning("default A1 = 0 dB is stated up to 4 kHz; used up to %.0f Hz",
                    bands.nominal[-1])
    return ATerms(bands=bands, a1=np.zeros(len(bands)), a2=a2,
                  source="default: A1 = 0, A2 continuous Timoshenko track + flexible wheel")


def simplified_method(level: PassbyLevel, decay_rate, terms: ATerms, *,
                      contact: contact_mod.HertzContact, contact_filter: str = "analytical",
                      frequency=None) -> RoughnessEstimate:
    """Simplified method on one pass-by (module docstring). decay_rate: (nb,) dB/m on
    ``level.bands`` (NaN where unknown: that band gets no roughness). frequency: the
    narrow-band grid for the band average of A3 (default 1/9 octave)."""
    from railfem.standards.iec61260 import ninth_octave_grid

    b = level.bands
    if len(terms.bands) != len(b) or not np.allclose(terms.bands.centre, b.centre):
        raise ValueError("the A terms are on other bands than the measurement: compute them "
                         "for the measured bands")
    d = np.asarray(decay_rate, dtype=float)
    if d.shape != (len(b),):
        raise ValueError(f"decay_rate must have one value per band ({len(b)}), got shape "
                         f"{d.shape}")
    f = ninth_octave_grid(b.nominal[0], b.nominal[-1]) if frequency is None else frequency
    a3 = 10 * np.log10(band_average(f, np.sqrt(contact_mod.filter_power(
        contact_filter, f, level.speed, contact)), b) ** 2)
    beta = d / DB_PER_NEPER
    with np.errstate(invalid="ignore", divide="ignore"):
        n_eff = effective_wheel_count(np.where(beta > 0, beta, np.nan), level.wheels.positions)
        const = 10 * np.log10(n_eff / (beta * level.length))
        lv = level.velocity_level()
        lr = (lv - const - 20 * np.log10(2 * np.pi * b.centre) - terms.a1 - terms.a2 - a3
              + REF_DB)
    status = tuple("ok" if np.isfinite(x) else "no_decay_rate" if not np.isfinite(di) or
                   di <= 0 else "no_level" for x, di in zip(lr, d))
    return RoughnessEstimate(
        method="simplified", wavelength=level.speed / b.centre, level=lr, speed=level.speed,
        frequency=b.centre, name=level.name, status=status,
        terms={"L_v_db": lv, "constant_db": const, "A1_db": terms.a1, "A2_db": terms.a2,
               "A3_db": a3, "decay_rate_db_per_m": d, "N_eff": n_eff,
               "window_m": level.length, "a_terms": terms.source})


def combine(estimates, wavelengths=None, name: str = "") -> RoughnessEstimate:
    """Energy average of several pass-bys' estimates on common wavelength bands (default:
    the base-10 one-third-octave bands they cover), each interpolated linearly in
    log(lambda); a band is estimated from the pass-bys that cover it and gave a value."""
    estimates = list(estimates)
    if not estimates:
        raise ValueError("no roughness estimates to combine")
    if wavelengths is None:
        lam = np.concatenate([e.wavelength for e in estimates])
        wavelengths = wavelength_bands(lam.min(), lam.max())
    wl = np.asarray(wavelengths, dtype=float)
    power = np.zeros(wl.size)
    count = np.zeros(wl.size, int)
    for e in estimates:
        order = np.argsort(e.wavelength)
        x, y = np.log(e.wavelength[order]), e.level[order]
        ok = np.isfinite(y)
        inside = (np.log(wl) >= x.min() - 1e-9) & (np.log(wl) <= x.max() + 1e-9)
        if ok.sum() < 2:
            continue
        yi = np.interp(np.log(wl), x[ok], y[ok])
        # a band between two estimated bands only (no extrapolation, no bridging of gaps)
        j = np.searchsorted(x, np.log(wl))
        near = np.clip(j, 0, len(x) - 1)
        prev = np.clip(j - 1, 0, len(x) - 1)
        valid = inside & ok[near] & ok[prev]
        power[valid] += 10 ** (yi[valid] / 10)
        count[valid] += 1
    with np.errstate(divide="ignore", invalid="ignore"):
        level = np.where(count > 0, 10 * np.log10(power / np.maximum(count, 1)), np.nan)
    methods = sorted({e.method for e in estimates})
    return RoughnessEstimate(
        method="combined " + "+".join(methods), wavelength=wl, level=level, speed=float("nan"),
        frequency=np.full(wl.size, np.nan), name=name,
        status=tuple("ok" if c else "no_value" for c in count), terms={"n_passbys": count})
