"""Multi-wheel interaction and the train pass-by (METHOD.md section 5).

Wheels stand still at positions stepped by ``step`` (0.1 m) past the sensor (Doppler
neglected). With receptances (alpha = Y / i omega) the wheel-rail equations for roughness
r_i acting at wheel i alone are

    (alpha_rh + alpha_c + alpha_w) F^(i) = r_i e_i          i.e.  F^(i) = B e_i r_i,

B = (alpha_rh + alpha_c + alpha_w)^-1, alpha_rh the rail-head receptance matrix between the
wheels (from the track model, for where each wheel stands relative to the supports),
alpha_c and alpha_w diagonal. The sensor velocity due to source i is
V^(i) = i omega sum_n alpha_s,n F_n^(i). Roughness is incoherent between wheels with the
same spectrum |r|, so

    exact:  |V|^2 = omega^2 |r|^2 sum_i |sum_n alpha_s,n B_ni|^2
    paper:  |F_n|^2 = |r|^2 sum_i |B_ni|^2,   |V|^2 = omega^2 sum_n |F_n|^2 |alpha_s,n|^2

(the paper's form drops the cross terms between wheels of the same source). With one
wheel, F = r / (alpha_rh + alpha_c + alpha_w) = i omega r / (Y_rh + Y_c + Y_w).

The track enters only through :class:`RailTables`: receptances on a grid of response
positions for force positions within one period of the track (the sleeper spacing for
discrete supports, one position for a continuous support). :func:`rail_tables` is the one
adapter to the track model. Since the wheels move together on the grid, alpha_rh and B
repeat with the track period: they are solved once per phase.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..spec import MODEL_KINDS
from ..standards import iec61260
from .train import TrainLayout

log = logging.getLogger(__name__)

__all__ = ["RailTables", "rail_tables", "table_receptance", "PassbyResult", "simulate_passby",
           "train_positions", "simplified_band_velocity", "DEFAULT_STEP", "FORMS", "OUTPUTS"]

DEFAULT_STEP = 0.1  # m, METHOD.md section 5
FORMS = ("exact", "paper")
OUTPUTS = ("head", "foot")
CONTINUOUS_OF = {name: kind.continuous.name for name, kind in MODEL_KINDS.items()}


@dataclass(frozen=True, kw_only=True, eq=False)
class RailTables:
    """Rail receptances for forces on the rail head, on a grid.

    frequency: (nf,) Hz. step: grid step (m). period: track period (m), a multiple of
    step (step itself for a position-independent rail). response_x: (n_r,) grid of
    response positions (m). force_x: (n_p,) force positions 0, step, ... < period.
    receptance: (nf, 2, n_r, n_p) complex (m/N), outputs (head, foot) as OUTPUTS.
    description: what produced them. Supports sit at x = j * period for discrete tracks.
    """

    frequency: np.ndarray
    step: float
    period: float
    response_x: np.ndarray
    force_x: np.ndarray
    receptance: np.ndarray
    description: str = ""

    def __post_init__(self):
        nf = len(self.frequency)
        shape = (nf, len(OUTPUTS), len(self.response_x), len(self.force_x))
        if self.receptance.shape != shape:
            raise ValueError(f"RailTables.receptance has shape {self.receptance.shape}, "
                             f"expected {shape}")
        p = self.period / self.step
        if abs(p - round(p)) > 1e-6 or round(p) != len(self.force_x):
            raise ValueError(f"RailTables: the period {self.period} m must hold a whole number "
                             f"of steps {self.step} m, one force position per step")

    @property
    def max_distance(self) -> float:
        """Largest |response - force| separation covered on both sides (m)."""
        return float(min(-self.response_x[0], self.response_x[-1] - self.period))


def rail_tables(spec, frequency, *, model: str | None = None, step: float = DEFAULT_STEP,
                max_distance: float = 30.0, continuous: bool = False, cache=None,
                progress=None) -> RailTables:
    """THE adapter to the track model: receptance tables for the pass-by, from the model
    door (railfem.models.receptance).

    spec: the track, a railfem.spec.TrackSpec (railfem.spec.preset(name) for a Table 1
    track). model: overrides the spec's model kind. continuous: the 'position-independent
    rail' switch (the continuous-support counterpart of the model, point supports).
    max_distance: largest force-response separation (m); transfers beyond it are taken as
    zero (the log says how small they were). cache: the door's kernel cache.
    """
    from ..models import receptance
    from ..spec import TrackSpec

    if not isinstance(spec, TrackSpec):
        raise TypeError(f"rail_tables takes a railfem.spec.TrackSpec, got "
                        f"{type(spec).__name__}: use railfem.spec.preset(name) for a Table 1 "
                        "track")
    model = model or spec.model
    if model not in CONTINUOUS_OF:
        raise ValueError(f"unknown track model {model!r}; choose one of "
                         f"{', '.join(CONTINUOUS_OF)}")
    if not (step > 0 and max_distance > 0):
        raise ValueError(f"step = {step!r} m and max_distance = {max_distance!r} m must be > 0")
    if continuous:
        spec, period = spec.replace(model=CONTINUOUS_OF[model], pad_length=0.0, n_rows=1), step
    else:
        spec, period = spec.replace(model=model), spec.spacing
    n_p = round(period / step)
    if abs(n_p * step - period) > 1e-9 * period:
        raise ValueError(f"the sleeper spacing {spec.spacing} m is not a whole number of steps "
                         f"{step} m: choose a step that divides it")
    n_s = math.ceil(max_distance / step - 1e-9)
    rx = np.round(np.arange(-n_s, n_s + n_p) * step, 10)
    fx = np.round(np.arange(n_p) * step, 10)
    t0 = time.perf_counter()
    a = receptance(spec, frequency, fx, rx, outputs=("head", "foot"), cache=cache,
                   progress=progress)
    log.info("rail tables %s, %s: %d x %d positions, %d frequencies in %.1f s", spec.name,
             spec.model, len(rx), len(fx), len(frequency), time.perf_counter() - t0)
    edge = np.abs(a[:, 0, [0, -1], 0]).max(axis=1) / np.abs(a[:, 0, n_s, 0])
    log.info("rail tables: head transfer at +-%.1f m is %.0f dB below the point receptance "
             "at worst (%.0f Hz)", n_s * step, -20 * np.log10(edge.max()),
             frequency[int(np.argmax(edge))])
    return RailTables(frequency=np.asarray(frequency, dtype=float), step=step, period=period,
                      response_x=rx, force_x=fx, receptance=a,
                      description=f"{spec.name} track, {spec.model}")


def _grid(x, step: float, what: str) -> np.ndarray:
    i = np.round(np.asarray(x, dtype=float) / step)
    if np.any(np.abs(i * step - np.asarray(x)) > 1e-6):
        raise ValueError(f"{what} must lie on the {step} m grid of the rail tables; got "
                         f"{np.asarray(x)[np.abs(i * step - np.asarray(x)) > 1e-6][:5]} m: "
                         "round the positions or use a finer step")
    return i.astype(np.int64)


def table_receptance(tables: RailTables, output: int, x_resp, x_force) -> np.ndarray:
    """Receptance (nf, *shape) for responses at x_resp and forces at x_force (broadcast
    together, on the grid); zero beyond the tables' max_distance."""
    n_p = len(tables.force_x)
    ir = _grid(x_resp, tables.step, "response positions")
    jf = _grid(x_force, tables.step, "force positions")
    ir, jf = np.broadcast_arrays(ir, jf)
    phase = np.mod(jf, n_p)
    shift = jf - phase
    k = ir - shift - int(round(tables.response_x[0] / tables.step))
    inside = (k >= 0) & (k < len(tables.response_x))
    out = tables.receptance[:, output, np.clip(k, 0, len(tables.response_x) - 1), phase]
    return np.where(inside[None], out, 0.0)


