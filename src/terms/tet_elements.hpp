// What the two kinds of tet terms share: elements whose energy is a function of the deformation
// gradient F = Ds Dm^{-1}, so forces are w P Dm^{-T} and stiffnesses w B^T (dP/dF) B, w the
// element's weight (its rest volume for an energy density, 1 for an energy per element). A term
// (continuum_tets, mass_spring_tets) says which cells it holds and what one element stores.
#pragma once
#include <array>
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "terms/energy_term.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

class TetElements : public EnergyTerm {
 public:
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override;
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override;
  PetscErrorCode add_laplacian(Mat A, double scale, int components) const override;
  void add_tet_laplacians(double scale, double min_weight, std::vector<TetLaplacian>& out) const override;
  void tet_weight_range(double& softest, double& stiffest) const override;
  void add_lumped_mass(PetscScalar* mass) const override;
  double local_mass() const override;
  // Cauchy stress, von Mises stress, principal stretches, Green strain and energy density per rest
  // volume of each tet, from element_energy's psi and P (per rest volume: divided by the volume
  // where the energy is per element, as the mass-spring tets').
  std::vector<ElementField> element_fields() const override;
  void fill_element_fields(const std::vector<double>& pos, std::vector<ElementFieldValues>& fields) const override;

 protected:
  // The rest volume of element k before any crack opened (mass_volume_): its mass over density.
  double mass_volume(size_t k) const;
  // cells: the local tets of this term (indices into mesh.cells), in mesh order; density: mass
  // per rest volume of each material (by mesh.cell_material); per_volume: the element energies
  // are densities (weighted by the rest volume) rather than energies per element (weight 1).
  TetElements(const DistributedMesh& mesh, std::vector<PetscInt> cells, std::vector<double> density, bool per_volume);
  // Per element k of this term (cell cells_[k], material m): its energy, with P = dE/dF if P is
  // not null; dP/dF; and its 4 x 4 vertex matrix in L (scaled by scale).
  virtual double element_energy(PetscInt k, int m, const Mat3& F, Mat3* P) const = 0;
  // The same for the n elements k .. k + n - 1 (all of material m) of a batch: psi and P from F.
  // This default calls element_energy per element.
  virtual void element_energy_batch(size_t k, int m, StressBatch& b, int n) const;
  virtual Mat9 element_stress_derivative(PetscInt k, int m, const Mat3& F, bool psd) const = 0;
  // The same as element_energy_batch in the elements' state as it stands (the output fields): for
  // a material with history, its current values and no step's dissipation; else element_energy_batch.
  virtual void stored_energy_batch(size_t k, int m, StressBatch& b, int n) const { element_energy_batch(k, m, b, n); }
  virtual Eigen::Matrix<double, 4, 4, Eigen::RowMajor> element_laplacian(PetscInt k, int m, double scale) const = 0;
  // Element k's weight w in its L_e = w V G^T G: element_laplacian's over w = 1's (a diagonal entry
  // of V G^T G is positive); a term whose w is its material's returns that without the matrices.
  virtual double tet_weight(size_t k, int m) const { return element_laplacian(k, m, 1.0)(0, 0) / weighted_laplacian(k, 1.0)(0, 0); }

  // A batch's F = Ds Dm^{-1}, and its forces w P Dm^{-T} (column j: the force on vertex j + 1),
  // for the batch that starts at element k (see add_energy).
  // The batch that starts at element k: its n (returned) elements, up to kBatch consecutive ones of
  // one material (*material), their edge matrices in Ds and F = Ds Dm^{-1} in b. Ds's lanes past n
  // keep what they held.
  int load_batch(const std::vector<double>& pos, size_t k, Lanes (&Ds)[9], StressBatch& b, int* material) const;
  void batch_deformation_gradients(const Lanes (&Ds)[9], size_t k, StressBatch& b) const;
  void batch_forces(const StressBatch& b, size_t k, Lanes (&H)[9]) const;
  // w V_k G_k^T G_k, G_k the gradients of element k's 4 barycentric shape functions: its matrix in L
  // with weight w.
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> weighted_laplacian(size_t k, double w) const {
    // Gradients of the 4 barycentric shape functions: rows of Dm^{-1}, and minus their sum.
    Eigen::Matrix<double, 3, 4> G;
    G.rightCols<3>() = Dm_inv(k).transpose();
    G.col(0) = -G.rightCols<3>().rowwise().sum();
    return ((w * volume_[k]) * (G.transpose() * G)).eval();
  }
  // Element k's inverse rest edge matrix Dm^{-1}.
  Mat3 Dm_inv(size_t k) const {
    Mat3 D;
    for (int c = 0; c < 9; ++c) D(c) = Dm_inv_[c][k];
    return D;
  }

  const DistributedMesh& mesh_;
  std::vector<PetscInt> cells_;  // local cell index per element
  // Dm^{-1} by component: Dm_inv_[c][k] is component c (column-major) of element k's, so that a
  // batch reads each component of consecutive elements from consecutive doubles. kBatch zeros
  // follow the last element, so a batch's full-width loops stay inside.
  std::array<std::vector<double>, 9> Dm_inv_;
  std::vector<double> volume_;   // per element: rest volume
  // per element: rest volume before any crack opened (mass_rest), which its mass comes from; a
  // kerf changes volume_ (the elastic rest shape) but not this. Empty: the same as volume_.
  std::vector<double> mass_volume_;
  std::vector<double> weight_;   // per element: weight of its energy (rest volume, or 1); kBatch zeros follow
  std::vector<double> density_;  // per material
};

// The local cells whose material m satisfies pick(m), in mesh order.
template <class Pick>
std::vector<PetscInt> cells_where(const DistributedMesh& mesh, Pick pick) {
  std::vector<PetscInt> cells;
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    if (pick(mesh.cell_material[c])) cells.push_back(c);
  return cells;
}

}  // namespace hyperqn
