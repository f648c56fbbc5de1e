"""The sleeper carrying both rails, the two-rail track and the participating ballast mass
(railfem.track.sleeper), each against a value computed independently here: closed-form
beam roots, a 3D elasticity model, the Euler-Bernoulli beam on a Winkler bed solved
exactly, rigid-body mechanics, and an explicitly coupled two-rail track."""
import math

import numpy as np
import pytest

from railfem.models import discrete_kernel, frf, head
from railfem.spec import Numerics, TrackSpec, preset, spec_from_dict, spec_to_dict
from railfem.track.sleeper import (B90, Sleeper, clear_cache, rectangular_section,
                                   reference_seat_receptance)
from railfem.track.supports import SupportParameters, dynamic_stiffness

F = np.geomspace(20.0, 3000.0, 25)
W = 2 * np.pi * F
KB = 42e6 * (1 + 1.0j)  # site ballast per rail
MS = 150.0  # kg per rail: half of a 300 kg sleeper


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b))


# ------------------------------------------------------------------ (a) free-free modes


def test_free_free_euler_bernoulli_roots():
    sl = Sleeper(kGA=math.inf, rotary_inertia=0.0, n_elements=40)
    roots = np.array([4.730040745, 7.853204624, 10.995607838])
    ref = roots ** 2 * np.sqrt(sl.EI / (sl.mass_per_length * sl.length ** 4)) / (2 * np.pi)
    assert rel(sl.free_frequencies(3), ref) < 1e-3
    assert np.all(np.abs(sl.free_frequencies(3) / ref - 1) < 1e-3)


def _solid_bending_frequencies(length, width, depth, E, nu, rho, n=3):
    """Vertical bending frequencies of a free prismatic bar, 3D elasticity (27-node hexes)."""
    from scipy.sparse.linalg import eigsh
    from skfem import Basis, BilinearForm, ElementHex2, ElementVector, MeshHex, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = MeshHex.init_tensor(np.linspace(0, length, 15), np.linspace(0, width, 3),
                               np.linspace(0, depth, 3))
    basis = Basis(mesh, ElementVector(ElementHex2()), intorder=4)

    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)

    K = asm(linear_elasticity(*lame_parameters(E, nu)), basis)
    M = asm(mass, basis)
    lam, vec = eigsh(K, k=20, M=M, sigma=-100.0, which="LM")
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    x = mesh.p[0]
    slabs = [np.isclose(x, s) for s in np.unique(np.round(x, 9))]
    out = []
    for j in range(len(lam)):
        f = math.sqrt(max(lam[j], 0.0)) / (2 * math.pi)
        uz = vec[basis.nodal_dofs[2], j]
        # a vertical bending mode moves whole cross-sections vertically
        mean_share = sum(m.sum() * uz[m].mean() ** 2 for m in slabs) / (uz ** 2).sum()
        if f > 20 and mean_share > 0.9:
            out.append(f)
    return np.array(out[:n])


def test_timoshenko_sleeper_against_3d_elasticity():
    b, h, E, nu, rho = 0.25, 0.19, 37e9, 0.2, 2400.0
    sl = Sleeper(**rectangular_section(b, h, E, nu, rho), n_elements=30)
    solid = _solid_bending_frequencies(2.6, b, h, E, nu, rho)
    assert len(solid) == 3
    assert np.all(np.abs(sl.free_frequencies(3) / solid - 1) < 0.03)
    # shear and rotary inertia matter at this slenderness: Euler-Bernoulli misses mode 3
    eb = Sleeper(**{**rectangular_section(b, h, E, nu, rho), "kGA": math.inf,
                    "rotary_inertia": 0.0}, n_elements=30)
    assert eb.free_frequencies(3)[2] / solid[2] - 1 > 0.05


def test_default_sleeper_is_b90_like():
    assert B90.mass == pytest.approx(300.0)
    assert 90 < B90.free_frequencies(1)[0] < 160


# ------------------------------------------------------ the beam on its bed, exactly


def _euler_bernoulli_on_bed(sl, omega, bed, a):
    """Deflections at +a and -a of a free-free Euler-Bernoulli beam (complex EI) on the
    Winkler bed s = 2 bed / L, unit force at +a: homogeneous exponentials on each side of
    the load, free ends, and the shear jump at the load."""
    L, EI = sl.length, sl.EI * (1 + 1j * sl.eta)
    s = 2 * bed / L
    mu = (omega ** 2 * sl.mass_per_length - s) / EI
    lam = mu ** 0.25 * np.array([1, 1j, -1, -1j])

    def rows(x, orders):  # derivative rows of exp(lam (x - a))
        return np.array([lam ** k * np.exp(lam * (x - a)) for k in orders])

    A = np.zeros((8, 8), dtype=complex)
    rhs = np.zeros(8, dtype=complex)
    A[0:2, 0:4] = rows(-L / 2, (2, 3))
    A[2:4, 4:8] = rows(L / 2, (2, 3))
    A[4:8, 0:4] = -rows(a, (0, 1, 2, 3))
    A[4:8, 4:8] = rows(a, (0, 1, 2, 3))
    rhs[7] = 1 / EI
    c = np.linalg.solve(A, rhs)
    return rows(a, (0,))[0] @ c[4:], rows(-a, (0,))[0] @ c[:4]


