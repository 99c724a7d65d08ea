#include "model/fracture.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "parallel/collectives.hpp"
#include "terms/element_fields.hpp"

namespace hyperqn {

std::vector<FractureSpec> fracture_specs(const SceneSpec& spec) {
  std::vector<MaterialSpec> materials;
  if (!spec.bodies.empty()) {
    materials = body_materials(spec.bodies).materials;
  } else {
    materials.push_back(spec.material);
    for (const MaterialRegion& r : spec.regions) materials.push_back(r.material);
  }
  std::vector<FractureSpec> specs;
  bool any = false;
  for (const MaterialSpec& m : materials) {
    specs.push_back(m.fracture);
    any = any || m.fracture.given;
  }
  return any ? specs : std::vector<FractureSpec>();
}

namespace {

// What a face's judgement needs of one tet: integers (number, material, 4 vertex ids) and doubles
// (Cauchy stress in kSymmetricRow's order, energy density, 4 positions).
constexpr int kInts = 6, kDoubles = 6 + 1 + 12;

struct TetRecord {
  const int64_t* ints;
  const double* doubles;
  int64_t number() const { return ints[0]; }
  int32_t material() const { return int32_t(ints[1]); }
  Eigen::Vector3d at(int64_t id) const {  // the position of its vertex of this id
    for (int j = 0; j < 4; ++j)
      if (ints[2 + j] == id) return Eigen::Vector3d(doubles + 7 + 3 * j);
    return Eigen::Vector3d::Constant(NAN);
  }
};

using FaceKey = TetFaces::Key;

// The face of tet record (ints) without its vertex `skip`.
FaceKey face_of(const int64_t* ints, int skip) {
  FaceKey f;
  for (int j = 0, k = 0; j < 4; ++j)
    if (j != skip) f[k++] = ints[2 + j];
  std::sort(f.begin(), f.end());
  return f;
}

// Whether face f between tets p and q breaks: computed from the lower-numbered tet first, so the
// same bits whichever rank judges it.
bool breaks(const TetRecord& p, const TetRecord& q, const FaceKey& f, const std::vector<FractureSpec>& specs) {
  const TetRecord& a = p.number() < q.number() ? p : q;
  const TetRecord& b = p.number() < q.number() ? q : p;
  const Eigen::Vector3d x0 = a.at(f[0]), x1 = a.at(f[1]), x2 = a.at(f[2]);
  const Eigen::Vector3d n = (x1 - x0).cross(x2 - x0).normalized();
  Eigen::Matrix3d sigma;
  for (int c = 0; c < 6; ++c) {
    const double s = 0.5 * (a.doubles[c] + b.doubles[c]);
    sigma(kSymmetricRow[c], kSymmetricCol[c]) = sigma(kSymmetricCol[c], kSymmetricRow[c]) = s;
  }
  const double normal_stress = n.dot(sigma * n), energy_density = 0.5 * (a.doubles[6] + b.doubles[6]);
  for (const TetRecord* side : {&a, &b}) {
    const int32_t m = side->material();
    if (m < 0 || m >= (int32_t)specs.size() || !specs[m].given) continue;
    const FractureSpec& spec = specs[m];
    const double value = spec.criterion == FractureCriterion::normal_stress ? normal_stress : energy_density;
    if (value > fracture_face_threshold(spec, a.number(), b.number())) return true;  // false for NaN
  }
  return false;
}

}  // namespace

TetFaces tet_faces(const DistributedMesh& mesh) {
  TetFaces t;
  std::map<TetFaces::Key, std::vector<PetscInt>> faces;
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    for (int skip = 0; skip < 4; ++skip) {
      TetFaces::Key f;
      for (int j = 0, k = 0; j < 4; ++j)
        if (j != skip) f[k++] = mesh.vertex_ids[mesh.cells[4 * c + j]];
      std::sort(f.begin(), f.end());
      faces[f].push_back(c);
    }
  std::vector<char> exported(size_t(mesh.num_cells), 0);
  for (const auto& [f, tets] : faces) {
    if (tets.size() == 2) {
      t.pairs.push_back({tets[0], tets[1]});
      t.pair_keys.push_back(f);
      continue;
    }
    const PetscInt c = tets[0];
    t.lone.push_back(c);
    t.lone_keys.push_back(f);
    // A face of one local tet whose other tet is on another rank has a ghost vertex on one of the
    // two ranks at least (on the higher rank all three are ghosts: a vertex's owner is the lowest
    // rank that holds it), which sends its tet to every rank.
    for (int j = 0; j < 4; ++j) {
      const PetscInt v = mesh.cells[4 * c + j];
      const int64_t id = mesh.vertex_ids[v];
      if ((id == f[0] || id == f[1] || id == f[2]) && !mesh.owned[v]) exported[c] = 1;
    }
  }
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    if (exported[c]) t.exported.push_back(c);
  return t;
}

PetscErrorCode overloaded_faces(MPI_Comm comm, const DistributedMesh& mesh, const TetFaces& table, const Body& body, Vec x,
                                const std::vector<FractureSpec>& specs, const std::set<TetPair>& separated,
                                std::vector<TetPair>& faces) {
  PetscFunctionBeginUser;
  faces.clear();
  std::vector<double> pos;
  PetscCall(body.local_positions(x, pos));
  // The tets' stress and energy density from their terms (an element without them: NaN, no break).
  const size_t elements = size_t(mesh.num_cells + mesh.num_segments + mesh.num_triangles);
  std::vector<ElementFieldValues> fields = {
      {ElementField::cauchy_stress, std::vector<double>(6 * elements, NAN)},
      {ElementField::energy_density, std::vector<double>(elements, NAN)}};
  for (const auto& term : body.terms()) term->fill_element_fields(pos, fields);
  const PetscInt nt = mesh.num_cells;
  std::vector<int64_t> ints(kInts * size_t(nt));
  std::vector<double> doubles(kDoubles * size_t(nt));
  for (PetscInt c = 0; c < nt; ++c) {
    int64_t* i = &ints[kInts * size_t(c)];
    double* d = &doubles[kDoubles * size_t(c)];
    i[0] = mesh.cell_ids[c];
    i[1] = mesh.cell_material.empty() ? 0 : mesh.cell_material[c];
    for (int j = 0; j < 4; ++j) {
      const PetscInt v = mesh.cells[4 * c + j];
      i[2 + j] = mesh.vertex_ids[v];
      for (int k = 0; k < 3; ++k) d[7 + 3 * j + k] = pos[3 * size_t(v) + k];
    }
    for (int k = 0; k < 6; ++k) d[k] = fields[0].values[6 * size_t(c) + k];
    d[6] = fields[1].values[c];
  }
  auto record = [](const std::vector<int64_t>& is, const std::vector<double>& ds, size_t k) {
    return TetRecord{&is[kInts * k], &ds[kDoubles * k]};
  };
  auto broken_pair = [](const TetRecord& p, const TetRecord& q) {
    return TetPair{std::min(p.number(), q.number()), std::max(p.number(), q.number())};
  };
  std::vector<TetPair> mine;
  for (size_t k = 0; k < table.pairs.size(); ++k) {  // the faces of two local tets: judged here
    const TetRecord p = record(ints, doubles, size_t(table.pairs[k][0])), q = record(ints, doubles, size_t(table.pairs[k][1]));
    if (!separated.count(broken_pair(p, q)) && breaks(p, q, table.pair_keys[k], specs)) mine.push_back(broken_pair(p, q));
  }
  std::vector<int64_t> out_ints;
  std::vector<double> out_doubles;
  for (PetscInt c : table.exported) {
    out_ints.insert(out_ints.end(), &ints[kInts * size_t(c)], &ints[kInts * size_t(c)] + kInts);
    out_doubles.insert(out_doubles.end(), &doubles[kDoubles * size_t(c)], &doubles[kDoubles * size_t(c)] + kDoubles);
  }
  const std::vector<int64_t> all_ints = all_gathered(comm, out_ints, MPI_INT64_T);
  const std::vector<double> all_doubles = all_gathered(comm, out_doubles, MPI_DOUBLE);
  std::map<FaceKey, std::vector<size_t>> gathered;
  for (size_t k = 0; k < all_ints.size() / kInts; ++k)
    for (int skip = 0; skip < 4; ++skip) gathered[face_of(&all_ints[kInts * k], skip)].push_back(k);
  // A face of one local tet meets its other tet among the gathered ones (not itself).
  for (size_t k = 0; k < table.lone.size() && !gathered.empty(); ++k) {
    const auto it = gathered.find(table.lone_keys[k]);
    if (it == gathered.end()) continue;
    const TetRecord p = record(ints, doubles, size_t(table.lone[k]));
    for (size_t g : it->second) {
      const TetRecord q = record(all_ints, all_doubles, g);
      if (q.number() == p.number()) continue;
      if (!separated.count(broken_pair(p, q)) && breaks(p, q, table.lone_keys[k], specs)) mine.push_back(broken_pair(p, q));
    }
  }
  std::vector<int64_t> flat;
  for (const TetPair& t : mine) flat.insert(flat.end(), t.begin(), t.end());
  const std::vector<int64_t> all = all_gathered(comm, flat, MPI_INT64_T);
  for (size_t k = 0; k + 1 < all.size(); k += 2) faces.push_back({all[k], all[k + 1]});
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
