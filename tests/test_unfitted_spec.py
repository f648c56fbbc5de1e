"""An effect's assumed spec values (railfem.diagnosis.effects.AssumedValue): a value the
effect sets and does not fit, with the SD of its log10, enters the fitted parameters'
intervals as an unfitted random term (railfem.diagnosis.problem.EffectModel.
unfitted_tangents). The known answers are computed here without the hook: the residual
of the plain base with the value changed in its spec, and the least-squares projection of
that column on the Jacobian."""
import numpy as np
import pytest

from benchmarks.blind import generators as g
from railfem.diagnosis import effects, prepare
from railfem.diagnosis.effects import AssumedValue, Effect
from railfem.diagnosis.evaluate import Evaluator
from railfem.diagnosis.problem import Problem
from railfem.diagnosis.refit import refit

SMALL_F = g.frequencies(low=50.0, high=4000.0)[::3]
SCALE = {q: 0.4 for q in ("point", "phase", "transfer", "tdr")}
MS = 120.0  # kg: the truth's sleeper mass per rail (g.truth_spec)
SD = 0.2  # decades


def sleeper_mass(spec, theta, record=None):
    return spec.replace(ms=float(theta.get("ms", MS)))


EFFECT = Effect(name="assumed_mass", title="an assumed sleeper mass", kind="spec",
                meaning="the sleeper mass set, not fitted", parameters=(),
                apply=sleeper_mass,
                assumed=(AssumedValue(name="ms", unit="kg", value=MS, sd=SD,
                                      source="this test"),))


@pytest.fixture(scope="module")
def clean():
    """Clean data of the truth (the estimator's own form): the fit at the truth is exact,
    so the intervals hold the assumed value's share alone."""
    data = prepare(g.dataset("none", 0, f=SMALL_F, level=0.0))
    x = np.log10([g.TRUTH[k] for k in ("kp", "eta_p", "kb", "eta_b")])
    return data, x


def plain_residual(data, ms, x):
    """The base problem (no effect) with the sleeper mass set in its spec."""
    pb = Problem(data=data, evaluator=Evaluator(), spec=g.truth_spec().replace(ms=ms),
                 scale=SCALE)
    return pb.residual(x)


def reference_column(data, x, h=1e-3):
    """SD x d residual / d log10 ms: a central difference of the plain residual."""
    lo, hi = (plain_residual(data, MS * 10 ** d, x) for d in (-h, h))
    return SD * (hi - lo) / (2 * h)


def test_assumed_value_is_an_unfitted_column(clean):
    data, x = clean
    pb = Problem(data=data, evaluator=Evaluator(), spec=g.truth_spec(), effects=(EFFECT,),
                 scale=SCALE)
    np.testing.assert_allclose(pb.residual(x), plain_residual(data, MS, x), atol=1e-12)
    N = pb.unfitted_jacobian(x)
    assert N.shape == (len(pb.residual(x)), 1)
    ref = reference_column(data, x)
    assert np.linalg.norm(ref) > 1.0  # the mass moves the residual
    assert np.linalg.norm(N[:, 0] - ref) < 0.02 * np.linalg.norm(ref)


def test_interval_widens_by_the_assumed_values_projected_variance(clean):
    """On clean data of the model the noise's variance is nil: each base parameter's
    variance is the assumed mass's share, ||(J^T J)^-1 J^T n||^2 per parameter (n the
    reference column), e.g. the ballast stiffness, which the sleeper's resonance on the
    ballast ties to the mass; without the term (unfitted=False) it is nil."""
    data, x = clean
    spec = g.truth_spec()
    with_term = refit(data, Evaluator(), spec, (EFFECT,), x, SCALE, refine=False,
                      x_start=x)
    without = refit(data, Evaluator(), spec, (EFFECT,), x, SCALE, refine=False,
                    x_start=x, unfitted=False)
    assert with_term.analysis["unfitted_terms"] == 1
    pb = Problem(data=data, evaluator=Evaluator(), spec=spec, scale=SCALE)
    J = pb.central_jacobian(with_term.x)
    coef = np.linalg.lstsq(J, reference_column(data, with_term.x), rcond=None)[0]
    sd = np.array([p["std_vector"] for p in with_term.analysis["parameters"]])
    sd0 = np.array([p["std_vector"] for p in without.analysis["parameters"]])
    kb = 2
    assert abs(coef[kb]) > 0.05  # decades of kb per SD of the mass: a real share
    np.testing.assert_allclose(sd, np.abs(coef), rtol=0.03, atol=1e-3 * abs(coef[kb]))
    assert np.all(sd0 < 1e-2 * abs(coef[kb]))


