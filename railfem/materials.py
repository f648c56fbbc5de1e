"""Isotropic linear elastic material with hysteretic damping."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, kw_only=True)
class Material:
    """Isotropic material.

    E: Young's modulus (Pa). nu: Poisson's ratio (-). rho: density (kg/m^3).
    loss_factor: hysteretic loss factor eta, E* = E (1 + i eta) (-).
    """

    E: float = 2.1e11
    nu: float = 0.3
    rho: float = 7850.0
    loss_factor: float = 0.0

    def __post_init__(self):
        for name, value in (("E", self.E), ("rho", self.rho)):
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"Material {name} must be a positive finite number, got {value!r}")
        if not (-1.0 < self.nu < 0.5):
            raise ValueError(f"Material Poisson ratio nu must lie in (-1, 0.5), got {self.nu!r}")
        if not np.isfinite(self.loss_factor) or self.loss_factor < 0:
            raise ValueError(
                f"Material loss_factor must be >= 0 (a negative loss factor creates energy), "
                f"got {self.loss_factor!r}")

    @classmethod
    def steel(cls, loss_factor: float = 0.0) -> "Material":
        """Rail steel, METHOD.md defaults: E = 210 GPa, nu = 0.3, rho = 7850 kg/m^3."""
        return cls(loss_factor=loss_factor)

    @property
    def E_complex(self) -> complex:
        return self.E * (1 + 1j * self.loss_factor)

    @property
    def G(self) -> float:
        return self.E / (2 * (1 + self.nu))

    def lame(self) -> tuple[complex, complex]:
        """Complex Lame constants (lambda, mu) in Pa."""
        E, nu = self.E_complex, self.nu
        return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
