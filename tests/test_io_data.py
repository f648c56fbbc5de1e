"""What a DATA path is (railfem.io.data), the one TOML reader and the track config
(railfem.io.config): the kinds, the row selection of a table, and errors that name the
file, the line and the key."""
import json

import pytest

from railfem import cli
from railfem.io import MalformedFileError
from railfem.io.config import read_toml, read_track_config
from railfem.io.data import data_kind, parse_select, read_data
from railfem.io.recording import read_recording

SBB_LIKE = ("loc,sec,messdatum,temp,rail,dir,100,125,160\n"
            "Ni,B1,2012-09-12,10.6,li,v,3.0,4.5,5.4\n"
            "Ni,B1,2012-09-12,10.6,re,h,13.5,NA,13.4\n"
            "Ni,B5,2013-01-20,-2.0,li,v,3.5,4.0,5.0\n")


def test_data_kind_of_each_path(tmp_path):
    (tmp_path / "set").mkdir()
    assert data_kind(tmp_path / "set") == "hammer"
    assert data_kind(tmp_path / "m.toml") == "hammer"
    assert data_kind(tmp_path / "M.TOML") == "hammer"
    assert data_kind(tmp_path / "run1.npz") == "passby"
    assert data_kind(tmp_path / "run1.WAV") == "passby"
    assert data_kind(tmp_path / "tdr.csv") == "table"
    assert data_kind([tmp_path / "a.npz", tmp_path / "b.wav"]) == "passby"


def test_data_kind_refuses_mixed_or_several_data(tmp_path):
    with pytest.raises(ValueError, match="mixes pass-by recordings"):
        data_kind([tmp_path / "a.npz", tmp_path / "tdr.csv"])
    with pytest.raises(ValueError, match="several are allowed for pass-by"):
        data_kind([tmp_path / "a.csv", tmp_path / "b.csv"])


def test_parse_select_spellings_and_lists():
    assert parse_select("dir=v, sec=B1|B5,side=li") == {
        "direction": "v", "section": ["B1", "B5"], "rail_side": "li"}
    assert parse_select("") == {} and parse_select(None) == {}
    with pytest.raises(ValueError, match="KEY=VALUE"):
        parse_select("colour=red")


def test_read_data_selects_rows_of_a_table(tmp_path):
    p = tmp_path / "sbb.csv"
    p.write_text(SBB_LIKE)  # 'messdatum' in the header: the SBB column names
    kind, items = read_data(p, select="dir=v", campaign=True)
    assert kind == "table" and [i for i, _ in items] == [0, 2]
    kind, items = read_data(p, select={"direction": "v"}, row=1)
    assert [i for i, _ in items] == [2] and items[0][1].metadata.section == "B5"
    with pytest.raises(ValueError, match="holds 3 rows"):
        read_data(p)
    with pytest.raises(ValueError, match="--row 2: the selection has 2 rows"):
        read_data(p, select="dir=v", row=2)


def test_read_data_names_what_it_cannot_read(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        read_data(tmp_path / "nothing.csv")
    (tmp_path / "run.npz").write_bytes(b"")
    with pytest.raises(ValueError, match="pass-by recording"):
        read_data(tmp_path / "run.npz")
    (tmp_path / "set").mkdir()
    with pytest.raises(ValueError, match="apply to decay-rate tables"):
        read_data(tmp_path / "set", select="dir=v")


def test_toml_syntax_error_names_file_line_and_column(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text('preset = "soft"\n[support]\nkp = = 3e8\n')
    with pytest.raises(MalformedFileError) as err:
        read_toml(p)
    assert str(p) in str(err.value) and "line 3, column" in str(err.value)
    assert err.value.key.startswith("line 3")
    with pytest.raises(MalformedFileError, match="not found"):
        read_toml(tmp_path / "missing.toml")


def test_track_config_from_toml_and_run_json(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text('preset = "soft"\n[support]\nkp = 3e8\n[job]\nf_low = 100\n')
    assert read_track_config(p) == ({"preset": "soft", "support": {"kp": 3e8}},
                                     {"f_low": 100})
    (tmp_path / "run.json").write_text(json.dumps({"config": {"spec": {"preset": "site"}}}))
    assert read_track_config(tmp_path) == ({"preset": "site"}, {})
    (tmp_path / "other.json").write_text(json.dumps({"command": "fit"}))
    with pytest.raises(MalformedFileError, match="not a run.json of 'railfem track'"):
        read_track_config(tmp_path / "other.json")


@pytest.mark.parametrize("text, message", [
    ("[support]\nkp = \n", "line 2, column"),  # TOML syntax: file, line and column
    ("[support]\nkpp = 3e8\n", "support.kpp"),  # a key the spec does not know: the file
])
def test_track_cli_names_the_config_file(tmp_path, capsys, text, message):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    code = cli.main(["-q", "track", "--config", str(p), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == cli.EXIT_BAD_INPUT and str(p) in err and message in err


def test_recording_sidecar_syntax_error_names_the_line(tmp_path):
    import numpy as np

    np.savez(tmp_path / "r.npz", samples=np.zeros(100))
    (tmp_path / "r.toml").write_text('quantity = "acceleration"\nfs_hz = 1e3\nscale = \n')
    with pytest.raises(ValueError, match="r.toml, line 3, column"):
        read_recording(tmp_path / "r.npz")
