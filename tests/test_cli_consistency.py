"""The command line: starts fast, and its commands spell the same thing the same way."""
import json
import os
import subprocess
import sys

import pytest



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


def _parse(argv):
    from railfem.cli import build_parser

    return build_parser().parse_args(argv)


def test_every_frequency_band_option_states_its_unit():
    """No bare F_LOW / F_HIGH metavar: every frequency option shows HZ."""
    for name, text in _help_texts().items():
        assert "F_LOW" not in text and "F_HIGH" not in text, name
        for opt in ("--f-low", "--f-high"):
            if opt in text:
                assert f"{opt} HZ" in text, (name, opt)


def test_speed_is_given_in_kmh_by_every_command():
    texts = _help_texts()
    for name in ("passby", "roughness", "tdr passby", "diagnose"):
        assert "--speed-kmh KMH" in texts[name], name
        assert "M/S" not in texts[name] and "--speed " not in texts[name], name
    for cmd in (["roughness", "r.npz", "--track", "site"], ["tdr", "passby", "r.npz"],
                ["diagnose", "r.npz"]):
        assert _parse([*cmd, "--speed-kmh", "72"]).speed == pytest.approx(20.0)
        assert _parse([*cmd, "--speed", "20"]).speed == pytest.approx(20.0)  # older spelling
    assert _parse(["passby", "--speed-kmh", "216"]).speed_kmh == 216.0


def test_workers_has_one_default_stated_in_help():
    from railfem.cli.common import MAX_WORKERS, workers_from_args

    texts = _help_texts()
    for name, argv in (("fit", ["fit", "d"]), ("diagnose", ["diagnose", "d"]),
                       ("study passby", ["study", "passby"])):
        assert f"(default: all cores, at most {MAX_WORKERS})" in " ".join(texts[name].split())
        args = _parse(argv)
        assert args.workers is None
        assert workers_from_args(args) == max(1, min(os.cpu_count() or 1, MAX_WORKERS))
        assert workers_from_args(_parse([*argv, "--workers", "3"])) == 3


def test_older_frequency_spellings_still_read_but_not_shown():
    args = _parse(["dispersion", "--fmin", "100", "--fmax", "200"])
    assert (args.fmin, args.fmax) == (100.0, 200.0)
    args = _parse(["dispersion", "--f-low", "100", "--f-high", "200"])
    assert (args.fmin, args.fmax) == (100.0, 200.0)
    assert "--fmin" not in _help_texts()["dispersion"]


def test_select_reports_directions_in_the_tables_own_words(tmp_path):
    from railfem.io.data import read_data

    path = tmp_path / "table.csv"
    path.write_text("# railfem decay-rate table v1; unit=dB/m; band columns: one-third-octave "
                    "centre frequency (Hz)\n"
                    "direction,sensor,date,temperature_c,section,rail_side,100,125\n"
                    "v,,,,A,,1,1\nh,,,,A,,2,2\n")
    with pytest.raises(ValueError) as err:
        read_data(path, select="dir=x")
    msg = str(err.value)
    assert "dir = v, h" in msg or "dir = h, v" in msg
    assert "'y'" not in msg and "'z'" not in msg
    kind, items = read_data(path, select="dir=v")
    assert [i for i, _ in items] == [0]
