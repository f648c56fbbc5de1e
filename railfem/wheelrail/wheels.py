"""Wheel models seen from the contact: rigid, flexible (axisymmetric FE), tabulated.

METHOD.md section 4. Every model returns the vertical (radial) point receptance at the
contact, ``alpha_w = u / F`` (m/N), with frequency on axis 0; the mobility is
``i omega alpha_w``. The sign convention is that of the rail: a force pushing wheel and rail
apart, each displacement measured away from the contact, so in the coupled problem
``(Y_rh + Y_c + Y_w) F = i omega r`` the receptances add.

* :class:`RigidWheel`: ``alpha = -1 / (omega^2 m)`` with m the unsprung mass per wheel.
* :class:`ModalWheel`: a modal sum over circumferential harmonics from
  :mod:`railfem.wheelrail.wheelfe`, built by :func:`flexible_wheel`; modal damping per mode.
* :class:`TabulatedWheel`: a measured or tabulated receptance (railfem.io.wheel_frf reads
  and writes it as an FRF CSV file), interpolated linearly in log frequency (real and
  imaginary parts of the receptance times omega^2, which is smooth for a mass-like wheel).

The default wheel is a 920 mm passenger wheel (docs/wheels.md): ``DEFAULT_UNSPRUNG_MASS``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

log = logging.getLogger(__name__)

__all__ = ["RigidWheel", "ModalWheel", "TabulatedWheel", "receptance", "flexible_wheel",
           "DEFAULT_UNSPRUNG_MASS", "DEFAULT_WHEEL_RADIUS"]

#: Unsprung mass per wheel (kg): half of a 1200 kg passenger wheelset with brake discs
#: (an assumed typical value, docs/wheels.md).
DEFAULT_UNSPRUNG_MASS = 600.0
#: Rolling radius of a new 920 mm wheel (m).
DEFAULT_WHEEL_RADIUS = 0.46


def _omega(frequency) -> np.ndarray:
    f = np.asarray(frequency, dtype=float)
    if np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise ValueError("wheel receptance needs frequencies > 0 Hz (a free mass has no "
                         "static receptance)")
    return 2 * np.pi * f


@dataclass(frozen=True, kw_only=True)
class RigidWheel:
    """A rigid wheel: mass = unsprung mass per wheel (kg)."""

    mass: float = DEFAULT_UNSPRUNG_MASS

    def __post_init__(self):
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ValueError(f"RigidWheel.mass = {self.mass!r} kg: give the unsprung mass per "
                             "wheel, > 0 kg")

    def receptance(self, frequency) -> np.ndarray:
        w = _omega(frequency)
        return -1.0 / (w**2 * self.mass) + 0j


@dataclass(frozen=True, kw_only=True, eq=False)
class ModalWheel:
    """Radial point receptance at the contact as a modal sum.

    frequency: (m,) natural frequencies (Hz, 0 for rigid-body modes). constant: (m,)
    modal constants phi(contact)^2 (1/kg). damping: (m,) modal damping ratios zeta
    (loss factor 2 zeta). harmonic: (m,) circumferential order n of each mode.
    residual: static compliance of the truncated modes (m/N). mass: total wheel + axle
    mass in the model (kg). name: free text. modes: the wheelfe.HarmonicModes (for
    rendering; optional).
    """

    frequency: np.ndarray
    constant: np.ndarray
    damping: np.ndarray
    harmonic: np.ndarray
    residual: float = 0.0
    mass: float = float("nan")
    name: str = "flexible wheel"
    modes: tuple = field(default=(), repr=False)

    def receptance(self, frequency) -> np.ndarray:
        w = _omega(frequency)
        wm2 = (2 * np.pi * self.frequency) ** 2 * (1 + 2j * self.damping)
        terms = self.constant[None, :] / (wm2[None, :] - w[:, None] ** 2)
        return terms.sum(axis=1) + self.residual


@dataclass(frozen=True, kw_only=True, eq=False)
class TabulatedWheel:
    """A tabulated receptance: frequency (Hz, increasing) and values (m/N, complex)."""

    frequency: np.ndarray
    values: np.ndarray
    name: str = "tabulated wheel"

    def __post_init__(self):
        f = np.asarray(self.frequency, dtype=float)
        if f.ndim != 1 or f.size < 2 or np.any(np.diff(f) <= 0) or f[0] <= 0:
            raise ValueError("TabulatedWheel.frequency must be >= 2 increasing values > 0 Hz")
        if np.shape(self.values) != f.shape:
            raise ValueError(f"TabulatedWheel.values has shape {np.shape(self.values)}, "
                             f"expected {f.shape}")

    def receptance(self, frequency) -> np.ndarray:
        f = np.asarray(frequency, dtype=float)
        lo, hi = self.frequency[0], self.frequency[-1]
        if np.any(f < lo * (1 - 1e-9)) or np.any(f > hi * (1 + 1e-9)):
            raise ValueError(f"the tabulated wheel {self.name!r} covers {lo:g}-{hi:g} Hz; "
                             f"asked for {f.min():g}-{f.max():g} Hz: narrow the frequency "
                             "range or extend the table")
        w0 = (2 * np.pi * self.frequency) ** 2
        x, xi = np.log(self.frequency), np.log(f)
        g = self.values * w0
        out = np.interp(xi, x, g.real) + 1j * np.interp(xi, x, g.imag)
        return out / (2 * np.pi * f) ** 2


def receptance(wheel, frequency) -> np.ndarray:
    """The radial contact receptance of any wheel model (m/N), frequency on axis 0."""
    return wheel.receptance(frequency)


def flexible_wheel(*, section=None, h: float | None = None, mass: float = DEFAULT_UNSPRUNG_MASS,
                   f_max: float = 10000.0, n_max: int | None = None, cut_factor: float = 1.5,
                   damping=None, material=None, include_residual: bool = False,
                   progress=None) -> ModalWheel:
    """The axisymmetric FE wheel (wheelfe) as a ModalWheel.

    section: wheelfe.WheelSection (default 920 mm wheel). h: element size (m).
    mass: unsprung mass per wheel (kg); the part not in the wheel section is the rigid
    lumped axle mass on the bore, so the low-frequency limit is RigidWheel(mass).
    f_max: highest frequency of use (Hz); modes up to cut_factor * f_max are kept and the
    rest are left out (see include_residual). n_max: highest harmonic (default: every
    harmonic with a mode below the cut-off; n <= 12 alone misses up to 4 dB at 5 kHz for
    the default wheel). damping: callable
    n -> zeta (default wheelfe.default_damping). include_residual: add the static
    compliance of the truncated modes at the contact node; off by default because it is
    mostly the local deformation under a point force, which the Hertz spring already
    represents (and it grows as the mesh is refined; docs/wheels.md)."""
    from . import wheelfe

    sec = section or wheelfe.WheelSection()
    mesh = wheelfe.mesh_section(sec, h or wheelfe.DEFAULT_WHEEL_H)
    bare = wheelfe.assemble(mesh, material)
    if mass <= bare.mass:
        raise ValueError(f"unsprung mass {mass:.1f} kg is below the wheel's own mass "
                         f"{bare.mass:.1f} kg: give the mass of wheel + share of the axle")
    wheel = replace(bare, axle_mass=mass - bare.mass)
    modes = wheelfe.all_modes(wheel, n_max, cut_factor * f_max, progress=progress)
    damping = damping or wheelfe.default_damping
    freq, const, zeta, harm, resid = [], [], [], [], 0.0
    for hm in modes:
        phi = hm.contact_constants(wheel.contact_node)[:, 0]
        freq.append(hm.frequency)
        const.append(phi**2)
        zeta.append(np.full(len(phi), damping(hm.n)))
        harm.append(np.full(len(phi), hm.n))
        resid += float(hm.residual[0, 0]) if include_residual else 0.0
    return ModalWheel(frequency=np.concatenate(freq), constant=np.concatenate(const),
                      damping=np.concatenate(zeta), harmonic=np.concatenate(harm),
                      residual=resid, mass=wheel.mass + wheel.axle_mass,
                      name=f"axisymmetric FE wheel, R = {sec.radius:g} m, n <= {modes[-1].n}",
                      modes=(wheel, tuple(modes)))


def natural_frequencies(wheel: ModalWheel, n: int) -> np.ndarray:
    """Natural frequencies (Hz) of harmonic n in a ModalWheel."""
    return np.sort(wheel.frequency[wheel.harmonic == n])
