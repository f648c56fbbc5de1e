"""Test-session environment, set before any test module imports numpy or VTK.

* One BLAS/OpenMP thread per process: the dense eigensolvers oversubscribe a small, loaded
  machine and then run many times slower (see benchmarks/bench_waveguide.py). Subprocesses
  started by the tests (examples, import checks) inherit these variables.
* Headless VTK: the EGL render window. railfem.plotting.render already selects it when there is
  no DISPLAY; setting it here covers tests that import pyvista directly.
* One kernel cache for the whole run, never the user's: ``RAILFEM_CACHE`` points at a fresh
  temporary folder (removed at the end), so a kernel several tests need is built once per run
  and a stale or foreign kernel can never make a test pass. Subprocesses (the CLI, examples)
  and pytest-xdist workers inherit it. ``RAILFEM_TEST_CACHE=<folder>`` keeps the test kernels
  in that folder instead, across runs (a warm cache for repeated local runs).

``setdefault``: a thread count given on the command line always wins.

* Bytecode is written (``sys.dont_write_bytecode = False`` and ``PYTHONDONTWRITEBYTECODE``
  dropped from the environment that the workers and subprocesses inherit), whatever the
  shell says: otherwise every pytest worker compiles railfem and rewrites the test
  modules at collection (~3 s of CPU each) and every CLI, example or doc command a test
  starts compiles railfem again (~0.1 s each). The files go to the git-ignored
  ``__pycache__`` folders, as on a machine that does not set the variable.

Under pytest-xdist the tests of a module that share a module-scoped fixture of that module
run on one worker (``pytest_collection_modifyitems``: one xdist_group per module), so the
fixture is built once per run, not once per worker.

``--cpu-durations=N`` lists the N tests that used the most CPU (this process and the
subprocesses it waited for, setup and teardown included) and the total: on a shared machine
the wall times of ``--durations`` measure the load as much as the tests.
"""
import os
import shutil
import sys
import tempfile

sys.dont_write_bytecode = False
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

_OWNER = "RAILFEM_TEST_CACHE_OWNER"  # pid of the process that made the temporary cache
if os.environ.get("RAILFEM_TEST_CACHE"):
    os.environ["RAILFEM_CACHE"] = os.environ["RAILFEM_TEST_CACHE"]
elif not os.environ.get(_OWNER):  # not an xdist worker of a run that made one already
    os.environ["RAILFEM_CACHE"] = tempfile.mkdtemp(prefix="railfem-test-cache-")
    os.environ[_OWNER] = str(os.getpid())


import pytest  # noqa: E402  (after the environment above)


def pytest_unconfigure(config):
    """The temporary kernel cache goes with the process that made it."""
    if os.environ.get(_OWNER) == str(os.getpid()) and not os.environ.get("RAILFEM_TEST_CACHE"):
        shutil.rmtree(os.environ.get("RAILFEM_CACHE", ""), ignore_errors=True)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the xdist_group marks
def pytest_collection_modifyitems(config, items):
    """The tests of a module that use a module-scoped fixture of that module run on one
    pytest-xdist worker (one xdist_group per module, ``--dist loadgroup``): the fixture (a
    fitted pair, a kernel, a mesh) is built once per run, not once per worker that draws
    one of its tests. Tests with an xdist_group of their own keep it."""
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        info = getattr(item, "_fixtureinfo", None)
        module = item.nodeid.split("::")[0]
        for name in getattr(info, "names_closure", ()):
            defs = info.name2fixturedefs.get(name) or ()
            if any(d.scope == "module" and d.baseid == module for d in defs):
                item.add_marker(pytest.mark.xdist_group(f"{module}::module-fixtures"))
                break


@pytest.fixture(autouse=True)
def _fresh_warn_once():
    """Each test hears the once-per-process warnings (railfem.validators.warn_once) anew."""
    from railfem.validators import reset_warn_once

    reset_warn_once()
    yield


# --- CPU time per test -------------------------------------------------------------------

def pytest_addoption(parser):
    parser.addoption("--cpu-durations", type=int, default=None, metavar="N",
                     help="list the N tests using the most CPU time (0: all) and the total")


def _cpu() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    # makereport runs right after each phase (setup, call, teardown): the CPU used since the
    # previous phase ended belongs to this one
    now = _cpu()
    start = getattr(item, "_cpu_mark", None)
    item._cpu_mark = now
    outcome = yield
    if start is not None:
        outcome.get_result().user_properties.append(("cpu_s", now - start))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    item._cpu_mark = _cpu()
    yield


_CPU: dict[str, float] = {}


def pytest_runtest_logreport(report):
    for name, value in report.user_properties:
        if name == "cpu_s":
            _CPU[report.nodeid] = _CPU.get(report.nodeid, 0.0) + value


def pytest_terminal_summary(terminalreporter, config):
    n = config.getoption("--cpu-durations")
    if n is None or not _CPU:
        return
    rows = sorted(_CPU.items(), key=lambda kv: -kv[1])
    tr = terminalreporter
    tr.write_sep("=", f"CPU time per test (total {sum(_CPU.values()):.1f} s over "
                      f"{len(_CPU)} tests; load average {os.getloadavg()[0]:.1f})")
    for nodeid, seconds in rows[:n] if n > 0 else rows:
        tr.write_line(f"{seconds:8.2f}s  {nodeid}")


# --- shared sections of the lateral tests ----------------------------------------------

@pytest.fixture(scope="module")
def lateral_rail():
    """The 60E1 guide at 20 mm with an off-centre vertical and a lateral head patch."""
    from railfem import models
    from railfem.materials import Material
    from railfem.rail import meshing, mobility, waveguide

    g = waveguide.assemble(meshing.get_mesh("60E1", 0.02), Material.steel(0.02))
    top = g.nodes[g.node("head_top")]
    vert_off = mobility.surface_patch(g, (float(top[0]) + 0.01, float(top[1])), 0.02, "z",
                                      label="off-centre vertical")
    lat = mobility.surface_patch(g, models.head_side(g), 0.02, "y", label="lateral",
                                 along="z")
    return g, vert_off, lat


@pytest.fixture(scope="module")
def solid_bar():
    """A solid 100 x 40 mm bar: its section does not distort at low frequency, so the
    rigid-section beam is its exact low-frequency limit."""
    from railfem import models
    from railfem.materials import Material
    from railfem.rail import meshing, mobility, waveguide

    g = waveguide.assemble(meshing.get_mesh("rect:100x40", 0.01), Material.steel(0.02))
    lat = mobility.surface_patch(g, models.head_side(g), 0.02, "y", label="lateral",
                                 along="z")
    return g, lat
