"""A plain (non-editable) ``pip install .`` works: the shipped meshes and data are package
data, so an installed railfem runs its jobs with no repository around it (issue 10).

The venv reuses this interpreter's site-packages for the dependencies (``--no-deps``) so the
test needs no downloads beyond the build backend; railfem itself is built and installed
into the venv from a copy of the source tree, and the job runs from a folder outside it.
"""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_non_editable_install_runs_the_track_job(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(
        ".git", "*.egg-info", "build", "__pycache__", ".pytest_cache", "out", "railfem-output"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)],
                   check=True, timeout=120)
    py = venv / "bin" / "python"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    pip = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps",
                          "--disable-pip-version-check", str(src)],
                         capture_output=True, text=True, timeout=600, env=env)
    assert pip.returncode == 0, pip.stderr[-3000:]
    shutil.rmtree(src)  # nothing may come from the source tree any more
    where = subprocess.run([str(py), "-c", "import railfem, railfem.rail.meshing as m; "
                            "print(railfem.__file__); print(m.MESH_DIR)"],
                           capture_output=True, text=True, cwd=tmp_path, env=env, timeout=60)
    module, mesh_dir = where.stdout.split()
    assert module.startswith(str(venv)) and Path(mesh_dir, "60E1_h10mm.npz").is_file()
    out = tmp_path / "run"
    job = subprocess.run([str(venv / "bin" / "railfem"), "-q", "track", "--preset", "site",
                          "--model", "timoshenko-discrete", "--f-low", "100", "--f-high", "200",
                          "--no-cache", "--out", str(out)],
                         capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600)
    assert job.returncode == 0, job.stderr[-3000:]
    run = json.loads((out / "run.json").read_text())
    assert run["command"] == "track" and (out / "decay_rate.csv").is_file()
    assert run["mesh"]["name"] == "60E1_h10mm"  # the shipped mesh, found as package data
