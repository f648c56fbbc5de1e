"""Rail cross-section outlines, their named points and polygon section properties.

A profile is a closed counter-clockwise polygon in the (y, z) plane, metres, y lateral with
the (possible) mirror axis at y = 0, z vertical with z = 0 at the underside of the foot.
Nothing here assumes UIC60: any outline (54E1, a rectangle, a worn or asymmetric rail) goes
through the same path. Whether the outline is mirror-symmetric is measured
(:func:`mirror_deviation`), not assumed: :mod:`railfem.rail.meshing` mirrors a half mesh only for
a symmetric outline and meshes an asymmetric one whole.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from ..validators import show

log = logging.getLogger(__name__)

# EN 13674-1:2011 Annex A, profile 60E1: section data used as acceptance values.
EN13674_60E1 = {"area": 76.70e-4, "centroid_z": 80.9e-3, "I_y": 3038.3e-8, "I_z": 512.3e-8}

# Accelerometer on the upper surface of the foot, off the centreline, as a fraction of the
# foot half-width (32.8 mm of 75 mm in the shared reference simulation of 60E1).
FOOT_SENSOR_FRACTION = 32.8 / 75.0

#: An outline is mirror-symmetric when every vertex mirrored about y = 0 lies within this
#: fraction of the section size (larger of height and width) of the outline. The packaged
#: 60E1 outline is symmetric to 16 um (0.9e-4 of its 172 mm height: digitising round-off);
#: a deliberate asymmetry of a tenth of a millimetre is six times the tolerance.
SYMMETRY_TOL = 2e-4

#: Smallest plausible section height (m): an outline below it was almost certainly given in
#: metres where millimetres were expected (a 172 mm rail read as 0.172 mm).
MIN_HEIGHT = 1e-3


@dataclass(frozen=True, kw_only=True)
class RailProfile:
    """A cross-section outline.

    name: label used in file names and plots.
    outline: (n, 2) array of (y, z) vertices in m, counter-clockwise, not repeating the first.
    source: where the outline comes from (free text, kept with outputs).
    smooth: True (default) when the points digitise a curved outline: the mesher joins them
    by splines between the corners (turns sharper than meshing.CORNER_ANGLE_DEG); False
    when the outline is the polygon itself: straight edges between the points, every point
    a corner (what a CSV outline is unless the file asks for smoothing).
    """

    name: str
    outline: np.ndarray
    source: str = ""
    smooth: bool = True
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        pts = np.asarray(self.outline, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise ValueError(
                f"profile {self.name!r}: outline must be an (n, 2) array of (y, z) points with "
                f"n >= 3, got shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ValueError(f"profile {self.name!r}: outline contains NaN or inf coordinates")
        if not isinstance(self.smooth, (bool, np.bool_)):
            raise ValueError(f"profile {self.name!r}: smooth = {self.smooth!r}; give True "
                             "(splines through digitised points) or False (a polygon)")
        object.__setattr__(self, "smooth", bool(self.smooth))
        if np.allclose(pts[0], pts[-1]):
            pts = pts[:-1]
        if _signed_area(pts) <= 0:
            pts = pts[::-1]
        object.__setattr__(self, "outline", pts)
        height = np.ptp(pts[:, 1])
        if height > 1.0:
            raise ValueError(
                f"profile {self.name!r}: outline is {height:.3g} units high; "
                "coordinates must be in metres (use load_outline_csv(..., unit='mm'))")
        if height < MIN_HEIGHT:
            raise ValueError(
                f"profile {self.name!r}: outline is only {height * 1e3:.3g} mm high; it looks "
                "like coordinates in metres read as millimetres (use "
                "load_outline_csv(..., unit='m'), or give the file in mm)")
        crossing = self_intersection(pts)
        if crossing is not None:
            i, j = crossing
            raise ValueError(
                f"profile {self.name!r}: the outline crosses itself (edge {i}-{i + 1} "
                f"crosses edge {j}-{(j + 1) % len(pts)}, near y = {pts[i, 0]:.4g} m, "
                f"z = {pts[i, 1]:.4g} m); give a simple closed outline, points in order "
                "around the section")
        if pts[:, 0].min() >= 0 or pts[:, 0].max() <= 0:
            raise ValueError(
                f"profile {self.name!r}: the outline must straddle the mirror axis y = 0 "
                f"(y range {pts[:, 0].min():.4g} .. {pts[:, 0].max():.4g} m); shift it laterally")

    @property
    def size(self) -> float:
        """The larger of height and width (m): the scale of the symmetry tolerance."""
        return float(np.ptp(self.outline, axis=0).max())

    @property
    def symmetric(self) -> bool:
        """Mirror-symmetric about y = 0 within SYMMETRY_TOL of its size."""
        return mirror_deviation(self.outline) <= SYMMETRY_TOL * self.size

    @property
    def height(self) -> float:
        return float(np.ptp(self.outline[:, 1]))

    @property
    def foot_width(self) -> float:
        """Width of the underside (the outline points within 0.1 % of the height of z_min)."""
        z = self.outline[:, 1]
        bottom = self.outline[z <= z.min() + 1e-3 * self.height]
        return float(np.ptp(bottom[:, 0]))


@dataclass(frozen=True, kw_only=True)
class SectionProperties:
    """area (m^2); centroid_y, centroid_z (m); I_y: second moment about the horizontal
    centroidal axis, governs vertical bending (m^4); I_z: about the vertical axis, lateral
    bending (m^4)."""

    area: float
    centroid_y: float
    centroid_z: float
    I_y: float
    I_z: float


def _signed_area(p: np.ndarray) -> float:
    y, z = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(y * np.roll(z, -1) - np.roll(y, -1) * z))


def _segment_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each point to the closed polygon (nearest edge)."""
    a, b = poly, np.roll(poly, -1, axis=0)
    d = b - a
    out = np.empty(len(points))
    for s in range(0, len(points), 256):  # chunks keep the (n, m) temporaries small
        p = points[s:s + 256, None, :]
        t = np.clip(((p - a) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-300), 0.0, 1.0)
        out[s:s + 256] = np.linalg.norm(p - (a + t[..., None] * d), axis=-1).min(axis=1)
    return out


