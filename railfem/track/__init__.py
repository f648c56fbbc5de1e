"""The supported track: supports, footprints, kernels and coupling solves, the WFE tracks
(``wfe``) and the Timoshenko / Euler-Bernoulli reference tracks (``beams``)."""
