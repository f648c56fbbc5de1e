"""Wheel and rail at the contact: wheel models (``wheels``, ``wheelfe``), Hertz contact and
contact filters (``contact``), roughness spectra (``roughness``)."""