def mirror_deviation(outline: np.ndarray) -> float:
    """Largest distance (m) from a vertex mirrored about y = 0 to the outline: 0 for an
    exactly mirror-symmetric polygon (the mirror of every vertex lies on the outline)."""
    pts = np.asarray(outline, dtype=float)
    return float(_segment_distance(pts * [-1.0, 1.0], pts).max())


def self_intersection(outline: np.ndarray):
    """(i, j) of the first pair of non-adjacent edges that touch or cross, or None.

    Edge i runs from vertex i to vertex i + 1 (the last closes the polygon)."""
    p = np.asarray(outline, dtype=float)
    n = len(p)
    a, b = p, np.roll(p, -1, axis=0)
    lo, hi = np.minimum(a, b), np.maximum(a, b)

    def orient(p0, p1, q):
        return np.sign((p1[..., 0] - p0[..., 0]) * (q[..., 1] - p0[..., 1])
                       - (p1[..., 1] - p0[..., 1]) * (q[..., 0] - p0[..., 0]))

    for i in range(n - 2):
        j = np.arange(i + 2, n if i > 0 else n - 1)  # skip the two neighbours of edge i
        box = np.all((lo[j] <= hi[i]) & (hi[j] >= lo[i]), axis=1)
        j = j[box]
        if not len(j):
            continue
        o1, o2 = orient(a[i], b[i], a[j]), orient(a[i], b[i], b[j])
        o3, o4 = orient(a[j], b[j], a[i]), orient(a[j], b[j], b[i])
        hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
        if hit.any():
            return i, int(j[np.argmax(hit)])
    return None


