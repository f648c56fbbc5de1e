"""The command line: starts fast, and its commands spell the same thing the same way."""
import json
import subprocess
import sys



def test_building_the_parser_loads_neither_scipy_nor_the_fitting_code():
    """Every command (even --version) built the whole parser first, and the parser read its
    defaults from railfem.identify.fit and its choices from modules that load SciPy: about
    2 s before anything happened."""
    child = ("import json, sys\n"
             "import railfem.cli\n"
             "railfem.cli.build_parser()\n"
             "print(json.dumps(sorted(m for m in sys.modules if m == 'scipy' or "
             "m.startswith(('scipy.', 'railfem.identify', 'railfem.rail.', 'skfem')))))\n")
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []


def test_version_answers_without_heavy_imports():
    child = ("import sys\n"
             "import railfem.cli\n"
             "try:\n"
             "    railfem.cli.main(['--version'])\n"
             "except SystemExit:\n"
             "    pass\n"
             "assert 'scipy' not in sys.modules and 'railfem.identify' not in sys.modules\n")
    proc = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().startswith("railfem ")


def _help_texts():
    """The --help text of the command and of every subcommand."""
    from railfem.cli import COMMANDS, build_parser

    parser = build_parser()
    texts = {"railfem": parser.format_help()}
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name in COMMANDS:
        texts[name] = sub.choices[name].format_help()
        inner = [a for a in sub.choices[name]._actions
                 if a.__class__.__name__ == "_SubParsersAction"]
        for a in inner:
            for sname, sp in a.choices.items():
                texts[f"{name} {sname}"] = sp.format_help()
    return texts


def test_user_facing_text_cites_no_developer_document():
    """Help texts and the strings written into outputs (everything but docstrings and
    comments) must not send the user to METHOD.md, which is not shipped."""
    import ast
    from pathlib import Path

    import railfem

    for name, text in _help_texts().items():
        assert "METHOD.md" not in text, name
    offenders = []
    for path in sorted(Path(railfem.__file__).parent.rglob("*.py")):
        tree = ast.parse(path.read_text())
        docstrings = {id(n.value) for n in ast.walk(tree)
                      if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}
        offenders += [f"{path.name}:{n.lineno}" for n in ast.walk(tree)
                      if isinstance(n, ast.Constant) and isinstance(n.value, str)
                      and "METHOD.md" in n.value and id(n) not in docstrings]
    assert offenders == []
