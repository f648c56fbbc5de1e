"""Universal file type 58: written with pyuff here, read back by railfem.io.uff58; and a
TOML descriptor that turns UFF or CSV exports into hammer measurements."""
import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from railfem.estimators import tdr  # noqa: E402
from railfem.io import (FrequencyAxisError, MissingPositionError, NonFiniteValueError,  # noqa: E402
                        UnknownQuantityError, UnknownUnitError, hammer_measurement,
                        read_measurement, read_uff58)

G = 9.80665
F = np.geomspace(50, 2000, 17)
POS = {1: 0.02, 2: 0.15, 3: 0.3, 4: 0.6}  # hammer node -> distance from the sensor (m)


def accelerance(seed=0):
    rng = np.random.default_rng(seed)
    return (rng.normal(size=(F.size, 4)) + 1j * rng.normal(size=(F.size, 4))) * 1e-2  # m/s^2/N


def records(acc, *, unit=("g", "N"), func_type=4, ordinate=12, x=None, binary=1, ref_dir=-3,
            rsp_dir=3):
    out = []
    for j, node in enumerate(POS):
        sign = np.sign(ref_dir) * np.sign(rsp_dir)  # the file holds a_rsp / F_ref as signed
        out.append(pyuff.prepare_58(
            binary=binary, id1=f"FRF 100:+z/{node}:-z", func_type=func_type, rsp_node=100,
            rsp_dir=rsp_dir, ref_node=node, ref_dir=ref_dir, ord_data_type=6,
            data=sign * acc[:, j] / G, x=F if x is None else x, abscissa_spacing=0,
            abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate,
            orddenom_spec_data_type=13, abscissa_axis_units_lab="Hz",
            ordinate_axis_units_lab=unit[0], orddenom_axis_units_lab=unit[1]))
    return out


def write(path, sets):
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


@pytest.mark.parametrize("binary", [1, 0])
def test_uff58_round_trip(tmp_path, binary):
    acc = accelerance()
    p = write(tmp_path / "h.uff", records(acc, binary=binary))
    frf = read_uff58(p)
    assert frf.quantity == "accelerance"
    assert frf.response == ("node100:z",) and frf.force == tuple(f"node{n}:z" for n in POS)
    # binary records keep doubles; the ASCII form keeps 6 digits of frequency and 12 of values
    rtol_f, rtol_v = (0, 1e-15) if binary else (1e-5, 1e-10)
    np.testing.assert_allclose(frf.frequency, F, rtol=rtol_f)
    np.testing.assert_allclose(frf.values[:, 0, :], acc, rtol=rtol_v, atol=0)
    mob = read_uff58(p, quantity="mobility")
    np.testing.assert_allclose(mob.values[:, 0, :] * 2j * np.pi * mob.frequency[:, None],
                               acc, rtol=max(rtol_v, 1e-14))


def test_uff58_units_and_signs(tmp_path):
    acc = accelerance(1)
    p = write(tmp_path / "h.uff", records(acc, unit=("m/s^2", "N"), ref_dir=3, rsp_dir=3))
    np.testing.assert_allclose(read_uff58(p).values[:, 0, :], acc / G, rtol=1e-15)
    # same data, the file says -z for the hammer: railfem reports +z/+z
    p = write(tmp_path / "h.uff", records(acc, unit=("g", "N"), ref_dir=-3))
    np.testing.assert_allclose(read_uff58(p).values[:, 0, :], acc, rtol=1e-15)


@pytest.mark.parametrize("kw, error, match", [
    (dict(func_type=1), UnknownQuantityError, "function type 1 \\(time response\\)"),
    (dict(ordinate=15), UnknownQuantityError, "ordinate data type 15"),
    (dict(unit=("furlong", "N")), UnknownUnitError, "unknown ordinate unit"),
    (dict(unit=("NONE", "NONE")), UnknownUnitError, "states no ordinate unit"),
    (dict(unit=("m/s", "N")), UnknownQuantityError, "says accelerance but the unit"),
    (dict(x=F[::-1]), FrequencyAxisError, "strictly increasing"),
])
def test_uff58_rejects(tmp_path, kw, error, match):
    p = write(tmp_path / "h.uff", records(accelerance(), **kw))
    with pytest.raises(error, match=match) as info:
        read_uff58(p)
    assert str(p) in str(info.value)


