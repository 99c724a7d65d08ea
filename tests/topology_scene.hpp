// A tet mesh cut face by face and thinned tet by tet, as the edits of A = M + h^2 L that TopologyH0
// takes (solvers/topology_h0.hpp), and A assembled afresh from the changed mesh to check it
// against. Shared by tests/test_topology_h0.cpp and bench/topology_h0.cpp; not the mesh code a run
// will have (issue 44's topology operations on the distributed mesh), only enough of it to drive
// the operator: one rank, the P1 Laplacian of each tet times a weight, lumped mass.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <vector>

#include "mesh/mesh.hpp"
#include "solvers/topology_h0.hpp"

namespace hyperqn::topology_scene {

// One edit of A, replayed into a TopologyH0 by replay().
struct Edit {
  enum Kind { duplicate, mass, element } kind;
  std::vector<int64_t> rows;  // duplicate: the old row; mass: its row; element: its free rows
  std::vector<double> K;      // element: its matrix on those rows (row-major); duplicate / mass: {mass}
  double scale = 1;
};

class CutMesh {
 public:
  // The box's tets; the vertices with x <= fixed_x are fixed (no row of A).
  CutMesh(const TetMesh& mesh, double fixed_x, double density, double weight, double h) {
    X_ = mesh.coords;
    const int64_t nv = mesh.num_vertices();
    row_.assign(nv, -1);
    for (int64_t v = 0; v < nv; ++v)
      if (X_[3 * v] > fixed_x) row_[v] = rows_++;
    for (int64_t e = 0; e < mesh.num_tets(); ++e) {
      std::array<int64_t, 4> t;
      for (int j = 0; j < 4; ++j) t[j] = mesh.tets[4 * e + j];
      Eigen::Matrix3d Dm;
      for (int j = 0; j < 3; ++j)
        for (int d = 0; d < 3; ++d) Dm(d, j) = X_[3 * t[j + 1] + d] - X_[3 * t[0] + d];
      const double volume = std::abs(Dm.determinant()) / 6;
      Eigen::Matrix<double, 4, 3> G;  // gradients of the barycentric coordinates
      G.bottomRows<3>() = Dm.inverse();
      G.row(0) = -G.bottomRows<3>().colwise().sum();
      tets_.push_back(t);
      K_.push_back(h * h * weight * volume * G * G.transpose());
      quarter_.push_back(0.25 * density * volume);
      alive_.push_back(1);
    }
    star_.assign(nv, {});
    for (int64_t e = 0; e < (int64_t)tets_.size(); ++e)
      for (int64_t v : tets_[e]) star_[v].push_back(e);
  }

  int64_t rows() const { return rows_; }
  int64_t tets() const { return (int64_t)tets_.size(); }
  bool alive(int64_t e) const { return alive_[e]; }
  const std::array<int64_t, 4>& tet(int64_t e) const { return tets_[e]; }
  const double* rest(int64_t v) const { return &X_[3 * v]; }

  // A assembled from the mesh as it is now.
  SymmetricCsr assemble() const {
    std::vector<std::map<int64_t, double>> rows(rows_);
    for (int64_t e = 0; e < tets(); ++e) {
      if (!alive_[e]) continue;
      for (int a = 0; a < 4; ++a) {
        const int64_t ra = row_[tets_[e][a]];
        if (ra < 0) continue;
        rows[ra][ra] += quarter_[e];
        for (int b = 0; b < 4; ++b)
          if (const int64_t rb = row_[tets_[e][b]]; rb >= 0) rows[ra][rb] += K_[e](a, b);
      }
    }
    SymmetricCsr A;
    A.n = rows_;
    for (const auto& r : rows) {
      for (const auto& [j, a] : r) {
        A.column.push_back(j);
        A.value.push_back(a);
      }
      A.start.push_back((int64_t)A.column.size());
    }
    return A;
  }

  // The interior faces (two alive tets with the same three vertices, not separated) whose
  // vertices all pass `keep`, as (tet, tet) pairs, ascending.
  std::vector<std::pair<int64_t, int64_t>> interior_faces(const std::function<bool(const double*)>& keep) const {
    std::map<std::array<int64_t, 3>, std::vector<int64_t>> faces;
    for (int64_t e = 0; e < tets(); ++e) {
      if (!alive_[e]) continue;
      for (int skip = 0; skip < 4; ++skip) {
        std::array<int64_t, 3> f;
        for (int j = 0, c = 0; j < 4; ++j)
          if (j != skip) f[c++] = tets_[e][j];
        std::sort(f.begin(), f.end());
        if (keep(rest(f[0])) && keep(rest(f[1])) && keep(rest(f[2]))) faces[f].push_back(e);
      }
    }
    std::vector<std::pair<int64_t, int64_t>> out;
    for (const auto& [f, t] : faces)
      if (t.size() == 2 && !cracked_.count({t[0], t[1]})) out.push_back({t[0], t[1]});
    return out;
  }

