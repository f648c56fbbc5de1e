import os

import numpy as np
import pytest

from railfem.response import FRF
from railfem.io.frf_csv import FRFFileError, read_frf_csv, write_frf_csv
from railfem.standards.iec61260 import band_average, ninth_octave_grid, third_octave_bands


def make_frf(quantity="receptance", nf=40, seed=0, positions=True):
    rng = np.random.default_rng(seed)
    f = ninth_octave_grid(100, 1000)[:nf]
    v = rng.normal(size=(f.size, 2, 3)) + 1j * rng.normal(size=(f.size, 2, 3))
    return FRF(
        frequency=f,
        values=v * 1e-9,
        quantity=quantity,
        response=("head_z@x=0.300", "head_z@x=0.000"),
        force=("head_z@x=0.000", "head_z@x=0.600", "foot_y@x=1.200"),
        response_x=[0.3, 0.0] if positions else None,
        force_x=[0.0, 0.6, 1.2] if positions else None,
    )


def test_conversion_factors_follow_time_convention():
    # single-dof oscillator: u = F / (k - m w^2 + i c w); v = i w u; a = -w^2 u
    f = np.linspace(1, 200, 50)
    w = 2 * np.pi * f
    alpha = 1 / (1e6 - 10 * w**2 + 1j * 300 * w)
    rec = FRF(frequency=f, values=alpha, quantity="receptance", response=("u",), force=("F",))
    mob = rec.to("mobility")
    acc = rec.to("accelerance")
    np.testing.assert_allclose(mob.values[:, 0, 0], 1j * w * alpha, rtol=1e-14)
    np.testing.assert_allclose(acc.values[:, 0, 0], -(w**2) * alpha, rtol=1e-14)
    assert mob.units == "m/s/N" and acc.units == "m/s^2/N" and rec.units == "m/N"
    np.testing.assert_allclose(acc.to("mobility").values, mob.values, rtol=1e-14)


@pytest.mark.parametrize("start", ["receptance", "mobility", "accelerance"])
def test_conversions_round_trip(start):
    frf = make_frf(start)
    for other in ("receptance", "mobility", "accelerance"):
        back = frf.to(other).to(start)
        np.testing.assert_allclose(back.values, frf.values, rtol=1e-13)
        assert back.quantity == start


def test_values_are_read_only_and_copied():
    v = np.ones(5, dtype=complex)
    frf = FRF(frequency=np.arange(1, 6.0), values=v, quantity="mobility", response="r", force="f")
    v[0] = 7.0
    assert frf.values[0, 0, 0] == 1.0
    with pytest.raises(ValueError):
        frf.values[0, 0, 0] = 2.0
    assert frf.shape == (5, 1, 1) and frf.response == ("r",)


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(quantity="impedance"), "quantity 'impedance' is unknown"),
        (dict(frequency=np.array([1.0, 3.0, 2.0, 4.0])), r"strictly increasing.*frequency\[1\]=3.0"),
        (dict(frequency=np.array([0.0, 1.0, 2.0, 3.0])), "positive"),
        (dict(values=np.ones((3, 1, 1))), r"shape \(3, 1, 1\).*n_freq=4"),
        (dict(values=np.array([1, np.nan, 1, 1])), r"\(mobility\) has 1 NaN/inf.*2.0 Hz"),
        (dict(response=("a", "b")), "response has 2 label"),
        (dict(response=("",)), "non-empty"),
        (dict(force_x=[0.0, 1.0]), "force_x has 2 position"),
        (dict(response_x=[np.inf]), "NaN/inf"),
    ],
)
def test_validation_errors(change, match):
    kwargs = dict(
        frequency=np.array([1.0, 2.0, 3.0, 4.0]), values=np.ones(4), quantity="mobility",
        response=("r",), force=("f",),
    )
    kwargs.update(change)
    with pytest.raises(ValueError, match=match):
        FRF(**kwargs)


def test_select_by_labels():
    frf = make_frf()
    sub = frf.select(response="head_z@x=0.000", force=["foot_y@x=1.200", "head_z@x=0.000"])
    assert sub.shape == (frf.shape[0], 1, 2)
    np.testing.assert_array_equal(sub.values[:, 0, 0], frf.values[:, 1, 2])
    np.testing.assert_array_equal(sub.values[:, 0, 1], frf.values[:, 1, 0])
    np.testing.assert_array_equal(sub.force_x, [1.2, 0.0])
    with pytest.raises(KeyError, match="no force label"):
        frf.select(force="rail_x")


def test_band_average_and_db():
    frf = make_frf(nf=27)  # 100 ... 800 Hz bands, three points each
    bands = third_octave_bands(100, 800)
    out = frf.band_average(bands)
    assert out.shape == (len(bands), 2, 3)
    np.testing.assert_allclose(out[2], np.sqrt(np.mean(np.abs(frf.values[6:9]) ** 2, axis=0)))
    np.testing.assert_allclose(out, band_average(frf.frequency, frf.values, bands))
    lev = frf.db(ref=1e-9)
    np.testing.assert_allclose(lev, 20 * np.log10(np.abs(frf.values) / 1e-9))
    with pytest.raises(ValueError, match="positive"):
        frf.db(ref=0.0)


