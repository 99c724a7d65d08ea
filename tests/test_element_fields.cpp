// The per-element fields of the output frames (deck output.fields, terms/element_fields.hpp), as
// the scene's terms fill them, under a homogeneous deformation x = F X (the same F in every
// element):
// - every registered material model (materials/material_factory.cpp) and a fibre term: the Cauchy
//   stress equals P F^T / J with P from the model itself, and, for neohookean, stvk and the
//   mass-spring tets, the closed-form sigma written here; von Mises, the principal stretches, the
//   Green strain and the energy density against their definitions (1e-10 relative);
// - strand segments: the axial force EA (l/L - 1);
// - membrane cloth: sigma of the stvk and neohookean membranes in closed form, of all three against
//   finite differences of the membrane's energy;
// - the elements of other kinds stay NaN.
#include <petscdmplex.h>

#include <cmath>
#include <limits>

#include "check.hpp"
#include "materials/membrane.hpp"
#include "materials/tet_springs.hpp"
#include "materials/material_factory.hpp"
#include "terms/element_kernels.hpp"
#include "test_scene.hpp"

using namespace hyperqn;

namespace {

constexpr double kTol = 1e-10;
constexpr double kMu = 3.0, kLambda = 5.0, kSpring = 7.0, kEA = 20.0;

// A general deformation (not symmetric, det F = 1.26..., a little shear in every plane).
Mat3 deformation() {
  Mat3 F;
  F << 1.10, 0.20, -0.10,  //
      0.05, 0.90, 0.15,    //
      -0.10, 0.10, 1.25;
  return F;
}

struct FieldScene {
  DistributedMesh mesh;
  std::vector<std::unique_ptr<EnergyTerm>> terms;
};

// The test box (2 x 1 x 1, 4 x 2 x 2 cubes) of one material, optionally with two strands, or a
// 1 x 0.5 membrane sheet.
PetscErrorCode make(FieldScene& s, const MaterialSpec* material, bool strands, const ClothSpec* cloth) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  TetMesh serial;
  if (rank == 0) {
    if (cloth) {
      serial = generate_sheet({1.0, 0.5}, {4, 3});
      clean_mesh(serial, "sheet");
    } else {
      serial = generate_box({2.0, 1.0, 1.0}, {4, 2, 2});
      if (strands) {
        add_strand(serial, {{2.0, 1.0, 1.0}, {2.72, 1.96, 1.0}, 5, 0});
        add_strand(serial, {{0.0, 1.5, 0.0}, {0.3, 1.5, 0.4}, 3, 0});
      }
    }
  }
  const MeshPiece piece = scatter_serial_mesh(PETSC_COMM_WORLD, serial);
  PetscCall(distribute_mesh(PETSC_COMM_WORLD, piece, {}, {}, s.mesh));
  StrandMaterial strand;
  strand.axial_stiffness = kEA;
  strand.linear_density = 0.1;
  s.terms = elastic_terms(s.mesh, material ? std::vector<MaterialSpec>{*material} : std::vector<MaterialSpec>{}, strand,
                          cloth ? *cloth : ClothSpec{});
  PetscFunctionReturn(0);
}

// Every field the terms give, at x = F X, NaN where none writes.
std::vector<ElementFieldValues> fields_at(const FieldScene& s, const Mat3& F, std::vector<double>& pos) {
  pos.resize(3 * s.mesh.num_vertices);
  for (PetscInt v = 0; v < s.mesh.num_vertices; ++v) Eigen::Map<Vec3>{&pos[3 * v]} = F * Vec3(&s.mesh.rest[3 * v]);
  const size_t elements = size_t(s.mesh.num_cells + s.mesh.num_segments + s.mesh.num_triangles);
  std::vector<ElementFieldValues> fields;
  for (size_t f = 0; f < element_field_infos().size(); ++f)
    fields.push_back({ElementField(f), std::vector<double>(element_field_infos()[f].components * elements, NAN)});
  for (const auto& term : s.terms) term->fill_element_fields(pos, fields);
  return fields;
}

const double* at(const std::vector<ElementFieldValues>& fields, ElementField f, size_t element) {
  return &fields[size_t(f)].values[field_info(f).components * element];
}

// A symmetric tensor field's matrix from its 6 values (kSymmetricRow's order).
Mat3 tensor_at(const std::vector<ElementFieldValues>& fields, ElementField f, size_t element) {
  const double* v = at(fields, f, element);
  Mat3 A;
  for (int i = 0; i < 6; ++i) A(kSymmetricRow[i], kSymmetricCol[i]) = A(kSymmetricCol[i], kSymmetricRow[i]) = v[i];
  return A;
}

