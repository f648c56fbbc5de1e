"""The 2.5D waveguide finite element forms (METHOD.md section 1), for scikit-fem.

Trial/test fields are 3-component vectors (u_x, u_y, u_z) on the (y, z) section;
``u.grad[c, 0]`` is d u_c / dy and ``u.grad[c, 1]`` is d u_c / dz. With ``d/dx -> -i k``
the engineering strain in Voigt order (xx, yy, zz, yz, xz, xy) is

    eps = (B1 - i k B2) u,
    B1 u = (0, u_y,y, u_z,z, u_y,z + u_z,y, u_x,z, u_x,y)    (in-plane derivatives)
    B2 u = (u_x, 0, 0, 0, u_z, u_y)                          (coefficient of d/dx)

and A(k, omega) = k^2 K2 + i k K1 + K0 - omega^2 M with the forms below. The forms use the
real Lame constants; the hysteretic loss factor scales all stiffness matrices by (1 + i eta).
"""
from skfem import BilinearForm


def b1(u):
    g = u.grad
    return (0.0, g[1, 0], g[2, 1], g[1, 1] + g[2, 0], g[0, 1], g[0, 0])


def b2(u):
    return (u[0], 0.0, 0.0, 0.0, u[2], u[1])


def energy(e, f, lam, mu):
    """e^T D f for isotropic D with Lame constants lam, mu (engineering shear strains)."""
    normal = e[0] * f[0] + e[1] * f[1] + e[2] * f[2]
    shear = e[3] * f[3] + e[4] * f[4] + e[5] * f[5]
    return lam * (e[0] + e[1] + e[2]) * (f[0] + f[1] + f[2]) + 2 * mu * normal + mu * shear


@BilinearForm
def k0(u, v, w):
    """K0 = int B1^T D B1 dA"""
    return energy(b1(v), b1(u), w.lam, w.mu)


@BilinearForm
def k1(u, v, w):
    """K1 = int (B2^T D B1 - B1^T D B2) dA   (antisymmetric)"""
    return energy(b2(v), b1(u), w.lam, w.mu) - energy(b1(v), b2(u), w.lam, w.mu)


@BilinearForm
def k2(u, v, w):
    """K2 = int B2^T D B2 dA"""
    return energy(b2(v), b2(u), w.lam, w.mu)


@BilinearForm
def mass(u, v, w):
    """M = int rho N^T N dA"""
    return w.rho * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2])
