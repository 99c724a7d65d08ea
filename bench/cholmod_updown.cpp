// Contact in H0 by CHOLMOD's rank-k update instead of a refactorization (docs/contact.md, "Contact
// in H0"): what changing k diagonal entries of A1 = M + h^2 L costs each way, on one rank.
//
// Loads A1 (PETSc binary, e.g. from -hyperqn_h0_matrix_view binary:A1.bin), adds delta_v = A1(v, v)
// to k vertices' diagonal entries (contact stiffness of the order of A1's own, as the bunny's), and
// times, each the median of -repeat runs:
//   - refactor: the numerical supernodal factorization of A1 + D on the pattern analysed once
//     (what solver.h0_contact: refactor does, solvers/supernodal_cholesky.cpp);
//   - update: cholmod_updown of a simplicial LDL^T factor of A1 by C = [sqrt(delta_v) e_v] (an
//     n x k matrix), the only factor kind CHOLMOD updates; downdate: the same k removed again;
//   - the solve of 3 columns with each factor kind (an update path would solve with the simplicial one).
// and how far the updated factor's solution is from the refactored one's (an update is not the
// factorization of A1 + D bit for bit, so H0 would depend on the order the contacts came in).
// The k vertices: random ones (seeded), and k consecutive ones (a patch in the mesh's numbering).
// Run: build/cholmod_updown -f A1.bin [-k 10,100,1000] [-repeat 5]
#include <cholmod.h>
#include <petscmat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The lower triangle of a symmetric PETSc matrix as a CHOLMOD matrix (stype -1), plus the diagonal
// increment `add` (one value per row).
cholmod_sparse* lower_of(Mat A, const std::vector<double>& add, cholmod_common* c) {
  PetscInt n;
  MatGetSize(A, &n, nullptr);
  std::vector<int64_t> rows, cols;
  std::vector<double> vals;
  for (PetscInt i = 0; i < n; ++i) {
    PetscInt nc;
    const PetscInt* cj;
    const PetscScalar* v;
    MatGetRow(A, i, &nc, &cj, &v);
    for (PetscInt k = 0; k < nc; ++k)
      if (cj[k] <= i) {
        rows.push_back(i);
        cols.push_back(cj[k]);
        vals.push_back(v[k] + (cj[k] == i ? add[i] : 0.0));
      }
    MatRestoreRow(A, i, &nc, &cj, &v);
  }
  cholmod_triplet* t = cholmod_l_allocate_triplet(n, n, vals.size(), -1, CHOLMOD_REAL, c);
  std::copy(rows.begin(), rows.end(), static_cast<int64_t*>(t->i));
  std::copy(cols.begin(), cols.end(), static_cast<int64_t*>(t->j));
  std::copy(vals.begin(), vals.end(), static_cast<double*>(t->x));
  t->nnz = vals.size();
  cholmod_sparse* s = cholmod_l_triplet_to_sparse(t, vals.size(), c);
  cholmod_l_free_triplet(&t, c);
  return s;
}

// C = [sqrt(delta_v) e_v], one column per vertex, in L's permuted rows (cholmod_updown updates
// the factor of P A P^T by C C^T).
cholmod_sparse* update_columns(const cholmod_factor* L, const std::vector<int64_t>& vertices,
                               const std::vector<double>& delta, cholmod_common* c) {
  const int64_t n = (int64_t)L->n;
  const auto* perm = static_cast<const int64_t*>(L->Perm);
  std::vector<int64_t> position(n);
  for (int64_t q = 0; q < n; ++q) position[perm[q]] = q;
  const size_t k = vertices.size();
  cholmod_sparse* C = cholmod_l_allocate_sparse(n, k, k, 1, 1, 0, CHOLMOD_REAL, c);
  auto* p = static_cast<int64_t*>(C->p);
  auto* i = static_cast<int64_t*>(C->i);
  auto* x = static_cast<double*>(C->x);
  for (size_t j = 0; j < k; ++j) {
    p[j] = (int64_t)j;
    i[j] = position[vertices[j]];
    x[j] = std::sqrt(delta[vertices[j]]);
  }
  p[k] = (int64_t)k;
  return C;
}

