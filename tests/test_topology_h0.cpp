// TopologyH0 (solvers/topology_h0.hpp): after each change of a box's mesh (separations along
// random interior faces, which duplicate vertices once a vertex's star falls apart, and removals
// of random tets), the corrected inverse applied to random vectors equals a fresh factorization of
// the changed A, assembled from the changed mesh, to 1e-10 relative, with 1 and 3 interleaved
// right-hand sides. The check can fail: the same changes with one element's term dropped give a
// wrong correction, which it rejects. Also: SupernodalCholesky's sparse columns L^{-1} P e_i and
// its solve with a middle step against dense ones; the refactor trigger (a commit past
// max_touched refactors, and the result is the factorization of the changed matrix bit for bit);
// and a matrix that stops being positive definite is reported.
#include <cstring>
#include <random>

#include "check.hpp"
#include "topology_scene.hpp"

using namespace hyperqn;
using namespace hyperqn::topology_scene;

namespace {

std::vector<double> random_vector(int64_t size, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> v(size);
  for (double& x : v) x = u(rng);
  return v;
}

// max over k = 1, 3 and a few random b of |x - x_ref| / |x_ref|, x_ref by a fresh factor of A.
double error_against_fresh(const TopologyH0& h, const SymmetricCsr& A, std::mt19937_64& rng) {
  SupernodalCholesky fresh;
  if (fresh.factor(A.n, A.start.data(), A.column.data(), A.value.data()) != SupernodalCholesky::Status::ok) return 1e300;
  double worst = 0;
  for (int k : {1, 3})
    for (int trial = 0; trial < 2; ++trial) {
      const std::vector<double> b = random_vector(k * A.n, rng);
      std::vector<double> x(b.size()), y(b.size());
      h.solve(k, b.data(), x.data());
      fresh.solve(k, b.data(), y.data());
      double d = 0, n = 0;
      for (size_t i = 0; i < b.size(); ++i) {
        d += (x[i] - y[i]) * (x[i] - y[i]);
        n += y[i] * y[i];
      }
      worst = std::max(worst, std::sqrt(d / n));
    }
  return worst;
}

CutMesh small_box() {
  // 6 x 4 x 4 cells of 6 tets (576 tets), the x = 0 face fixed.
  return CutMesh(generate_box({1.5, 1.0, 1.0}, {6, 4, 4}), 1e-9, 1000.0, 1.3e5, 0.01);
}

// L^{-1} P e_i by forward_units against the dense L^{-1} P A P^T L^{-T} = I check: for columns
// w_i, w_j, w_i . w_j = (A^{-1})_ij, densely and by forward_units' Gram entries; a column and a
// Gram entry the same bits whatever they are computed with; and solve_corrected with an identity
// middle = solve.
void check_sparse_columns() {
  CutMesh mesh = small_box();
  const SymmetricCsr A = mesh.assemble();
  SupernodalCholesky L;
  CHECK(L.factor(A.n, A.start.data(), A.column.data(), A.value.data()) == SupernodalCholesky::Status::ok);
  std::vector<int64_t> position(A.n);
  for (int64_t q = 0; q < A.n; ++q) position[L.perm()[q]] = q;
  const std::vector<int64_t> rows = {0, 7, 8, 31, A.n / 4, A.n / 3, A.n / 2, 2 * A.n / 3, A.n - 2, A.n - 1};
  const int m = (int)rows.size();
  std::vector<int64_t> positions;
  for (int64_t r : rows) positions.push_back(position[r]);
  std::vector<SupernodalCholesky::SparseColumn> cols(m), alone(m), split(m);
  std::vector<double> gram(m * m), split_gram(m * m);
  L.forward_units(positions.data(), m, cols.data(), nullptr, 0, gram.data());
  for (int a = 0; a < m; ++a) L.forward_units(&positions[a], 1, &alone[a]);
  // A pass per group of columns (the smallest block), the earlier passes' columns dotted as others.
  L.forward_units(positions.data(), m, split.data(), nullptr, 0, split_gram.data(), 1);
  bool same = true;  // batched, alone or in passes: the same bits
  for (int a = 0; a < m; ++a)
    same = same && cols[a].nodes == alone[a].nodes && cols[a].values == alone[a].values &&
           split[a].values == cols[a].values;
  CHECK_MSG(same, "a sparse column depends on the columns batched with it");
  // A Gram entry is a function of its two columns: the batch's, the passes' and the pair's alone
  // (b given as an earlier column) are the same bits, and the batch's is symmetric.
  bool gram_same = std::memcmp(gram.data(), split_gram.data(), gram.size() * sizeof(double)) == 0;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) {
      SupernodalCholesky::SparseColumn col;
      double pair[2];
      const SupernodalCholesky::SparseColumn* other = &alone[b];
      L.forward_units(&positions[a], 1, &col, &other, 1, pair);
      gram_same = gram_same && std::memcmp(&pair[1], &gram[a * m + b], sizeof(double)) == 0 &&
                  std::memcmp(&gram[a * m + b], &gram[b * m + a], sizeof(double)) == 0;
    }
  CHECK_MSG(gram_same, "a Gram entry depends on the columns computed with it");
  double worst = 0;
  for (int a = 0; a < m; ++a) {
    std::vector<double> e(A.n, 0.0), z(A.n);
    e[rows[a]] = 1;
    L.solve(1, e.data(), z.data());  // (A^{-1})_{., i}
    for (int b = 0; b < m; ++b) {
      std::vector<double> wa(A.n, 0.0), wb(A.n, 0.0);
      for (auto [col, w] : {std::pair{&cols[a], &wa}, std::pair{&cols[b], &wb}}) {
        size_t v = 0;
        for (int32_t node : col->nodes)
          for (int64_t i = L.nodes()[node].column; i < L.nodes()[node].column + L.nodes()[node].width; ++i) (*w)[i] = col->values[v++];
      }
      double dot = 0;
      for (int64_t i = 0; i < A.n; ++i) dot += wa[i] * wb[i];
      worst = std::max(worst, std::abs(dot - z[rows[b]]) / std::abs(z[rows[a]]));
      worst = std::max(worst, std::abs(gram[a * m + b] - z[rows[b]]) / std::abs(z[rows[a]]));
    }
  }
  CHECK_MSG(worst < 1e-12, "w_i . w_j (and forward_units' Gram entries) against (A^{-1})_ij: " + std::to_string(worst));
  std::mt19937_64 rng(3);
  const std::vector<double> b = random_vector(3 * A.n, rng);
  std::vector<double> x(b.size()), y(b.size());
  L.solve(3, b.data(), x.data());
  L.solve_corrected(3, b.data(), y.data(), [](double*, int) {});
  CHECK_MSG(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0, "solve_corrected with nothing between differs from solve");
}

