#include "geometry/pair_distance.hpp"

#include "geometry/triangle_queries.hpp"

namespace hyperqn {

using Eigen::Vector3d;

namespace {

// The distance of a point to a point, a line or a plane is the minimum over w of |r(x, w)|^2
// with r affine in both the points and the M parameters w: r = sum_k (c0_k + sum_j C_kj w_j) x_k
// = r0 + R w (the columns of R are the line's or plane's directions). With w* the minimizer (R^T r = 0), the envelope
// theorem gives dD/dx_k = 2 c_k(w*) r, and the Hessian is f_xx - f_xw f_ww^-1 f_wx of
// f(x, w) = |r|^2 (w* moves with x): f_xx = 2 c c^T (x) I, f_ww = 2 R^T R, and column j of f_xw
// is 2 (C_kj r + c_k R_j) in block k.
template <int N, int M>
double affine_squared_distance(const Eigen::Matrix<double, 3, N>& points, const Eigen::Matrix<double, N, 1>& c0,
                               const Eigen::Matrix<double, N, M>& C, Eigen::Matrix<double, 3 * N, 1>* gradient,
                               Eigen::Matrix<double, 3 * N, 3 * N>* hessian) {
  const Vector3d r0 = points * c0;
  const Eigen::Matrix<double, 3, M> R = points * C;
  // (R^T R)^-1; its determinant for two parameters is |R0 x R1|^2, computed without cancellation.
  Eigen::Matrix<double, M, M> gram_inverse;
  if constexpr (M == 1) {
    const double g = R.col(0).squaredNorm();
    gram_inverse(0, 0) = g > 0 ? 1 / g : 0;
  } else {
    const double det = R.col(0).cross(R.col(1)).squaredNorm();
    const double a = R.col(0).squaredNorm(), b = R.col(0).dot(R.col(1)), c = R.col(1).squaredNorm();
    if (det > 0) gram_inverse << c / det, -b / det, -b / det, a / det;
    else gram_inverse.setZero();  // a degenerate primitive: no minimizer to follow
  }
  const Eigen::Matrix<double, M, 1> w = -gram_inverse * (R.transpose() * r0);
  const Vector3d r = r0 + R * w;
  const Eigen::Matrix<double, N, 1> c = c0 + C * w;

  if (gradient)
    for (int k = 0; k < N; ++k) gradient->template segment<3>(3 * k) = 2 * c[k] * r;
  if (hessian) {
    Eigen::Matrix<double, 3 * N, M> f_xw;
    for (int k = 0; k < N; ++k) {
      for (int l = 0; l < N; ++l)
        hessian->template block<3, 3>(3 * k, 3 * l) = 2 * c[k] * c[l] * Eigen::Matrix3d::Identity();
      for (int j = 0; j < M; ++j) f_xw.template block<3, 1>(3 * k, j) = 2 * (C(k, j) * r + c[k] * R.col(j));
    }
    *hessian -= 0.5 * f_xw * gram_inverse * f_xw.transpose();  // f_ww^-1 = (R^T R)^-1 / 2
  }
  return r.squaredNorm();
}

// The sub-case's own points and coefficients, then its derivatives scattered into the pair's 12.
template <int N, int M>
double case_distance(const PairCase& pc, const Vector12d& x, const Eigen::Matrix<double, N, 1>& c0,
                     const Eigen::Matrix<double, N, M>& C, Vector12d* gradient, Matrix12d* hessian) {
  Eigen::Matrix<double, 3, N> points;
  for (int k = 0; k < N; ++k) points.col(k) = x.segment<3>(3 * pc.points[k]);
  Eigen::Matrix<double, 3 * N, 1> g;
  Eigen::Matrix<double, 3 * N, 3 * N> H;
  const double d = affine_squared_distance<N, M>(points, c0, C, gradient ? &g : nullptr, hessian ? &H : nullptr);
  if (gradient) {
    gradient->setZero();
    for (int k = 0; k < N; ++k) gradient->segment<3>(3 * pc.points[k]) = g.template segment<3>(3 * k);
  }
  if (hessian) {
    hessian->setZero();
    for (int k = 0; k < N; ++k)
      for (int l = 0; l < N; ++l)
        hessian->block<3, 3>(3 * pc.points[k], 3 * pc.points[l]) = H.template block<3, 3>(3 * k, 3 * l);
  }
  return d;
}

Eigen::Matrix3d skew(const Vector3d& a) {  // skew(a) y = a x y
  Eigen::Matrix3d s;
  s << 0, -a[2], a[1], a[2], 0, -a[0], -a[1], a[0], 0;
  return s;
}

// c = |u x v|^2 with its derivatives with respect to (u, v). With n = u x v, dn/du = -[v]x and
// dn/dv = [u]x: dc/du = 2 v x n, dc/dv = 2 n x u; d2c/du2 = -2 [v]x^2, d2c/dv2 = -2 [u]x^2,
// d2c/du dv = 2 [v]x [u]x - 2 [n]x.
double cross_squared_norm(const Vector3d& u, const Vector3d& v, Eigen::Matrix<double, 6, 1>& gradient,
                          Eigen::Matrix<double, 6, 6>& hessian) {
  const Vector3d n = u.cross(v);
  gradient << 2 * v.cross(n), 2 * n.cross(u);
  const Eigen::Matrix3d su = skew(u), sv = skew(v);
  hessian.block<3, 3>(0, 0) = -2 * sv * sv;
  hessian.block<3, 3>(3, 3) = -2 * su * su;
  hessian.block<3, 3>(0, 3) = 2 * sv * su - 2 * skew(n);
  hessian.block<3, 3>(3, 0) = hessian.block<3, 3>(0, 3).transpose();
  return n.squaredNorm();
}

// The distance between the lines through (x0, x1) and (x2, x3) as q^2 / N with q = w . n,
// N = |n|^2, n = u x v (u = x1 - x0, v = x3 - x2, w = x0 - x2): its error grows like 1/theta for
// lines at a small angle theta, where solving for the closest points loses 1/theta^2.
double line_line_squared_distance(const Vector12d& x, Vector12d* gradient, Matrix12d* hessian) {
  const Vector3d u = x.segment<3>(3) - x.segment<3>(0), v = x.segment<3>(9) - x.segment<3>(6);
  const Vector3d w = x.segment<3>(0) - x.segment<3>(6), n = u.cross(v);
  Eigen::Matrix<double, 6, 1> dN_uv;
  Eigen::Matrix<double, 6, 6> d2N_uv;
  const double N = cross_squared_norm(u, v, dN_uv, d2N_uv), q = w.dot(n);
  if (!gradient && !hessian) return q * q / N;
  // In the variables (w, u, v): q = det[w, u, v], so dq = (u x v, v x w, w x u) and its second
  // derivatives are -[v]x (w, u), [u]x (w, v), -[w]x (u, v); N does not depend on w.
  Eigen::Matrix<double, 9, 1> dq, dN = Eigen::Matrix<double, 9, 1>::Zero();
  dq << n, v.cross(w), w.cross(u);
  dN.tail<6>() = dN_uv;
  // (w, u, v) = S x.
  Eigen::Matrix<double, 9, 12> S = Eigen::Matrix<double, 9, 12>::Zero();
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  S.block<3, 3>(0, 0) = I, S.block<3, 3>(0, 6) = -I;
  S.block<3, 3>(3, 0) = -I, S.block<3, 3>(3, 3) = I;
  S.block<3, 3>(6, 6) = -I, S.block<3, 3>(6, 9) = I;
  // D = q^2 / N: dD = (2 q / N) dq - (q^2 / N^2) dN.
  if (gradient) *gradient = S.transpose() * ((2 * q / N) * dq - (q * q / (N * N)) * dN);
  if (hessian) {
    Eigen::Matrix<double, 9, 9> d2q = Eigen::Matrix<double, 9, 9>::Zero(), d2N = Eigen::Matrix<double, 9, 9>::Zero();
    d2q.block<3, 3>(0, 3) = -skew(v);
    d2q.block<3, 3>(0, 6) = skew(u);
    d2q.block<3, 3>(3, 6) = -skew(w);
    d2q.block<3, 3>(3, 0) = d2q.block<3, 3>(0, 3).transpose();
    d2q.block<3, 3>(6, 0) = d2q.block<3, 3>(0, 6).transpose();
    d2q.block<3, 3>(6, 3) = d2q.block<3, 3>(3, 6).transpose();
    d2N.bottomRightCorner<6, 6>() = d2N_uv;
    const Eigen::Matrix<double, 9, 9> cross = dq * dN.transpose();
    const Eigen::Matrix<double, 9, 9> H = (2 / N) * dq * dq.transpose() + (2 * q / N) * d2q -
                                          (2 * q / (N * N)) * (cross + cross.transpose()) +
                                          (2 * q * q / (N * N * N)) * dN * dN.transpose() - (q * q / (N * N)) * d2N;
    *hessian = S.transpose() * H * S;
  }
  return q * q / N;
}

Vector12d stack(const Vector3d& x0, const Vector3d& x1, const Vector3d& x2, const Vector3d& x3) {
  Vector12d x;
  x << x0, x1, x2, x3;
  return x;
}

// The case of point `point` against the segment (`e0`, `e1`), and its squared distance.
struct Candidate {
  PairCase pair_case;
  double squared_distance;
};
Candidate point_segment(const Vector3d* x, int point, int e0, int e1) {
  const Vector3d e = x[e1] - x[e0];
  const double length2 = e.squaredNorm();
  const double s = length2 > 0 ? e.dot(x[point] - x[e0]) / length2 : 0;
  if (s <= 0) return {{PairCase::PointPoint, {point, e0, -1, -1}}, (x[point] - x[e0]).squaredNorm()};
  if (s >= 1) return {{PairCase::PointPoint, {point, e1, -1, -1}}, (x[point] - x[e1]).squaredNorm()};
  return {{PairCase::PointEdge, {point, e0, e1, -1}}, (x[point] - x[e0] - s * e).squaredNorm()};
}

}  // namespace

double case_squared_distance(const PairCase& pc, const Vector12d& x, Vector12d* gradient, Matrix12d* hessian) {
  switch (pc.kind) {
    case PairCase::PointPoint:  // r = x0 - x1
      return case_distance<2, 1>(pc, x, Eigen::Vector2d(1, -1), Eigen::Vector2d::Zero(), gradient, hessian);
    case PairCase::PointEdge:  // r = x0 - x1 - s (x2 - x1)
      return case_distance<3, 1>(pc, x, Eigen::Vector3d(1, -1, 0), Eigen::Vector3d(0, 1, -1), gradient, hessian);
    case PairCase::PointPlane: {  // r = x0 - x1 - u (x2 - x1) - v (x3 - x1)
      Eigen::Matrix<double, 4, 2> C;
      C << 0, 0, 1, 1, -1, 0, 0, -1;
      return case_distance<4, 2>(pc, x, Eigen::Vector4d(1, -1, 0, 0), C, gradient, hessian);
    }
    case PairCase::EdgeEdge:
      return line_line_squared_distance(x, gradient, hessian);
  }
  return 0;
}

PairCase point_triangle_case(const Vector3d& p, const Vector3d& t0, const Vector3d& t1, const Vector3d& t2) {
  const TriangleFeature feature = closest_on_triangle(p, t0, t1, t2).feature;
  switch (feature.kind) {
    case TriangleFeature::Vertex: return {PairCase::PointPoint, {0, 1 + feature.index, -1, -1}};
    case TriangleFeature::Edge: return {PairCase::PointEdge, {0, 1 + feature.index, 1 + (feature.index + 1) % 3, -1}};
    case TriangleFeature::Face: break;
  }
  return {PairCase::PointPlane, {0, 1, 2, 3}};
}

double point_triangle_squared_distance(const Vector3d& p, const Vector3d& t0, const Vector3d& t1, const Vector3d& t2,
                                       Vector12d* gradient, Matrix12d* hessian) {
  return case_squared_distance(point_triangle_case(p, t0, t1, t2), stack(p, t0, t1, t2), gradient, hessian);
}

PairCase edge_edge_case(const Vector3d& a0, const Vector3d& a1, const Vector3d& b0, const Vector3d& b1) {
  // The squared distance between points of the two segments is convex in their parameters (s, t)
  // over [0, 1]^2: its minimum is the lines' closest points if those lie inside the square, and
  // otherwise on the square's boundary, which is an end point of one edge against the other edge.
  constexpr double kParallel = 2.5e-16;  // sin^2 of the angle below which edges count as parallel
  const Vector3d u = a1 - a0, v = b1 - b0, w = a0 - b0;
  const double det = u.cross(v).squaredNorm();  // |u|^2 |v|^2 - (u.v)^2
  if (det > kParallel * u.squaredNorm() * v.squaredNorm()) {
    const double uv = u.dot(v), uw = u.dot(w), vw = v.dot(w);
    const double s = (uv * vw - v.squaredNorm() * uw) / det;
    const double t = (u.squaredNorm() * vw - uv * uw) / det;
    if (s > 0 && s < 1 && t > 0 && t < 1) return {PairCase::EdgeEdge, {0, 1, 2, 3}};
  }
  const Vector3d x[4] = {a0, a1, b0, b1};
  Candidate best = point_segment(x, 0, 2, 3);
  for (const Candidate& c : {point_segment(x, 1, 2, 3), point_segment(x, 2, 0, 1), point_segment(x, 3, 0, 1)})
    if (c.squared_distance < best.squared_distance) best = c;
  return best.pair_case;
}

double edge_edge_squared_distance(const Vector3d& a0, const Vector3d& a1, const Vector3d& b0, const Vector3d& b1,
                                  Vector12d* gradient, Matrix12d* hessian) {
  return case_squared_distance(edge_edge_case(a0, a1, b0, b1), stack(a0, a1, b0, b1), gradient, hessian);
}

double edge_edge_mollifier_threshold(const Vector3d& a0_rest, const Vector3d& a1_rest, const Vector3d& b0_rest,
                                     const Vector3d& b1_rest) {
  return 1e-3 * (a1_rest - a0_rest).squaredNorm() * (b1_rest - b0_rest).squaredNorm();
}

double edge_edge_mollifier(const Vector3d& a0, const Vector3d& a1, const Vector3d& b0, const Vector3d& b1,
                           double eps_x, Vector12d* gradient, Matrix12d* hessian) {
  Eigen::Matrix<double, 6, 1> dc;  // with respect to (u, v) = (a1 - a0, b1 - b0)
  Eigen::Matrix<double, 6, 6> d2c;
  const double c = cross_squared_norm(a1 - a0, b1 - b0, dc, d2c);
  if (!(c < eps_x)) {
    if (gradient) gradient->setZero();
    if (hessian) hessian->setZero();
    return 1;
  }
  const double q = c / eps_x;
  const double dm = 2 * (1 - q) / eps_x;     // dm/dc
  const double d2m = -2 / (eps_x * eps_x);  // d2m/dc2
  // (u, v) = S x.
  Eigen::Matrix<double, 6, 12> S = Eigen::Matrix<double, 6, 12>::Zero();
  S.block<3, 3>(0, 0) = -Eigen::Matrix3d::Identity();
  S.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();
  S.block<3, 3>(3, 6) = -Eigen::Matrix3d::Identity();
  S.block<3, 3>(3, 9) = Eigen::Matrix3d::Identity();
  const Vector12d dc_dx = S.transpose() * dc;
  if (gradient) *gradient = dm * dc_dx;
  if (hessian) *hessian = dm * (S.transpose() * d2c * S) + d2m * dc_dx * dc_dx.transpose();
  return (2 - q) * q;
}

}  // namespace hyperqn