def test_the_contract_of_an_assumed_value():
    with pytest.raises(ValueError, match="sd"):
        AssumedValue(name="eta", unit="-", value=0.1, sd=0.0, source="x")
    with pytest.raises(ValueError, match="source"):
        AssumedValue(name="eta", unit="-", value=0.1, sd=0.3, source="")
    with pytest.raises(ValueError, match="repeated"):
        Effect(name="e", title="t", meaning="m", kind="spec", apply=sleeper_mass,
               parameters=(effects.EffectParameter(name="ms", unit="kg", lower=1.0,
                                                   upper=1e3, log=True, start=100.0,
                                                   meaning="m"),),
               assumed=(AssumedValue(name="ms", unit="kg", value=MS, sd=SD, source="s"),))
    assert EFFECT.describe()["assumed"] == [{"name": "ms", "unit": "kg", "value": MS,
                                             "sd_decades": SD, "source": "this test"}]


def test_roll_restraint_assumes_its_loss_factor():
    """roll_restraint declares its grip's loss factor as an assumed value (0.1, SD 0.3
    decades) and applies the value it is given."""
    from railfem.diagnosis.effects import roll_restraint as rr

    e = effects.get("roll_restraint")
    (a,) = e.assumed
    assert (a.name, a.value, a.sd) == ("eta_roll", 0.1, 0.3) == \
        ("eta_roll", rr.ETA_ROLL, rr.ETA_ROLL_SD)
    base = g.lateral_truth_spec("none")
    assert e.apply(base, {"grip": 0.5, "eta_roll": 0.2}).support.eta_roll == 0.2
    assert e.apply(base, {"grip": 0.5}).support.eta_roll == 0.1


def test_unfitted_share_is_added_to_the_larger_noise_variance():
    """The shift an unfitted term makes is independent of the noise and absorbed by the
    fit, so the cluster-robust variance does not see it: with clustered noise (the robust
    variance the larger) the parameter's variance is the robust one plus the term's
    projected variance, sum_k (lstsq coefficient of column k)^2, not the larger of the
    two (which kept the robust one alone)."""
    from types import SimpleNamespace

    from railfem.identify import uncertainty as u
    from railfem.params import Parameter

    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 1.0, 200)
    J = np.column_stack([np.ones_like(t), t])
    clusters = np.repeat(np.arange(20), 10)
    r = np.repeat(rng.standard_normal(20), 10) + 0.1 * rng.standard_normal(200)
    r -= J @ np.linalg.lstsq(J, r, rcond=None)[0]  # a residual at the optimum
    N = 0.5 * np.column_stack([np.sin(3 * t), t ** 2])
    space = SimpleNamespace(
        parameters=tuple(Parameter(name=n, unit="-", log=False, lower=-1e3, upper=1e3)
                         for n in "ab"),
        names=("a", "b"), lower=np.full(2, -1e3), upper=np.full(2, 1e3))
    noise = u.analyse(space, np.zeros(2), J, r, clusters=clusters)["parameters"]
    plain = u.analyse(space, np.zeros(2), J, r)["parameters"]
    both = u.analyse(space, np.zeros(2), J, r, clusters=clusters,
                     nuisance=N)["parameters"]
    coef = np.linalg.lstsq(J, N, rcond=None)[0]  # (parameters, terms)
    share = np.sum(coef ** 2, axis=1)
    for i in range(2):
        assert noise[i]["std_vector"] > 2 * plain[i]["std_vector"]  # robust the larger
        assert share[i] > 0.1 * noise[i]["std_vector"] ** 2  # a share that shows
        assert both[i]["std_vector"] ** 2 == pytest.approx(
            noise[i]["std_vector"] ** 2 + share[i], rel=1e-9)


