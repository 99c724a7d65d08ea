// What H0 costs after a topology change on box130k (docs/topology-cost.md): TopologyH0's
// correction (solvers/topology_h0.hpp) against a refactorization of the changed A, interleaved.
//
// box130k is bench/bench.py's box (100 x 15 x 15 cells of 6 tets, 6.67 x 1 x 1, its -x end's 1 %
// fixed: 25,344 free vertices), A = M + h^2 L with bench.py's material (Neo-Hookean E = 1e6,
// nu = 0.3, density 1000: L's weight 2.0066 mu + 1.0122 lambda) and h = 1/30, L the P1 Laplacian
// (tests/topology_scene.hpp). One change: faces of the plane x = 3.33 separated, nearest a seed
// first, until the change touches at least `target` rows of A (it may pass it by a vertex's
// edits), or `target` / 4 tets removed around the seed. For each target and repeat, from the
// factor of the uncut box: the commit (the correction's setup: W's sparse columns, G, the LU of
// I + G E), one solve of 3 interleaved columns with the correction and without it, and the
// factorization of the changed A (analysis included: the pattern changed), in that order, then
// the check against it. Then one growing crack, change after change of `--grow` rows, to show the
// commit's and the solve's cost against the correction's size t (what chose kDefaultMaxTouched).
// Medians of --repeat. Prints a table, writes --json.
// Run: OMP_NUM_THREADS=1 build/topology_h0_bench [--repeat 5] [--json output/topology_h0.json]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <string>

#include "../tests/topology_scene.hpp"

using namespace hyperqn;
using namespace hyperqn::topology_scene;

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
// This thread's CPU time: the commit's without the time other jobs on the cores take from it.
double cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * t.tv_sec + 1e-6 * t.tv_nsec;
}
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

constexpr double kLength = 100.0 / 15;
CutMesh box130k() {
  const double mu = 1e6 / (2 * 1.3), lambda = 1e6 * 0.3 / (1.3 * 0.4);
  return CutMesh(generate_box({kLength, 1.0, 1.0}, {100, 15, 15}), 0.01 * kLength + 1e-9, 1000.0,
                 2.0066 * mu + 1.0122 * lambda, 1.0 / 30);
}

// The rows the edits touch.
int64_t touched_rows(const std::vector<Edit>& edits) {
  std::vector<int64_t> rows;
  for (const Edit& e : edits) rows.insert(rows.end(), e.rows.begin(), e.rows.end());
  std::sort(rows.begin(), rows.end());
  return std::unique(rows.begin(), rows.end()) - rows.begin();
}

double distance2(const double* x, const double* seed) {
  return (x[1] - seed[1]) * (x[1] - seed[1]) + (x[2] - seed[2]) * (x[2] - seed[2]);
}

// Faces of the plane x = 3.33 (50 cells in) ordered by their first tet's distance from seed.
std::vector<std::pair<int64_t, int64_t>> crack_faces(const CutMesh& mesh, const double* seed) {
  const double x0 = 50 * kLength / 100;
  auto faces = mesh.interior_faces([&](const double* x) { return std::abs(x[0] - x0) < 1e-9; });
  auto centre = [&](int64_t e) {
    double c[3] = {0, 0, 0};
    for (int64_t v : mesh.tet(e))
      for (int d = 0; d < 3; ++d) c[d] += 0.25 * mesh.rest(v)[d];
    return distance2(c, seed);
  };
  std::stable_sort(faces.begin(), faces.end(), [&](const auto& a, const auto& b) {
    return centre(a.first) + centre(a.second) < centre(b.first) + centre(b.second);
  });
  return faces;
}

// One change: the next faces of `faces` (from *next) separated until `target` rows are touched.
std::vector<Edit> crack_change(CutMesh& mesh, const std::vector<std::pair<int64_t, int64_t>>& faces, size_t* next,
                               int64_t target, int* added) {
  std::vector<Edit> edits;
  while (*next < faces.size() && touched_rows(edits) < target) {
    const auto [a, b] = faces[(*next)++];
    const auto more = mesh.separate(a, b, added);
    edits.insert(edits.end(), more.begin(), more.end());
  }
  return edits;
}

