"""The one atomic writer and the output-folder checks every job runs before computing."""
import json
import os
import signal
import subprocess
import sys

import pytest

from railfem import atomic, cli


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid  # finished and reaped: no process has this id (barring instant reuse)


def test_write_is_atomic_and_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "a.csv"
    atomic.write_text(target, "old\n")
    with pytest.raises(RuntimeError):
        with atomic.atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


def test_written_file_has_usual_permissions(tmp_path):
    p = atomic.write_text(tmp_path / "x.txt", "x")
    assert p.stat().st_mode & 0o777 == atomic.FILE_MODE


def test_stale_temporaries_of_dead_runs_are_removed(tmp_path):
    stale = tmp_path / f".decay_rate.{_dead_pid()}.tmp.csv"
    stale.write_text("")
    mine = tmp_path / f".other.{os.getpid()}.tmp.png"  # a live writer's file stays
    mine.write_text("")
    user = tmp_path / ".hidden.tmp"  # not ours: never touched
    user.write_text("")
    atomic.prepare_output_dir(tmp_path, "track")
    assert not stale.exists() and mine.exists() and user.exists()


def test_output_folder_that_is_a_file_fails_before_computing(tmp_path):
    f = tmp_path / "out"
    f.write_text("not a folder")
    with pytest.raises(ValueError, match="is a file"):
        atomic.prepare_output_dir(f, "track")


def test_unwritable_output_folder_fails_before_computing():
    # /proc refuses new entries even to root, where chmod-based read-only tests pass
    with pytest.raises(ValueError, match="cannot write to output folder"):
        atomic.prepare_output_dir("/proc/railfem-test-output", "track")


def test_a_second_command_does_not_replace_the_first_ones_record(tmp_path):
    atomic.write_text(tmp_path / "run.json", json.dumps({"command": "mobility"}))
    with pytest.raises(ValueError, match="railfem mobility"):
        atomic.prepare_output_dir(tmp_path, "track")
    atomic.prepare_output_dir(tmp_path, "mobility")  # the same command may re-run


def test_cli_reports_file_as_output_folder_without_computing(tmp_path, capsys):
    f = tmp_path / "out"
    f.write_text("")
    code = cli.main(["dispersion", "--fmin", "100", "--fmax", "200", "--n", "2",
                     "--out", str(f)])
    assert code == cli.EXIT_BAD_INPUT
    assert "is a file" in capsys.readouterr().err


def _with_command(monkeypatch, run):
    commands = dict(cli.COMMANDS)
    commands["probe"] = (lambda p: None, run, "test probe")
    monkeypatch.setattr(cli, "COMMANDS", commands)


def test_closed_stdout_is_not_an_error(monkeypatch):
    class Closed:
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            raise BrokenPipeError(32, "Broken pipe")

    def run(args):
        sys.stdout.write("many lines\n")
        return 0

    _with_command(monkeypatch, run)
    monkeypatch.setattr(sys, "stdout", Closed())
    assert cli.main(["probe"]) == 0


def test_sigterm_unwinds_and_removes_temporaries(tmp_path, monkeypatch):
    def run(args):
        with atomic.atomic_path(tmp_path / "big.csv") as tmp:
            tmp.write_text("partial")
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(10**6):  # the handler raises at the next bytecode
                pass
        return 0

    _with_command(monkeypatch, run)
    assert cli.main(["probe"]) == 130
    assert list(tmp_path.iterdir()) == []
    assert signal.getsignal(signal.SIGTERM) is not cli._terminate  # restored


def test_version_option(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("railfem ")


def test_json_safe_gives_strict_json():
    import json

    import numpy as np

    from railfem.atomic import json_safe

    data = {1: np.array([1.0, np.nan, np.inf]), "n": np.int64(3), "b": np.bool_(True),
            "t": (np.float32(0.5), None, "x")}
    out = json_safe(data)
    assert out == {"1": [1.0, None, None], "n": 3, "b": True, "t": [0.5, None, "x"]}
    json.dumps(out, allow_nan=False)


def test_mesh_and_frf_files_go_through_the_one_writer(tmp_path, monkeypatch):
    """save_mesh and write_frf_csv write through railfem.atomic: a failed write leaves the
    old file and no temporary; a mesh is world-readable (shipped meshes)."""
    import numpy as np

    from railfem.response import FRF
    from railfem.io.frf_csv import write_frf_csv
    from railfem.rail import meshing

    mesh = meshing.load_mesh(meshing.MESH_DIR / "60E1_h20mm.npz")
    target = meshing.save_mesh(mesh, tmp_path / "m.npz")
    assert target.stat().st_mode & 0o777 == 0o644
    frf = FRF(frequency=[10.0, 20.0], values=np.ones((2, 1, 1), dtype=complex),
              quantity="mobility", response=("a",), force=("b",))
    write_frf_csv(tmp_path / "f.csv", frf)
    old = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    calls = []

    def through(path, **kw):
        calls.append(path)
        return real(path, **kw)

    real = atomic.atomic_path
    monkeypatch.setattr("railfem.rail.meshing.atomic_path", through)
    monkeypatch.setattr("railfem.io.frf_csv.atomic_path", through)

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(np, "savez_compressed", boom)
    monkeypatch.setattr(np, "savetxt", boom)
    with pytest.raises(RuntimeError):
        meshing.save_mesh(mesh, tmp_path / "m.npz")
    with pytest.raises(RuntimeError):
        write_frf_csv(tmp_path / "f.csv", frf)
    assert calls == [tmp_path / "m.npz", tmp_path / "f.csv"]
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == old
