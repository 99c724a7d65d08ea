// The inelastic models' batched kernels (InelasticModel::energy_batch, materials/inelastic_model.hpp)
// against their element-by-element energy(): the Maxwell branches' loop over the lanes
// (materials/maxwell_branches.cpp, spectral3's lane helpers) and plasticity's default (to 1e-14:
// only the rounding of adding to the batch's psi and P). Four
// branches, a rest and a flowed history (each lane its own), batches of 8 and of 5 elements, the
// poses of tests/test_viscoelastic.cpp plus strong compressions (b's smallest eigenvalue from det b),
// two and three eigenvalues of b 1e-4 and 1e-8 apart, and det F = 0 (+inf, P left as it was):
// W and P within 1e-12 of their size plus 1e-15 of sum mu |F| (b's own rounding; the same bound
// as the closed forms against the eigensolver in test_viscoelastic).
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "check.hpp"
#include "materials/material_factory.hpp"
#include "materials/maxwell_branches.hpp"

using namespace hyperqn;

namespace {

Mat3 rotation(double a, const Vec3& axis) { return Eigen::AngleAxisd(a, axis.normalized()).toRotationMatrix(); }

std::vector<std::pair<std::string, Mat3>> poses() {
  Mat3 shear = Mat3::Identity();
  shear(0, 1) = 1.5;
  Mat3 general;
  general << 1.3, 0.2, -0.1, 0.05, 0.8, 0.3, -0.2, 0.1, 1.1;
  const Mat3 R = rotation(0.9, Vec3(1, -2, 0.5)), R2 = rotation(2.1, Vec3(0.3, 1, -0.7));
  std::vector<std::pair<std::string, Mat3>> p = {
      {"rest", Mat3::Identity()},
      {"uniform 1.2", 1.2 * Mat3::Identity()},
      {"stretch 2", Vec3(2.0, 0.75, 0.75).asDiagonal()},
      {"compression 0.5", Vec3(0.5, 1.3, 1.3).asDiagonal()},
      {"shear 1.5", shear},
      {"general", general},
      {"inverted", Vec3(1.1, 0.9, -0.8).asDiagonal()},
      {"two equal, rotated", rotation(0.3, Vec3(0, 1, 1)) * Vec3(1.4, 0.9, 0.9).asDiagonal()},
      {"compression 1e-2", R * Vec3(1e-2, 1.0, 1.1).asDiagonal() * R2},
      {"compression 1e-3", R * Vec3(1e-3, 1.2, 0.9).asDiagonal() * R2},
      {"det F = 0", Vec3(1.0, 1.0, 0.0).asDiagonal()},
  };
  for (double gap : {1e-4, 1e-8}) {
    const std::string g = std::to_string(gap);
    p.push_back({"pair apart by " + g, R * Vec3(1.3, 1.3 * std::sqrt(1 + gap), 0.8).asDiagonal()});
    p.push_back({"three apart by " + g, 1.2 * R * Vec3(std::sqrt(1 - gap), 1, std::sqrt(1 + gap)).asDiagonal()});
  }
  return p;
}

// Every pose in every lane position: batches of the poses in turn (8 lanes, then 5), each lane with
// the history of its own (histories[e % count]); P starts from a material's value (here a fixed
// matrix per lane) that the model adds to.
void check_model(const InelasticModel& m, const std::vector<std::vector<double>>& histories, double dt, double mu_sum,
                 const std::string& label, double& worst) {
  const auto all = poses();
  for (int n : {kBatch, 5}) {
    for (size_t first = 0; first < all.size(); ++first) {
      StressBatch b;
      const double* h[kBatch];
      Mat3 F[kBatch], P0[kBatch];
      for (int e = 0; e < kBatch; ++e) {
        F[e] = all[(first + e) % all.size()].second;
        P0[e] = 0.1 * (e + 1) * Mat3::Identity();
        h[e] = histories[(first + e) % histories.size()].data();
        for (int c = 0; c < 9; ++c) {
          b.F[c][e] = F[e](c);
          b.P[c][e] = P0[e](c);
        }
        b.psi[e] = 0.5 * e;
      }
      m.energy_batch(b, n, h, dt);
      for (int e = 0; e < n; ++e) {
        const std::string where = label + ", " + all[(first + e) % all.size()].first + ", lane " + std::to_string(e) +
                                  " of " + std::to_string(n) + ", dt " + std::to_string(dt);
        Mat3 P = Mat3::Zero(), Pb;
        const double W = m.energy(F[e], h[e], dt, &P);
        for (int c = 0; c < 9; ++c) Pb(c) = b.P[c][e] - P0[e](c);
        const double Wb = b.psi[e] - 0.5 * e;
        if (std::isinf(W)) {
          CHECK_MSG(std::isinf(Wb) && Wb > 0, where + ": +inf");
          CHECK_MSG(Pb.norm() == 0, where + ": P left as it was");
          continue;
        }
        const double floor = 1e-3 * mu_sum * F[e].norm();
        const double eW = std::fabs(Wb - W) / (std::fabs(W) + floor), eP = (Pb - P).norm() / (P.norm() + floor);
        CHECK_MSG(eW <= 1e-12, where + ": W batched against element by element, rel " + std::to_string(eW));
        CHECK_MSG(eP <= 1e-12, where + ": P batched against element by element, rel " + std::to_string(eP));
        worst = std::max(worst, std::max(eW, eP));
      }
    }
  }
}

}  // namespace

int main() {
  const MaxwellBranches m({{0.7, 0.1}, {0.4, 2.0}, {1.3, 0.01}, {0.2, 30.0}});
  const int width = m.history_width();
  std::vector<double> rest(width), h(width), flowed(width);
  m.rest(rest.data());
  const Mat3 F1 = Vec3(2.0, 1 / std::sqrt(2.0), 1 / std::sqrt(2.0)).asDiagonal();
  m.update(F1, rest.data(), 0.05, h.data());
  Mat3 F2 = F1;
  F2(0, 1) = 0.8;
  F2 = rotation(0.7, Vec3(1, 2, 3)) * F2;
  m.update(F2, h.data(), 0.05, flowed.data());
  double worst = 0;
  for (double dt : {0.0, 0.005, 1.0}) check_model(m, {rest, flowed, h}, dt, 2.6, "maxwell", worst);
  std::printf("  Maxwell branches, batched against element by element: worst %.1e\n", worst);

  // Plasticity keeps InelasticModel's default (element by element): the same numbers exactly.
  MaterialSpec spec;
  spec.model = "hencky";
  spec.mu = 80.0;
  spec.lambda = 120.0;
  spec.inelastic.kind = "plastic";
  spec.inelastic.values = {{"yield_stress", 0.4}, {"isotropic_hardening", 20.0}, {"kinematic_hardening", 10.0}};
  const auto p = make_inelastic(spec);
  std::vector<double> prest(p->history_width()), pflowed(p->history_width());
  p->rest(prest.data());
  p->update(F2, prest.data(), 0.1, pflowed.data());
  double pworst = 0;
  check_model(*p, {prest, pflowed}, 0.1, 80.0, "plastic", pworst);
  CHECK_MSG(pworst <= 1e-14, "plasticity's default batch (the batch's P and psi added to): " + std::to_string(pworst));
  std::printf("  plasticity's default batch against element by element: worst %.1e\n", pworst);
  return check::summary("test_inelastic_batch");
}
