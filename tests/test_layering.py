"""The package's layering, read from the source (AST, no import):

(a) the core (everything except io, plotting, studies, jobs and cli) imports none of those,
    at module level or inside a function;
(b) a command's module in railfem/jobs/ imports no other jobs module except
    railfem.jobs.common;
(c) no private name (leading underscore) is imported from another railfem module;
(d) the railfem modules' module-level imports form no cycle.

Each test names every offender (module, line, what it imports).
"""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "railfem"
EDGE = ("io", "plotting", "studies", "jobs", "cli")  # packages the core must not import


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _known(name: str) -> str:
    """The railfem module ``name`` or the nearest package holding it."""
    while name not in MODULES and "." in name:
        name = name.rsplit(".", 1)[0]
    return name


def _base(module: str, node: ast.ImportFrom) -> str:
    """The absolute module an ImportFrom reads from."""
    if node.level == 0:
        return node.module or ""
    parts = module.split(".")
    if MODULES[module].name != "__init__.py":
        parts = parts[:-1]
    parts = parts[:len(parts) - node.level + 1]
    return ".".join(parts + ([node.module] if node.module else []))


def _module_level(tree: ast.Module):
    """The import statements run when the module is imported (top level, inside if / try
    at top level, except under ``if TYPE_CHECKING``)."""
    todo = list(tree.body)
    while todo:
        n = todo.pop(0)
        if isinstance(n, (ast.Import, ast.ImportFrom)):
            yield n
        elif isinstance(n, ast.If) and "TYPE_CHECKING" not in ast.unparse(n.test):
            todo += n.body + n.orelse
        elif isinstance(n, ast.Try):
            todo += n.body + n.orelse + n.finalbody + [s for h in n.handlers for s in h.body]


def imports(module: str, module_level_only: bool = False):
    """[(line, imported railfem module, name or None)] of ``module``: ``from a import b``
    gives a.b when that is a module, else (a, b)."""
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    nodes = _module_level(tree) if module_level_only else ast.walk(tree)
    out = []
    for n in nodes:
        if isinstance(n, ast.Import):
            out += [(n.lineno, _known(a.name), None) for a in n.names
                    if a.name.split(".")[0] == "railfem"]
        elif isinstance(n, ast.ImportFrom):
            base = _base(module, n)
            if base.split(".")[0] != "railfem":
                continue
            for a in n.names:
                sub = f"{base}.{a.name}"
                out.append((n.lineno, sub, None) if sub in MODULES
                           else (n.lineno, _known(base), a.name))
    return out


def _package(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _report(offenders) -> str:
    return "\n".join(["", *offenders])


def test_core_imports_no_edge_package():
    offenders = [f"{m}:{line} imports {target}"
                 for m in MODULES if _package(m) not in EDGE
                 for line, target, _ in imports(m) if _package(target) in EDGE]
    assert not offenders, "the core imports io/plotting/studies/jobs/cli:" + _report(offenders)


def test_jobs_import_no_other_job():
    offenders = [f"{m}:{line} imports {target}"
                 for m in MODULES if _package(m) == "jobs" and m != "railfem.jobs"
                 for line, target, _ in imports(m)
                 if _package(target) == "jobs"
                 and target not in (m, "railfem.jobs.common")]
    assert not offenders, "a job imports another job:" + _report(offenders)


def test_no_private_name_crosses_a_module():
    offenders = [f"{m}:{line} imports {name} from {target}"
                 for m in MODULES for line, target, name in imports(m)
                 if name and name.startswith("_") and not name.startswith("__")
                 and target != m]
    assert not offenders, "private names imported from another module:" + _report(offenders)


def _cycles(graph: dict) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while not comp or comp[-1] != v:
                comp.append(stack.pop())
                on.discard(comp[-1])
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_import_cycle_at_module_level():
    graph = {m: sorted({t for _, t, _ in imports(m, module_level_only=True)} - {m})
             for m in MODULES}
    cycles = _cycles(graph)
    lines = [f"{' <-> '.join(c)}: " + "; ".join(f"{a} -> {b}" for a in c for b in graph[a]
                                                 if b in c) for c in cycles]
    assert not cycles, "import cycles among railfem modules:" + _report(lines)


def test_the_checks_see_what_they_check():
    """The scanner finds imports of each kind in modules known to have them."""
    found = {(t, n) for _, t, n in imports("railfem.track.wfe")}
    assert ("railfem.rail.greens", "residue_sum") in found  # from ..rail.greens import x
    assert ("railfem.track.coupling", "DiscreteKernel") in found
    found = {t for _, t, _ in imports("railfem.models", module_level_only=True)}
    assert {"railfem.track.beams", "railfem.spec"} <= found
    assert _cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [["a", "b", "c"]]
