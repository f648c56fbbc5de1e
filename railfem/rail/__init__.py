"""The free rail: outline -> curved P2 section mesh -> K0, K1, K2, M -> waves -> mobilities.

``profiles`` (outlines), ``meshing`` (Gmsh and mesh files), ``quality`` (mesh-quality
summary), ``section`` (beam constants on the mesh), ``forms`` and ``waveguide`` (assembly),
``waves`` (k(omega), omega(k)), ``shapes`` (cross-section shapes of the waves),
``labels`` and ``branches`` (wave names and dispersion branches), ``greens`` (free-rail
Green's functions) and ``mobility`` (forced response by residues).
"""