def train_positions(train: TrainLayout, sensor_x: float, *, before: float, after: float,
                    step: float = DEFAULT_STEP) -> np.ndarray:
    """Positions X of the leading wheel (m) from sensor_x - before to sensor_x +
    train.length + after, on the step grid (the train runs towards +x)."""
    i0 = math.floor((sensor_x - before) / step + 1e-9)
    i1 = math.ceil((sensor_x + train.length + after) / step - 1e-9)
    return np.round(np.arange(i0, i1 + 1) * step, 10)


@dataclass(frozen=True, kw_only=True, eq=False)
class PassbyResult:
    """A simulated pass-by.

    frequency: (nf,) Hz. position: (nx,) leading-wheel position X (m); wheel n stands at
    X - offset_n. velocity_sq: (nf, nx) |V_s|^2 at the sensor ((m/s)^2 per narrow-band
    point: the band-RMS velocity in a one-third-octave band centred there).
    force_sq: (nf, nx, N) |F_n|^2 (N^2) incoherent sum over the sources. bands: the
    one-third-octave bands; band_velocity: (nb, nx) band RMS velocity (m/s).
    roughness: (nf,) effective roughness amplitude used (m, contact filter included).
    settings: dict of the switches and inputs.
    """

    frequency: np.ndarray
    position: np.ndarray
    velocity_sq: np.ndarray
    force_sq: np.ndarray
    bands: iec61260.ThirdOctaveBands
    band_velocity: np.ndarray
    roughness: np.ndarray
    settings: dict = field(default_factory=dict)

    def band_level(self, v_ref: float = 1e-9) -> np.ndarray:
        """(nb, nx) band velocity level, dB re v_ref (default 1e-9 m/s); -inf where no
        wheel is within the rail tables' max_distance of the sensor."""
        with np.errstate(divide="ignore"):
            return 20 * np.log10(self.band_velocity / v_ref)

    def average_level(self, window=None, v_ref: float = 1e-9) -> np.ndarray:
        """(nb,) pass-by average: 10 lg of the mean of |V|^2 over the positions in window
        (min, max of X; default all simulated positions), dB re v_ref."""
        sel = np.ones(len(self.position), bool) if window is None else \
            (self.position >= window[0] - 1e-9) & (self.position <= window[1] + 1e-9)
        return 10 * np.log10(np.mean(self.band_velocity[:, sel] ** 2, axis=1) / v_ref**2)


