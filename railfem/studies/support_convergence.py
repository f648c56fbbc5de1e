"""Convergence of the supported WFE track in its support discretisation (issue 8, item 4).

A support's pad is represented by springs: across the foot width by a quadrature
(railfem.track.footprints: ``midpoint`` springs through the P2 edge shape functions, or the seed's
springs at ``nodes``), along the rail by rows over the pad length (each row spread over its
slice with the closed-form wave kernels of railfem.track.wfe). This module measures what the
track's answers do when these choices and the section mesh are refined:

* the rail-on-pad resonance of the head point mobility (hammer 20 mm from the sensor at
  mid-span, as in ``railfem track``): its frequency and level, found by a coarse grid and
  a bounded Brent refinement of |Y(f)| (``rail_pad_peak``) on the discrete track;
* the EN 15461 decay rate per one-third-octave band (``decay_rates``) on the periodic
  track (infinitely many supports: the same track without truncation or re-centring).

``support_study`` runs a list of cases (``SupportCase``) in one call; ``railfem
support-convergence`` is its command. Every solve that does not depend on the footprint
(free-rail waves per frequency and mesh, the frozen near-field tail) is shared between the
cases through the wave cache of railfem.rail.waves.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from ..track import footprints
from ..rail import meshing
from ..rail import mobility
from ..rail import section
from ..track import wfe as track
from ..rail import waveguide
from ..materials import Material
from ..standards import en15461, iec61260
from ..spec import TrackSpec, preset as get_preset
from ..track.supports import uniform_layout

log = logging.getLogger(__name__)

POINT_OFFSET = 0.02  # m: the point mobility's hammer sits 20 mm from the sensor (railfem track)
TAIL_FREQUENCY = 50.0  # Hz: the frozen tail of every solve (the track job's lowest band)


@dataclass(frozen=True, kw_only=True)
class SupportCase:
    """One discretisation of the supported track.

    h: section element size (m). rule: footprint rule across the foot width
    (railfem.track.footprints.RULES). n_width: springs across the foot. pad_length: pad length
    along the rail (m), 0 = point-like. n_rows: spring rows along the pad.
    """

    h: float
    rule: str = "midpoint"
    n_width: int = 16
    pad_length: float = 0.0
    n_rows: int = 1

    def __post_init__(self):
        if not (np.isfinite(self.h) and self.h > 0):
            raise ValueError(f"SupportCase.h = {self.h!r} m: use an element size > 0 m")
        if self.rule not in footprints.RULES:
            raise ValueError(f"SupportCase.rule = {self.rule!r}: use one of "
                             f"{', '.join(footprints.RULES)}")
        for name in ("n_width", "n_rows"):
            v = getattr(self, name)
            if isinstance(v, bool) or int(v) != v or v < 1:
                raise ValueError(f"SupportCase.{name} = {v!r}: use an integer >= 1")
        if not (np.isfinite(self.pad_length) and self.pad_length >= 0):
            raise ValueError(f"SupportCase.pad_length = {self.pad_length!r} m: use >= 0 m")
        if self.n_rows > 1 and self.pad_length == 0:
            raise ValueError(f"SupportCase.n_rows = {self.n_rows} needs pad_length > 0 m")

    @property
    def label(self) -> str:
        pad = f"pad {self.pad_length * 1e3:g} mm x {self.n_rows} rows" if self.pad_length \
            else "point-like pad"
        return f"h {self.h * 1e3:g} mm, {self.rule} {self.n_width}, {pad}"


@dataclass(frozen=True, kw_only=True)
class PeakResult:
    """Rail-on-pad resonance of one case: frequency (Hz), level (dB re 1 m/s/N) of the head
    point mobility, the number of frequencies solved and the time taken (s)."""

    case: SupportCase
    frequency: float
    level_db: float
    n_evaluations: int
    seconds: float


@dataclass(frozen=True, kw_only=True)
class DecayResult:
    """EN 15461 decay rates of one case: band centres (Hz), head and foot rates (dB/m)."""

    case: SupportCase
    bands: np.ndarray
    head: np.ndarray
    foot: np.ndarray
    seconds: float


@dataclass
class Rails:
    """Assembled rails by element size, shared by the cases of a study (the rail material
    of the track ``spec``: its loss factor)."""

    spec: TrackSpec
    profile: str = "60E1"
    guides: dict = field(default_factory=dict)

    def get(self, h: float):
        if h not in self.guides:
            mesh = meshing.get_mesh(self.profile, h)
            self.guides[h] = waveguide.assemble(mesh, Material.steel(self.spec.rail.eta))
        return self.guides[h]


def track_spec(track: str | TrackSpec) -> TrackSpec:
    """The track of a study: a TrackSpec as given, a Table 1 name as railfem.spec.preset.
    The studies take its support, sleeper spacing and rail loss factor; the support
    discretisation is each SupportCase's."""
    return track if isinstance(track, TrackSpec) else get_preset(track)