// Random separations in the plane x = 0.75 (a crack that grows face by face, so vertices come
// apart) and anywhere, and random removals; after each change the check against a fresh factor.
void check_changes() {
  CutMesh mesh = small_box();
  TopologyH0 h;
  CHECK(h.setup(mesh.assemble(), 100000) == TopologyH0::Status::ok);
  std::mt19937_64 rng(44);
  std::vector<std::pair<int64_t, int64_t>> plane =
      mesh.interior_faces([](const double* x) { return std::abs(x[0] - 0.75) < 1e-9; });
  std::shuffle(plane.begin(), plane.end(), rng);
  std::vector<Edit> history;
  int added = 0, removed = 0, separations = 0, changes = 0;
  double worst = 0;
  for (int step = 0; step < 60; ++step) {
    std::vector<Edit> edits;
    const int kind = step % 3;
    if (kind < 2 && !plane.empty()) {  // the crack grows
      const auto [a, b] = plane.back();
      plane.pop_back();
      edits = mesh.separate(a, b, &added);
      ++separations;
    } else if (step % 2 == 0) {  // a random interior face anywhere
      const auto faces = mesh.interior_faces([](const double*) { return true; });
      const auto [a, b] = faces[std::uniform_int_distribution<size_t>(0, faces.size() - 1)(rng)];
      edits = mesh.separate(a, b, &added);
      ++separations;
    } else {  // a random tet removed
      int64_t e;
      do e = std::uniform_int_distribution<int64_t>(0, mesh.tets() - 1)(rng);
      while (!mesh.removable(e));
      edits = mesh.remove(e);
      ++removed;
    }
    replay(h, edits);
    history.insert(history.end(), edits.begin(), edits.end());
    CHECK(h.commit() == TopologyH0::Status::ok);
    CHECK(h.size() == mesh.rows());
    const double error = error_against_fresh(h, mesh.assemble(), rng);
    worst = std::max(worst, error);
    CHECK_MSG(error < 1e-10, "step " + std::to_string(step) + ": relative error " + std::to_string(error));
    ++changes;
  }
  std::printf("%d changes (%d separations, %d removals), %d new vertices, t = %lld, nnz(W) = %lld: worst %.3g\n",
              changes, separations, removed, added, (long long)h.touched(), (long long)h.correction_nonzeros(), worst);
  CHECK_MSG(added >= 10, "the crack duplicated too few vertices to test them: " + std::to_string(added));
  CHECK(removed >= 10);
  CHECK(h.refactorizations() == 0);
  CHECK(h.size() == mesh.assemble().n);

  // On purpose: the same history with one element's term left out. The check must fail.
  int64_t dropped = -1;
  for (int64_t i = (int64_t)history.size() - 1; i >= 0 && dropped < 0; --i)
    if (history[i].kind == Edit::element) dropped = i;
  TopologyH0 wrong;
  CHECK(wrong.setup(small_box().assemble(), 100000) == TopologyH0::Status::ok);
  replay(wrong, history, dropped);
  CHECK(wrong.commit() == TopologyH0::Status::ok);
  const double wrong_error = error_against_fresh(wrong, mesh.assemble(), rng);
  std::printf("one element term dropped: relative error %.3g (must fail the 1e-10 check)\n", wrong_error);
  CHECK_MSG(!(wrong_error < 1e-10), "the check passed a wrong correction: " + std::to_string(wrong_error));
  // ... and the whole history in one commit is right too.
  TopologyH0 once;
  CHECK(once.setup(small_box().assemble(), 100000) == TopologyH0::Status::ok);
  replay(once, history);
  CHECK(once.commit() == TopologyH0::Status::ok);
  CHECK(error_against_fresh(once, mesh.assemble(), rng) < 1e-10);
}

