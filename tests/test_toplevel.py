"""The top-level names of ``railfem`` stay what the README says they are."""
import importlib.util
import subprocess
import sys
from types import ModuleType


def test_frf_stays_the_model_door_after_submodules_load():
    """Importing a submodule sets it as an attribute of its package: a module named
    ``railfem.frf`` replaced the lazily exported function ``rf.frf`` as soon as anything
    imported the FRF container, and the README's ``rf.frf(spec, ...)`` failed with
    "'module' object is not callable"."""
    child = ("import railfem as rf\n"
             "rf.FRF\n"
             "import railfem.io, railfem.measurement, railfem.models\n"
             "assert callable(rf.frf), type(rf.frf)\n"
             "assert rf.frf.__module__ == 'railfem.models', rf.frf.__module__\n")
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_no_submodule_shadows_an_exported_name():
    """A lazily exported name must not also be a submodule of ``railfem``: whichever loads
    last would win."""
    import railfem

    exported = [name for name in railfem.__all__ if name != "__version__"
                and not isinstance(getattr(railfem, name), ModuleType)]
    assert "frf" in exported and "FRF" in exported
    clashes = [name for name in exported
               if importlib.util.find_spec(f"railfem.{name}") is not None]
    assert clashes == []
