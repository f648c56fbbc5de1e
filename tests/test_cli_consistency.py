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
