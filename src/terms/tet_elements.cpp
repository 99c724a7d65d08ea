#include "terms/tet_elements.hpp"

#include <algorithm>
#include <cstring>

#include "materials/stress_measures.hpp"

namespace hyperqn {

TetElements::TetElements(const DistributedMesh& mesh, std::vector<PetscInt> cells, std::vector<double> density,
                         bool per_volume)
    : mesh_(mesh), cells_(std::move(cells)), density_(std::move(density)) {
  for (auto& component : Dm_inv_) component.assign(cells_.size() + kBatch, 0.0);
  volume_.reserve(cells_.size());
  for (PetscInt c : cells_) {
    const Mat3 Dm = edge_matrix(mesh.rest.data(), &mesh.cells[4 * c]);
    const Mat3 inverse = Dm.inverse();
    for (int k = 0; k < 9; ++k) Dm_inv_[k][volume_.size()] = inverse(k);
    volume_.push_back(Dm.determinant() / 6.0);  // cells are positively oriented by clean_mesh
    weight_.push_back(per_volume ? volume_.back() : 1.0);
  }
  weight_.resize(cells_.size() + kBatch, 0.0);  // for the batches' full-width loops
  if (!mesh.unopened_rest.empty())
    for (PetscInt c : cells_)
      mass_volume_.push_back(edge_matrix(mass_rest(mesh), &mesh.cells[4 * c]).determinant() / 6.0);
}

double TetElements::mass_volume(size_t k) const { return mass_volume_.empty() ? volume_[k] : mass_volume_[k]; }

void TetElements::element_energy_batch(size_t k, int m, StressBatch& b, int n) const {
  per_element(b, n, [&](int e, const Mat3& F, Mat3& P) { return element_energy(static_cast<PetscInt>(k) + e, m, F, &P); });
}

// The elements in batches of up to kBatch consecutive ones of one material: F = Ds Dm^{-1} for the
// batch, then psi and P from the material, then the forces w P Dm^{-T}, each a loop across the
// batch (structure of arrays) that the compiler vectorizes; only reading positions and adding
// forces into the gradient go element by element. Energies are summed in element order.
PetscErrorCode TetElements::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  double e_sum = *energy;
  const size_t count = cells_.size();
  if (!gradient) {  // energy only: element by element
    for (size_t k = 0; k < count; ++k) {
      const Mat3 F = edge_matrix(pos.data(), &mesh_.cells[4 * cells_[k]]) * Dm_inv(k);
      e_sum += weight_[k] * element_energy(k, mesh_.cell_material[cells_[k]], F, nullptr);
    }
    *energy = e_sum;
    PetscFunctionReturn(0);
  }
  StressBatch b;
  Lanes Ds[9] = {};
  for (size_t k = 0; k < count;) {
    int m;
    const int n = load_batch(pos, k, Ds, b, &m);
    element_energy_batch(k, m, b, n);
    Lanes H[9];  // w P Dm^{-T}: column j is the force on vertex j + 1
    batch_forces(b, k, H);
    for (int e = 0; e < n; ++e) {
      e_sum += weight_[k + e] * b.psi[e];
      const PetscInt* cell = &mesh_.cells[4 * cells_[k + e]];
      Vec3 f0 = Vec3::Zero();
      for (int j = 0; j < 3; ++j) {
        const Vec3 f(H[3 * j][e], H[1 + 3 * j][e], H[2 + 3 * j][e]);
        add_vertex_vector(mesh_, cell[j + 1], f, gradient);
        f0 -= f;
      }
      add_vertex_vector(mesh_, cell[0], f0, gradient);
    }
    k += static_cast<size_t>(n);
  }
  *energy = e_sum;
  PetscFunctionReturn(0);
}

std::vector<ElementField> TetElements::element_fields() const {
  return {ElementField::cauchy_stress, ElementField::von_mises, ElementField::principal_stretches,
          ElementField::green_strain, ElementField::energy_density};
}