def pad_band(spec: TrackSpec, guide) -> tuple[float, float]:
    """Search band (Hz) of the rail-on-pad resonance: 0.6 to 1.4 times
    sqrt(k_p / (m' d)) / 2 pi, m' the rail mass per metre of the section mesh."""
    mass = guide.material.rho * section.section_constants(guide.mesh).area
    f0 = np.sqrt(spec.support.kp / (mass * spec.spacing)) / (2 * np.pi)
    return 0.6 * f0, 1.4 * f0


def _springs(guide, case: SupportCase):
    return track.foot_springs(guide, case.n_width, rule=case.rule)


def head_point_mobility(guide, spec: TrackSpec, case: SupportCase, f,
                        n_supports: int = 41) -> np.ndarray:
    """|Y| (m/s/N) of the head point mobility at frequencies f (Hz) on the discrete track
    of ``case`` (sensor at mid-span, hammer POINT_OFFSET away); the frozen tail is taken at
    TAIL_FREQUENCY for every call (one shared, cached tail)."""
    d = spec.spacing
    layout = uniform_layout(spec.support, d, n_supports, pad_length=case.pad_length,
                            n_rows=case.n_rows)
    freq = np.concatenate([[TAIL_FREQUENCY], np.atleast_1d(f)])
    r = track.discrete_receptance(
        guide, layout, freq, load=mobility.head_patch(guide, 0.02),
        outputs=[mobility.point(guide, "head_top", label="head")],
        force_x=[d / 2 + POINT_OFFSET], response_x=[d / 2], n_f=_springs(guide, case))
    return np.abs(r.mobility[1:, 0, 0, 0])


def rail_pad_peak(case: SupportCase, track: str | TrackSpec = "site", *,
                  n_supports: int = 41, step: float = 20.0, xtol: float = 0.05,
                  rails: Rails | None = None) -> PeakResult:
    """Frequency and level of the rail-on-pad resonance of the head point mobility.

    |Y| is computed on a grid of ``step`` (Hz) over ``pad_band``; the largest value is then
    refined by bounded Brent minimisation of -|Y(f)| within one step on either side, to
    ``xtol`` (Hz). n_supports discrete supports centred on the sensor span (41 give the
    peak of 131 to the grid resolution on the site track; the study reports the check).
    track: a TrackSpec or a Table 1 name (track_spec)."""
    from scipy.optimize import minimize_scalar

    spec = track_spec(track)
    rails = rails or Rails(spec)
    guide = rails.get(case.h)
    t0 = time.perf_counter()
    lo, hi = pad_band(spec, guide)
    grid = np.arange(np.ceil(lo / step) * step, hi + 1e-9, step)
    Y = head_point_mobility(guide, spec, case, grid, n_supports)
    i = int(np.argmax(Y))
    if i in (0, len(grid) - 1):
        raise ValueError(f"{case.label}: the largest mobility in {lo:.0f}-{hi:.0f} Hz lies "
                         f"on the band edge ({grid[i]:.0f} Hz): no rail-on-pad peak found")
    count = [len(grid)]

    def minus(f):
        count[0] += 1
        return -float(head_point_mobility(guide, spec, case, [f], n_supports)[0])

    res = minimize_scalar(minus, bounds=(grid[i - 1], grid[i + 1]), method="bounded",
                          options={"xatol": xtol})
    f_peak, y_peak = (float(res.x), -float(res.fun)) if -res.fun >= Y[i] else \
        (float(grid[i]), float(Y[i]))
    out = PeakResult(case=case, frequency=f_peak, level_db=20 * np.log10(y_peak),
                     n_evaluations=count[0], seconds=time.perf_counter() - t0)
    log.info("%s: rail-on-pad peak %.2f Hz, %.2f dB (%d frequencies, %.0f s)", case.label,
             out.frequency, out.level_db, out.n_evaluations, out.seconds)
    return out


