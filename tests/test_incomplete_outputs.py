"""What a failed or interrupted command leaves in its output folder: nothing when the input
was refused, an INCOMPLETE marker next to partial outputs when it was interrupted."""
import numpy as np
import pytest

pytest.importorskip("matplotlib")

from railfem.atomic import INCOMPLETE  # noqa: E402
from railfem.cli import main  # noqa: E402
from railfem.io import write_dataset  # noqa: E402
from railfem.measurement import HammerMeasurement, Metadata, Sensor  # noqa: E402
from railfem.response import FRF  # noqa: E402
from railfem.standards.en15461 import hammer_positions  # noqa: E402
from railfem.standards.iec61260 import ninth_octave_grid  # noqa: E402


def dataset(tmp_path):
    """A small hammer dataset: an exponential decay of 4 dB/m."""
    x = hammer_positions(0.6)
    x[0] = 0.02
    f = ninth_octave_grid(100, 1000)
    y = np.exp(-(4.0 / 8.685889638 + 1j * 2 * np.pi * f[:, None] / 300) * x[None, :])
    frf = FRF(frequency=f, values=1e-5 * y[:, None, :], quantity="mobility",
              response=("head",), force=tuple(f"p{i}" for i in range(29)))
    m = HammerMeasurement(frf=frf, positions=x, sensors=(Sensor(name="head"),),
                          sleeper_spacing=0.6, sensor_x=None, metadata=Metadata(section="T"))
    return write_dataset(tmp_path / "data", m)


@pytest.mark.parametrize("argv", [["tdr", "hammer"], ["fit"]])
def test_refused_input_leaves_no_output_folder(tmp_path, argv):
    out = tmp_path / "new" / "out"
    assert main(["-q", *argv, str(tmp_path / "missing"), "--out", str(out)]) == 2
    assert not out.exists()


def test_unknown_sensor_leaves_no_output_folder(tmp_path):
    out = tmp_path / "out"
    assert main(["-q", "tdr", "hammer", str(dataset(tmp_path)), "--sensor", "foot",
                 "--out", str(out)]) == 2
    assert not out.exists()


def test_refused_input_keeps_a_previous_complete_run_as_it_was(tmp_path):
    data, out = dataset(tmp_path), tmp_path / "out"
    assert main(["-q", "tdr", "hammer", str(data), "--out", str(out)]) == 0
    before = sorted(p.name for p in out.iterdir())
    assert INCOMPLETE not in before and "run.json" in before
    assert main(["-q", "tdr", "hammer", str(data), "--sensor", "foot", "--out", str(out)]) == 2
    assert sorted(p.name for p in out.iterdir()) == before


def test_interrupted_job_leaves_the_marker_next_to_partial_outputs(tmp_path, monkeypatch):
    import railfem.plotting

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(railfem.plotting, "save_figure", interrupted)  # after the CSV
    out = tmp_path / "out"
    assert main(["-q", "tdr", "hammer", str(dataset(tmp_path)), "--out", str(out)]) == 130
    names = sorted(p.name for p in out.iterdir())
    assert names == [INCOMPLETE, "decay_rate.csv"]
    assert "partial" in (out / INCOMPLETE).read_text()