double relative(const Mat3& a, const Mat3& b) { return (a - b).norm() / std::max(b.norm(), 1e-300); }

bool all_nan(const std::vector<ElementFieldValues>& fields, ElementField f, size_t first, size_t end) {
  for (size_t e = first; e < end; ++e)
    for (int c = 0; c < field_info(f).components; ++c)
      if (!std::isnan(at(fields, f, e)[c])) return false;
  return true;
}

// The tets of one material: sigma against P F^T / J (P from the model, or the springs' kernel),
// and, where `closed` gives one, against its closed form; the other fields against definitions.
void check_tets(const std::string& what, const MaterialSpec& spec, const Mat3& F,
                const std::function<bool(const Mat3& F, Mat3& sigma, double& psi)>& closed) {
  FieldScene s;
  if (make(s, &spec, false, nullptr)) {
    CHECK_MSG(false, what + ": scene");
    return;
  }
  std::vector<double> pos;
  const auto fields = fields_at(s, F, pos);
  const bool springs = !find_material_model(spec.model)->create;
  const std::unique_ptr<Material> material = springs ? nullptr : make_material(spec);
  const double J = F.determinant();
  double worst_sigma = 0, worst_closed = 0, worst_other = 0;
  for (PetscInt c = 0; c < s.mesh.num_cells; ++c) {
    const Mat3 Dm = edge_matrix(s.mesh.rest.data(), &s.mesh.cells[4 * c]);
    const double V = Dm.determinant() / 6;
    Mat3 P;
    double psi;
    if (springs) {  // an energy per element: per rest volume
      psi = tet_springs::energy_and_stress(F, Dm, kSpring, P) / V;
      P /= V;
    } else {
      psi = material->energy_and_stress(F, P);
    }
    const Mat3 sigma = P * F.transpose() / J;
    const Mat3 field = tensor_at(fields, ElementField::cauchy_stress, c);
    worst_sigma = std::max(worst_sigma, relative(field, sigma));
    Mat3 sigma_closed;
    double psi_closed;
    if (closed && closed(F, sigma_closed, psi_closed)) {
      worst_closed = std::max(worst_closed, relative(field, sigma_closed));
      worst_closed = std::max(worst_closed, std::fabs(*at(fields, ElementField::energy_density, c) - psi_closed) /
                                                std::fabs(psi_closed));
    }
    // von Mises in components: sqrt(((s11 - s22)^2 + (s22 - s33)^2 + (s33 - s11)^2)/2 + 3 (s12^2 + s23^2 + s13^2)).
    const Mat3& t = sigma;
    const double vm = std::sqrt(0.5 * (std::pow(t(0, 0) - t(1, 1), 2) + std::pow(t(1, 1) - t(2, 2), 2) +
                                       std::pow(t(2, 2) - t(0, 0), 2)) +
                                3 * (t(0, 1) * t(0, 1) + t(1, 2) * t(1, 2) + t(0, 2) * t(0, 2)));
    worst_other = std::max(worst_other, std::fabs(*at(fields, ElementField::von_mises, c) - vm) / vm);
    const Vec3 stretches = Eigen::JacobiSVD<Mat3>(F).singularValues();  // descending
    worst_other = std::max(worst_other, (Eigen::Map<const Vec3>(at(fields, ElementField::principal_stretches, c)) -
                                         stretches).norm() / stretches.norm());
    const Mat3 E = 0.5 * (F.transpose() * F - Mat3::Identity());
    worst_other = std::max(worst_other, relative(tensor_at(fields, ElementField::green_strain, c), E));
    worst_other = std::max(worst_other, std::fabs(*at(fields, ElementField::energy_density, c) - psi) / std::fabs(psi));
  }
  CHECK_MSG(worst_sigma <= kTol, what + ": sigma vs P F^T / J, worst " + std::to_string(worst_sigma));
  CHECK_MSG(worst_closed <= kTol, what + ": sigma, psi vs closed form, worst " + std::to_string(worst_closed));
  CHECK_MSG(worst_other <= kTol, what + ": von Mises, stretches, E, psi, worst " + std::to_string(worst_other));
}

// Neo-Hookean (J above J0): sigma = mu/J (B - I) + lambda log J / J I.
bool neohookean(const Mat3& F, Mat3& sigma, double& psi) {
  const double J = F.determinant(), L = std::log(J);
  sigma = kMu / J * (F * F.transpose() - Mat3::Identity()) + kLambda * L / J * Mat3::Identity();
  psi = kMu / 2 * ((F.transpose() * F).trace() - 3) - kMu * L + kLambda / 2 * L * L;
  return true;
}

