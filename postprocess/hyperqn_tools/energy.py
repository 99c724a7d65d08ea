"""The total energy of a neo-Hookean body in a VTK frame: kinetic, elastic and gravitational, with
hyperqn's lumped masses (a quarter of each tet's). For the integrators' energy checks
(tests/python/test_integrators.py, bench/integrator_energy.py); 1-rank frames."""
import numpy as np

from hyperqn_tools.output import frame_meshes


def neohookean_energies(path, youngs_modulus, poisson_ratio, density, gravity):
    """(kinetic, elastic, gravitational) energy of the frame at path: psi = mu/2 (|F|^2 - 3) -
    mu log J + lambda/2 log^2 J, and -sum m g.u (0 at rest) for gravity g = (0, -gravity, 0)."""
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    (m,) = frame_meshes(path)
    x = m.points
    u = m.point_data["displacement"]
    X = x - u
    v = m.point_data["velocity"]
    tets = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
    Dm = np.stack([X[tets[:, j]] - X[tets[:, 0]] for j in (1, 2, 3)], axis=2)
    Ds = np.stack([x[tets[:, j]] - x[tets[:, 0]] for j in (1, 2, 3)], axis=2)
    volume = np.abs(np.linalg.det(Dm)) / 6
    F = Ds @ np.linalg.inv(Dm)
    logJ = np.log(np.linalg.det(F))
    psi = 0.5 * mu * (np.einsum("eij,eij->e", F, F) - 3) - mu * logJ + 0.5 * lam * logJ**2
    mass = np.zeros(len(x))
    np.add.at(mass, tets.ravel(), np.repeat(density * volume / 4, 4))
    kinetic = 0.5 * np.sum(mass * np.sum(v * v, axis=1))
    return float(kinetic), float(np.sum(volume * psi)), float(np.sum(mass * gravity * u[:, 1]))