def test_interpolate_exact_for_linear_data_and_no_extrapolation():
    f = np.array([10.0, 20.0, 40.0])
    v = np.array([1 + 2j, 3 - 1j, 7 + 5j])
    frf = FRF(frequency=f, values=v, quantity="receptance", response="r", force="f")
    new = frf.interpolate([15.0, 30.0, 40.0])
    np.testing.assert_allclose(new.values[:, 0, 0], [2 + 0.5j, 5 + 2j, 7 + 5j])
    assert new.quantity == "receptance" and new.response == ("r",)
    with pytest.raises(ValueError, match="outside the data range"):
        frf.interpolate([5.0, 15.0])


# --- CSV ---------------------------------------------------------------------------------


def assert_identical(a, b):
    assert np.array_equal(a.frequency, b.frequency)
    assert np.array_equal(a.values, b.values)  # bit-identical, not approximately equal
    assert a.quantity == b.quantity and a.response == b.response and a.force == b.force
    for p, q in ((a.response_x, b.response_x), (a.force_x, b.force_x)):
        assert (p is None and q is None) or np.array_equal(p, q)


@pytest.mark.parametrize("positions", [True, False])
@pytest.mark.parametrize("quantity", ["receptance", "mobility", "accelerance"])
def test_csv_round_trip_identical(tmp_path, quantity, positions):
    frf = make_frf(quantity, positions=positions)
    path = write_frf_csv(tmp_path / "frf.csv", frf)
    assert_identical(read_frf_csv(path), frf)
    head = path.read_text().splitlines()
    assert head[0] == f"# railfem-frf v1; quantity={quantity}; units={frf.units}"
    header = [h for h in head if not h.startswith("#")][0].split(",")
    assert header[:3] == ["frequency_hz", "head_z@x=0.300|head_z@x=0.000_re", "head_z@x=0.300|head_z@x=0.000_im"]
    assert len(header) == 1 + 2 * 2 * 3


def test_atomic_write_leaves_no_temp_and_keeps_old_file_on_failure(tmp_path):
    frf = make_frf()
    path = write_frf_csv(tmp_path / "frf.csv", frf)
    old = path.read_text()
    bad = FRF(frequency=[1.0], values=[1.0], quantity="mobility", response="a,b", force="f")
    with pytest.raises(ValueError, match="label 'a,b'"):
        write_frf_csv(path, bad)
    assert path.read_text() == old
    write_frf_csv(path, make_frf(seed=1))  # overwrite in place
    assert sorted(os.listdir(tmp_path)) == ["frf.csv"]


def write(tmp_path, text):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    return p


GOOD_HEAD = "# railfem-frf v1; quantity=mobility; units=m/s/N\nfrequency_hz,r|f_re,r|f_im\n"


@pytest.mark.parametrize(
    "text, match",
    [
        ("frequency_hz,r|f_re,r|f_im\n1,2,3\n", r"line 1: no '# railfem-frf v1"),
        ("# railfem-frf v1; quantity=velocity; units=m/s\nfrequency_hz,r|f_re,r|f_im\n", "quantity 'velocity' is unknown"),
        ("# railfem-frf v1; quantity=mobility; units=m/N\nfrequency_hz,r|f_re,r|f_im\n", "do not match"),
        (GOOD_HEAD + "1,2,3\n2,5\n", r"line 4: 2 values but the header has 3 columns"),
        (GOOD_HEAD + "1,2,3\n2,x5,1\n", r"line 4: value 'x5' is not a number"),
        (GOOD_HEAD, "no data rows"),
        ("# railfem-frf v1; quantity=mobility; units=m/s/N\nfreq,r|f_re,r|f_im\n1,2,3\n", "line 2: header"),
        ("# railfem-frf v1; quantity=mobility; units=m/s/N\nfrequency_hz,r|f_re,s|f_im\n1,2,3\n", "line 2: columns"),
        (GOOD_HEAD + "2,2,3\n1,5,1\n", "strictly increasing"),
    ],
)
def test_malformed_files_name_file_line_and_fix(tmp_path, text, match):
    path = write(tmp_path, text)
    with pytest.raises(FRFFileError, match=match) as err:
        read_frf_csv(path)
    assert str(path) in str(err.value)


def test_missing_file_error(tmp_path):
    with pytest.raises(FRFFileError, match="cannot read the file"):
        read_frf_csv(tmp_path / "nope.csv")


def test_repr_is_short_and_says_what_the_frf_holds():
    """print(FRF) dumped every array; it now names quantity, shape, range and labels."""
    f = np.linspace(10.0, 5000.0, 1000)
    labels = tuple(f"head_z@x={0.1 * k:.3f}" for k in range(40))
    Y = FRF(frequency=f, values=np.ones((1000, 40, 1)) * 1e-9, quantity="mobility",
            response=labels, force=("head_z@x=0.000",))
    text = repr(Y)
    assert len(text) < 400 and text.count("\n") <= 3, text
    assert "mobility" in text and "m/s/N" in text and "(1000, 40, 1)" in text
    assert "10 Hz" in text and "5000 Hz" in text
    assert "head_z@x=0.000" in text and "head_z@x=3.900" in text and "..." in text
    assert "array(" not in text and "np." not in text
    assert str(Y) == text
