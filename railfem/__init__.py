"""railfem: railway track vibration with 2.5D waveguide finite elements.

The main public names are re-exported here (the model door of railfem.models, the track
specification of railfem.spec, the parameter space of railfem.params and the FRF
container); everything else lives in its module (``railfem.track``, ``railfem.beams``, ...).
"""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("railfem")  # single source: pyproject.toml
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

from . import models, params, spec  # noqa: E402
from .frf import FRF  # noqa: E402
from .materials import Material  # noqa: E402
from .models import Point, decay_rate, foot, frf, head, receptance  # noqa: E402
from .params import ParameterSpace  # noqa: E402
from .spec import MODELS, Numerics, RailSpec, SupportDeviation, TrackSpec, preset  # noqa: E402
from .supports import SupportParameters  # noqa: E402

__all__ = ["__version__", "FRF", "Material", "MODELS", "Numerics", "ParameterSpace", "Point",
           "RailSpec",
           "SupportDeviation", "SupportParameters", "TrackSpec", "decay_rate", "foot", "frf",
           "head", "preset", "receptance"]
