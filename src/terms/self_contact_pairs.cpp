// One self-contact pair's energies (terms/self_contact.hpp declares and describes them): its
// contact energy from the distance of its two primitives, and its lagged friction.
#include <cmath>

#include "terms/contact.hpp"
#include "terms/self_contact.hpp"
#include "terms/smoothed_friction.hpp"

namespace hyperqn {

using Vec3 = Eigen::Vector3d;

double self_contact_pair_energy(const ContactSpec& spec, PairKind kind, const Vector12d& x, double mollifier_eps,
                                double xi, Vector12d* gradient, Matrix12d* hessian) {
  const bool derivatives = gradient || hessian;
  Vector12d gD;
  Matrix12d HD;
  const Vec3 p0 = x.segment<3>(0), p1 = x.segment<3>(3), p2 = x.segment<3>(6), p3 = x.segment<3>(9);
  const double D = kind == PairKind::vertex_triangle
                       ? point_triangle_squared_distance(p0, p1, p2, p3, derivatives ? &gD : nullptr, hessian ? &HD : nullptr)
                       : edge_edge_squared_distance(p0, p1, p2, p3, derivatives ? &gD : nullptr, hessian ? &HD : nullptr);
  if (gradient) gradient->setZero();
  if (hessian) hessian->setZero();
  const double reach = spec.distance + xi;
  if (!(D < reach * reach)) return 0;
  const double phi = std::sqrt(D);
  double b, db, d2b;
  contact_profile(spec, phi - xi, &b, &db, &d2b);  // the offset distance: derivatives are phi's
  if (!std::isfinite(b)) return HUGE_VAL;  // the barrier at contact: a rejected point
  // phi = sqrt(D): grad phi = grad D / (2 phi), hess phi = hess D / (2 phi) - grad D grad D^T / (4 phi^3);
  // at phi = 0 (the penalty only) the direction is undefined: no force.
  Vector12d g = Vector12d::Zero();
  Matrix12d H = Matrix12d::Zero();
  if (derivatives && phi > 0) {
    const Vector12d gphi = gD / (2 * phi);
    g = db * gphi;
    if (hessian) H = d2b * gphi * gphi.transpose() + db * (HD / (2 * phi) - gphi * gphi.transpose() / phi);
  }
  double e = b;
  if (kind == PairKind::edge_edge) {  // m e: the product rule
    Vector12d gm;
    Matrix12d Hm;
    const double m = edge_edge_mollifier(p0, p1, p2, p3, mollifier_eps, derivatives ? &gm : nullptr, hessian ? &Hm : nullptr);
    if (hessian) H = m * H + g * gm.transpose() + gm * g.transpose() + e * Hm;
    if (derivatives) g = m * g + e * gm;
    e *= m;
  }
  if (gradient) *gradient = g;
  if (hessian) *hessian = H;
  return e;
}

bool lagged_pair_friction(const ContactSpec& spec, PairKind kind, const Vector12d& x, double mollifier_eps, double xi,
                          double k, double mu, PairFriction* out) {
  const Vec3 p0 = x.segment<3>(0), p1 = x.segment<3>(3), p2 = x.segment<3>(6), p3 = x.segment<3>(9);
  Vector12d gD;
  const double D = kind == PairKind::vertex_triangle ? point_triangle_squared_distance(p0, p1, p2, p3, &gD)
                                                     : edge_edge_squared_distance(p0, p1, p2, p3, &gD);
  const double reach = spec.distance + xi;
  if (!(D < reach * reach) || !(D > 0)) return false;
  double b, db, d2b;
  contact_profile(spec, std::sqrt(D) - xi, &b, &db, &d2b);  // as self_contact_pair_energy
  const double m = kind == PairKind::edge_edge ? edge_edge_mollifier(p0, p1, p2, p3, mollifier_eps) : 1.0;
  if (!std::isfinite(db) || !(m > 0)) return false;
  // The closest points from the distance's gradient (geometry/pair_distance.cpp): dD/dx_i = 2 c_i r,
  // r = sum_i c_i x_i the vector between the closest points, whose weights c_i sum to +-1 over each
  // primitive. Half the first primitive's gradient is r oriented from the second's closest point
  // to the first's, and w_i = dD/dx_i . r / (2 |r|^2) are the weights of that orientation.
  const int first_points = kind == PairKind::vertex_triangle ? 1 : 2;
  Vec3 r = Vec3::Zero();
  for (int i = 0; i < first_points; ++i) r += gD.segment<3>(3 * i) / 2;
  const double rr = r.squaredNorm();
  if (!(rr > 0)) return false;
  for (int i = 0; i < 4; ++i) out->weights[i] = gD.segment<3>(3 * i).dot(r) / (2 * rr);
  out->mu_lambda = mu * k * std::abs(db) * m;
  out->T = tangent_basis(r / std::sqrt(rr));
  out->start = x;
  return true;
}

double pair_friction_energy(const PairFriction& f, double eps_h, const Vector12d& x, Vector12d* gradient,
                            Matrix12d* hessian) {
  Vec3 displacement = Vec3::Zero();  // of the closest points, relative
  for (int i = 0; i < 4; ++i) displacement += f.weights[i] * (x.segment<3>(3 * i) - f.start.segment<3>(3 * i));
  const Eigen::Vector2d u = f.T.transpose() * displacement;
  const SmoothedFriction sf = smoothed_friction(u.norm(), eps_h);
  if (gradient) {
    const Vec3 force = f.mu_lambda * sf.f1_over_s * (f.T * u);  // on the first primitive's closest point, negated
    for (int i = 0; i < 4; ++i) gradient->segment<3>(3 * i) = f.weights[i] * force;
  }
  if (hessian) {
    Eigen::Matrix2d h2 = sf.f1_over_s * Eigen::Matrix2d::Identity();
    if (sf.slope != 0) h2 += sf.slope * u * u.transpose();
    const Eigen::Matrix3d block = f.mu_lambda * f.T * h2 * f.T.transpose();  // positive semidefinite
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) hessian->block<3, 3>(3 * i, 3 * j) = f.weights[i] * f.weights[j] * block;
  }
  return f.mu_lambda * sf.f0;
}

}  // namespace hyperqn
