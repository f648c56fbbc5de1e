"""Every third-party module the package imports is a declared dependency (or installed by
one): a fresh `pip install .` must not miss one that this machine happens to have."""
import ast
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _requirement_name(req: str) -> str:
    return _norm(re.split(r"[\s<>=!~;\[]", req, maxsplit=1)[0])


def _imported_top_level() -> set[str]:
    names = set()
    for path in (ROOT / "railfem").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names and n != "railfem"}


def _closure(declared: set[str]) -> set[str]:
    """The declared distributions and everything they require (as installed here)."""
    seen, todo = set(), list(declared)
    while todo:
        d = todo.pop()
        if d in seen:
            continue
        seen.add(d)
        try:
            reqs = metadata.requires(d) or []
        except metadata.PackageNotFoundError:
            continue
        todo += [_requirement_name(r) for r in reqs if "extra ==" not in r]
    return seen


def test_imports_are_declared_dependencies():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    # the core's dependencies and the extras' (the libraries imported inside functions)
    extras = [r for name, reqs in project["optional-dependencies"].items() if name != "test"
              for r in reqs if not r.startswith("railfem")]
    declared = {_requirement_name(r) for r in project["dependencies"] + extras}
    provided = _closure(declared)
    owners = metadata.packages_distributions()
    missing = {}
    for module in _imported_top_level():
        dists = {_norm(d) for d in owners.get(module, [])}
        assert dists, f"{module} is imported by railfem but not installed"
        if not dists & provided:
            missing[module] = sorted(dists)
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"


def test_core_dependencies_are_few_and_the_heavy_ones_are_extras():
    """numpy, scipy, scikit-fem and threadpoolctl are what the core needs (and tqdm, small
    and pure Python, for the command line's progress bars); the libraries
    imported inside the functions that use them are optional extras that 'all' collects and
    the test extra (what scripts/setup.sh installs) includes."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    core = {_requirement_name(r) for r in project["dependencies"]}
    assert core == {"numpy", "scipy", "scikit-fem", "threadpoolctl", "tqdm"}
    extras = project["optional-dependencies"]
    heavy = {_requirement_name(r) for name, reqs in extras.items() if name not in ("all", "test")
             for r in reqs}
    assert {"gmsh", "meshio", "matplotlib", "pyvista", "pyuff", "dask"} <= heavy
    assert "railfem[all]" in extras["test"]
    assert set(extras["all"][0].split("[")[1].rstrip("]").split(",")) == (
        set(extras) - {"all", "test"})
