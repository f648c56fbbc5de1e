"""Test-session environment, set before any test module imports numpy or VTK.

* One BLAS/OpenMP thread per process: the dense eigensolvers oversubscribe a small, loaded
  machine and then run many times slower (see benchmarks/bench_waveguide.py). Subprocesses
  started by the tests (examples, import checks) inherit these variables.
* Headless VTK: the EGL render window. railfem.plotting.render already selects it when there is
  no DISPLAY; setting it here covers tests that import pyvista directly.

``setdefault``: a value given on the command line always wins.
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


import pytest  # noqa: E402  (after the environment above)


@pytest.fixture(autouse=True)
def _fresh_warn_once():
    """Each test hears the once-per-process warnings (railfem.validators.warn_once) anew."""
    from railfem.validators import reset_warn_once

    reset_warn_once()
    yield