// A small max_touched: commits past it refactor, to the bits of a factor of the changed matrix,
// and the operator stays exact across them.
void check_refactor_trigger() {
  CutMesh mesh = small_box();
  TopologyH0 h;
  const int64_t max_touched = 40;
  CHECK(h.setup(mesh.assemble(), max_touched) == TopologyH0::Status::ok);
  std::mt19937_64 rng(7);
  auto plane = mesh.interior_faces([](const double* x) { return std::abs(x[0] - 0.5) < 1e-9; });
  std::shuffle(plane.begin(), plane.end(), rng);
  double worst = 0;
  for (const auto& [a, b] : plane) {
    replay(h, mesh.separate(a, b));
    CHECK(h.commit() == TopologyH0::Status::ok);
    CHECK(h.touched() <= max_touched);
    worst = std::max(worst, error_against_fresh(h, mesh.assemble(), rng));
  }
  CHECK_MSG(worst < 1e-10, "across refactorizations: " + std::to_string(worst));
  CHECK_MSG(h.refactorizations() >= 2, "refactorizations: " + std::to_string(h.refactorizations()));
  // Right after a refactorization the operator is setup() of the changed matrix, bit for bit.
  CHECK(h.refactor() == TopologyH0::Status::ok);
  TopologyH0 fresh;
  CHECK(fresh.setup(h.changed_matrix(), max_touched) == TopologyH0::Status::ok);
  const std::vector<double> b = random_vector(3 * h.size(), rng);
  std::vector<double> x(b.size()), y(b.size());
  h.solve(3, b.data(), x.data());
  fresh.solve(3, b.data(), y.data());
  CHECK_MSG(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0, "refactor() is not setup() of A'");
  // The same list of changes and commits gives the same operator, bit for bit.
  CutMesh again = small_box();
  TopologyH0 g;
  CHECK(g.setup(again.assemble(), max_touched) == TopologyH0::Status::ok);
  for (const auto& [a, b2] : plane) {
    replay(g, again.separate(a, b2));
    CHECK(g.commit() == TopologyH0::Status::ok);
  }
  CHECK(g.refactor() == TopologyH0::Status::ok);
  g.solve(3, b.data(), y.data());
  CHECK(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0);
}

// A' not positive definite (an element's stiffness taken out twice over): reported by commit.
void check_not_positive_definite() {
  CutMesh mesh = small_box();
  TopologyH0 h;
  CHECK(h.setup(mesh.assemble()) == TopologyH0::Status::ok);
  const int64_t rows[2] = {10, 11};
  const double K[4] = {1e6, -1e6, -1e6, 1e6};  // far more than the rows' mass and stiffness
  h.add_element(2, rows, K, -1);
  CHECK(h.commit() == TopologyH0::Status::not_positive_definite);
}

}  // namespace

int main() {
  check_sparse_columns();
  check_changes();
  check_refactor_trigger();
  check_not_positive_definite();
  return check::summary("test_topology_h0");
}