// One change: `count` removable tets nearest the seed (in the middle of the box) removed.
std::vector<Edit> removal_change(CutMesh& mesh, const double* seed, int count) {
  std::vector<std::pair<double, int64_t>> order;
  for (int64_t e = 0; e < mesh.tets(); ++e) {
    double c[3] = {0, 0, 0};
    for (int64_t v : mesh.tet(e))
      for (int d = 0; d < 3; ++d) c[d] += 0.25 * mesh.rest(v)[d];
    order.push_back({(c[0] - seed[0]) * (c[0] - seed[0]) + distance2(c, seed), e});
  }
  std::sort(order.begin(), order.end());
  std::vector<Edit> edits;
  for (size_t i = 0; i < order.size() && count > 0; ++i)
    if (mesh.removable(order[i].second)) {
      const auto more = mesh.remove(order[i].second);
      edits.insert(edits.end(), more.begin(), more.end());
      --count;
    }
  return edits;
}

double relative_error(const std::vector<double>& x, const std::vector<double>& y) {
  double d = 0, n = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    d += (x[i] - y[i]) * (x[i] - y[i]);
    n += y[i] * y[i];
  }
  return std::sqrt(d / n);
}

struct Row {
  std::string kind;
  int64_t target = 0;
  std::vector<double> touched, added, commit, commit_cpu, solve, plain, factor, error;
};

}  // namespace