def polygon_properties(outline: np.ndarray) -> SectionProperties:
    """Exact area moments of a simple polygon (Green's theorem)."""
    y, z = outline[:, 0], outline[:, 1]
    y1, z1 = np.roll(y, -1), np.roll(z, -1)
    c = y * z1 - y1 * z
    A = 0.5 * c.sum()
    cy = ((y + y1) * c).sum() / (6 * A)
    cz = ((z + z1) * c).sum() / (6 * A)
    Iyy0 = ((z * z + z * z1 + z1 * z1) * c).sum() / 12  # about z = 0
    Izz0 = ((y * y + y * y1 + y1 * y1) * c).sum() / 12
    return SectionProperties(area=A, centroid_y=cy, centroid_z=cz,
                             I_y=Iyy0 - A * cz**2, I_z=Izz0 - A * cy**2)


#: A comment line of an outline CSV asking for splines through its points (RailProfile.smooth).
SMOOTH_DIRECTIVE = "smooth"


def load_outline_csv(path, *, name: str | None = None, unit: str = "mm",
                     smooth: bool | None = None) -> RailProfile:
    """Read a two-column (y, z) outline; '#' lines are comments, a header row is skipped.

    The outline is the polygon of the points (straight edges, RailProfile.smooth False)
    unless the file has a comment line ``# smooth`` (the points digitise curves: splines
    through them) or ``smooth`` is given."""
    scale = {"mm": 1e-3, "m": 1.0}.get(unit)
    if scale is None:
        raise ValueError(f"outline unit must be 'mm' or 'm', got {unit!r}")
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise OSError(f"cannot read rail outline file {path}: {exc}") from exc
    rows = []
    asked = False
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if s.startswith("#"):
            asked = asked or s.lstrip("#").strip().lower() == SMOOTH_DIRECTIVE
        if not s or s.startswith("#"):
            continue
        parts = s.replace(";", ",").split(",")
        try:
            rows.append([float(parts[0]), float(parts[1])])
        except (ValueError, IndexError):
            if rows:  # a header is allowed only before the data
                raise ValueError(
                    f"{path}:{lineno}: expected two numbers 'y,z' in {unit}, got {s!r}") from None
    if len(rows) < 3:
        raise ValueError(f"{path}: found {len(rows)} outline points, need at least 3")
    return RailProfile(name=name or path.stem, outline=np.array(rows) * scale, source=str(path),
                       smooth=asked if smooth is None else smooth)


def uic60() -> RailProfile:
    """UIC60 = EN 13674-1 60E1 from the packaged outline (see railfem/data/SOURCES.md)."""
    ref = resources.files("railfem") / "data" / "uic60_60E1_outline_mm.csv"
    with resources.as_file(ref) as p:
        prof = load_outline_csv(p, name="60E1", smooth=True)  # digitised curves
    return RailProfile(name="60E1", outline=prof.outline, smooth=True,
                       source="alex-nehls/rolland UIC60_cords_pts @32c5c9d (railfem/data)")


def rectangle(width: float, height: float) -> RailProfile:
    """A width x height bar centred on y = 0 with its underside at z = 0 (m)."""
    if not (width > 0 and height > 0):
        raise ValueError(f"rectangle width and height must be > 0 m, got {show(width)}, "
                         f"{show(height)}")
    w = width / 2
    pts = np.array([[-w, 0.0], [w, 0.0], [w, height], [-w, height]])
    return RailProfile(name=f"rect{width * 1e3:g}x{height * 1e3:g}", outline=pts,
                       source="railfem.rail.profiles.rectangle", smooth=False)