def test_seat_receptance_against_exact_beam_on_bed():
    sl = Sleeper(kGA=math.inf, rotary_inertia=0.0, n_elements=48)
    A = sl.seat_matrix(W, KB)
    ref = np.array([_euler_bernoulli_on_bed(sl, w, KB, sl.seat_distance / 2) for w in W])
    assert rel(A[:, 0, 0], ref[:, 0]) < 1e-5
    assert rel(A[:, 0, 1], ref[:, 1]) < 1e-5
    assert np.allclose(A[:, 0, 1], A[:, 1, 0])


# ------------------------------------------- the modal form against the full solve

F_MODAL = np.geomspace(20.0, 5000.0, 300)
TABLE1_BEDS = [42e6 * (1 + 1.0j), 48e6 * (1 + 2.0j), 90e6 * (1 + 1.5j), 120e6 * (1 + 1.0j),
               360e6 * (1 + 0.5j), 1e9 + 0j]  # kb* per rail: Table 1 and a stiff, undamped one


def _with_f1(sl, f1):  # stiffness scaled: the free frequencies scale with its square root
    k = (f1 / sl.free_frequencies(1)[0]) ** 2
    return Sleeper(EI=sl.EI * k, kGA=sl.kGA * k)


@pytest.mark.parametrize("sleeper", [B90, _with_f1(B90, 40.0), _with_f1(B90, 800.0),
                                     Sleeper(eta=0.5), Sleeper(n_elements=80)],
                         ids=["B90", "f1=40Hz", "f1=800Hz", "eta=0.5", "80 elements"])
def test_modal_seat_receptance_against_the_full_solve(sleeper):
    w = 2 * np.pi * F_MODAL
    for bed in TABLE1_BEDS:
        for case in ("symmetric", "antisymmetric"):
            ref = reference_seat_receptance(sleeper, w, bed, case)
            err = np.abs(sleeper.seat_receptance(w, bed, case) / ref - 1)
            assert err.max() < 1e-3, (bed, case, err.max())


def test_modal_form_with_a_frequency_dependent_bed_and_light_damping():
    w = 2 * np.pi * F_MODAL
    p = SupportParameters(kp=600e6, ms=MS, kb=90e6, eta_b=0.5, mb=400.0, kf=80e6, eta_f=0.5)
    from railfem.track.sleeper import ballast_stiffness
    bed = ballast_stiffness(p, w)  # a participating ballast mass on the subgrade
    for sl in (B90, Sleeper(eta=0.002)):
        for case in ("symmetric", "antisymmetric"):
            ref = reference_seat_receptance(sl, w, bed, case)
            assert np.abs(sl.seat_receptance(w, bed, case) / ref - 1).max() < 1e-3


def test_modal_form_is_exact_without_rotary_inertia():
    # rho I = 0: the bed matrix is the mass matrix / rho A, diagonal in the modes
    sl = Sleeper(rotary_inertia=0.0)
    w = 2 * np.pi * np.geomspace(20.0, 8000.0, 200)
    for case in ("symmetric", "antisymmetric"):
        ref = reference_seat_receptance(sl, w, 1e9 + 0j, case)
        assert rel(sl.seat_receptance(w, 1e9 + 0j, case), ref) < 1e-10


def test_modes_cached_by_value_do_not_change_results():
    w = 2 * np.pi * F
    clear_cache()
    first = B90.seat_receptance(w, KB, "antisymmetric")
    for other in (_with_f1(B90, 300.0), B90.scaled(0.5), Sleeper(eta=0.1)):
        other.seat_receptance(w, KB * 0.7, "antisymmetric")  # same geometry, other values
    clear_cache()
    _with_f1(B90, 300.0).seat_receptance(w, KB, "antisymmetric")
    assert np.array_equal(B90.seat_receptance(w, KB, "antisymmetric"), first)
    # the sleeper scaled by a weight has the receptance / weight on the bed times weight
    assert rel(B90.scaled(0.5).seat_receptance(w, KB * 0.5, "antisymmetric"),
               first / 0.5) < 1e-12


# ------------------------------------------------------------------ (b) the rigid limit