def test_uff58_unit_override_and_mismatched_axes(tmp_path):
    acc = accelerance()
    p = write(tmp_path / "h.uff", records(acc, unit=("NONE", "NONE")))
    np.testing.assert_allclose(read_uff58(p, unit="g/N").values[:, 0, :], acc, rtol=1e-15)
    sets = records(acc)
    sets[2] = records(acc, x=F * 1.01)[2]
    with pytest.raises(FrequencyAxisError, match="record 2 .* differs from record 0"):
        read_uff58(write(tmp_path / "m.uff", sets))
    # pyuff writes NaN as 0, so the NaN is put into an ASCII file by hand
    p = write(tmp_path / "n.uff", records(acc, binary=0))
    value = f"{-acc[0, 0].real / G:.11e}"  # first value of record 0 (signed: ref_dir = -z)
    text = p.read_text()
    assert value in text
    p.write_text(text.replace(value, "nan".rjust(len(value)), 1))
    with pytest.raises(NonFiniteValueError, match="record 0 .* NaN/inf value"):
        read_uff58(p)


def test_hammer_geometry_for_uff(tmp_path):
    p = write(tmp_path / "h.uff", records(accelerance()))
    frf = read_uff58(p)
    labels = {f"node{n}:z": x for n, x in POS.items()}
    m = hammer_measurement(frf, positions=labels, sleeper_spacing=0.6, sensors={"node100:z": "head"})
    np.testing.assert_array_equal(m.positions, list(POS.values()))
    assert m.sensor_names == ("head",)
    with pytest.raises(MissingPositionError, match="node4:z"):
        hammer_measurement(frf, positions={k: v for k, v in labels.items() if k != "node4:z"},
                           sleeper_spacing=0.6, source=str(p))


DESCRIPTOR_UFF = """
file = "h.uff"
sleeper_spacing_m = 0.6
sensor_x_m = 0.3
rail = "60E1"
[positions_m]
"node4:z" = 0.6
"node1:z" = 0.02
"node2:z" = 0.15
"node3:z" = 0.3
[sensors.head]
response = "node100:z"
z_m = 0.172
[metadata]
date = "2024-05-01"
temperature_c = 14.0
"""


def test_toml_descriptor_for_uff(tmp_path):
    acc = accelerance()
    write(tmp_path / "h.uff", records(acc))
    (tmp_path / "m.toml").write_text(DESCRIPTOR_UFF)
    m = read_measurement(tmp_path / "m.toml")
    np.testing.assert_array_equal(m.positions, [0.02, 0.15, 0.3, 0.6])
    np.testing.assert_allclose(m.transfer("head"), acc, rtol=1e-15)
    assert m.sensor("head").z == 0.172 and m.metadata.temperature_c == 14.0
    np.testing.assert_allclose(m.frf.force_x, 0.3 + m.positions)
    tdr.hammer(m)  # the estimator accepts it as it is
    (tmp_path / "bad.toml").write_text(DESCRIPTOR_UFF.replace('"node4:z" = 0.6\n', ""))
    with pytest.raises(MissingPositionError, match="node4:z"):
        read_measurement(tmp_path / "bad.toml")
    (tmp_path / "typo.toml").write_text(DESCRIPTOR_UFF.replace("rail =", "rial ="))
    with pytest.raises(ValueError, match="unknown key\\(s\\) \\['rial'\\]"):
        read_measurement(tmp_path / "typo.toml")


def test_toml_descriptor_for_csv(tmp_path):
    acc = accelerance(4)
    cols = ["f"] + [f"{n}{p}" for n in POS for p in ("r", "i")]
    rows = [[F[k]] + [v for j in range(4) for v in (acc[k, j].real, acc[k, j].imag)]
            for k in range(F.size)]
    (tmp_path / "h.csv").write_text(",".join(cols) + "\n" + "\n".join(
        ",".join(repr(float(x)) for x in r) for r in rows) + "\n")
    chans = ", ".join(f'{{sensor = "head", force = "p{n}", columns = ["{n}r", "{n}i"]}}'
                      for n in POS)
    pos = "\n".join(f'"p{n}" = {x}' for n, x in POS.items())
    (tmp_path / "c.toml").write_text(
        f'file = "h.csv"\nsleeper_spacing_m = 0.6\nunit = "m/s^2/N"\n[positions_m]\n{pos}\n'
        f'[csv]\nfrequency = "f"\nchannels = [{chans}]\n')
    m = read_measurement(tmp_path / "c.toml", quantity="mobility")
    np.testing.assert_allclose(m.transfer("head") * 2j * np.pi * F[:, None], acc, rtol=1e-14)