int main(int argc, char** argv) {
  int repeat = 5, grow = 20;
  std::string json = "output/topology_h0.json";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--json")) json = argv[i + 1];
    else if (!std::strcmp(argv[i], "--grow")) grow = std::atoi(argv[i + 1]);
  }
  const CutMesh uncut = box130k();
  const SymmetricCsr A = uncut.assemble();
  std::printf("box130k: %lld rows, %lld tets\n", (long long)A.n, (long long)uncut.tets());
  std::mt19937_64 rng(130);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Row> rows;
  for (int64_t target : {1, 5, 10, 20, 35, 50}) rows.push_back(Row{"crack", target, {}, {}, {}, {}, {}, {}, {}, {}});
  for (int64_t target : {4, 20, 40}) rows.push_back(Row{"removal", target, {}, {}, {}, {}, {}, {}, {}, {}});
  TopologyH0 h;
  for (int r = 0; r < repeat; ++r)
    for (Row& row : rows) {
      // A seed per repeat, the same for every row (the row's order interleaves the measurements).
      const double seed[3] = {kLength / 2, 0.5 + 0.3 * std::sin(1.0 + r), 0.5 + 0.3 * std::cos(2.0 + r)};
      CutMesh mesh = uncut;
      if (h.setup(A, 100000) != TopologyH0::Status::ok) return 1;
      int added = 0;
      std::vector<Edit> edits;
      if (row.kind == "crack") {
        const auto faces = crack_faces(mesh, seed);
        size_t next = 0;
        edits = crack_change(mesh, faces, &next, row.target, &added);
      } else {
        edits = removal_change(mesh, seed, (int)row.target / 4);
      }
      std::vector<double> b(3 * mesh.rows()), x(b.size()), y(b.size()), x0(3 * A.n);
      for (double& v : b) v = u(rng);
      auto t0 = Clock::now();
      h.solve(3, b.data(), x0.data());  // before the change: the factor's own solve
      row.plain.push_back(ms_since(t0));
      replay(h, edits);
      t0 = Clock::now();
      const double c0 = cpu_ms();
      if (h.commit() != TopologyH0::Status::ok) return 1;
      row.commit_cpu.push_back(cpu_ms() - c0);
      row.commit.push_back(ms_since(t0));
      t0 = Clock::now();
      h.solve(3, b.data(), x.data());
      row.solve.push_back(ms_since(t0));
      const SymmetricCsr changed = mesh.assemble();
      SupernodalCholesky fresh;
      t0 = Clock::now();
      if (fresh.factor(changed.n, changed.start.data(), changed.column.data(), changed.value.data()) !=
          SupernodalCholesky::Status::ok)
        return 1;
      row.factor.push_back(ms_since(t0));
      fresh.solve(3, b.data(), y.data());
      row.error.push_back(relative_error(x, y));
      row.touched.push_back((double)h.touched());
      row.added.push_back(added);
    }
  std::printf("\n%-8s %6s %8s %6s %10s %10s %10s %10s %12s %10s\n", "change", "target", "touched", "new", "commit ms",
              "(cpu ms)", "solve ms", "plain ms", "refactor ms", "max error");
  for (const Row& row : rows)
    std::printf("%-8s %6lld %8.0f %6.0f %10.3f %10.3f %10.3f %10.3f %12.1f %10.2g\n", row.kind.c_str(),
                (long long)row.target, median(row.touched), median(row.added), median(row.commit),
                median(row.commit_cpu), median(row.solve), median(row.plain), median(row.factor),
                *std::max_element(row.error.begin(), row.error.end()));

  // One crack growing change after change: cost against the correction's size t.
  struct Step {
    int64_t t, nnz;
    double commit, commit_cpu, solve, plain;
  };
  std::vector<Step> steps;
  TopologyH0 plain;  // the uncut factor, its solve timed beside the corrected one
  if (plain.setup(A, 100000) != TopologyH0::Status::ok) return 1;
  {
    CutMesh mesh = uncut;
    if (h.setup(A, 100000) != TopologyH0::Status::ok) return 1;
    const double seed[3] = {kLength / 2, 0.5, 0.5};
    const auto faces = crack_faces(mesh, seed);
    size_t next = 0;
    int added = 0;
    while (next < faces.size() && h.touched() < 600) {
      replay(h, crack_change(mesh, faces, &next, grow, &added));
      auto t0 = Clock::now();
      const double c0 = cpu_ms();
      if (h.commit() != TopologyH0::Status::ok) return 1;
      const double commit = ms_since(t0), commit_cpu = cpu_ms() - c0;
      std::vector<double> b(3 * h.size()), x(b.size());
      for (double& v : b) v = u(rng);
      std::vector<double> s, p;
      for (int r = 0; r < repeat; ++r) {
        t0 = Clock::now();
        h.solve(3, b.data(), x.data());
        s.push_back(ms_since(t0));
        t0 = Clock::now();
        plain.solve(3, b.data(), x.data());
        p.push_back(ms_since(t0));
      }
      steps.push_back({h.touched(), h.correction_nonzeros(), commit, commit_cpu, median(s), median(p)});
    }
  }
  std::printf("\ngrowing crack, changes of >= %d rows:\n%8s %10s %10s %10s %10s %10s\n", grow, "t", "nnz(W)",
              "commit ms", "(cpu ms)", "solve ms", "plain ms");
  for (const Step& s : steps)
    std::printf("%8lld %10lld %10.3f %10.3f %10.3f %10.3f\n", (long long)s.t, (long long)s.nnz, s.commit, s.commit_cpu,
                s.solve, s.plain);

  if (FILE* f = std::fopen(json.c_str(), "w")) {
    std::fprintf(f, "{\"case\": \"box130k\", \"rows\": %lld, \"repeat\": %d, \"changes\": [", (long long)A.n, repeat);
    for (size_t i = 0; i < rows.size(); ++i) {
      const Row& row = rows[i];
      std::fprintf(f,
                   "%s\n  {\"kind\": \"%s\", \"target\": %lld, \"touched\": %.0f, \"new_vertices\": %.0f, "
                   "\"commit_ms\": %.4f, \"commit_cpu_ms\": %.4f, \"solve_ms\": %.4f, \"plain_solve_ms\": %.4f, \"refactor_ms\": %.3f, "
                   "\"max_error\": %.3g}",
                   i ? "," : "", row.kind.c_str(), (long long)row.target, median(row.touched), median(row.added),
                   median(row.commit), median(row.commit_cpu), median(row.solve), median(row.plain), median(row.factor),
                   *std::max_element(row.error.begin(), row.error.end()));
    }
    std::fprintf(f, "],\n \"growing\": [");
    for (size_t i = 0; i < steps.size(); ++i)
      std::fprintf(f, "%s\n  {\"t\": %lld, \"nnz_w\": %lld, \"commit_ms\": %.4f, \"commit_cpu_ms\": %.4f, \"solve_ms\": %.4f, \"plain_solve_ms\": %.4f}",
                   i ? "," : "", (long long)steps[i].t, (long long)steps[i].nnz, steps[i].commit, steps[i].commit_cpu,
                   steps[i].solve, steps[i].plain);
    std::fprintf(f, "]}\n");
    std::fclose(f);
    std::printf("\nwrote %s\n", json.c_str());
  }
  return 0;
}
