"""hyperqn's lumped masses (a quarter of each tet's rest mass on each of its vertices), and the total
energy of a neo-Hookean body in a VTK frame: kinetic, elastic and gravitational, also per tet (with
each tet's share of the momenta: what a removed tet takes, docs/removal.md). For the tests'
momentum and energy checks (tests/python/test_integrators.py, test_cuts.py, test_reactions.py, ...)
and bench/integrator_energy.py; 1-rank frames."""
import numpy as np

from hyperqn_tools.output import Frame


def tet_volumes(rest, tets):
    """Each tet's rest volume (rest: n x 3 rest positions; tets: m x 4 vertex indices)."""
    e = rest[tets[:, 1:]] - rest[tets[:, :1]]
    return np.abs(np.linalg.det(e)) / 6


def lumped_masses(rest, tets, density):
    """Each vertex's mass as hyperqn lumps it: density times a quarter of the rest volume of each of
    its tets (rest: the rest positions, n x 3; tets: m x 4 vertex indices)."""
    volume = tet_volumes(rest, tets)
    mass = np.zeros(len(rest))
    np.add.at(mass, tets.ravel(), np.repeat(density * volume / 4, 4))
    return mass


def frame_lumped_masses(frame, density):
    """lumped_masses of a Frame (hyperqn_tools.output): its rest positions are points - displacement."""
    return lumped_masses(frame.points - frame.displacement, frame.cells["tetra"], density)


def tet_energies(x, X, v, tets, youngs_modulus, poisson_ratio, density):
    """Per tet (kinetic, elastic) energy of a neo-Hookean body: the kinetic energy of its lumped
    quarters, rho V / 4 sum_a |v_a|^2 / 2 (their sum over tets is the lumped masses' kinetic
    energy), and V psi, psi = mu/2 (|F|^2 - 3) - mu log J + lambda/2 log^2 J. x, X, v: positions,
    rest positions and velocities (n x 3); tets: m x 4 vertex indices."""
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    Dm = np.stack([X[tets[:, j]] - X[tets[:, 0]] for j in (1, 2, 3)], axis=2)
    Ds = np.stack([x[tets[:, j]] - x[tets[:, 0]] for j in (1, 2, 3)], axis=2)
    volume = np.abs(np.linalg.det(Dm)) / 6
    F = Ds @ np.linalg.inv(Dm)
    logJ = np.log(np.linalg.det(F))
    psi = 0.5 * mu * (np.einsum("eij,eij->e", F, F) - 3) - mu * logJ + 0.5 * lam * logJ**2
    kinetic = density * volume / 4 * 0.5 * np.sum(v[tets] ** 2, axis=(1, 2))
    return kinetic, volume * psi


def frame_tet_energies(frame, youngs_modulus, poisson_ratio, density):
    """tet_energies of a Frame (hyperqn_tools.output)."""
    return tet_energies(frame.points, frame.points - frame.displacement, frame.velocity, frame.cells["tetra"],
                        youngs_modulus, poisson_ratio, density)


def frame_tet_momenta(frame, density):
    """Per tet (linear, angular about the origin) momentum of its lumped quarters, m x 3 each:
    rho V / 4 sum_a v_a and rho V / 4 sum_a x_a x v_a; their sums over tets are the lumped
    masses' momenta."""
    x, v, tets = frame.points, frame.velocity, frame.cells["tetra"]
    quarter = density * tet_volumes(x - frame.displacement, tets)[:, None] / 4
    return quarter * v[tets].sum(axis=1), quarter * np.cross(x[tets], v[tets]).sum(axis=1)


def neohookean_energies(path, youngs_modulus, poisson_ratio, density, gravity):
    """(kinetic, elastic, gravitational) energy of the frame at path: psi = mu/2 (|F|^2 - 3) -
    mu log J + lambda/2 log^2 J, and -sum m g.u (0 at rest) for gravity g = (0, -gravity, 0)."""
    f = Frame(path)  # merged over the ranks' pieces (a .pvtu of several) and over XDMF alike
    x, u, v = f.points, f.displacement, f.velocity
    X = x - u
    tets = f.cells["tetra"]
    _, elastic = tet_energies(x, X, v, tets, youngs_modulus, poisson_ratio, density)
    mass = lumped_masses(X, tets, density)
    kinetic = 0.5 * np.sum(mass * np.sum(v * v, axis=1))
    return float(kinetic), float(np.sum(elastic)), float(np.sum(mass * gravity * u[:, 1]))
