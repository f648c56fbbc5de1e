"""The railfem command line and the jobs behind it (small rectangle meshes: fast)."""
import csv
import json

import numpy as np
import pytest

from railfem import cli
from railfem.studies import convergence
from railfem.rail import meshing
from railfem.rail import profiles
from railfem.rail.quality import format_mesh_quality, mesh_quality
from railfem.rail.shapes import wave_shapes


def read_csv(path):
    with open(path) as fh:
        rows = [r for r in fh if not r.startswith("#")]
    return list(csv.DictReader(rows))


def test_mesh_command_writes_mesh_and_quality(tmp_path, capsys):
    assert cli.main(["-q", "mesh", "--profile", "rect:20x50", "--h", "5",
                     "--out", str(tmp_path)]) == 0
    mesh = meshing.load_mesh(tmp_path / "rect20x50_h5mm.npz")
    assert mesh.h == pytest.approx(0.005)
    q = json.loads((tmp_path / "rect20x50_h5mm_quality.json").read_text())
    assert q["n_dofs"] == 3 * q["n_p2_nodes"]
    assert q["n_dofs"] == sum(q["n_dofs_family"].values())
    assert q["min_angle_deg"] > 20 and q["max_aspect_ratio"] < 2
    assert all(abs(e) < 1e-12 for e in q["relative_error_vs_polygon"].values())
    assert "DOFs" in capsys.readouterr().out
    assert (tmp_path / "rect20x50_h5mm_quality.txt").exists()


def test_mesh_quality_of_60E1_reports_EN13674_errors():
    q = mesh_quality(meshing.mesh_profile("60E1", 0.01))
    assert set(q["relative_error_vs_EN13674_1"]) == {"area", "centroid_z", "I_y", "I_z"}
    assert all(abs(e) < 0.005 for e in q["relative_error_vs_EN13674_1"].values())
    assert "vs EN 13674-1" in format_mesh_quality(q)


def test_dispersion_command_k_of_omega(tmp_path):
    out = tmp_path / "disp"
    assert cli.main(["-q", "dispersion", "--profile", "rect:20x50", "--h", "10",
                     "--frequencies", "500", "2000", "--render-frequency", "2000",
                     "--out", str(out)]) == 0
    header = (out / "dispersion.csv").read_text()
    assert "k_re, k_im" in header and "rad/m" in header
    rows = read_csv(out / "dispersion.csv")
    assert set(rows[0]) == {"frequency_hz", "wave", "family", "label", "k_re", "k_im",
                            "propagating"}
    assert {float(r["frequency_hz"]) for r in rows} == {500.0, 2000.0}
    assert all(float(r["k_im"]) <= 1e-9 for r in rows)
    prop = {r["label"] for r in rows if r["propagating"] == "1" and r["frequency_hz"] == "500"}
    assert {"vertical bending", "lateral bending", "torsion", "longitudinal"} <= prop
    assert (out / "dispersion.png").stat().st_size > 1000
    renders = sorted((out / "renders").glob("*.png"))
    assert len(renders) == 4  # the four beam waves propagate at 2 kHz on the bar
    meta = json.loads((out / "run.json").read_text())
    assert meta["mode"] == "k(omega)" and meta["profile"] == "rect20x50"


def test_dispersion_command_omega_of_k(tmp_path):
    out = tmp_path / "wk"
    assert cli.main(["-q", "dispersion", "--profile", "rect:20x50", "--h", "10",
                     "--k-range", "0.5", "5", "3", "--n-modes", "3", "--no-render",
                     "--out", str(out)]) == 0
    rows = read_csv(out / "dispersion.csv")
    assert len(rows) == 3 * 2 * 3
    assert {float(r["k_re"]) for r in rows} == {0.5, 2.75, 5.0}
    assert not (out / "renders").exists()


