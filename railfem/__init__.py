"""railfem: railway track vibration with 2.5D waveguide finite elements.

The main public names are available here (the model door of railfem.models, the track
specification of railfem.spec, the parameter space of railfem.params and the FRF
container); everything else lives in its module (``railfem.track.wfe``,
``railfem.track.beams``, ...).

They are loaded on first use (PEP 562): ``import railfem`` itself imports neither numpy
nor scipy, so a program (the ``railfem`` command among them) can still choose its BLAS
threading before numpy loads.
"""
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("railfem")  # single source: pyproject.toml
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

#: public name -> module that defines it
_EXPORTS = {
    "FRF": "response", "Material": "materials", "SupportParameters": "track.supports",
    "Point": "models", "decay_rate": "models", "foot": "models", "frf": "models",
    "head": "models", "receptance": "models",
    "ParameterSpace": "params",
    "MODELS": "spec", "Numerics": "spec", "RailSpec": "spec", "SupportDeviation": "spec",
    "TrackSpec": "spec", "preset": "spec",
}
_MODULES = ("diagnosis", "identify", "io", "models", "params", "spec")

__all__ = ["__version__", *_EXPORTS, *_MODULES]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
    elif name in _MODULES:
        value = import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'railfem' has no attribute {name!r}")
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
