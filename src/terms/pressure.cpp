// A pressure p on boundary faces that follows the deformed surface (a follower load): the force on
// a face is -p n dA, n its deformed outward normal, shared by its three vertices. Positive p
// pushes the surface into the body (an outer surface is compressed, a cavity's wall is pushed
// out: inflation).
//
// On a closed surface (every edge of the region's faces shared by two of them: a body's whole
// surface, a cavity) the load is conservative, E = p V with V = sum_faces (1/6) (a - c) . ((b - c)
// x (d - c)) the volume the surface encloses (the body's, or minus a cavity's; the reference point
// c drops out), and -dE/dx is exactly the follower force. c is the centre of the surface's own rest
// bounding box (the same at any rank count): the centre of the deck's box, which may reach far past
// the body, cost the sum its digits (a cube's hydrostatic stress was off by 3.5e-4 with the box
// reaching 1e3 m, by 30 % at 1e5 m). Its
// Hessian is indefinite: Newton's (psd) clamps each face's 9 x 9 block.
//
// On an open surface no such energy exists (the cone volume above gives a third of the force on a
// flat patch), so the normals are lagged: each step takes the faces' normals and areas at its start
// x_n and applies their force as a dead load through the step, E = -sum f . (x - X). The force
// follows the surface from step to step; it is exact as the steps shrink (a quasi-static run's
// load steps, a dynamic run's frames).
#include <algorithm>
#include <map>

#include "parallel/collectives.hpp"
#include "terms/element_kernels.hpp"
#include "terms/load_kind.hpp"

namespace hyperqn {

namespace {

using Mat9x9 = Eigen::Matrix<double, 9, 9>;
using Vec9 = Eigen::Matrix<double, 9, 1>;

Mat3 cross_matrix(const Vec3& v) {
  Mat3 m;
  m << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
  return m;
}

// The centre of the rest bounding box of the region's faces over all ranks (0 without faces).
Vec3 rest_centre(const DistributedMesh& mesh, const LoadRegion& region) {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const auto& f : region.faces)
    for (PetscInt v : f)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], mesh.rest[3 * v + k]);
        hi[k] = std::max(hi[k], mesh.rest[3 * v + k]);
      }
  const MPI_Comm comm = PetscObjectComm((PetscObject)mesh.dm);
  MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, comm);
  MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, comm);
  return lo[0] <= hi[0] ? Vec3((Vec3(lo) + Vec3(hi)) / 2) : Vec3::Zero();
}

// Whether every edge of the region's faces (over all ranks) is shared by exactly two of them.
bool closed_surface(const DistributedMesh& mesh, const LoadRegion& region) {
  std::vector<int64_t> edges;
  for (const auto& f : region.faces)
    for (int k = 0; k < 3; ++k) {
      const int64_t a = mesh.vertex_ids[f[k]], b = mesh.vertex_ids[f[(k + 1) % 3]];
      edges.push_back(std::min(a, b));
      edges.push_back(std::max(a, b));
    }
  std::map<std::pair<int64_t, int64_t>, int> count;
  const std::vector<int64_t> all = all_gathered(PetscObjectComm((PetscObject)mesh.dm), edges, MPI_INT64_T);
  for (size_t k = 0; k < all.size(); k += 2) ++count[{all[k], all[k + 1]}];
  for (const auto& [edge, n] : count)
    if (n != 2) return false;
  return !count.empty();
}

class Pressure : public LoadTerm {
 public:
  Pressure(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region)
      : LoadTerm(mesh, spec, index, std::move(region)),
        p_(spec_.number("pressure")),
        c_(rest_centre(mesh_, region_)),
        closed_(closed_surface(mesh_, region_)) {}
  std::string describe() const override {
    return LoadTerm::describe() + (closed_ ? ", closed: E = p V" : ", open: normals of each step's start");
  }
  bool needs_step_positions() const override { return !closed_; }
  PetscErrorCode begin_step(const StepStart& step) override {
    LoadTerm::begin_step(step);
    if (closed_) return 0;
    const std::vector<double>& pos = *step.start_positions;
    dead_vertices_.clear();
    dead_forces_.clear();
    for (const auto& f : region_.faces) {
      const Vec3 a(&pos[3 * f[0]]);
      // -p n A / 3 per vertex: n A = (b - a) x (d - a) / 2; the dead load scales it by factor_.
      const Vec3 share = -p_ / 6 * (Vec3(&pos[3 * f[1]]) - a).cross(Vec3(&pos[3 * f[2]]) - a);
      for (PetscInt v : f) {
        dead_vertices_.push_back(v);
        dead_forces_.push_back(share);
      }
    }
    return 0;
  }
  PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const override {
    if (!closed_) return LoadTerm::add_energy(x, pos, energy, gradient);
    double e = *energy;
    const double p = factor_ * p_;
    for (const auto& f : region_.faces) {
      const Vec3 a = Vec3(&pos[3 * f[0]]) - c_, b = Vec3(&pos[3 * f[1]]) - c_, d = Vec3(&pos[3 * f[2]]) - c_;
      e += p / 6 * a.dot(b.cross(d));
      if (gradient) {
        add_vertex_vector(mesh_, f[0], p / 6 * b.cross(d), gradient);
        add_vertex_vector(mesh_, f[1], p / 6 * d.cross(a), gradient);
        add_vertex_vector(mesh_, f[2], p / 6 * a.cross(b), gradient);
      }
    }
    *energy = e;
    return 0;
  }
  PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const override {
    PetscFunctionBeginUser;
    if (!closed_) PetscFunctionReturn(0);  // a dead load within the step
    for (const auto& f : region_.faces) {
      const Vec3 a = Vec3(&pos[3 * f[0]]) - c_, b = Vec3(&pos[3 * f[1]]) - c_, d = Vec3(&pos[3 * f[2]]) - c_;
      Mat9x9 He = Mat9x9::Zero();
      He.block<3, 3>(0, 3) = -cross_matrix(d);  // d/db (b x d)
      He.block<3, 3>(0, 6) = cross_matrix(b);   // d/dd (b x d)
      He.block<3, 3>(3, 6) = -cross_matrix(a);  // d/dd (d x a)
      He.block<3, 3>(3, 0) = He.block<3, 3>(0, 3).transpose();
      He.block<3, 3>(6, 0) = He.block<3, 3>(0, 6).transpose();
      He.block<3, 3>(6, 3) = He.block<3, 3>(3, 6).transpose();
      He *= factor_ * p_ / 6;
      if (psd) {
        Eigen::SelfAdjointEigenSolver<Mat9x9> eig(He);
        const Vec9 lambda = eig.eigenvalues().cwiseMax(0.0);
        He = eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
      }
      PetscCall(add_element_hessian<3>(mesh_, H, f.data(), He, scale));
    }
    PetscFunctionReturn(0);
  }
  bool projective_dynamics_exact() const override { return !closed_; }

 private:
  double p_;
  Vec3 c_;
  bool closed_;
};

std::unique_ptr<EnergyTerm> build(const DistributedMesh& mesh, const LoadSpec& spec, int index, LoadRegion region) {
  return std::make_unique<Pressure>(mesh, spec, index, std::move(region));
}

}  // namespace

LoadKind pressure_kind() {
  const DeckKey<LoadSpec> pressure{
      "pressure", number_field("pressure"),
      "force per deformed area (Pa in SI); positive pushes the surface into the body (a cavity inflates)",
      above(0, "0 acts on nothing")};
  return {"pressure", "a pressure on boundary faces that follows the deformed normal (follower load)", LoadTarget::faces,
          {pressure}, build};
}

}  // namespace hyperqn