def get_profile(name_or_path: str) -> RailProfile:
    """'60E1'/'UIC60', '60E1:foot=F,web=W,head=H' (60E1 as built, changes in mm,
    :func:`uic60_modified`), 'rect:WxH' (mm), or a path to an outline CSV in mm (a polygon unless
    the file asks for smoothing, load_outline_csv)."""
    key = str(name_or_path)
    if key.upper() in ("60E1", "UIC60"):
        return uic60()
    if key.upper().startswith(MODIFIED_PREFIX.upper()):
        return uic60_modified(**parse_modified(key))
    if key.lower().startswith("rect:"):
        try:
            w, h = (float(v) * 1e-3 for v in key[5:].lower().split("x"))
        except ValueError:
            raise ValueError(
                f"profile {key!r}: a rectangle is 'rect:WIDTHxHEIGHT' with two numbers in mm, "
                "e.g. 'rect:20x50'") from None
        if not (np.isfinite(w) and np.isfinite(h) and w > 0 and h > 0):
            raise ValueError(f"profile {key!r}: rectangle width and height must be positive "
                             "finite numbers in mm, e.g. 'rect:20x50'")
        return rectangle(w, h)
    if Path(key).exists():
        return load_outline_csv(key)
    if Path(key).suffix or any(sep in key for sep in ("/", "\\")):
        raise FileNotFoundError(
            f"profile file not found: {key} (an outline CSV, y,z in mm; or use '60E1' or "
            "'rect:WIDTHxHEIGHT')")
    raise ValueError(
        f"unknown profile {key!r}: use '60E1', 'rect:WIDTHxHEIGHT' in mm, or the path of an "
        "outline CSV (y,z in mm)")