// StVK (kappa 0): sigma = F S F^T / J, S = 2 mu E + lambda tr E I.
bool stvk(const Mat3& F, Mat3& sigma, double& psi) {
  const Mat3 E = 0.5 * (F.transpose() * F - Mat3::Identity());
  const Mat3 S = 2 * kMu * E + kLambda * E.trace() * Mat3::Identity();
  sigma = F * S * F.transpose() / F.determinant();
  psi = kMu * E.squaredNorm() + kLambda / 2 * E.trace() * E.trace();
  return true;
}

// Mass-spring tets: sigma is the springs' virial stress sum_edges k (l - L) u u^T / l / (J V), u = F D
// each edge of the tet (D its rest edge), V the tet's rest volume.
void check_spring_virial(const Mat3& F) {
  FieldScene s;
  MaterialSpec spec;
  spec.model = "mass-spring";
  spec.spring_stiffness = kSpring;
  spec.has_density = true;
  if (make(s, &spec, false, nullptr)) return;
  std::vector<double> pos;
  const auto fields = fields_at(s, F, pos);
  double worst = 0;
  for (PetscInt c = 0; c < s.mesh.num_cells; ++c) {
    const PetscInt* cell = &s.mesh.cells[4 * c];
    const Mat3 Dm = edge_matrix(s.mesh.rest.data(), cell);
    Mat3 sigma = Mat3::Zero();
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        const Vec3 D = Vec3(&s.mesh.rest[3 * cell[b]]) - Vec3(&s.mesh.rest[3 * cell[a]]);
        const Vec3 u = F * D;
        sigma += kSpring * (u.norm() - D.norm()) / u.norm() * u * u.transpose();
      }
    sigma /= F.determinant() * Dm.determinant() / 6;
    worst = std::max(worst, relative(tensor_at(fields, ElementField::cauchy_stress, c), sigma));
  }
  CHECK_MSG(worst <= kTol, "mass-spring: sigma vs the springs' virial stress, worst " + std::to_string(worst));
}

void check_materials() {
  const Mat3 F = deformation();
  for (const MaterialModel& model : material_models()) {
    MaterialSpec spec;
    spec.model = model.name;
    spec.mu = kMu;
    spec.lambda = kLambda;
    spec.spring_stiffness = kSpring;
    spec.has_density = true;
    if (model.name == "principal-stretch") {  // f(x) = 2 (x - 1)^2, g(y) = 0.5 (y - 1)^2, h(J) = 1.5 (J - 1)^2
      spec.f = {"polynomial", {0, 0, 2.0}, {}, {}};
      spec.g = {"polynomial", {0, 0, 0.5}, {}, {}};
      spec.h = {"polynomial", {0, 0, 1.5}, {}, {}};
    }
    const auto closed = model.name == "neohookean" ? neohookean : model.name == "stvk" ? stvk : nullptr;
    check_tets(model.name, spec, F, closed);
    check_tets(model.name + ", compressed", spec, 0.8 * F, closed);  // J = 0.65: below 1, above J0
    if (model.fiber) {
      spec.has_fiber = true;
      spec.fiber_direction = {1.0, 1.0, 0.0};
      spec.fiber_stiffness = 4.0;
      check_tets(model.name + " + fibre", spec, F, nullptr);
    }
  }
  check_spring_virial(deformation());
}

// Strands beside the tets: each segment's tension EA (l/L - 1); the tets' fields NaN there, and
// the strands' field NaN at the tets.
void check_strands() {
  FieldScene s;
  MaterialSpec spec;
  spec.model = "corotated";
  spec.mu = kMu;
  spec.lambda = kLambda;
  spec.has_density = true;
  if (make(s, &spec, true, nullptr)) return;
  const Mat3 F = deformation();
  std::vector<double> pos;
  const auto fields = fields_at(s, F, pos);
  const size_t nt = s.mesh.num_cells, ns = s.mesh.num_segments;
  double worst = 0;
  for (size_t k = 0; k < ns; ++k) {
    const Vec3 D = Vec3(&s.mesh.rest[3 * s.mesh.segments[2 * k + 1]]) - Vec3(&s.mesh.rest[3 * s.mesh.segments[2 * k]]);
    const double force = kEA * ((F * D).norm() / D.norm() - 1);
    worst = std::max(worst, std::fabs(*at(fields, ElementField::axial_force, nt + k) - force) / std::fabs(force));
  }
  CHECK_MSG(worst <= kTol, "strands: axial force vs EA (l/L - 1), worst " + std::to_string(worst));
  CHECK(all_nan(fields, ElementField::axial_force, 0, nt));
  CHECK(all_nan(fields, ElementField::cauchy_stress, nt, nt + ns));
  CHECK(all_nan(fields, ElementField::membrane_stress, 0, nt + ns));
  long long segments = (long long)ns;
  MPI_Allreduce(MPI_IN_PLACE, &segments, 1, MPI_LONG_LONG, MPI_SUM, PETSC_COMM_WORLD);
  CHECK(segments == 8);  // 5 + 3
}