def decay_rates(case: SupportCase, track: str | TrackSpec = "site", *,
                f_low: float = 100.0, f_high: float = 4000.0,
                rails: Rails | None = None) -> DecayResult:
    """EN 15461 decay rates (head and foot sensor) per one-third-octave band of the
    periodic track: sensor at mid-span, hammer at the 29 positions (position 0 realised
    POINT_OFFSET from the sensor, as in ``railfem track``). track: a TrackSpec or a
    Table 1 name (track_spec)."""
    spec = track_spec(track)
    rails = rails or Rails(spec)
    guide = rails.get(case.h)
    t0 = time.perf_counter()
    d = spec.spacing
    pos = en15461.hammer_positions(d)
    fx = d / 2 + np.where(pos == 0, POINT_OFFSET, pos)
    f = iec61260.ninth_octave_grid(f_low, f_high)
    freq = np.concatenate([[TAIL_FREQUENCY], f]) if f.min() > TAIL_FREQUENCY else f
    outputs = [mobility.point(guide, "head_top", label="head"),
               mobility.point(guide, "foot_sensor", label="foot")]
    r = track.periodic_receptance(guide, spec.support, d, freq,
                                  load=mobility.head_patch(guide, 0.02), outputs=outputs,
                                  force_x=fx, response_x=[d / 2], pad_length=case.pad_length,
                                  n_rows=case.n_rows, n_f=_springs(guide, case))
    Y = r.mobility[len(freq) - len(f):, :, 0, :]  # (nf, 2, n_pos)
    res = [en15461.decay_rate(f, Y[:, j, :], pos) for j in range(2)]
    out = DecayResult(case=case, bands=res[0].frequency, head=res[0].decay_rate,
                      foot=res[1].decay_rate, seconds=time.perf_counter() - t0)
    log.info("%s: decay rates done (%.0f s)", case.label, out.seconds)
    return out


def sweeps(sizes, widths, rows=(1, 2, 3, 6), pad_lengths=(0.0, 0.15), *,
           rule: str = "midpoint", h_ref: float | None = None, width_ref: int | None = None,
           rows_ref: int = 3) -> dict:
    """Three one-at-a-time sweeps around a reference discretisation, per pad length:
    "h" (each element size, m), "width" (each number of springs across the foot),
    "rows" (each number of rows, pads of finite length only). The reference is the finest
    size, the most springs and ``rows_ref`` rows unless given. Returns
    {(sweep, pad_length): [SupportCase, ...]} in refinement order."""
    sizes = sorted({float(h) for h in sizes}, reverse=True)
    widths = sorted({int(n) for n in widths})
    rows = sorted({int(r) for r in rows})
    if not sizes or not widths:
        raise ValueError("the support study needs at least one element size and one width "
                         "quadrature")
    h_ref = min(sizes) if h_ref is None else float(h_ref)
    width_ref = max(widths) if width_ref is None else int(width_ref)
    out = {}
    for L in pad_lengths:
        r_ref = int(rows_ref) if L > 0 else 1
        ref = {"h": h_ref, "rule": rule, "n_width": width_ref, "pad_length": float(L),
               "n_rows": r_ref}
        out["h", L] = [SupportCase(**{**ref, "h": h}) for h in sizes]
        out["width", L] = [SupportCase(**{**ref, "n_width": n}) for n in widths]
        if L > 0:
            out["rows", L] = [SupportCase(**{**ref, "n_rows": r}) for r in rows]
    return out