def test_wave_shapes_are_full_per_node_shapes():
    from railfem.rail import waveguide

    g = waveguide.assemble(meshing.mesh_profile(profiles.rectangle(0.02, 0.05), 0.01))
    shapes = wave_shapes(g, 1000.0)
    labels = {s.label for s in shapes}
    assert labels == {"vertical bending", "longitudinal", "lateral bending", "torsion"}
    for s in shapes:
        assert s.shape.shape == (len(g.nodes), 3)
        assert np.linalg.norm(s.shape) == pytest.approx(1.0)
        assert np.abs(s.shape[:, 1:].imag).max() < 1e-6 * np.abs(s.shape[:, 1:]).max()
    vb = next(s for s in shapes if s.label == "vertical bending").shape
    assert np.abs(vb[:, 2]).min() > 0.9 * np.abs(vb[:, 2]).max()  # whole section moves in z


@pytest.mark.parametrize("argv, message", [
    (["dispersion", "--profile", "nonsense", "--no-render"], "unknown profile"),
    (["dispersion", "--fmin", "500", "--fmax", "100", "--no-render"], "--f-high"),
    (["dispersion", "--mesh", "/nonexistent/m.npz", "--no-render"], "railfem mesh"),
    (["mesh", "--profile", "rect:20x50", "--h", "80"], "element size"),
    (["convergence", "--profile", "rect:20x50", "--sizes", "5"], "at least two"),
])
def test_bad_input_exits_with_code_2(argv, message, tmp_path, capsys):
    assert cli.main([*argv, "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err


def test_malformed_arguments_exit_with_code_2(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["mesh", "--h", "-3"])
    assert exc.value.code == 2
    assert "positive" in capsys.readouterr().err


def test_richardson_recovers_order_and_limit():
    h = np.array([0.4, 0.25, 0.1])
    v0, p = convergence.richardson(h, 3.0 + 2.0 * h**3.5)
    assert v0 == pytest.approx(3.0, rel=1e-10) and p == pytest.approx(3.5, rel=1e-8)
    with pytest.raises(ValueError, match="monoton"):
        convergence.richardson(h, [1.0, 2.0, 1.5])


def test_convergence_study_and_command(tmp_path):
    st = convergence.convergence_study("rect:20x50", [0.01, 0.005, 0.0025],
                                       frequencies=[1000.0], n_cut_on=2)
    assert st.cut_on.shape == (3, 2) and st.n_dofs[0] < st.n_dofs[-1]
    assert np.all(np.diff(st.cut_on, axis=0) < 0)  # converges from above
    assert st.reference["cut_on"] == "richardson"
    assert np.all((st.cut_on_rate > 2) & (st.cut_on_rate < 6))  # coarse: pre-asymptotic
    assert set(st.wave_label[0]) == {"vertical bending", "longitudinal", "lateral bending",
                                     "torsion"}
    assert np.all(np.isfinite(st.wavenumbers))
    out = tmp_path / "conv"
    assert cli.main(["-q", "convergence", "--profile", "rect:20x50", "--sizes", "10", "5",
                     "--n-cut-on", "2", "--reference", "finest", "--out", str(out)]) == 0
    rows = read_csv(out / "convergence.csv")
    assert [r["h_mm"] for r in rows] == ["10", "5", "reference", "rate", "richardson_order"]
    assert (out / "convergence.png").exists()
    data = json.loads((out / "convergence.json").read_text())
    assert data["reference"]["cut_on"] == "finest"


# ------------------------------------------------------------------ railfem track
TRACK_FAST = ["--model", "timoshenko-discrete", "--f-low", "100", "--f-high", "250"]
TRACK_CSV = ("transfer_mobility.csv", "decay_rate.csv", "along_rail.csv")


def _track(tmp_path, name, *argv):
    out = tmp_path / name
    code = cli.main(["-q", "track", *argv, "--cache-dir", str(tmp_path / "cache"),
                     "--out", str(out)])
    return code, out


def _same_outputs(a, b):
    return all((a / f).read_bytes() == (b / f).read_bytes() for f in TRACK_CSV)


@pytest.mark.parametrize("model", ["timoshenko-discrete", "wfe-periodic"])
def test_track_config_file_equals_options_and_rerun_from_run_json(tmp_path, model):
    """A TOML config and the same values as options give byte-identical CSVs; so does a
    re-run from the first run's run.json (with --config and with --from-run)."""
    argv = ["--preset", "soft", "--model", model, "--f-low", "100", "--f-high", "160"]
    code, opt = _track(tmp_path, "opt", *argv, "--kp", "300", "--eta-p", "0.2", "--kb", "80",
                       "--eta-b", "1.2", "--ms", "150", "--eta-r", "0.02", "--pad-length",
                       "120", "--n-rows", "2")
    assert code == 0
    (tmp_path / "c.toml").write_text(f"""
preset = "soft"
model = "{model}"
[support]
kp = "300 MN/m"
eta_p = 0.2
kb = 80e6
eta_b = 1.2
ms = "150 kg"
[rail]
eta = 0.02
[track]
pad_length = "120 mm"
n_rows = 2
[job]
f_low = 100
f_high = 160
""")
    code, cfg = _track(tmp_path, "cfg", "--config", str(tmp_path / "c.toml"))
    assert code == 0 and _same_outputs(opt, cfg)
    code, rerun = _track(tmp_path, "rerun", "--config", str(opt / "run.json"))
    assert code == 0 and _same_outputs(opt, rerun)
    code, rerun2 = _track(tmp_path, "rerun2", "--from-run", str(opt))
    assert code == 0 and _same_outputs(opt, rerun2)
    run = json.loads((opt / "run.json").read_text())
    assert run["config"]["spec"]["support"]["kp"] == 300e6
    assert run["config"]["spec"]["track"]["pad_length"] == pytest.approx(0.12)
    assert run["railfem_version"] and len(run["frequency_hz"]) == 9  # 92.6-171 Hz, 1/9 oct
    assert run["mesh"]["name"] == "60E1_h10mm"


@pytest.mark.parametrize("toml, message", [
    ("[support]\nkpp = 3e8\n", "support.kpp"),
    ("[support]\nkp = \"300 MPa\"\n", "support.kp"),
    ("[support]\nkb = -4e7\n", "kb"),
    ("[job]\nf_lo = 100\n", "job.f_lo"),
    ("[track]\npad_length = \"10 m\"\n", "pad_length"),
    ("model = \"winkler\"\n", "model"),
])
def test_track_bad_config_fails_before_computing(tmp_path, capsys, monkeypatch, toml, message):
    from railfem import models

    def boom(*a, **k):
        raise AssertionError("computed despite a bad config")

    monkeypatch.setattr(models, "receptance", boom)
    (tmp_path / "bad.toml").write_text(toml)
    code, out = _track(tmp_path, "bad", "--config", str(tmp_path / "bad.toml"))
    assert code == 2 and message in capsys.readouterr().err
    assert not (out / "run.json").exists()


@pytest.mark.parametrize("argv, message", [
    (["--pad-length", "10000"], "--pad-length"),      # 10 m (issue 10)
    (["--pad-length", "700"], "pad_length"),          # longer than the 600 mm spacing
    (["--pad-length", "0.15"], "in mm"),              # metres given
    (["--h", "0.01"], "--h 0.01 mm"),                 # hung before (issue 10)
    (["--h", "1000"], "between 0.5 and 100 mm"),      # said "give metres" before
    (["--spacing", "0.6"], "--spacing"),
    (["--model", "timoshenko-continuous", "--pad-length", "150"], "continuous"),
])
def test_track_bad_options_fail_before_computing(tmp_path, capsys, monkeypatch, argv, message):
    from railfem import models

    monkeypatch.setattr(models, "receptance", lambda *a, **k: 1 / 0)
    code, _ = _track(tmp_path, "bad", *argv)
    assert code == 2 and message in capsys.readouterr().err


def test_timoshenko_discrete_uses_the_pad_length(tmp_path):
    """Issue 10: the beam model spread its supports over the pad length instead of ignoring
    it; a 150 mm pad changes the point mobility above the rail-on-pad resonance."""
    _, point = _track(tmp_path, "point", *TRACK_FAST, "--pad-length", "0")
    _, pad = _track(tmp_path, "pad", *TRACK_FAST, "--pad-length", "150")
    from railfem.io.frf_csv import read_frf_csv

    a = read_frf_csv(point / "transfer_mobility.csv").values[:, 0, 0]
    b = read_frf_csv(pad / "transfer_mobility.csv").values[:, 0, 0]
    assert np.abs(b / a - 1).max() > 1e-3


def test_one_frequency_syntax_and_one_loss_factor_name(tmp_path):
    """Issue 10: --f-low/--f-high (and --n or --frequencies) and --eta-r mean the same on
    every command that takes them; the older spellings still work."""
    p = cli.build_parser()
    a = p.parse_args(["dispersion", "--f-low", "100", "--f-high", "200", "--n", "3",
                      "--eta-r", "0.02"])
    b = p.parse_args(["dispersion", "--fmin", "100", "--fmax", "200", "--n", "3",
                      "--loss-factor", "0.02"])
    assert (a.fmin, a.fmax, a.loss_factor) == (b.fmin, b.fmax, b.loss_factor) == (100, 200, 0.02)
    m = p.parse_args(["mobility", "--f-low", "100", "--f-high", "1000", "--n", "3",
                      "--eta-r", "0.02"])
    assert np.allclose(cli._mobility_frequencies(m), [100, 316.227766, 1000])
    assert m.eta == 0.02
    old = p.parse_args(["mobility", "--freq", "100:1000:3"])
    assert np.allclose(cli._mobility_frequencies(old), [100, 316.227766, 1000])
    assert cli.main(["mobility", "--f-low", "100", "--frequencies", "200",
                     "--out", str(tmp_path / "m")]) == cli.EXIT_BAD_INPUT
    for command in (["track"], ["passby"], ["tdr", "passby", "x.npz"], ["fit", "x"],
                    ["roughness", "x.npz", "--track", "site"]):
        args = p.parse_args(command + ["--f-low", "100", "--f-high", "200"])
        assert (args.f_low, args.f_high) == (100, 200), command


def test_fit_row_is_zero_based(capsys):
    """`railfem fit TABLE --row N` counts from 0 as its help says: row 0 is accepted, a
    negative row is refused with the rule named."""
    p = cli.build_parser()
    assert p.parse_args(["fit", "table.csv", "--row", "0"]).row == 0
    with pytest.raises(SystemExit) as e:
        p.parse_args(["fit", "table.csv", "--row", "-1"])
    assert e.value.code == 2
    assert "0-based" in capsys.readouterr().err


def test_track_job_lateral_outputs(tmp_path):
    """Issue 15: with supports acting laterally the track job writes the lateral EN 15461
    decay rate next to the vertical ones, the lateral transfer mobilities it comes from
    (recomputing the decay rate from that file gives the column back) and a run.json block;
    without 'y' it writes none of them. On the 20 mm mesh: the outputs, not the mesh, are
    tested here (7.7 -> 5.6 s of CPU)."""
    from railfem.io.frf_csv import read_frf_csv
    from railfem.standards import en15461

    code, out = _track(tmp_path, "lat", "--preset", "site", "--model", "wfe-periodic",
                       "--support-directions", "zy", "--f-low", "200", "--f-high", "500",
                       "--h", "20")
    assert code == 0
    rows = read_csv(out / "decay_rate.csv")
    lat = np.array([float(r["head_lateral_db_per_m"]) for r in rows])
    head = np.array([float(r["head_db_per_m"]) for r in rows])
    assert np.all(np.isfinite(lat)) and np.all(lat > 0)
    assert np.abs(lat - head).max() > 1.0  # its own quantity, not a copy of the vertical
    Y = read_frf_csv(out / "transfer_mobility_lateral.csv")
    run = json.loads((out / "run.json").read_text())
    res = en15461.decay_rate(Y.frequency, Y.values[:, 0, :], np.array(run["hammer_positions_m"]))
    assert np.allclose(res.decay_rate[:len(lat)], lat, atol=6e-5)  # CSV rounding
    assert run["lateral"]["channel"] == "head_lateral"
    assert (out / "decay_rate_lateral.png").exists()
    code, plain = _track(tmp_path, "vert", "--preset", "site", "--model", "wfe-periodic",
                         "--f-low", "200", "--f-high", "500", "--h", "20")
    assert "head_lateral_db_per_m" not in read_csv(plain / "decay_rate.csv")[0]
    assert not (plain / "transfer_mobility_lateral.csv").exists()