  // Separates tets a and b along their shared face: every vertex of it whose star (its alive tets,
  // joined through the faces at it that are not separated) falls apart is duplicated, the
  // component holding its lowest tet keeping it and each other one getting a copy with the mass
  // of its tets. Returns the edits (and the new vertices' count in *added).
  std::vector<Edit> separate(int64_t a, int64_t b, int* added = nullptr) {
    std::vector<Edit> edits;
    cracked_.insert({std::min(a, b), std::max(a, b)});
    std::array<int64_t, 3> face;
    for (int j = 0, c = 0; j < 4; ++j)
      if (std::count(tets_[b].begin(), tets_[b].end(), tets_[a][j])) face[c++] = tets_[a][j];
    for (int64_t v : face) {
      const std::vector<std::vector<int64_t>> parts = components(v);
      for (size_t p = 1; p < parts.size(); ++p) {
        const int64_t copy = (int64_t)X_.size() / 3;
        X_.insert(X_.end(), &X_[3 * v], &X_[3 * v] + 3);
        star_.push_back({});
        row_.push_back(row_[v] >= 0 ? rows_++ : -1);
        double moved = 0;
        for (int64_t e : parts[p]) moved += quarter_[e];
        if (row_[v] >= 0) edits.push_back({Edit::duplicate, {row_[v]}, {moved}, 1});
        for (int64_t e : parts[p]) {
          push_element(edits, e, -1);
          std::replace(tets_[e].begin(), tets_[e].end(), v, copy);
          push_element(edits, e, +1);
          star_[v].erase(std::find(star_[v].begin(), star_[v].end(), e));
          star_[copy].push_back(e);
        }
        if (added) ++*added;
      }
    }
    return edits;
  }

  // Whether removing tet e leaves each of its vertices another alive tet (else it would be left
  // without mass and stiffness, a singular A).
  bool removable(int64_t e) const {
    if (!alive_[e]) return false;
    for (int64_t v : tets_[e]) {
      int others = 0;
      for (int64_t f : star_[v]) others += f != e && alive_[f];
      if (others == 0) return false;
    }
    return true;
  }

  // Removes tet e: its stiffness and its mass.
  std::vector<Edit> remove(int64_t e) {
    std::vector<Edit> edits;
    push_element(edits, e, -1);
    for (int64_t v : tets_[e])
      if (row_[v] >= 0) edits.push_back({Edit::mass, {row_[v]}, {-quarter_[e]}, 1});
    alive_[e] = 0;
    return edits;
  }

 private:
  void push_element(std::vector<Edit>& edits, int64_t e, double scale) const {
    Edit edit{Edit::element, {}, {}, scale};
    std::vector<int> local;
    for (int j = 0; j < 4; ++j)
      if (row_[tets_[e][j]] >= 0) {
        edit.rows.push_back(row_[tets_[e][j]]);
        local.push_back(j);
      }
    for (int i : local)
      for (int j : local) edit.K.push_back(K_[e](i, j));
    if (!edit.rows.empty()) edits.push_back(edit);
  }

  // The components of v's star, each ascending, in the order of their lowest tet.
  std::vector<std::vector<int64_t>> components(int64_t v) const {
    std::vector<int64_t> star;
    for (int64_t e : star_[v])
      if (alive_[e]) star.push_back(e);
    std::sort(star.begin(), star.end());
    std::vector<int> part(star.size(), -1);
    std::vector<std::vector<int64_t>> parts;
    for (size_t s = 0; s < star.size(); ++s) {
      if (part[s] >= 0) continue;
      parts.push_back({});
      std::vector<size_t> todo{s};
      part[s] = (int)parts.size() - 1;
      while (!todo.empty()) {
        const size_t i = todo.back();
        todo.pop_back();
        parts.back().push_back(star[i]);
        for (size_t j = 0; j < star.size(); ++j)
          if (part[j] < 0 && joined(star[i], star[j])) {
            part[j] = part[s];
            todo.push_back(j);
          }
      }
      std::sort(parts.back().begin(), parts.back().end());
    }
    return parts;
  }

  // Two tets of a star share a face (three vertices) that is not separated.
  bool joined(int64_t a, int64_t b) const {
    int shared = 0;
    for (int64_t v : tets_[a]) shared += (int)std::count(tets_[b].begin(), tets_[b].end(), v);
    return shared == 3 && !cracked_.count({std::min(a, b), std::max(a, b)});
  }

  std::vector<double> X_;                      // rest positions (a copy at its original's)
  std::vector<std::array<int64_t, 4>> tets_;   // their vertices now
  std::vector<Eigen::Matrix4d> K_;             // h^2 weight times the P1 Laplacian
  std::vector<double> quarter_;                // a quarter of each tet's mass
  std::vector<char> alive_;
  std::vector<int64_t> row_;                   // per vertex: its row of A (-1: fixed)
  std::vector<std::vector<int64_t>> star_;     // per vertex: the tets at it (alive or not)
  std::set<std::pair<int64_t, int64_t>> cracked_;
  int64_t rows_ = 0;
};

// Replays edits into h (the one at `skip`, if any, left out: a wrong correction on purpose).
inline void replay(TopologyH0& h, const std::vector<Edit>& edits, int64_t skip = -1) {
  for (int64_t i = 0; i < (int64_t)edits.size(); ++i) {
    if (i == skip) continue;
    const Edit& e = edits[i];
    if (e.kind == Edit::duplicate) h.duplicate_vertex(e.rows[0], e.K[0]);
    else if (e.kind == Edit::mass) h.add_mass(e.rows[0], e.K[0]);
    else h.add_element((int)e.rows.size(), e.rows.data(), e.K.data(), e.scale);
  }
}

}  // namespace hyperqn::topology_scene
