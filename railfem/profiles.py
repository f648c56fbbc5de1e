"""Rail cross-section outlines, their named points and polygon section properties.

A profile is a closed counter-clockwise polygon in the (y, z) plane, metres, y lateral with
the mirror axis at y = 0, z vertical with z = 0 at the underside of the foot. Nothing here
assumes UIC60: any outline (54E1, a rectangle) goes through the same path.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

# EN 13674-1:2011 Annex A, profile 60E1: section data used as acceptance values.
EN13674_60E1 = {"area": 76.70e-4, "centroid_z": 80.9e-3, "I_y": 3038.3e-8, "I_z": 512.3e-8}

# Accelerometer on the upper surface of the foot, off the centreline, as a fraction of the
# foot half-width (32.8 mm of 75 mm in the shared reference simulation of 60E1).
FOOT_SENSOR_FRACTION = 32.8 / 75.0


@dataclass(frozen=True, kw_only=True)
class RailProfile:
    """A cross-section outline.

    name: label used in file names and plots.
    outline: (n, 2) array of (y, z) vertices in m, counter-clockwise, not repeating the first.
    source: where the outline comes from (free text, kept with outputs).
    """

    name: str
    outline: np.ndarray
    source: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        pts = np.asarray(self.outline, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise ValueError(
                f"profile {self.name!r}: outline must be an (n, 2) array of (y, z) points with "
                f"n >= 3, got shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ValueError(f"profile {self.name!r}: outline contains NaN or inf coordinates")
        if np.allclose(pts[0], pts[-1]):
            pts = pts[:-1]
        if _signed_area(pts) <= 0:
            pts = pts[::-1]
        object.__setattr__(self, "outline", pts)
        if pts[:, 1].max() - pts[:, 1].min() > 1.0:
            raise ValueError(
                f"profile {self.name!r}: outline is {np.ptp(pts[:, 1]):.3g} units high; "
                "coordinates must be in metres (use load_outline_csv(..., unit='mm'))")
        if pts[:, 0].min() >= 0 or pts[:, 0].max() <= 0:
            raise ValueError(
                f"profile {self.name!r}: the outline must straddle the mirror axis y = 0 "
                f"(y range {pts[:, 0].min():.4g} .. {pts[:, 0].max():.4g} m); shift it laterally")

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


def load_outline_csv(path, *, name: str | None = None, unit: str = "mm") -> RailProfile:
    """Read a two-column (y, z) outline; '#' lines are comments, a header row is skipped."""
    scale = {"mm": 1e-3, "m": 1.0}.get(unit)
    if scale is None:
        raise ValueError(f"outline unit must be 'mm' or 'm', got {unit!r}")
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise OSError(f"cannot read rail outline file {path}: {exc}") from exc
    rows = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
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
    return RailProfile(name=name or path.stem, outline=np.array(rows) * scale, source=str(path))


def uic60() -> RailProfile:
    """UIC60 = EN 13674-1 60E1 from the packaged outline (see railfem/data/SOURCES.md)."""
    ref = resources.files("railfem") / "data" / "uic60_60E1_outline_mm.csv"
    with resources.as_file(ref) as p:
        prof = load_outline_csv(p, name="60E1")
    return RailProfile(name="60E1", outline=prof.outline,
                       source="alex-nehls/rolland UIC60_cords_pts @32c5c9d (railfem/data)")


def rectangle(width: float, height: float) -> RailProfile:
    """A width x height bar centred on y = 0 with its underside at z = 0 (m)."""
    if not (width > 0 and height > 0):
        raise ValueError(f"rectangle width and height must be > 0 m, got {width!r}, {height!r}")
    w = width / 2
    pts = np.array([[-w, 0.0], [w, 0.0], [w, height], [-w, height]])
    return RailProfile(name=f"rect{width * 1e3:g}x{height * 1e3:g}", outline=pts,
                       source="railfem.profiles.rectangle")


def get_profile(name_or_path: str) -> RailProfile:
    """'60E1'/'UIC60', 'rect:WxH' (mm), or a path to an outline CSV in mm."""
    key = str(name_or_path)
    if key.upper() in ("60E1", "UIC60"):
        return uic60()
    if key.lower().startswith("rect:"):
        w, h = (float(v) * 1e-3 for v in key[5:].lower().split("x"))
        return rectangle(w, h)
    if Path(key).exists():
        return load_outline_csv(key)
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
