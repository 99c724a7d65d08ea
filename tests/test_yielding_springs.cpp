// Springs that yield (materials/yielding_spring.hpp, SpringSet::set_yield; docs/yielding-springs.md):
//  - the 1-D return map: w against a brute-force minimization of stored + dissipation over the
//    increment; dw/deps and d2w/deps2 against central differences of w and dw/deps, at rest
//    history and after plastic flow either way, inside the elastic range, beyond yield, and within
//    1e-4 of the yield surface on either side; w is C1 across the yield surface;
//  - a spring set (one spring between two free vertices, in 3-D): its energy's gradient and
//    Hessian against central differences at poses elastic, flowing in tension and in compression;
//    the psd Hessian has no negative eigenvalue; the elastic set (no yield) is untouched;
//  - a pull to eps_max and a release (monotone, quasi-static in 1-D) leaves the closed-form plastic
//    strain (eps_max - eps_y)/(1 + h); its dissipation is k L^2 eps_y dgamma >= 0; the history goes
//    back with ElementState::undo.
#include <petscmat.h>

#include <cmath>
#include <string>

#include "check.hpp"
#include "materials/yielding_spring.hpp"
#include "terms/element_kernels.hpp"  // Eigen, Mat3
#include "terms/spring_set.hpp"

using namespace hyperqn;

namespace {

double rel(double a, double b) { return std::fabs(a - b) / std::max(1.0, std::fabs(b)); }

// min over dgamma >= 0 of stored + dissipation, by scanning (the flow's direction the trial's sign).
double brute_force_w(double eps, const double* h, const SpringYield& y) {
  const double trial = eps - h[0], s = trial >= 0 ? 1.0 : -1.0;
  double best = 1e300;
  for (int i = 0; i <= 200000; ++i) {
    const double g = 1e-6 * i;
    const double e = trial - s * g, a = h[1] + g;
    best = std::min(best, 0.5 * e * e + 0.5 * y.hardening * a * a + y.strain * g);
  }
  return best;
}

void check_flow(const SpringYield& y) {
  const double histories[3][3] = {{0, 0, 0}, {0.03, 0.02, 0}, {-0.02, 0.05, 0}};
  for (const auto& h : histories) {
    const double centre = h[0], reach = y.strain + y.hardening * h[1];  // the elastic range's centre, half width
    for (double eps : {centre, centre + 0.5 * reach, centre - 0.5 * reach, centre + 2 * reach, centre - 3 * reach,
                       centre + reach + 1e-4, centre + reach - 1e-4, centre - reach - 1e-4, centre - reach + 1e-4}) {
      const std::string where = "h " + std::to_string(y.hardening) + " history (" + std::to_string(h[0]) + ", " +
                                std::to_string(h[1]) + ") eps " + std::to_string(eps);
      const yielding_spring::Flow f = yielding_spring::flow(eps, h, y);
      CHECK_MSG(std::fabs(f.w - brute_force_w(eps, h, y)) < 1e-10, where + ": w is the minimum over the increment");
      const double d = 1e-7;
      const yielding_spring::Flow p = yielding_spring::flow(eps + d, h, y), m = yielding_spring::flow(eps - d, h, y);
      // Within d of the surface the curvature jumps: compare the slope there by one-sided halves.
      const bool near_surface = std::fabs(std::fabs(eps - centre) - reach) < 2 * d;
      CHECK_MSG(rel((p.w - m.w) / (2 * d), f.slope) < 1e-7, where + ": dw/deps vs FD");
      if (!near_surface)
        CHECK_MSG(rel((p.slope - m.slope) / (2 * d), f.curvature) < 1e-6, where + ": d2w/deps2 vs FD");
      CHECK_MSG(f.dgamma >= 0 && f.curvature >= 0, where + ": dgamma, curvature >= 0");
      CHECK_MSG(std::fabs(f.elastic) <= y.strain + y.hardening * (h[1] + f.dgamma) + 1e-15, where + ": on or inside the surface");
    }
    // C1 across the yield surface: the slopes on either side of it meet.
    const double at = centre + reach, d = 1e-9;
    CHECK_MSG(std::fabs(yielding_spring::flow(at + d, h, y).slope - yielding_spring::flow(at - d, h, y).slope) < 1e-8,
              "slope continuous across the yield surface");
  }
}

// One spring between local vertices 0 and 1 (both free, dofs 0..5) on a hand-made one-rank mesh.
struct TwoVertices {
  DistributedMesh mesh;
  TwoVertices() {
    mesh.num_vertices = 2;
    mesh.rest = {0, 0, 0, 1, 0, 0};
    mesh.local_dof = {0, 3};
    mesh.global_dof = {0, 3};
  }
};

double energy_at(const SpringSet& set, const double* x, double* grad = nullptr) {
  double e = 0;
  if (grad)
    for (int i = 0; i < 6; ++i) grad[i] = 0;
  set.add_energy(x, &e, grad);
  return e;
}

PetscErrorCode check_spring_set(const SpringYield& y) {
  PetscFunctionBeginUser;
  TwoVertices tv;
  SpringSet set(tv.mesh);
  const double L = 1.0, k = 7.0;
  set.add(0, 1, L, k, 0);
  set.arrange();
  set.set_yield(y, "test");
  ElementState& state = *set.element_state();
  state.current(0)[0] = 0.01, state.current(0)[1] = 0.01;  // a history: stretched once, then
  state.begin();
  // Poses: elastic (l = 1.012, within 0.01 +- eps_y), flowing in tension, flowing in compression.
  for (double l : {1.012, 1.3, 0.8}) {
    const double x[6] = {0.1, -0.2, 0.05, 0.1 + l * 0.6, -0.2 + l * 0.8, 0.05};
    double g[6], gp[6], gm[6];
    energy_at(set, x, g);
    Mat H;
    PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, 6, 6, nullptr, &H));
    PetscCall(set.add_hessian(x, H, 1.0, false));
    PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
    double err_g = 0, err_h = 0;
    for (int i = 0; i < 6; ++i) {
      double xp[6], xm[6];
      for (int j = 0; j < 6; ++j) xp[j] = xm[j] = x[j];
      const double d = 1e-6;
      xp[i] += d, xm[i] -= d;
      err_g = std::max(err_g, rel((energy_at(set, xp) - energy_at(set, xm)) / (2 * d), g[i]));
      energy_at(set, xp, gp);
      energy_at(set, xm, gm);
      for (int j = 0; j < 6; ++j) {
        PetscScalar v;
        PetscCall(MatGetValue(H, j, i, &v));
        err_h = std::max(err_h, rel((gp[j] - gm[j]) / (2 * d), v));
      }
    }
    const std::string where = "spring set h " + std::to_string(y.hardening) + " l " + std::to_string(l);
    CHECK_MSG(err_g < 1e-7, where + ": gradient vs FD " + std::to_string(err_g));
    CHECK_MSG(err_h < 1e-6, where + ": Hessian vs FD " + std::to_string(err_h));
    // The psd Hessian: no negative eigenvalue (a compressed spring's transverse term clamped).
    PetscCall(MatZeroEntries(H));
    PetscCall(set.add_hessian(x, H, 1.0, true));
    PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
    Eigen::Matrix<double, 6, 6> Hd;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) PetscCall(MatGetValue(H, i, j, &Hd(i, j)));
    const double min_eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(Hd).eigenvalues().minCoeff();
    CHECK_MSG(min_eig >= -1e-12 * Hd.norm(), where + ": psd Hessian, eigenvalue " + std::to_string(min_eig));
    PetscCall(MatDestroy(&H));
  }
  PetscFunctionReturn(0);
}