// sigma = sym(P F^T) / J, J = det F, for the n elements of a batch, P scaled by per_volume first:
// stress_measures::cauchy<3> and Eigen's 3 x 3 determinant lane by lane, each operation in the order
// Eigen evaluates them, so the files hold the same bits as with that per-element form (compared
// file by file, docs/records/2026-12-03-field-cost.md; this function is not cloned: no FMA
// contraction). sigma in kSymmetricRow's order; lanes past n hold J = 1.
static void batch_cauchy(const StressBatch& b, const Lanes& per_volume, int n, Lanes (&sigma)[6]) {
  const Lanes* F = b.F;  // column-major: F(i, j) is F[i + 3 j]
  Lanes J = (F[0] * (F[4] * F[8] - F[7] * F[5]) - F[3] * (F[1] * F[8] - F[7] * F[2])) + F[6] * (F[1] * F[5] - F[4] * F[2]);
  for (int e = n; e < kBatch; ++e) J[e] = 1.0;
  Lanes P[9];
  for (int i = 0; i < 9; ++i) P[i] = per_volume * b.P[i];
  // (P F^T)(i, j) / J, the sum over l of P(i, l) F(j, l) in the order of Eigen 3.4's 3 x 3 product
  // at SSE2 (rows 0 and 1 as one packet: (t0 + t1) + t2; row 2 alone: t0 + (t1 + t2)), then over J.
  Lanes A[9];
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 2; ++i) A[i + 3 * j] = ((P[i] * F[j] + P[i + 3] * F[j + 3]) + P[i + 6] * F[j + 6]) / J;
    A[2 + 3 * j] = (P[2] * F[j] + (P[5] * F[j + 3] + P[8] * F[j + 6])) / J;
  }
  for (int c = 0; c < 6; ++c) {
    const int i = kSymmetricRow[c], j = kSymmetricCol[c];
    sigma[c] = 0.5 * (A[i + 3 * j] + A[j + 3 * i]);
  }
  // A flat or inverted tet (J <= 0) has no Cauchy stress (force per deformed area): NaN, as an
  // element without the field (inverted_frames counts it), not P F^T / J's inf or sign-flipped
  // value; nor does it break a fracture criterion.
  for (int e = 0; e < n; ++e)
    if (!(J[e] > 0))
      for (int c = 0; c < 6; ++c) sigma[c][e] = NAN;
}

// In add_energy's batches (the same kernels, psi and P of a batch at once), one pass for all the
// fields asked for; the Cauchy stress across the batch, the other measures of F and P element by
// element: an output frame's cost is about one gradient's.
void TetElements::fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const {
  static_assert(size_t(ElementField::energy_density) == 4, "the tets' fields are the enum's first five");
  double* out[5] = {};  // by ElementField: cauchy_stress, von_mises, principal_stretches, green_strain, energy_density
  for (ElementFieldValues& f : fields)
    if (f.field <= ElementField::energy_density) out[size_t(f.field)] = f.values.data();
  if (std::none_of(std::begin(out), std::end(out), [](double* p) { return p; })) return;
  const int sym = field_info(ElementField::cauchy_stress).components;
  StressBatch b;
  Lanes Ds[9] = {};
  const size_t count = cells_.size();
  for (size_t k = 0; k < count;) {
    int m;
    const int n = load_batch(pos, k, Ds, b, &m);
    if (out[0] || out[1] || out[4]) stored_energy_batch(k, m, b, n);
    Lanes per_volume, sigma[6];  // per_volume: 1 for an energy density
    for (int e = 0; e < kBatch; ++e) per_volume[e] = e < n ? weight_[k + e] / volume_[k + e] : 1.0;
    if (out[0] || out[1]) batch_cauchy(b, per_volume, n, sigma);
    for (int e = 0; e < n; ++e) {
      const PetscInt c = cells_[k + e];
      if (out[0])
        for (int i = 0; i < sym; ++i) out[0][sym * c + i] = sigma[i][e];
      if (out[1]) {
        Mat3 s;
        for (int i = 0; i < sym; ++i) s(kSymmetricRow[i], kSymmetricCol[i]) = s(kSymmetricCol[i], kSymmetricRow[i]) = sigma[i][e];
        out[1][c] = stress_measures::von_mises(s);
      }
      if (out[2] || out[3]) {
        Mat3 F;
        for (int i = 0; i < 9; ++i) F(i) = b.F[i][e];
        if (out[2]) Eigen::Map<Vec3>(out[2] + 3 * c) = stress_measures::principal_stretches(F);
        if (out[3]) store_symmetric(stress_measures::green_strain(F), out[3] + sym * c);
      }
      if (out[4]) out[4][c] = per_volume[e] * b.psi[e];
    }
    k += static_cast<size_t>(n);
  }
}

// kBatch consecutive doubles from p on (any alignment).
static inline void load_lanes(const double* p, Lanes& v) { std::memcpy(&v, p, sizeof v); }

// b.F = Ds Dm^{-1} for the batch at element k: F(i, j) = sum_l Ds(i, l) Dm^{-1}(l, j).
int TetElements::load_batch(const std::vector<double>& pos, size_t k, Lanes (&Ds)[9], StressBatch& b, int* material) const {
  const int m = *material = mesh_.cell_material[cells_[k]];
  int n = 0;
  while (n < kBatch && k + n < cells_.size() && mesh_.cell_material[cells_[k + n]] == m) ++n;
  for (int e = 0; e < n; ++e) {  // Ds: columns x_j - x_0, j = 1..3
    const PetscInt* cell = &mesh_.cells[4 * cells_[k + e]];
    const double* x0 = &pos[3 * cell[0]];
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) Ds[i + 3 * j][e] = pos[3 * cell[j + 1] + i] - x0[i];
  }
  batch_deformation_gradients(Ds, k, b);
  return n;
}

