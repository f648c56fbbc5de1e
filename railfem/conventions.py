"""Sign conventions and names shared by every module.

* Time dependence ``exp(+i omega t)``; a wave along the rail is ``exp(-i k x)``.
* A wave is *positive-going* when ``Im k < 0`` (it decays towards +x); with no damping a
  propagating wave is positive-going when its group velocity is positive.
* Mobility ``Y = v / F`` (m/s/N), receptance ``alpha = u / F = Y / (i omega)`` (m/N),
  accelerance ``A = a / F = i omega Y`` (m/s^2/N).
* Axes: x along the rail, y lateral, z vertical. DOF order per node: (u_x, u_y, u_z).
* Frequency is axis 0 of every frequency-dependent array.
"""

QUANTITIES = ("receptance", "mobility", "accelerance")
QUANTITY_UNITS = {"receptance": "m/N", "mobility": "m/s/N", "accelerance": "m/s^2/N"}
# power of (i omega) that turns a receptance into the quantity
QUANTITY_ORDER = {"receptance": 0, "mobility": 1, "accelerance": 2}
DIRECTIONS = {"x": 0, "y": 1, "z": 2}

V_REF = 1e-9  # m/s, reference for velocity levels
R_REF = 1e-6  # m, reference for roughness levels