// max |a - b| / max |b|
double relative_difference(const cholmod_dense* a, const cholmod_dense* b) {
  const auto* x = static_cast<const double*>(a->x);
  const auto* y = static_cast<const double*>(b->x);
  double d = 0, top = 0;
  for (size_t t = 0; t < a->nrow * a->ncol; ++t) {
    d = std::max(d, std::abs(x[t] - y[t]));
    top = std::max(top, std::abs(y[t]));
  }
  return top > 0 ? d / top : d;
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  char file[PETSC_MAX_PATH_LEN] = "", ks_text[256] = "10,30,100,300,1000";
  PetscInt repeat = 5;
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-f", file, sizeof file, nullptr));
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-k", ks_text, sizeof ks_text, nullptr));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-repeat", &repeat, nullptr));
  if (!file[0]) SETERRQ(PETSC_COMM_SELF, PETSC_ERR_USER, "give the matrix: -f A1.bin");
  PetscViewer viewer;
  Mat A;
  PetscCall(PetscViewerBinaryOpen(PETSC_COMM_SELF, file, FILE_MODE_READ, &viewer));
  PetscCall(MatCreate(PETSC_COMM_SELF, &A));
  PetscCall(MatSetType(A, MATSEQAIJ));
  PetscCall(MatLoad(A, viewer));
  PetscCall(PetscViewerDestroy(&viewer));
  PetscInt n;
  PetscCall(MatGetSize(A, &n, nullptr));
  std::vector<double> diagonal(n);
  for (PetscInt i = 0; i < n; ++i) PetscCall(MatGetValue(A, i, i, &diagonal[i]));
  std::vector<int64_t> ks;
  {
    std::stringstream in(ks_text);
    std::string item;
    while (std::getline(in, item, ',')) ks.push_back(std::min<int64_t>(std::stoll(item), n));
  }

  cholmod_common c;
  cholmod_l_start(&c);
  const std::vector<double> zero(n, 0.0);
  cholmod_sparse* A0 = lower_of(A, zero, &c);
  // Supernodal: analysed once, refactored numerically (as solver.h0_contact: refactor).
  cholmod_factor* Ls = cholmod_l_analyze(A0, &c);
  cholmod_l_factorize(A0, Ls, &c);
  const bool supernodal = Ls->is_super;
  // Simplicial LDL^T, the kind cholmod_updown changes.
  cholmod_common cs;
  cholmod_l_start(&cs);
  cs.supernodal = CHOLMOD_SIMPLICIAL;
  cs.final_ll = false;
  cholmod_factor* Ld = cholmod_l_analyze(A0, &cs);
  std::vector<double> t_simplicial;
  for (PetscInt r = 0; r < repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    cholmod_l_factorize(A0, Ld, &cs);
    t_simplicial.push_back(seconds_since(t0));
  }
  cholmod_dense* B = cholmod_l_ones(n, 3, CHOLMOD_REAL, &c);
  std::vector<double> t_solve_super, t_solve_simplicial;
  for (PetscInt r = 0; r < repeat; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    cholmod_dense* X = cholmod_l_solve(CHOLMOD_A, Ls, B, &c);
    t_solve_super.push_back(seconds_since(t0));
    cholmod_l_free_dense(&X, &c);
    t0 = std::chrono::steady_clock::now();
    X = cholmod_l_solve(CHOLMOD_A, Ld, B, &cs);
    t_solve_simplicial.push_back(seconds_since(t0));
    cholmod_l_free_dense(&X, &cs);
  }
  std::printf("%s: n = %lld, nnz(L) = %.0f (%s), simplicial LDL^T factorization %.3f ms\n", file, (long long)n,
              c.lnz, supernodal ? "supernodal" : "simplicial", 1e3 * median(t_simplicial));
  std::printf("solve of 3 columns: supernodal %.3f ms, simplicial LDL^T %.3f ms\n", 1e3 * median(t_solve_super),
              1e3 * median(t_solve_simplicial));
  std::printf("%-12s %6s %12s %12s %12s %14s\n", "vertices", "k", "refactor ms", "update ms", "downdate ms",
              "update vs refactor");

  std::mt19937_64 random(12345);
  for (const char* choice : {"random", "consecutive"})
    for (int64_t k : ks) {
      std::vector<int64_t> vertices(n);
      for (int64_t v = 0; v < n; ++v) vertices[v] = v;
      if (std::string(choice) == "random") {
        std::shuffle(vertices.begin(), vertices.end(), random);
        vertices.resize(k);
      } else {
        vertices = std::vector<int64_t>(vertices.begin() + n / 3, vertices.begin() + std::min<int64_t>(n, n / 3 + k));
      }
      std::sort(vertices.begin(), vertices.end());
      std::vector<double> delta(n, 0.0);
      for (int64_t v : vertices) delta[v] = diagonal[v];
      cholmod_sparse* A1 = lower_of(A, delta, &c);
      cholmod_sparse* C = update_columns(Ld, vertices, delta, &c);
      std::vector<double> t_refactor, t_update, t_downdate;
      double difference = 0;
      for (PetscInt r = 0; r < repeat; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        cholmod_l_factorize(A1, Ls, &c);
        t_refactor.push_back(seconds_since(t0));
        cholmod_factor* L = cholmod_l_copy_factor(Ld, &cs);  // LDL^T of A0
        t0 = std::chrono::steady_clock::now();
        cholmod_l_updown(1, C, L, &cs);
        t_update.push_back(seconds_since(t0));
        if (r == 0) {
          cholmod_dense* X_update = cholmod_l_solve(CHOLMOD_A, L, B, &cs);
          cholmod_dense* X_refactor = cholmod_l_solve(CHOLMOD_A, Ls, B, &c);
          difference = relative_difference(X_update, X_refactor);
          cholmod_l_free_dense(&X_update, &cs);
          cholmod_l_free_dense(&X_refactor, &c);
        }
        t0 = std::chrono::steady_clock::now();
        cholmod_l_updown(0, C, L, &cs);
        t_downdate.push_back(seconds_since(t0));
        cholmod_l_free_factor(&L, &cs);
      }
      std::printf("%-12s %6lld %12.3f %12.3f %12.3f %14.1e\n", choice, (long long)k, 1e3 * median(t_refactor),
                  1e3 * median(t_update), 1e3 * median(t_downdate), difference);
      cholmod_l_free_sparse(&C, &c);
      cholmod_l_free_sparse(&A1, &c);
    }
  cholmod_l_free_dense(&B, &c);
  cholmod_l_free_factor(&Ls, &c);
  cholmod_l_free_factor(&Ld, &cs);
  cholmod_l_free_sparse(&A0, &c);
  cholmod_l_finish(&cs);
  cholmod_l_finish(&c);
  PetscCall(MatDestroy(&A));
  PetscCall(PetscFinalize());
  return 0;
}