// Pull to eps_max in steps, release to zero tension: eps_p = (eps_max - eps_y)/(1 + h), the set's
// tension at the released length 0, the dissipation k L^2 eps_y eps_p; undo puts the start back.
void check_pull_and_release(const SpringYield& y) {
  TwoVertices tv;
  SpringSet set(tv.mesh);
  const double L = 2.0, k = 3.0, eps_max = 0.05;
  set.add(0, 1, L, k, 0);
  set.arrange();
  set.set_yield(y, "test");
  ElementState& state = *set.element_state();
  for (int n = 1; n <= 10; ++n) {
    state.begin();
    const double x[6] = {0, 0, 0, L * (1 + eps_max * n / 10), 0, 0};
    set.update_state(x);
  }
  const double eps_p = (eps_max - y.strain) / (1 + y.hardening);
  CHECK_MSG(rel(state.current(0)[0], eps_p) < 1e-12, "plastic strain after the pull " + std::to_string(state.current(0)[0]));
  CHECK_MSG(rel(state.current(0)[2], k * L * L * y.strain * eps_p) < 1e-12, "dissipation k L^2 eps_y eps_p");
  // Released: the tension vanishes at L (1 + eps_p), and there nothing flows back.
  state.begin();
  const double before = state.start(0)[0];
  const double x[6] = {0, 0, 0, L * (1 + eps_p), 0, 0};
  CHECK_MSG(std::fabs(set.tension(0, x)) < 1e-12, "no tension at the residual length");
  set.update_state(x);
  CHECK_MSG(rel(state.current(0)[0], eps_p) < 1e-15, "unloading is elastic");
  const double pulled[6] = {0, 0, 0, 1.5 * L, 0, 0};
  set.update_state(pulled);
  CHECK_MSG(state.current(0)[0] > eps_p, "a second pull flows on");
  state.undo();
  CHECK_MSG(state.current(0)[0] == before, "undo puts the step's start back");
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  for (double h : {0.0, 0.3, 5.0}) {
    const SpringYield y{0.02, h};
    check_flow(y);
    PetscCall(check_spring_set(y));
    check_pull_and_release(y);
  }
  const int code = check::summary("test_yielding_springs");
  PetscCall(PetscFinalize());
  return code;
}
