// SupernodalCholesky (solvers/supernodal_cholesky.hpp) on matrices chosen for the shapes of
// supernode its solve has a loop for: a chain (lone columns), one dense block (a single wide
// supernode), dense blocks of every width 1..9 (every remainder of the loops that take four rows
// or four columns at a time), and a 2-D grid (the mix a mesh gives). For each, with 1 and 3
// interleaved right-hand sides: x = A^{-1} b against a known x, b and x the same array, L's
// entries (no zeros are merged in: a chain's L has 2n - 1, a dense block's n(n + 1)/2), and a
// matrix that is not positive definite refused. With a separator (the split factor's interior, its
// last rows ordered last): the two halves of a solve with the dense separator block between them
// give A^{-1} b, on a grid whose last rows are the separator, and with every row in it. With a kept
// analysis (CholeskyAnalysis): a second matrix of the same pattern is factored without analysing
// it again, to the same bits as a new analysis gives, and another pattern is analysed anew. Kept in
// single precision (keep_single_precision): within 1e-6 of the double solve, symmetric to round-off,
// positive definite, the same bits at every call, and refused beyond float's range.
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
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

// A^{-1} b through the interior's halves and the separator's dense L_S (as SplitCholesky does on
// one rank): g = b_S - X y, x_S = L_S^{-T} L_S^{-1} g, then x_I.
void check_separator(const std::string& name, const Csr& A, int64_t s) {
  SupernodalCholesky f;
  std::vector<double> L;
  const auto status = f.factor(A.n, A.start.data(), A.column.data(), A.value.data(), s, &L);
  CHECK_MSG(status == SupernodalCholesky::Status::ok && f.separator() == s, name + ": factorization failed");
  if (status != SupernodalCholesky::Status::ok) return;
  const int64_t interior = A.n - s;
  std::mt19937 gen(2);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k : {1, 3}) {
    std::vector<double> x(k * A.n);
    for (double& v : x) v = u(gen);
    const std::vector<double> b = A.times(x, k);
    std::vector<double> g(k * s), solved(k * A.n);
    f.solve_interior_forward(k, b.data(), g.data());
    for (int64_t i = 0; i < s; ++i)
      for (int c = 0; c < k; ++c) g[k * i + c] += b[k * (interior + i) + c];
    for (int c = 0; c < k; ++c) {  // L_S z = g, then L_S^T x_S = z (L_S by columns)
      for (int64_t j = 0; j < s; ++j) {
        g[k * j + c] /= L[j + j * s];
        for (int64_t i = j + 1; i < s; ++i) g[k * i + c] -= L[i + j * s] * g[k * j + c];
      }
      for (int64_t j = s - 1; j >= 0; --j) {
        for (int64_t i = j + 1; i < s; ++i) g[k * j + c] -= L[i + j * s] * g[k * i + c];
        g[k * j + c] /= L[j + j * s];
      }
    }
    f.solve_interior_backward(k, g.data(), solved.data());
    for (int64_t i = 0; i < k * s; ++i) solved[k * interior + i] = g[i];
    double err = 0, scale = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      err = std::max(err, std::fabs(solved[i] - x[i]));
      scale = std::max(scale, std::fabs(x[i]));
    }
    CHECK_MSG(err <= 1e-13 * scale, name + ", k = " + std::to_string(k) + ": |x - A^-1 A x| = " + std::to_string(err));
  }
}

// The first n entries of A^{-1} b (k = 3) by the factor f, for a fixed b.
std::vector<double> solution(const SupernodalCholesky& f, int64_t n) {
  std::vector<double> b(3 * n);
  for (size_t i = 0; i < b.size(); ++i) b[i] = std::sin(1.0 + static_cast<double>(i));
  f.solve(3, b.data(), b.data());
  return b;
}

