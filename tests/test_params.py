"""The parameter space (railfem.params) and the spec's dict/TOML form (railfem.spec):
round trips, bounds and the errors that name the parameter or key."""
import numpy as np
import pytest

import railfem as rf
from railfem import params, spec as specmod

def same(a, b, rtol=1e-12):
    """Specs equal up to the round-off of 10 ** log10(v)."""
    da, db = specmod.spec_to_dict(a), specmod.spec_to_dict(b)

    def flat(d, p=""):
        for k, v in (d.items() if isinstance(d, dict) else enumerate(d)):
            yield from flat(v, f"{p}.{k}") if isinstance(v, (dict, list)) else [(f"{p}.{k}", v)]

    fa, fb = dict(flat(da)), dict(flat(db))
    return fa.keys() == fb.keys() and all(
        fa[k] == pytest.approx(fb[k], rel=rtol) if isinstance(fa[k], float) else fa[k] == fb[k]
        for k in fa)


NAMES = ["kp", "eta_p", "ms", "kb", "eta_b", "eta_r", "pad_length", "kb[3]", "kp[-5]"]


def test_vector_to_spec_and_back_round_trips():
    space = params.ParameterSpace(rf.preset("site"), NAMES)
    rng = np.random.default_rng(0)
    for _ in range(20):
        x = space.lower + rng.uniform(0, 1, len(space)) * (space.upper - space.lower)
        s = space.to_spec(x)
        np.testing.assert_allclose(space.from_spec(s), x, rtol=1e-12, atol=1e-15)
        assert same(space.to_spec(space.from_spec(s)), s)


def test_vector_sets_the_fields_it_names():
    space = params.ParameterSpace(rf.preset("site"), NAMES)
    x = space.from_spec(space.base)
    x[0] = np.log10(3e8)  # kp
    x[NAMES.index("kb[3]")] = np.log10(0.01)  # support 3: 1 % ballast stiffness
    x[NAMES.index("pad_length")] = 0.15
    s = space.to_spec(x)
    assert s.support.kp == pytest.approx(3e8) and s.pad_length == 0.15
    assert same(s.replace(kp=3e8, pad_length=0.15, deviations=s.deviations),
                rf.preset("site").replace(kp=3e8, pad_length=0.15, deviations=s.deviations))
    lay = s.layout()
    centre = (s.n_supports - 1) // 2
    assert lay.params[centre + 3].kb == pytest.approx(0.01 * s.support.kb)
    assert lay.params[centre + 3].kp == s.support.kp
    assert lay.params[centre - 5].kp == pytest.approx(s.support.kp)  # factor 1 at the base


def test_spec_dict_round_trip_and_units():
    s = rf.preset("soft", model="wfe-periodic", pad_length=0.15, n_rows=3,
                  deviations=()).replace(kb=1e8)
    assert specmod.spec_from_dict(specmod.spec_to_dict(s)) == s
    d = {"preset": "soft", "support": {"kp": "300 MN/m", "ms": "0.1 t"},
         "track": {"pad_length": "150 mm"}, "rail": {"h": "10 mm", "E": "210 GPa"}}
    t = specmod.spec_from_dict(d)
    assert t.support.kp == 300e6 and t.support.ms == pytest.approx(100.0)
    assert t.pad_length == pytest.approx(0.15) and t.rail.h == pytest.approx(0.01)


@pytest.mark.parametrize("bad, key", [
    ({"support": {"kpp": 1.0}}, "support.kpp"),
    ({"support": {"kp": "300 MPa"}}, "support.kp"),
    ({"support": {"kp": -3e8}}, "support"),
    ({"track": {"pad_length": "10 m"}}, "pad_length"),
    ({"numerics": {"n_waves": 2.5}}, "numerics.n_waves"),
    ({"deviations": [{"index": 400, "kb": 0.1}]}, "deviations"),
    ({"colour": "red"}, "colour"),
])
def test_bad_config_names_the_key(bad, key):
    with pytest.raises(ValueError, match=key.replace("[", r"\[")):
        specmod.spec_from_dict(bad)


def test_space_errors_name_the_parameter():
    with pytest.raises(ValueError, match="unknown track parameter 'kq'"):
        params.ParameterSpace(rf.preset("site"), ["kq"])
    space = params.ParameterSpace(rf.preset("site"), ["kp", "eta_b"])
    with pytest.raises(ValueError, match="kp = .* outside its bounds"):
        space.to_spec([12.0, 0.0])
    with pytest.raises(ValueError, match="discrete model"):
        params.ParameterSpace(rf.preset("site", model="wfe-periodic"), ["kb[1]"])
    with pytest.raises(ValueError, match="outside the 131 supports"):
        params.ParameterSpace(rf.preset("site"), ["kb[70]"])
