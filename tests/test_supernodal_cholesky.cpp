// SupernodalCholesky (solvers/supernodal_cholesky.hpp) on matrices chosen for the shapes of
// supernode its solve has a loop for: a chain (lone columns), one dense block (a single wide
// supernode), dense blocks of every width 1..9 (every remainder of the loops that take four rows
// or four columns at a time), and a 2-D grid (the mix a mesh gives). For each, with 1 and 3
// interleaved right-hand sides: x = A^{-1} b against a known x, b and x the same array, L's
// entries (no zeros are merged in: a chain's L has 2n - 1, a dense block's n(n + 1)/2), and a
// matrix that is not positive definite refused.
#include <cmath>
#include <random>
#include <vector>

#include "check.hpp"
#include "solvers/supernodal_cholesky.hpp"

using namespace hyperqn;

namespace {

// A symmetric matrix in compressed rows, both triangles.
struct Csr {
  int64_t n = 0;
  std::vector<int64_t> start{0}, column;
  std::vector<double> value;
  void add_row(const std::vector<std::pair<int64_t, double>>& entries) {
    for (const auto& [j, a] : entries) {
      column.push_back(j);
      value.push_back(a);
    }
    start.push_back(static_cast<int64_t>(column.size()));
    ++n;
  }
  // y = A x for k interleaved columns.
  std::vector<double> times(const std::vector<double>& x, int k) const {
    std::vector<double> y(x.size(), 0.0);
    for (int64_t i = 0; i < n; ++i)
      for (int64_t p = start[i]; p < start[i + 1]; ++p)
        for (int c = 0; c < k; ++c) y[k * i + c] += value[p] * x[k * column[p] + c];
    return y;
  }
};

Csr chain(int64_t n) {  // tridiagonal, diagonally dominant
  Csr A;
  for (int64_t i = 0; i < n; ++i) {
    std::vector<std::pair<int64_t, double>> row;
    if (i > 0) row.push_back({i - 1, -1.0});
    row.push_back({i, 3.0});
    if (i + 1 < n) row.push_back({i + 1, -1.0});
    A.add_row(row);
  }
  return A;
}

// Dense diagonal blocks of the given sizes: entries 1 off the diagonal, size + 1 on it.
Csr dense_blocks(const std::vector<int64_t>& sizes) {
  Csr A;
  int64_t first = 0;
  for (int64_t m : sizes) {
    for (int64_t i = 0; i < m; ++i) {
      std::vector<std::pair<int64_t, double>> row;
      for (int64_t j = 0; j < m; ++j) row.push_back({first + j, i == j ? m + 1.0 : 1.0});
      A.add_row(row);
    }
    first += m;
  }
  return A;
}

Csr grid(int64_t side) {  // 9-point stencil on side x side points, diagonally dominant
  Csr A;
  for (int64_t a = 0; a < side; ++a)
    for (int64_t b = 0; b < side; ++b) {
      std::vector<std::pair<int64_t, double>> row;
      for (int64_t da = -1; da <= 1; ++da)
        for (int64_t db = -1; db <= 1; ++db) {
          const int64_t aa = a + da, bb = b + db;
          if (aa < 0 || bb < 0 || aa >= side || bb >= side) continue;
          row.push_back({aa * side + bb, da == 0 && db == 0 ? 9.0 : -1.0});
        }
      A.add_row(row);
    }
  return A;
}

void check_solves(const std::string& name, const Csr& A, int64_t expected_entries) {
  SupernodalCholesky f;
  const auto status = f.factor(A.n, A.start.data(), A.column.data(), A.value.data());
  CHECK_MSG(status == SupernodalCholesky::Status::ok, name + ": factorization failed");
  if (status != SupernodalCholesky::Status::ok) return;
  if (expected_entries > 0)
    CHECK_MSG(f.nonzeros() == expected_entries, name + ": L has " + std::to_string(f.nonzeros()) + " entries, not " +
                                                    std::to_string(expected_entries));
  std::mt19937 gen(1);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k : {1, 3}) {
    std::vector<double> x(k * A.n);
    for (double& v : x) v = u(gen);
    std::vector<double> b = A.times(x, k), solved(b.size());
    f.solve(k, b.data(), solved.data());
    f.solve(k, b.data(), b.data());  // in place
    double err = 0, scale = 0, same = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      err = std::max(err, std::fabs(solved[i] - x[i]));
      scale = std::max(scale, std::fabs(x[i]));
      same = std::max(same, std::fabs(b[i] - solved[i]));
    }
    CHECK_MSG(err <= 1e-13 * scale, name + ", k = " + std::to_string(k) + ": |x - A^-1 A x| = " + std::to_string(err));
    CHECK_MSG(same == 0, name + ", k = " + std::to_string(k) + ": the solve in place differs");
  }
}

}  // namespace

int main() {
  check_solves("chain of 50", chain(50), 2 * 50 - 1);
  check_solves("dense 37 x 37", dense_blocks({37}), 37 * 38 / 2);
  const std::vector<int64_t> sizes{1, 2, 3, 4, 5, 6, 7, 8, 9};
  int64_t triangles = 0;
  for (int64_t m : sizes) triangles += m * (m + 1) / 2;
  check_solves("dense blocks of 1 to 9", dense_blocks(sizes), triangles);
  check_solves("9-point grid 40 x 40", grid(40), 0);

  Csr indefinite = chain(10);
  indefinite.value[indefinite.start[4] + 1] = -3.0;  // a negative diagonal entry (row 4's middle)
  SupernodalCholesky f;
  CHECK(f.factor(indefinite.n, indefinite.start.data(), indefinite.column.data(), indefinite.value.data()) ==
        SupernodalCholesky::Status::not_positive_definite);
  CHECK(f.size() == 0);
  return check::summary("test_supernodal_cholesky");
}