// A with `extra` added to the diagonal of every third row (the pattern unchanged).
Csr with_diagonal(Csr A, double extra) {
  for (int64_t i = 0; i < A.n; i += 3)
    for (int64_t p = A.start[i]; p < A.start[i + 1]; ++p)
      if (A.column[p] == i) A.value[p] += extra;
  return A;
}

void check_kept_analysis(const std::string& name, const Csr& A) {
  CholeskyAnalysis kept;
  SupernodalCholesky first, second, fresh;
  CHECK_MSG(first.factor(A.n, A.start.data(), A.column.data(), A.value.data(), 0, nullptr, &kept) ==
                SupernodalCholesky::Status::ok && kept.analyses() == 1, name + ": the first factorization");
  const Csr B = with_diagonal(A, 5.0);
  CHECK_MSG(second.factor(B.n, B.start.data(), B.column.data(), B.value.data(), 0, nullptr, &kept) ==
                SupernodalCholesky::Status::ok, name + ": the second factorization");
  CHECK_MSG(kept.analyses() == 1, name + ": the same pattern analysed " + std::to_string(kept.analyses()) + " times");
  CholeskyAnalysis once;
  CHECK(fresh.factor(B.n, B.start.data(), B.column.data(), B.value.data(), 0, nullptr, &once) ==
        SupernodalCholesky::Status::ok);
  CHECK_MSG(solution(second, B.n) == solution(fresh, B.n), name + ": the kept analysis's factor differs from a new one's");
  const std::vector<double> x = solution(second, B.n), b = B.times(x, 3);
  double err = 0;
  for (size_t i = 0; i < x.size(); ++i) err = std::max(err, std::fabs(b[i] - std::sin(1.0 + static_cast<double>(i))));
  CHECK_MSG(err <= 1e-12, name + ": |A A^-1 b - b| = " + std::to_string(err));
  SupernodalCholesky exact;  // without an analysis no zeros are merged in
  CHECK(exact.factor(A.n, A.start.data(), A.column.data(), A.value.data()) == SupernodalCholesky::Status::ok);
  CHECK_MSG(second.nonzeros() >= exact.nonzeros(), name + ": the relaxed factor has fewer entries than the exact one");

  const Csr other = chain(A.n + 1);  // another pattern: analysed again
  SupernodalCholesky third;
  CHECK(third.factor(other.n, other.start.data(), other.column.data(), other.value.data(), 0, nullptr, &kept) ==
        SupernodalCholesky::Status::ok);
  CHECK_MSG(kept.analyses() == 2 && third.size() == other.n, name + ": another pattern was not analysed again");
  // The same size and count of entries in another pattern: analysed again, and solved right.
  CholeskyAnalysis blocks;
  const Csr P = dense_blocks({3, 5}), Q = dense_blocks({5, 3});
  SupernodalCholesky p, q, q_alone;
  CHECK(p.factor(P.n, P.start.data(), P.column.data(), P.value.data(), 0, nullptr, &blocks) == SupernodalCholesky::Status::ok);
  CHECK(q.factor(Q.n, Q.start.data(), Q.column.data(), Q.value.data(), 0, nullptr, &blocks) == SupernodalCholesky::Status::ok);
  CHECK(q_alone.factor(Q.n, Q.start.data(), Q.column.data(), Q.value.data()) == SupernodalCholesky::Status::ok);
  CHECK_MSG(blocks.analyses() == 2 && solution(q, Q.n) == solution(q_alone, Q.n),
            name + ": a pattern of the same size and entries took the kept analysis");

  // With a separator (the split factor's interior): the same bits for the separator block too.
  const int64_t s = A.n / 10;
  CholeskyAnalysis split_kept, split_once;
  std::vector<double> L1, L2, L3;
  SupernodalCholesky s1, s2, s3;
  CHECK(s1.factor(A.n, A.start.data(), A.column.data(), A.value.data(), s, &L1, &split_kept) ==
        SupernodalCholesky::Status::ok);
  CHECK(s2.factor(B.n, B.start.data(), B.column.data(), B.value.data(), s, &L2, &split_kept) ==
        SupernodalCholesky::Status::ok);
  CHECK(s3.factor(B.n, B.start.data(), B.column.data(), B.value.data(), s, &L3, &split_once) ==
        SupernodalCholesky::Status::ok);
  CHECK_MSG(split_kept.analyses() == 1 && L2 == L3 && L2 != L1, name + ": with a separator, the kept analysis");
}