def _check_options(form, output):
    if form not in FORMS:
        raise ValueError(f"form = {form!r}: choose one of {FORMS}")
    if output not in OUTPUTS:
        raise ValueError(f"sensor output {output!r}: choose one of {OUTPUTS}")


def simulate_passby(tables: RailTables, train: TrainLayout, wheel_receptance,
                    contact_receptance, roughness, *, sensor_x: float | None = None,
                    positions=None, output: str = "foot", form: str = "exact",
                    interaction: bool = True, before: float = 30.0, after: float = 30.0,
                    settings: dict | None = None) -> PassbyResult:
    """Band levels at the sensor for every train position (see the module docstring).

    wheel_receptance, contact_receptance: (nf,) complex on tables.frequency (m/N).
    roughness: (nf,) effective roughness amplitude per narrow-band point (m), contact
    filter applied. sensor_x: sensor position (m; default mid-span, period/2 rounded to the
    grid). positions: leading-wheel positions X (default train_positions(before, after)).
    output: sensor on the 'head' or the 'foot'. form: 'exact' or 'paper'.
    interaction: False = no interference between wheels (diagonal alpha_rh)."""
    _check_options(form, output)
    f = tables.frequency
    nf = len(f)
    aw = np.broadcast_to(np.asarray(wheel_receptance, dtype=complex), (nf,))
    ac = np.broadcast_to(np.asarray(contact_receptance, dtype=complex), (nf,))
    r = np.broadcast_to(np.asarray(roughness, dtype=float), (nf,))
    step = tables.step
    if sensor_x is None:
        sensor_x = round(tables.period / 2 / step) * step
    X = train_positions(train, sensor_x, before=before, after=after, step=step) \
        if positions is None else np.asarray(positions, dtype=float)
    iX = _grid(X, step, "train positions")
    io = _grid(train.offsets, step, "axle offsets")
    _grid([sensor_x], step, "the sensor position")
    n_p = len(tables.force_x)
    N = train.n_wheels
    out_idx = OUTPUTS.index(output)
    omega2 = (2 * np.pi * f) ** 2
    vel = np.empty((nf, len(X)))
    force = np.empty((nf, len(X), N))
    t0 = time.perf_counter()
    for ph in np.unique(np.mod(iX, n_p)):
        xw = (ph - io) * step  # wheel positions for this phase (X = ph * step)
        a = table_receptance(tables, 0, xw[:, None], xw[None, :])  # (nf, N, N)
        if not interaction:
            a = a * np.eye(N)[None]
        a = a + np.eye(N)[None] * (aw + ac)[:, None, None]
        B = np.linalg.inv(a)                                      # (nf, N, N)
        fsq = np.sum(np.abs(B) ** 2, axis=2) * (r**2)[:, None]    # |F_n|^2 (nf, N)
        sel = np.nonzero(np.mod(iX, n_p) == ph)[0]
        wheels_x = (iX[sel, None] - io[None, :]) * step           # (ns, N)
        s = table_receptance(tables, out_idx, np.full(wheels_x.shape, sensor_x), wheels_x)
        if form == "exact":
            z = np.einsum("fsn,fni->fsi", s, B)
            vel[:, sel] = omega2[:, None] * r[:, None] ** 2 * np.sum(np.abs(z) ** 2, axis=2)
        else:
            vel[:, sel] = omega2[:, None] * np.einsum("fn,fsn->fs", fsq, np.abs(s) ** 2)
        force[:, sel, :] = fsq[:, None, :]
    log.info("pass-by: %d wheels, %d positions, %d frequencies (%s form%s) in %.2f s", N,
             len(X), nf, form, "" if interaction else ", no interaction",
             time.perf_counter() - t0)
    bands = iec61260.third_octave_bands(float(f.min()), float(f.max()))
    band_v = iec61260.band_average(f, np.sqrt(vel), bands)
    cfg = {"form": form, "interaction": interaction, "output": output,
           "sensor_x_m": float(sensor_x), "step_m": step, "n_wheels": N,
           "tables": tables.description, "max_distance_m": tables.max_distance}
    cfg.update(settings or {})
    return PassbyResult(frequency=f, position=X, velocity_sq=vel, force_sq=force, bands=bands,
                        band_velocity=band_v, roughness=np.asarray(r), settings=cfg)


def simplified_band_velocity(frequency, bands, *, rail_receptance, sensor_receptance,
                             wheel_receptance, contact_receptance, roughness, decay_rate,
                             n_wheels: int, length: float) -> np.ndarray:
    """METHOD.md section 8, simplified method, forward: band RMS sensor velocity (m/s)

        v^2 = <omega^2 |alpha_s|^2 |r|^2 / |alpha_rh + alpha_w + alpha_c|^2>_band N/(beta L)

    with beta = D / (20 lg e) (D the band decay rate, dB/m) and L the length of train
    positions the average runs over (docs/passby.md derives the constant). Arrays are
    narrow-band on ``frequency``; decay_rate is per band of ``bands``."""
    w2 = (2 * np.pi * np.asarray(frequency)) ** 2
    num = w2 * np.abs(sensor_receptance) ** 2 * np.asarray(roughness) ** 2
    per_wheel = num / np.abs(rail_receptance + wheel_receptance + contact_receptance) ** 2
    band = iec61260.band_average(frequency, np.sqrt(per_wheel), bands) ** 2
    beta = np.asarray(decay_rate) / (20 * np.log10(np.e))
    return np.sqrt(band * n_wheels / (beta * length))