HYPERQN_VECTOR_CLONES void TetElements::batch_deformation_gradients(const Lanes (&Ds)[9], size_t k, StressBatch& b) const {
  Lanes G[9];  // Dm^{-1} of the batch's elements
  for (int c = 0; c < 9; ++c) load_lanes(&Dm_inv_[c][k], G[c]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b.F[i + 3 * j] = Ds[i] * G[3 * j] + Ds[i + 3] * G[1 + 3 * j] + Ds[i + 6] * G[2 + 3 * j];
}

// H = w P Dm^{-T} for the batch at element k: H(i, j) = w sum_l P(i, l) Dm^{-1}(j, l).
HYPERQN_VECTOR_CLONES void TetElements::batch_forces(const StressBatch& b, size_t k, Lanes (&H)[9]) const {
  Lanes G[9], w;
  for (int c = 0; c < 9; ++c) load_lanes(&Dm_inv_[c][k], G[c]);
  load_lanes(&weight_[k], w);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) H[i + 3 * j] = w * (b.P[i] * G[j] + b.P[i + 3] * G[j + 3] + b.P[i + 6] * G[j + 6]);
}

PetscErrorCode TetElements::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> Ke;  // row-major: the layout MatSetValues reads
  PetscInt idx[12];
  PetscFunctionBeginUser;
  for (size_t k = 0; k < cells_.size(); ++k) {
    const PetscInt* cell = &mesh_.cells[4 * cells_[k]];
    const Mat3 Dmi = Dm_inv(k);
    const Mat3 F = edge_matrix(pos.data(), cell) * Dmi;
    const Mat9 C = element_stress_derivative(k, mesh_.cell_material[cells_[k]], F, psd);
    const Eigen::Matrix<double, 9, 12> B = deformation_jacobian(Dmi);
    Ke.noalias() = (scale * weight_[k]) * (B.transpose() * (C * B));
    // Average with the transpose so H is exactly symmetric whatever the rounding above.
    for (int i = 0; i < 12; ++i)
      for (int j = 0; j < i; ++j) Ke(i, j) = Ke(j, i) = 0.5 * (Ke(i, j) + Ke(j, i));
    element_dofs<4>(mesh_, cell, idx);
    PetscCall(MatSetValues(H, 12, idx, 12, idx, Ke.data(), ADD_VALUES));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode TetElements::add_laplacian(Mat A, double scale, int components) const {
  PetscFunctionBeginUser;
  for (size_t k = 0; k < cells_.size(); ++k)
    PetscCall(add_element_laplacian<4>(mesh_, A, &mesh_.cells[4 * cells_[k]],
                                       element_laplacian(k, mesh_.cell_material[cells_[k]], scale), components));
  PetscFunctionReturn(0);
}

void TetElements::add_tet_laplacians(double scale, double min_weight, std::vector<TetLaplacian>& out) const {
  for (size_t k = 0; k < cells_.size(); ++k) {
    const int m = mesh_.cell_material[cells_[k]];
    TetLaplacian t;
    t.weight = tet_weight(k, m);
    if (!(t.weight >= min_weight)) continue;
    for (int j = 0; j < 4; ++j) {
      const PetscInt v = mesh_.cells[4 * cells_[k] + j];
      t.vertex[j] = mesh_.vertex_ids[v];
      t.dof[j] = mesh_.global_dof[v];
    }
    Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(t.K.data()) = element_laplacian(k, m, scale);
    out.push_back(t);
  }
}

void TetElements::tet_weight_range(double& softest, double& stiffest) const {
  for (size_t k = 0; k < cells_.size(); ++k) {
    const double w = tet_weight(k, mesh_.cell_material[cells_[k]]);
    softest = std::min(softest, w);
    stiffest = std::max(stiffest, w);
  }
}

// Each vertex gets a quarter of the mass of each of its tets.
void TetElements::add_lumped_mass(PetscScalar* mass) const {
  for (size_t k = 0; k < cells_.size(); ++k) {
    const double quarter = 0.25 * density_[mesh_.cell_material[cells_[k]]] * mass_volume(k);
    for (int j = 0; j < 4; ++j) {
      const PetscInt off = mesh_.local_dof[mesh_.cells[4 * cells_[k] + j]];
      if (off < 0) continue;
      for (int d = 0; d < 3; ++d) mass[off + d] += quarter;
    }
  }
}

double TetElements::local_mass() const {
  double m = 0;
  for (size_t k = 0; k < cells_.size(); ++k) m += density_[mesh_.cell_material[cells_[k]]] * mass_volume(k);
  return m;
}

}  // namespace hyperqn
