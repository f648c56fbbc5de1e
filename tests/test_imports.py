"""``import railfem`` and its modules stay light: no gmsh, PyVista/VTK or Matplotlib at import.

Those libraries are imported inside the functions that need them (meshing: gmsh; plotting:
Matplotlib; rendering: PyVista), so the core and the command line start fast and work on a
machine where a heavy optional library is broken. The check runs in a fresh interpreter
(this test session may have imported them already) and names the module that pulled a
library in. Every ``railfem/**/*.py`` is checked, so new modules are covered automatically.
"""
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

HEAVY = ("gmsh", "pyvista", "vtk", "vtkmodules", "matplotlib")
CORE = ("railfem", "railfem.rail.profiles", "railfem.rail.meshing", "railfem.rail.forms", "railfem.rail.waveguide",
        "railfem.rail.waves", "railfem.rail.section", "railfem.rail.mobility", "railfem.track.supports",
        "railfem.track.beams", "railfem.response", "railfem.standards", "railfem.standards.en15461",
        "railfem.standards.iec61260", "railfem.spec", "railfem.models",
        "railfem.params", "railfem.track.coupling", "railfem.track.kernelcache", "railfem.atomic")
EDGE = ("railfem.plotting", "railfem.plotting.render", "railfem.jobs.common", "railfem.cli")

CHILD = """
import importlib, json, sys
heavy = set(sys.argv[1].split(","))
loaded = lambda: {n.split(".")[0] for n in sys.modules} & heavy
before = loaded()
offenders = {}
for name in sys.argv[2:]:
    seen = loaded()
    importlib.import_module(name)
    if loaded() - seen:
        offenders[name] = sorted(loaded() - seen)
print(json.dumps({"before": sorted(before), "offenders": offenders}))
"""


def package_modules() -> list[str]:
    root = Path(importlib.util.find_spec("railfem").origin).parent
    names = []
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def test_no_module_imports_gmsh_pyvista_or_matplotlib():
    discovered = package_modules()
    assert set(CORE) | set(EDGE) <= set(discovered), "a listed module is missing"
    order = list(CORE) + [m for m in discovered if m not in CORE]  # core first: clearer blame
    proc = subprocess.run([sys.executable, "-c", CHILD, ",".join(HEAVY), *order],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"import failed:\n{proc.stderr[-3000:]}"
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["before"] == [], f"interpreter pre-loads {result['before']}"
    assert result["offenders"] == {}, (
        "modules importing heavy libraries at import time (move the import into the "
        f"function that needs it): {result['offenders']}")


def test_package_exposes_version_and_door():
    """`import railfem` gives the version from the installed metadata (pyproject.toml is its
    single source) and the door's names."""
    from importlib.metadata import version

    import railfem as rf

    assert rf.__version__ == version("railfem")
    for name in ("TrackSpec", "preset", "frf", "decay_rate", "head", "foot", "FRF",
                 "ParameterSpace", "SupportParameters"):
        assert name in rf.__all__ and hasattr(rf, name)


def test_cli_chooses_single_thread_blas_before_numpy_loads():
    """`import railfem` must not load numpy (its names load lazily), so the `railfem`
    command can set one BLAS thread before numpy starts OpenBLAS: with threaded BLAS the
    main job ran 7x slower on 2 cores (many small matrices)."""
    child = ("import sys, os\n"
             "import railfem\n"
             "assert 'numpy' not in sys.modules, 'import railfem loaded numpy'\n"
             "import railfem.cli\n"
             "from threadpoolctl import threadpool_info\n"
             "print(max(i['num_threads'] for i in threadpool_info()))\n")
    env = {k: v for k, v in __import__("os").environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True,
                          timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "1"


def test_docs_entry_points_resolve_from_the_package():
    """The docs write rf.io.read_measurement, rf.identify.fit, rf.diagnosis.diagnose:
    they load lazily from `import railfem as rf`."""
    import railfem as rf

    assert callable(rf.io.read_measurement)
    assert callable(rf.identify.fit)
    assert callable(rf.diagnosis.diagnose)