// y = A^{-1} b by f, k interleaved columns (the separator's half by its dense L_S, as SplitCholesky
// does on one rank, when f has one).
std::vector<double> apply(const SupernodalCholesky& f, const std::vector<double>& L, int k, std::vector<double> b) {
  const int64_t s = f.separator(), interior = f.size() - s;
  if (s == 0) {
    f.solve(k, b.data(), b.data());
    return b;
  }
  std::vector<double> g(k * s), x(b.size());
  f.solve_interior_forward(k, b.data(), g.data());
  for (int64_t i = 0; i < s; ++i)
    for (int c = 0; c < k; ++c) g[k * i + c] += b[k * (interior + i) + c];
  for (int c = 0; c < k; ++c) {
    for (int64_t j = 0; j < s; ++j) {
      g[k * j + c] /= L[j + j * s];
      for (int64_t i = j + 1; i < s; ++i) g[k * i + c] -= L[i + j * s] * g[k * j + c];
    }
    for (int64_t j = s - 1; j >= 0; --j) {
      for (int64_t i = j + 1; i < s; ++i) g[k * j + c] -= L[i + j * s] * g[k * i + c];
      g[k * j + c] /= L[j + j * s];
    }
  }
  f.solve_interior_backward(k, g.data(), x.data());
  for (int64_t i = 0; i < k * s; ++i) x[k * interior + i] = g[i];
  return x;
}

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d += a[i] * b[i];
  return d;
}

// keep_single_precision: on random vectors H = (L_f L_f^T)^{-1} is within 1e-6 of the double
// factor's A^{-1} (relative, 2-norm) yet not equal to it (the floats are used), symmetric to
// double round-off (|<Hu, v> - <u, Hv>| <= 1e-13 sqrt(<Hu, u> <Hv, v>): the forward and the
// backward pass use the same rounded values; a float's rounding would show at 1e-7), positive
// definite, and the same bits at every call.
void check_single(const std::string& name, const Csr& A, int64_t s = 0) {
  SupernodalCholesky f, g;
  std::vector<double> Lf, Lg;
  CHECK(f.factor(A.n, A.start.data(), A.column.data(), A.value.data(), s, s ? &Lf : nullptr) ==
        SupernodalCholesky::Status::ok);
  CHECK(g.factor(A.n, A.start.data(), A.column.data(), A.value.data(), s, s ? &Lg : nullptr) ==
        SupernodalCholesky::Status::ok);
  CHECK_MSG(g.keep_single_precision() && g.single_precision() && !f.single_precision(), name + ": not kept in single");
  std::mt19937 gen(3);
  std::uniform_real_distribution<double> u(-1, 1);
  double worst = 0, asymmetry = 0;
  for (int k : {1, 3})
    for (int trial = 0; trial < 5; ++trial) {
      std::vector<double> a(k * A.n), b(k * A.n);
      for (double& v : a) v = u(gen);
      for (double& v : b) v = u(gen);
      const std::vector<double> exact = apply(f, Lf, k, a), ha = apply(g, Lg, k, a), hb = apply(g, Lg, k, b);
      std::vector<double> diff(ha.size());
      for (size_t i = 0; i < ha.size(); ++i) diff[i] = ha[i] - exact[i];
      const double relative = std::sqrt(dot(diff, diff) / dot(exact, exact));
      worst = std::max(worst, relative);
      CHECK_MSG(relative <= 1e-6 && relative > 0,
                name + ", k = " + std::to_string(k) + ": |H a - A^-1 a| / |A^-1 a| = " + std::to_string(relative));
      const double haa = dot(ha, a), hbb = dot(hb, b);
      CHECK_MSG(haa > 0 && hbb > 0, name + ": <H a, a> <= 0");
      asymmetry = std::max(asymmetry, std::fabs(dot(ha, b) - dot(a, hb)) / std::sqrt(haa * hbb));
      CHECK_MSG(apply(g, Lg, k, a) == ha, name + ": another call gave other bits");
    }
  CHECK_MSG(asymmetry <= 1e-13, name + ": |<Ha, b> - <a, Hb>| / sqrt(<Ha, a> <Hb, b>) = " + std::to_string(asymmetry));
  std::printf("%s: single precision, relative difference %.2e, asymmetry %.2e\n", name.c_str(), worst, asymmetry);
  if (s == 0) {  // forward_units and solve_corrected need the doubles
    bool refused = false;
    try {
      const int64_t position = 0;
      std::vector<SupernodalCholesky::SparseColumn> out(1);
      g.forward_units(&position, 1, out.data());
    } catch (const std::logic_error&) {
      refused = true;
    }
    CHECK_MSG(refused, name + ": forward_units ran on a single-precision factor");
  }
}