ENV_SD = 0.03  # decades: the sleeper mass between 0.87 and 1.15 x MS (2 SD)
ENV_EFFECT = Effect(name="assumed_mass", title="an assumed sleeper mass", kind="spec",
                    meaning="the sleeper mass set, not fitted", parameters=(),
                    apply=sleeper_mass,
                    assumed=(AssumedValue(name="ms", unit="kg", value=MS, sd=ENV_SD,
                                          source="this test"),))


@pytest.mark.parametrize("profile", [False, True])
def test_final_intervals_span_the_assumed_range(profile):
    """The chosen model's final intervals are the envelope over the assumed value's range
    (railfem.diagnosis.envelope): each base parameter's reported 95 % interval holds its
    estimate refitted with the sleeper mass at either end of the range, MS x 10^(+-2 SD),
    computed here without the hook (the plain base, the mass set in its spec, started
    from the final estimate, the final rail loss factor). The estimates move nonlinearly
    with the mass (on these noisy data the ballast's loss factor by +0.12 and -0.10
    decades at the ends), which a tangent at the assumed mass does not carry: its
    intervals missed the low-mass estimates of kp, kb and eta_b (by up to 0.014
    decades). The reported value stays
    the fit's at the assumed mass; the interval says it spans the assumed range."""
    from railfem.diagnosis.loop import Search, final_refit

    data = prepare(g.dataset("none", 0, f=SMALL_F, level=0.05))
    x0 = np.log10([g.TRUTH[k] for k in ("kp", "eta_p", "kb", "eta_b")])
    ev, spec = Evaluator(), g.truth_spec()
    chosen = refit(data, ev, spec, (ENV_EFFECT,), x0, SCALE, refine=False)
    s = Search(data=data, model=g.MODEL, ev=ev, spec=spec, scale=SCALE, base=chosen,
               profile_final=profile)
    final = final_refit(s, chosen)
    par = {p["name"]: p for p in final.parameters()}
    for i, n in enumerate(("kp", "eta_p", "kb", "eta_b")):
        assert par[n]["value"] == pytest.approx(10 ** final.x[i], rel=1e-12)
    assert profile == ("eta_r" in par)
    moved = []
    for d in (-2 * ENV_SD, 2 * ENV_SD):
        end = refit(data, ev, spec.replace(ms=MS * 10 ** d, eta_r=final.eta_r), (), x0,
                    SCALE, refine=False, x_start=final.x)
        for i, n in enumerate(("kp", "eta_p", "kb", "eta_b")):
            lo, hi = par[n]["ci95"]
            assert lo <= 10 ** end.x[i] <= hi, (n, d, 10 ** end.x[i], par[n])
            moved.append(abs(end.x[i] - final.x[i]))
        assert "spans assumed_mass's assumed ms" in par["kb"]["assumed_range"]
    assert max(moved) > 0.05  # the ends move the estimates: a real test


def test_an_envelope_that_cannot_be_refitted_keeps_the_tangent(caplog):
    """An end of the range the model cannot be evaluated at (here: the effect refuses any
    mass 1 % away from the assumed one, which lets the tangent's 0.001-decade steps
    through) does not cost the candidate its final refit: its intervals keep the
    linearised term, and the log says so."""
    from railfem.diagnosis.envelope import assumed_envelope

    def only_assumed(spec, theta, record=None):
        if abs(float(theta.get("ms", MS)) / MS - 1.0) > 0.01:
            raise ValueError("no other mass")
        return sleeper_mass(spec, theta, record)

    eff = Effect(name="assumed_mass", title="t", kind="spec", meaning="m", parameters=(),
                 apply=only_assumed, assumed=ENV_EFFECT.assumed)
    data = prepare(g.dataset("none", 0, f=SMALL_F, level=0.05))
    x0 = np.log10([g.TRUTH[k] for k in ("kp", "eta_p", "kb", "eta_b")])
    o = refit(data, Evaluator(), g.truth_spec(), (eff,), x0, SCALE, refine=False)
    got = assumed_envelope(o)
    assert got is o and not o.envelope and o.analysis["unfitted_terms"] == 1
    assert "keep their linearised terms" in caplog.text
