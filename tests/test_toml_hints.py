"""A typo in a TOML file: the hint lists the valid keys and the valid tables."""
import pytest

from railfem.io.config import read_descriptor, read_track_config


def test_track_config_typo_in_a_table_name(tmp_path):
    path = tmp_path / "track.toml"
    path.write_text('preset = "site"\n\n[suport]\nkp = "600 MN/m"\n')
    with pytest.raises(ValueError) as err:
        read_track_config(path)
    msg = str(err.value)
    assert "line 3" in msg and "'suport'" in msg
    for key in ("preset", "model", "name"):
        assert key in msg
    for table in ("[support]", "[rail]", "[numerics]", "[track]", "[sleeper]", "[job]",
                  "[[deviations]]"):
        assert table in msg


def test_track_config_typo_in_a_key(tmp_path):
    path = tmp_path / "track.toml"
    path.write_text('presett = "site"\n')
    with pytest.raises(ValueError, match=r"line 1.*'presett'.*valid keys: .*preset.*"
                                         r"valid tables: .*\[support\]"):
        read_track_config(path)


def test_descriptor_typo_names_keys_and_tables_apart(tmp_path):
    path = tmp_path / "site.toml"
    path.write_text('file = "frf.csv"\nsleeper_spacing_m = 0.6\npositions_m = [0.0]\n\n'
                    '[sensor.head]\ndirection = "z"\n')
    with pytest.raises(ValueError) as err:
        read_descriptor(path)
    msg = str(err.value)
    assert "line 5" in msg and "'sensor'" in msg
    keys, tables = msg.split("valid keys: ")[1].split("; valid tables: ")
    assert "sleeper_spacing_m" in keys and "sensors" not in keys
    assert "[sensors]" in tables and "[csv]" in tables and "[metadata]" in tables


def test_spec_dict_typo_names_keys_and_tables():
    from railfem.spec import spec_from_dict

    with pytest.raises(ValueError, match=r"'suport'; valid keys: .*preset.*; valid tables: "
                                         r".*\[support\].*\[numerics\]"):
        spec_from_dict({"suport": {"kp": "600 MN/m"}})