// Values beyond float's range: keep_single_precision refuses and keeps the doubles.
void check_single_out_of_range() {
  Csr huge = chain(20);
  for (double& v : huge.value) v *= 1e90;  // L's entries about 1e45
  SupernodalCholesky f;
  CHECK(f.factor(huge.n, huge.start.data(), huge.column.data(), huge.value.data()) == SupernodalCholesky::Status::ok);
  CHECK_MSG(!f.keep_single_precision() && !f.single_precision(), "a factor beyond float's range was kept in single");
  std::vector<double> x(huge.n, 1.0), b = huge.times(x, 1);
  f.solve(1, b.data(), b.data());
  double err = 0;
  for (int64_t i = 0; i < huge.n; ++i) err = std::max(err, std::fabs(b[i] - 1.0));
  CHECK_MSG(err <= 1e-13, "the refused factor's doubles solve wrong: " + std::to_string(err));
}

}  // namespace

int main() {
  check_single("chain of 50", chain(50));
  check_single("dense blocks of 1 to 9", dense_blocks({1, 2, 3, 4, 5, 6, 7, 8, 9}));
  check_single("9-point grid 40 x 40", grid(40));
  check_single("9-point grid 30 x 30, its last 3 rows the separator", grid(30), 90);
  check_single_out_of_range();
  check_solves("chain of 50", chain(50), 2 * 50 - 1);
  check_solves("dense 37 x 37", dense_blocks({37}), 37 * 38 / 2);
  const std::vector<int64_t> sizes{1, 2, 3, 4, 5, 6, 7, 8, 9};
  int64_t triangles = 0;
  for (int64_t m : sizes) triangles += m * (m + 1) / 2;
  check_solves("dense blocks of 1 to 9", dense_blocks(sizes), triangles);
  check_solves("9-point grid 40 x 40", grid(40), 0);
  check_separator("9-point grid 30 x 30, its last row the separator", grid(30), 30);
  check_separator("9-point grid 30 x 30, its last 3 rows the separator", grid(30), 90);
  check_separator("chain of 40, its last 5 the separator", chain(40), 5);
  check_separator("dense 12 x 12, all of it the separator", dense_blocks({12}), 12);
  check_kept_analysis("9-point grid 40 x 40, kept analysis", grid(40));

  Csr indefinite = chain(10);
  indefinite.value[indefinite.start[4] + 1] = -3.0;  // a negative diagonal entry (row 4's middle)
  SupernodalCholesky f;
  CHECK(f.factor(indefinite.n, indefinite.start.data(), indefinite.column.data(), indefinite.value.data()) ==
        SupernodalCholesky::Status::not_positive_definite);
  CHECK(f.size() == 0);
  return check::summary("test_supernodal_cholesky");
}