// A membrane sheet (in the x-z plane) under x = F X: sigma = P F2^T / J with F2 = F T (3 x 2), T an
// orthonormal basis of the rest plane; stvk: P = F2 S, S = 2 mu E + lambda tr E I (2-D); neohookean:
// P = mu F2 + (lambda log J - mu) F2 C^-1. Every model also against finite differences of E(x).
void check_membrane() {
  const Mat3 F = deformation();
  Eigen::Matrix<double, 3, 2> T;
  T << 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix<double, 3, 2> F2 = F * T;
  const Eigen::Matrix2d C = F2.transpose() * F2, E = 0.5 * (C - Eigen::Matrix2d::Identity());
  const double J = std::sqrt(C.determinant());
  for (membrane::Model m : {membrane::Model::stvk, membrane::Model::neohookean, membrane::Model::corotated}) {
    ClothSpec cloth;
    cloth.model = ClothModel::membrane;
    cloth.material = m;
    cloth.mu = 30.0;
    cloth.lambda = 20.0;
    cloth.areal_density = 0.2;
    FieldScene s;
    if (make(s, nullptr, false, &cloth)) return;
    std::vector<double> pos;
    const auto fields = fields_at(s, F, pos);
    Eigen::Matrix<double, 3, 2> P;
    if (m == membrane::Model::stvk)
      P = F2 * (2 * cloth.mu * E + cloth.lambda * E.trace() * Eigen::Matrix2d::Identity());
    else
      P = cloth.mu * F2 + (cloth.lambda * std::log(J) - cloth.mu) * F2 * C.inverse();
    const Mat3 closed = P * F2.transpose() / J;
    double worst_closed = 0, worst_fd = 0;
    const size_t first = s.mesh.num_cells + s.mesh.num_segments;
    for (PetscInt t = 0; t < s.mesh.num_triangles; ++t) {
      const PetscInt* tri = &s.mesh.triangles[3 * t];
      const Mat3 field = tensor_at(fields, ElementField::membrane_stress, first + t);
      if (m != membrane::Model::corotated) worst_closed = std::max(worst_closed, relative(field, closed));
      // sigma = (g1 e1^T + g2 e2^T) / a with g the central differences of E(x) at x1, x2.
      const membrane::TriangleRest r =
          membrane::rest(Vec3(&s.mesh.rest[3 * tri[0]]), Vec3(&s.mesh.rest[3 * tri[1]]), Vec3(&s.mesh.rest[3 * tri[2]]));
      const membrane::Vec9 x = element_positions<3>(pos.data(), tri);
      Mat3 sigma = Mat3::Zero();
      const double h = 1e-6;
      for (int j = 1; j <= 2; ++j) {
        Vec3 g;
        for (int d = 0; d < 3; ++d) {
          membrane::Vec9 xp = x, xm = x;
          xp(3 * j + d) += h;
          xm(3 * j + d) -= h;
          g(d) = (membrane::energy(m, cloth.mu, cloth.lambda, r, xp) - membrane::energy(m, cloth.mu, cloth.lambda, r, xm)) / (2 * h);
        }
        sigma += g * (x.segment<3>(3 * j) - x.segment<3>(0)).transpose();
      }
      sigma /= r.area * J;
      worst_fd = std::max(worst_fd, relative(field, 0.5 * (sigma + sigma.transpose())));
    }
    const std::string name = m == membrane::Model::stvk ? "stvk" : m == membrane::Model::neohookean ? "neohookean" : "corotated";
    CHECK_MSG(worst_closed <= kTol, "membrane " + name + ": sigma vs closed form, worst " + std::to_string(worst_closed));
    CHECK_MSG(worst_fd <= 1e-6, "membrane " + name + ": sigma vs finite differences, worst " + std::to_string(worst_fd));
    CHECK(all_nan(fields, ElementField::cauchy_stress, first, first + s.mesh.num_triangles));
  }
  // A mass-spring cloth gives no membrane stress.
  ClothSpec springs;
  springs.stretch_stiffness = 40.0;
  springs.areal_density = 0.2;
  FieldScene s;
  if (make(s, nullptr, false, &springs)) return;
  bool gives = false;
  for (const auto& term : s.terms)
    for (ElementField f : term->element_fields()) gives = gives || f == ElementField::membrane_stress;
  CHECK(!gives);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  check_materials();
  check_strands();
  check_membrane();
  const int code = test_scene::tally("test_element_fields");
  PetscCall(PetscFinalize());
  return code;
}