def _rigid_sleeper_matrix(omega, kb, ms, L=2.6, g=1.5):
    """Seat receptances of a rigid uniform sleeper (mass 2 ms, length L) on a uniform bed
    (2 kb over L): bounce plus rocking about the centre."""
    a_t = 1 / (2 * kb - omega ** 2 * 2 * ms)
    a_r = (g / 2) ** 2 / (kb * L ** 2 / 6 - omega ** 2 * 2 * ms * L ** 2 / 12)
    return a_t + a_r, a_t - a_r


def _stiff(ms=MS):
    return Sleeper(EI=B90.EI * 1e14, kGA=math.inf, rotary_inertia=0.0,
                   mass_per_length=2 * ms / 2.6)


def test_rigid_limit_of_the_flexible_sleeper_is_todays_support():
    base = SupportParameters(kp=600e6, eta_p=0.25, ms=MS, kb=42e6, eta_b=1.0)
    flex = SupportParameters(kp=600e6, eta_p=0.25, ms=MS, kb=42e6, eta_b=1.0,
                             sleeper=_stiff())
    assert rel(dynamic_stiffness(flex, W), dynamic_stiffness(base, W)) < 1e-8
    # anti-phase: the stiff beam rocks like the rigid body, and like the rigid model
    a11, a12 = _rigid_sleeper_matrix(W, KB, MS)
    kp = 600e6 * (1 + 0.25j)
    ref = kp / (1 + kp * (a11 - a12))
    anti = dynamic_stiffness(SupportParameters(**{**vars_of(flex), "case": "antisymmetric"}), W)
    assert rel(anti, ref) < 1e-8
    rigid = SupportParameters(**{**vars_of(base), "sleeper": Sleeper(model="rigid"),
                                 "case": "antisymmetric"})
    assert rel(dynamic_stiffness(rigid, W), ref) < 1e-8


def vars_of(p):
    return {k: getattr(p, k) for k in p.__dataclass_fields__}


def test_default_support_unchanged():
    p = SupportParameters(kp=600e6, eta_p=0.25, ms=120.0, kb=42e6, eta_b=1.0)
    kp, kb = 600e6 * (1 + 0.25j), 42e6 * (1 + 1.0j)
    ref = kp * (kb - W ** 2 * 120) / (kp + kb - W ** 2 * 120)
    assert rel(dynamic_stiffness(p, W), ref) < 1e-14
    assert rel(dynamic_stiffness(p.__class__(**{**vars_of(p), "sleeper": Sleeper(
        model="rigid")}), W), ref) < 1e-14


# ------------------------------------------------------ (e) participating ballast mass


def test_ballast_mass_limits_and_chain():
    base = dict(kp=300e6, eta_p=0.1, ms=MS, kb=90e6, eta_b=0.5)
    today = dynamic_stiffness(SupportParameters(**base), W)
    tiny = SupportParameters(**base, mb=1e-9, kf=1e30, eta_f=0.3)
    assert rel(dynamic_stiffness(tiny, W), today) < 1e-8
    mb, kf, eta_f = 400.0, 80e6, 0.4
    p = SupportParameters(**base, mb=mb, kf=kf, eta_f=eta_f)
    kp, kb, kf_ = 300e6 * (1 + 0.1j), 90e6 * (1 + 0.5j), kf * (1 + 1j * eta_f)
    ref = []
    for w in W:  # rail seat, sleeper, ballast mass: condense onto the rail seat
        D = np.array([[kp, -kp, 0], [-kp, kp + kb - w ** 2 * MS, -kb],
                      [0, -kb, kb + kf_ - w ** 2 * mb]])
        ref.append(D[0, 0] - D[0, 1:] @ np.linalg.solve(D[1:, 1:], D[1:, 0]))
    assert rel(dynamic_stiffness(p, W), np.array(ref)) < 1e-10


# ------------------------------------------- (c), (d) two rails coupled through sleepers

FX, RX = np.array([0.1]), np.array([0.1, 0.4])


def _beam_spec(**changes):
    return preset("site", model="timoshenko-discrete", pad_length=0.0, n_supports=41,
                  numerics=Numerics(load_length=0.0), **changes)