def half_outline(profile: RailProfile) -> np.ndarray:
    """The part of the outline with y >= 0, from the bottom axis crossing to the top one.

    Returns (m, 2) points starting on y = 0 at the lowest crossing and ending on y = 0 at
    the highest crossing, counter-clockwise, so that closing it along the axis gives the
    right half of a mirror-symmetric section.
    """
    p = profile.outline
    n = len(p)
    crossings = []  # (position along polygon, point)
    for i in range(n):
        a, b = p[i], p[(i + 1) % n]
        if a[0] == 0.0:
            crossings.append((float(i), a.copy()))
        elif a[0] * b[0] < 0:
            t = a[0] / (a[0] - b[0])
            crossings.append((i + t, a + t * (b - a)))
    if len(crossings) != 2:
        raise ValueError(
            f"profile {profile.name!r}: the outline crosses the mirror axis y = 0 "
            f"{len(crossings)} times; a rail section must cross it exactly twice "
            "(once on the foot underside, once on the head top)")
    (s0, q0), (s1, q1) = sorted(crossings, key=lambda c: c[1][1])
    span = (s1 - s0) % n
    first = int(np.floor(s0)) + 1
    inner = [p[j % n] for j in range(first, first + n) if 0 < (j - s0) % n < span]
    half = np.array([[0.0, q0[1]], *[q for q in inner if q[0] > 0], [0.0, q1[1]]])
    if half[1:-1, 0].min() <= 0 or half[len(half) // 2, 0] <= 0:
        raise ValueError(
            f"profile {profile.name!r}: the outline between the axis crossings does not lie "
            "on the y > 0 side; give the outline counter-clockwise with the foot at z = 0")
    return half


# --------------------------------------------------- the 60E1 section as built
#: Where the deformations of :func:`uic60_modified` act on the 60E1 outline (mm, measured
#: on the packaged outline): the foot tip is 11.8 mm thick (its upper surface starts at
#: z = 11.8); the web faces (|y| 8.25 mm at their narrowest) and their fillets lie at
#: |y| < 18 between the foot's upper surface (z >= 24.7) and the head's underside
#: (z <= 127.6); the head's sides start at z = 136.9 (below: the head's underside).
UIC60_FOOT_TIP = 11.8
UIC60_WEB_FULL, UIC60_WEB_ZERO = 12.0, 18.0  # |y|: full web shift inside, none outside
UIC60_WEB_BAND = (15.0, 150.0)  # z range of the web zone (nothing else at |y| < 18 there)
UIC60_HEAD_BASE = 137.0  # z below which head wear moves nothing
#: Largest change accepted per parameter (mm): beyond it the outline's parts run into each
#: other (a foot tip thinner than 8 mm, a web thinner than 13 mm, a head lower by 20 mm).
MODIFY_LIMITS = {"foot": (-4.0, 10.0), "web": (-3.0, 6.0), "head": (-10.0, 20.0)}
MODIFIED_PREFIX = "60E1:"


def modify_uic60_outline(outline_mm: np.ndarray, *, foot: float = 0.0, web: float = 0.0,
                         head: float = 0.0) -> np.ndarray:
    """The 60E1 outline (mm) with the foot thicker by ``foot`` (mm), the web thicker by
    ``web`` (mm) and the head lower by ``head`` (mm); each may be negative.

    foot: every point above the foot tip's thickness (11.8 mm) moves up by ``foot`` and the
    points of the foot tip's end face in proportion to their height (the underside stays at
    z = 0): the foot is ``foot`` thicker at every y, the web and head ride on it (the rail
    is that much taller). web: the web's two faces move apart by ``web`` / 2 each (the full
    shift at |y| <= 12 mm, tapering to none at |y| = 18 mm over the fillets). head: the
    head above z = 137 mm is compressed so that its top is ``head`` lower (a point at
    height z above 137 mm moves down by head (z - 137) / (172 - 137)). Each map is
    monotone in its coordinate, so the outline stays simple within MODIFY_LIMITS."""
    for name, val in (("foot", foot), ("web", web), ("head", head)):
        lo, hi = MODIFY_LIMITS[name]
        if not (np.isfinite(val) and lo <= val <= hi):
            raise ValueError(f"60E1 {name} change = {show(val)} mm: give a change in mm "
                             f"between {lo:g} and {hi:g}")
    p = np.array(outline_mm, dtype=float)
    y, z = p[:, 0], p[:, 1]
    top = z.max()
    a = np.abs(y)
    web_zone = (z > UIC60_WEB_BAND[0]) & (z < UIC60_WEB_BAND[1])
    taper = np.clip((UIC60_WEB_ZERO - a) / (UIC60_WEB_ZERO - UIC60_WEB_FULL), 0.0, 1.0)
    y_new = y + np.sign(y) * 0.5 * web * taper * web_zone
    span = top - UIC60_HEAD_BASE
    z_new = z - head * np.clip((z - UIC60_HEAD_BASE) / span, 0.0, 1.0)
    z_new = z_new + foot * np.clip(z / UIC60_FOOT_TIP, 0.0, 1.0)
    return np.column_stack([y_new, z_new])


def modified_name(*, foot: float = 0.0, web: float = 0.0, head: float = 0.0) -> str:
    """The profile name :func:`get_profile` reads back: '60E1:foot=+2,web=-1.5,head=0'
    (mm); the nominal '60E1' when all three are 0."""
    if foot == 0 and web == 0 and head == 0:
        return "60E1"
    return f"{MODIFIED_PREFIX}foot={foot:+g},web={web:+g},head={head:+g}"


def uic60_modified(*, foot: float = 0.0, web: float = 0.0, head: float = 0.0) -> RailProfile:
    """60E1 as built: foot thicker by ``foot``, web thicker by ``web``, head lower by
    ``head`` (all mm, see :func:`modify_uic60_outline`). The nominal outline when all are
    0. Its name (:func:`modified_name`) is a profile string of RailSpec.profile."""
    nominal = uic60()
    if foot == 0 and web == 0 and head == 0:
        return nominal
    pts = modify_uic60_outline(nominal.outline * 1e3, foot=foot, web=web, head=head) * 1e-3
    return RailProfile(name=modified_name(foot=foot, web=web, head=head), outline=pts,
                       smooth=True, source=f"{nominal.source}, modified (foot {foot:+g} mm, "
                       f"web {web:+g} mm, head {head:+g} mm)",
                       meta={"foot": float(foot), "web": float(web), "head": float(head)})


def parse_modified(key: str) -> dict:
    """{'foot', 'web', 'head'} in mm from '60E1:foot=+2,web=-1.5' (keys may be left out)."""
    body = key[len(MODIFIED_PREFIX):]
    out = {"foot": 0.0, "web": 0.0, "head": 0.0}
    for part in filter(None, (s.strip() for s in body.split(","))):
        name, _, val = part.partition("=")
        name = name.strip().lower()
        try:
            if name not in out:
                raise ValueError
            out[name] = float(val)
        except ValueError:
            raise ValueError(f"profile {key!r}: a modified 60E1 is '60E1:foot=F,web=W,head=H' "
                             "with changes in mm (any of the three), e.g. "
                             "'60E1:foot=+2,web=-1.5'") from None
    return out