def support_study(cases: dict, track: str | TrackSpec = "site", *, decay: bool = False,
                  n_supports: int = 41, profile: str = "60E1", progress=None) -> dict:
    """Peaks (and with ``decay`` the decay rates) of every case of ``cases`` ({key: [case]},
    e.g. from ``sweeps``); a case shared by several sweeps is computed once and rails are
    assembled once per h. track: a TrackSpec or a Table 1 name (track_spec). Returns
    {"peaks": {key: [PeakResult]}, "decay": {key: [...]}}."""
    if not cases or not all(cases.values()):
        raise ValueError("support_study needs at least one SupportCase per sweep")
    spec = track_spec(track)
    rails = Rails(spec, profile)
    unique = list(dict.fromkeys(c for group in cases.values() for c in group))
    unique.sort(key=lambda c: -c.h)  # one rail at a time, coarse first
    peaks, rates = {}, {}
    for i, case in enumerate(unique):
        if case.h not in rails.guides:
            rails.guides.clear()  # keep one assembled rail in memory
        peaks[case] = rail_pad_peak(case, spec, n_supports=n_supports, rails=rails)
        if decay:
            rates[case] = decay_rates(case, spec, rails=rails)
        if progress:
            progress(i + 1, len(unique))
    return {"peaks": {k: [peaks[c] for c in v] for k, v in cases.items()},
            "decay": {k: [rates[c] for c in v] for k, v in cases.items()} if decay else {}}


def changes(values) -> np.ndarray:
    """Relative change of each value from the previous one (first: NaN)."""
    v = np.asarray(values, dtype=float)
    return np.concatenate([[np.nan], np.abs(np.diff(v)) / np.abs(v[1:])])


PEAK_COLUMNS = ("sweep", "h_mm", "rule", "n_width", "pad_length_m", "n_rows", "peak_hz",
                "level_db", "change_pct", "level_change_db", "n_evaluations", "seconds")


def peak_rows(peaks: dict) -> list[tuple]:
    """One row per case of ``support_study(...)["peaks"]`` (columns PEAK_COLUMNS); the
    changes are from the previous, coarser case of the same sweep."""
    return [row for (sweep, _), group in peaks.items() for row in _group_rows(sweep, group)]


def _group_rows(sweep, group):
    ch = changes([p.frequency for p in group])
    dl = np.concatenate([[np.nan], np.diff([p.level_db for p in group])])
    return [(sweep, p.case.h * 1e3, p.case.rule, p.case.n_width, p.case.pad_length,
             p.case.n_rows, p.frequency, p.level_db, 100 * c, d, p.n_evaluations, p.seconds)
            for p, c, d in zip(group, ch, dl)]


def peak_table(peaks: dict) -> str:
    """Text table of ``support_study(...)["peaks"]``: per sweep, peak and level with the
    change from the coarser case above."""
    lines = [(f"{'sweep':<6} {'case':<44} {'peak Hz':>9} {'level dB':>9} {'df/f %':>7} "
              f"{'dL dB':>6} {'evals':>6} {'s':>5}")]
    for (sweep, _), group in peaks.items():
        for r, p in zip(_group_rows(sweep, group), group):
            lines.append(f"{sweep:<6} {p.case.label:<44} {r[6]:9.2f} {r[7]:9.2f} "
                         f"{r[8]:7.2f} {r[9]:6.2f} {r[10]:6d} {r[11]:5.0f}")
    return "\n".join(lines)


def peak_csv(peaks: dict) -> str:
    """CSV text of ``peak_rows``."""
    lines = [",".join(PEAK_COLUMNS)]
    for r in peak_rows(peaks):
        lines.append(",".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in r))
    return "\n".join(lines) + "\n"


def decay_csv(rates: dict) -> str:
    """CSV text of ``support_study(...)["decay"]``: one row per case and band, head and
    foot decay rates (dB/m)."""
    lines = [("sweep,h_mm,rule,n_width,pad_length_m,n_rows,band_hz,head_db_per_m,"
              "foot_db_per_m")]
    for (sweep, _), group in rates.items():
        for r in group:
            k = r.case
            for b, fc in enumerate(r.bands):
                lines.append(f"{sweep},{k.h * 1e3:g},{k.rule},{k.n_width},{k.pad_length:g},"
                             f"{k.n_rows},{fc:g},{r.head[b]:.5g},{r.foot[b]:.5g}")
    return "\n".join(lines) + "\n"


__all__ = ["PEAK_COLUMNS", "POINT_OFFSET", "TAIL_FREQUENCY", "DecayResult", "PeakResult",
           "Rails", "SupportCase", "changes", "decay_csv", "decay_rates", "head_point_mobility",
           "pad_band", "track_spec",
           "peak_csv", "peak_rows", "peak_table", "rail_pad_peak", "support_study", "sweeps"]