def _coupled_two_rails(spec, seat_matrix, P):
    """Two rails on common sleepers solved as one system: rail k at the springs
    u_k = G_sP P_k - G_ss F_k, the support forces F = K (u_1, u_2) with the 2x2 support
    stiffness K = kp (I + kp A)^-1 per sleeper (A: the sleeper's seat receptances)."""
    f = F
    kernel, jr, jf = discrete_kernel(spec.replace(rails=1), f, FX, RX, outputs=("head",),
                                     cache=False)
    Gss = kernel.ss[:, kernel.ss_index, 0, 0]
    GsP = kernel.sP[:, kernel.sP_index, 0][:, :, 0]
    Grs = kernel.rs[:, kernel.rs_index, 0, 0]
    GrP = kernel.rP[:, kernel.rP_index, 0][:, :, 0]
    n = Gss.shape[1]
    kp = spec.support.kp * (1 + 1j * spec.support.eta_p)
    out = []
    for i in range(len(f)):
        K2 = kp * np.linalg.inv(np.eye(2) + kp * seat_matrix[i])
        K = np.kron(K2, np.eye(n))
        G = np.kron(np.eye(2), Gss[i])
        u0 = np.concatenate([GsP[i] * P[0], GsP[i] * P[1]])
        Fs = np.linalg.solve(np.eye(2 * n) + K @ G, K @ u0)
        out.append([GrP[i] * P[k] - Grs[i] @ Fs[k * n:(k + 1) * n] for k in (0, 1)])
    return np.array(out)  # (nf, rail, response)


def _door(spec, rail_force, rail_resp, x_force=0.1, x_resp=RX):
    r = frf(spec, F, force=[head(x_force, rail=rail_force)],
            response=[head(x, rail=rail_resp) for x in x_resp], quantity="receptance",
            cache=False)
    return r.values[:, :, 0]


def test_two_rails_rigid_sleeper_against_coupled_system():
    spec = _beam_spec(rails=2)
    a11, a12 = _rigid_sleeper_matrix(W, KB, spec.support.ms)
    A = np.stack([np.stack([a11, a12], -1), np.stack([a12, a11], -1)], -2)
    sym = _coupled_two_rails(spec, A, (1.0, 1.0))
    one_rail = _door(_beam_spec(), 1, 1)
    assert rel(sym[:, 0], one_rail) < 1e-8  # (c) in phase = one rail on ms per rail
    hammer = _coupled_two_rails(spec, A, (1.0, 0.0))
    assert rel(_door(spec, 1, 1), hammer[:, 0]) < 1e-8
    assert rel(_door(spec, 1, 2), hammer[:, 1]) < 1e-8


def test_two_rails_flexible_sleeper_against_coupled_system():
    spec = _beam_spec(rails=2, sleeper="flexible")
    sl = spec.support.sleeper
    hammer = _coupled_two_rails(spec, sl.seat_matrix(W, KB), (1.0, 0.0))
    assert rel(_door(spec, 1, 1), hammer[:, 0]) < 1e-8
    assert rel(_door(spec, 1, 2), hammer[:, 1]) < 1e-8
    # (c) a symmetric load on the two-rail track is the single-rail track on the sleeper
    sym = _door(spec, 1, 1) + _door(spec, 1, 2)
    assert rel(sym, _door(_beam_spec(sleeper="flexible"), 1, 1)) < 1e-12


@pytest.mark.parametrize("sleeper", ["rigid", "flexible"])
def test_rail_to_rail_reciprocity(sleeper):
    spec = _beam_spec(rails=2, sleeper=sleeper)
    y12 = _door(spec, 1, 2, x_force=0.1, x_resp=[0.7])
    y21 = _door(spec, 2, 1, x_force=0.7, x_resp=[0.1])
    assert rel(y12, y21) < 1e-9
    assert np.max(np.abs(y12)) > 1e-4 * np.max(np.abs(_door(spec, 1, 1)))  # not trivial


# ------------------------------------------------------------------ the spec options


def test_spec_options_round_trip_and_errors():
    spec = preset("site").replace(sleeper="flexible", rails=2, mb=300.0, kf=80e6, eta_f=0.5)
    assert isinstance(spec.support.sleeper, Sleeper) and spec.rails == 2
    assert spec_from_dict(spec_to_dict(spec)) == spec
    toml_like = {"preset": "site", "track": {"rails": 2},
                 "sleeper": {"model": "flexible", "length": "2.5 m"},
                 "support": {"mb": "0.3 t", "kf": "80 MN/m"}}
    s = spec_from_dict(toml_like)
    assert s.support.sleeper.length == 2.5 and s.support.mb == 300.0 and s.rails == 2
    assert preset("site").replace(sleeper="rigid").support == preset("site").support
    with pytest.raises(ValueError, match="rails"):
        preset("site").replace(rails=3)
    with pytest.raises(ValueError, match="case"):
        SupportParameters(kp=1e8, kb=1e8, case="antisymmetric")
    with pytest.raises(ValueError, match="rail 2"):
        frf(_beam_spec(), F[:2], force=[head(0.0)], response=[head(0.0, rail=2)],
            cache=False)
    with pytest.raises(ValueError, match="two-rail"):
        discrete_kernel(_beam_spec(rails=2), F[:2], [0.0], [0.0], cache=False)
    with pytest.raises(ValueError, match="seat"):
        Sleeper(seat_distance=3.0)
    assert isinstance(spec, TrackSpec)
