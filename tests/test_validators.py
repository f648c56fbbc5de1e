"""The shared parameter checks: messages a user can read, and the track's support chain."""
import math

import numpy as np
import pytest

from railfem import cli
from railfem import validators as v
from railfem.spec import TrackSpec, preset
from railfem.track.supports import SupportParameters


@pytest.mark.parametrize("value, shown", [
    (np.float64(0.3), "0.3"), (np.float32(-2.5), "-2.5"), (np.int64(7), "7"),
    (0.3, "0.3"), (np.float64("nan"), "nan"), (np.bool_(True), "True"),
    (np.complex128(1 + 2j), "(1+2j)"), (np.str_("abc"), "'abc'"),
])
def test_show_writes_plain_numbers(value, shown):
    assert v.show(value) == shown


def test_show_shortens_arrays():
    text = v.show(np.arange(1000.0))
    assert len(text) < 80 and "np." not in text and "999" in text and "..." in text


def test_messages_name_the_plain_number_not_the_numpy_repr():
    """numpy >= 2 writes np.float64(0.3); the user typed 0.3."""
    checks = [lambda: v.positive("X.spacing", np.float64(-0.3), "m"),
              lambda: v.non_negative("X.eta", np.float64(-0.3), "(-)"),
              lambda: v.finite("X.f", np.float64("inf"), "Hz")]
    for check in checks:
        with pytest.raises(ValueError) as err:
            check()
        assert "np." not in str(err.value) and "float64" not in str(err.value)
    with pytest.raises(ValueError, match=r"X.spacing = -0\.3 m"):
        checks[0]()
    with pytest.raises(ValueError) as err:
        v.strictly_increasing("X.f", np.array([1.0, 0.3]), "Hz")
    assert "X.f[0] = 1.0 Hz" in str(err.value) and "np." not in str(err.value)
    with pytest.raises(ValueError) as err:
        v.finite_array("X.a", [1.0, np.nan], "m", allow_nan=False)
    assert "(nan m)" in str(err.value)


@pytest.mark.parametrize("field, unit", [("kp", "N/m"), ("kb", "N/m"), ("ms", "kg")])
def test_a_track_needs_pad_sleeper_and_ballast(field, unit):
    """kp = 0 ran a rail with no pad at all; kb = 0 or ms = 0 likewise dropped a part of
    every support. SupportParameters keeps 0 for a single missing element (a voided
    sleeper, a deviation), the track's common support must have all three."""
    support = SupportParameters(**{"kp": 300e6, "kb": 100e6, "ms": 120.0, field: 0.0})
    with pytest.raises(ValueError) as err:
        TrackSpec(support=support)
    msg = str(err.value)
    assert f"support.{field} = 0" in msg and unit in msg and "> 0" in msg
    with pytest.raises(ValueError, match=f"support.{field}"):
        preset("site").replace(**{field: 0.0})
    # a negative value is refused by SupportParameters itself, in the same words
    with pytest.raises(ValueError, match=f"{field} = -1"):
        preset("site").replace(**{field: -1.0})


def test_track_support_limits_still_allowed():
    """Rigid elements (inf) and positive values stay valid; loss factors may be 0."""
    spec = preset("site").replace(kb=math.inf, eta_p=0.0, eta_b=0.0)
    assert spec.support.kb == math.inf
    assert preset("site").replace(kp=math.inf).support.kp == math.inf


@pytest.mark.parametrize("option, words", [("--kp", "rail pad stiffness"),
                                           ("--kb", "ballast stiffness"),
                                           ("--ms", "sleeper mass")])
def test_track_command_refuses_a_missing_support_part(tmp_path, capsys, option, words):
    out = tmp_path / "out"
    code = cli.main(["-q", "track", option, "0", "--cache-dir", str(tmp_path / "cache"),
                     "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert words in err and "= 0" in err and "> 0" in err and option in err
    assert not out.exists()


def test_messages_of_profiles_meshes_and_frfs_show_plain_numbers():
    from railfem.response import FRF
    from railfem.rail import meshing, profiles

    with pytest.raises(ValueError) as err:
        profiles.rectangle(np.float64(-0.02), np.float64(0.05))
    assert "got -0.02, 0.05" in str(err.value)
    with pytest.raises(ValueError) as err:
        meshing.mesh_profile(profiles.rectangle(0.02, 0.05), np.float64(2.0))
    assert "got 2.0 " in str(err.value)
    Y = FRF(frequency=[10.0, 20.0], values=[1.0, 2.0], quantity="mobility",
            response=("a",), force=("b",))
    with pytest.raises(ValueError) as err:
        Y.db(np.float64(-1.0))
    assert "got -1.0." in str(err.value)
