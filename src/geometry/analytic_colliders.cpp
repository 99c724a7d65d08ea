// Plane, sphere, solid box and capsule: closed-form signed distance, its derivatives, and exact
// first contact along a straight path, all in the obstacle's own frame.
#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/collider_shapes.hpp"

namespace hyperqn {

namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double kNoContact = std::numeric_limits<double>::infinity();

Vec3 vec(const std::array<double, 3>& a) { return Vec3(a[0], a[1], a[2]); }

// Smallest s >= 0 with |w + s d| = r for a start outside (|w| > r): the entry into a ball (or,
// with w and d projected across an axis, into an infinite cylinder); kNoContact if the line
// misses or moves away. Stable roots of a s^2 + 2 b s + c = 0.
double ball_entry(const Vec3& w, const Vec3& d, double r) {
  const double a = d.squaredNorm(), b = w.dot(d), c = w.squaredNorm() - r * r;
  if (c <= 0) return 0;
  if (b >= 0 || a == 0) return kNoContact;  // both roots <= 0, or not moving
  const double disc = b * b - a * c;
  if (disc < 0) return kNoContact;
  // b < 0: q = -b + sqrt(disc) > 0; the roots are q / a (exit) and c / q (entry).
  const double q = -b + std::sqrt(disc);
  return c / q;
}

// Derivatives of |v| at v != 0 with the directions in `fixed` taken out (a line's direction, or
// none for a point): gradient u = v / |v|, Hessian (I - t t^T - u u^T) / |v|.
void point_distance_derivatives(const Vec3& v, double dist, const Vec3* axis, Vec3* gradient, Mat3* hessian) {
  const Vec3 u = v / dist;
  if (gradient) *gradient = u;
  if (hessian) {
    Mat3 P = Mat3::Identity() - u * u.transpose();
    if (axis) P -= *axis * axis->transpose();
    *hessian = P / dist;
  }
}

double within_path(double s) { return s <= 1 ? s : kNoContact; }

class PlaneCollider : public Collider {
 public:
  explicit PlaneCollider(const ColliderSpec& spec) : Collider(spec), point_(vec(spec.point)), normal_(vec(spec.normal)) {
    const double len = normal_.norm();
    // The deck rejects a zero normal; should one get here, fall back to +y rather than NaN.
    normal_ = len > 0 && std::isfinite(len) ? Vec3(normal_ / len) : Vec3(0, 1, 0);
  }

 protected:
  double local_distance(const Vec3& q, Vec3* gradient, Mat3* hessian) const override {
    if (gradient) *gradient = normal_;
    if (hessian) hessian->setZero();
    return normal_.dot(q - point_);
  }
  double local_first_contact(const Vec3& q0, const Vec3& q1) const override {
    const double f0 = normal_.dot(q0 - point_), f1 = normal_.dot(q1 - point_);
    if (f0 <= 0) return 0;
    if (f1 > 0) return kNoContact;
    return within_path(f0 / (f0 - f1));
  }

 private:
  Vec3 point_, normal_;
};

class SphereCollider : public Collider {
 public:
  SphereCollider(const ColliderSpec& spec, const Vec3& center, double radius)
      : Collider(spec), center_(center), radius_(radius) {}

 protected:
  double local_distance(const Vec3& q, Vec3* gradient, Mat3* hessian) const override {
    const Vec3 v = q - center_;
    const double dist = v.norm();
    if (dist > 0) {
      point_distance_derivatives(v, dist, nullptr, gradient, hessian);
    } else {  // the centre: every direction is as good, and no curvature is usable
      if (gradient) *gradient = Vec3(0, 0, 1);
      if (hessian) hessian->setZero();
    }
    return dist - radius_;
  }
  double local_first_contact(const Vec3& q0, const Vec3& q1) const override {
    return within_path(ball_entry(q0 - center_, q1 - q0, radius_));
  }

 private:
  Vec3 center_;
  double radius_;
};

// Solid box: c +- h in its own frame.
class BoxCollider : public Collider {
 public:
  explicit BoxCollider(const ColliderSpec& spec)
      : Collider(spec), lo_(vec(spec.min).cwiseMin(vec(spec.max))), hi_(vec(spec.min).cwiseMax(vec(spec.max))) {}

 protected:
  double local_distance(const Vec3& q, Vec3* gradient, Mat3* hessian) const override {
    const Vec3 c = 0.5 * (lo_ + hi_), h = 0.5 * (hi_ - lo_);
    const Vec3 x = q - c;
    const Vec3 sign = x.unaryExpr([](double t) { return t < 0 ? -1.0 : 1.0; });
    const Vec3 excess = x.cwiseAbs() - h;  // > 0 along the axes where q is beyond a face
    if ((excess.array() > 0).any()) {
      // Outside: distance to the nearest face, edge or corner (the axes with excess > 0).
      Vec3 v = Vec3::Zero();
      Mat3 P = Mat3::Zero();  // projector onto those axes
      int active = 0;
      for (int k = 0; k < 3; ++k)
        if (excess[k] > 0) {
          v[k] = sign[k] * excess[k];
          P(k, k) = 1;
          ++active;
        }
      const double dist = v.norm();
      const Vec3 u = v / dist;
      if (gradient) *gradient = u;
      if (hessian) *hessian = active == 1 ? Mat3::Zero() : Mat3((P - u * u.transpose()) / dist);
      return dist;
    }
    // Inside (or on the surface): minus the distance to the nearest face.
    int k;
    const double phi = excess.maxCoeff(&k);
    if (gradient) *gradient = sign[k] * Vec3::Unit(k);
    if (hessian) hessian->setZero();
    return phi;
  }
  // Slab method: the entry parameter is the last of the entries into the three slabs.
  double local_first_contact(const Vec3& q0, const Vec3& q1) const override {
    const Vec3 d = q1 - q0;
    double enter = 0, leave = kNoContact;
    bool outside = false;
    for (int k = 0; k < 3; ++k) {
      if (q0[k] < lo_[k] || q0[k] > hi_[k]) outside = true;
      if (d[k] == 0) {
        if (q0[k] < lo_[k] || q0[k] > hi_[k]) return kNoContact;
        continue;
      }
      double a = (lo_[k] - q0[k]) / d[k], b = (hi_[k] - q0[k]) / d[k];
      if (a > b) std::swap(a, b);
      enter = std::max(enter, a);
      leave = std::min(leave, b);
    }
    if (!outside) return 0;
    if (enter > leave) return kNoContact;
    return within_path(enter);
  }

 private:
  Vec3 lo_, hi_;
};

// Points within radius of the segment a-b.
class CapsuleCollider : public Collider {
 public:
  CapsuleCollider(const ColliderSpec& spec, const Vec3& a, const Vec3& b)
      : Collider(spec), a_(a), radius_(spec.radius), length_((b - a).norm()), axis_((b - a) / length_) {}

 protected:
  double local_distance(const Vec3& q, Vec3* gradient, Mat3* hessian) const override {
    const double t = (q - a_).dot(axis_);
    const double tc = std::min(std::max(t, 0.0), length_);
    const bool side = t > 0 && t < length_;  // cylindrical part: the closest point is inside the segment
    const Vec3 v = q - (a_ + tc * axis_);
    const double dist = v.norm();
    if (dist > 0) {
      point_distance_derivatives(v, dist, side ? &axis_ : nullptr, gradient, hessian);
    } else {  // on the axis: any unit direction across it
      if (gradient) *gradient = axis_.unitOrthogonal();
      if (hessian) hessian->setZero();
    }
    return dist - radius_;
  }
  // The capsule is the union of the two end balls and the finite cylinder; entering through the
  // cylinder's flat ends means being in a ball already, so the first contact is the earliest of
  // the ball entries and the entry through the lateral surface (within the segment's length).
  double local_first_contact(const Vec3& q0, const Vec3& q1) const override {
    if (local_distance(q0, nullptr, nullptr) <= 0) return 0;
    const Vec3 d = q1 - q0, w = q0 - a_;
    double s = std::min(ball_entry(w, d, radius_), ball_entry(w - length_ * axis_, d, radius_));
    const Vec3 w_across = w - w.dot(axis_) * axis_, d_across = d - d.dot(axis_) * axis_;
    // Inside the infinite cylinder at the start (beyond an end): a line cannot re-enter it.
    if (w_across.squaredNorm() > radius_ * radius_) {
      const double sc = ball_entry(w_across, d_across, radius_);
      if (sc < s) {
        const double t = (w + sc * d).dot(axis_);
        if (t >= 0 && t <= length_) s = sc;
      }
    }
    return within_path(s);
  }

 private:
  Vec3 a_;
  double radius_, length_;
  Vec3 axis_;
};

}  // namespace

std::unique_ptr<Collider> make_plane_collider(const ColliderSpec& spec) { return std::make_unique<PlaneCollider>(spec); }

std::unique_ptr<Collider> make_sphere_collider(const ColliderSpec& spec) {
  return std::make_unique<SphereCollider>(spec, vec(spec.center), spec.radius);
}

std::unique_ptr<Collider> make_box_collider(const ColliderSpec& spec) { return std::make_unique<BoxCollider>(spec); }

std::unique_ptr<Collider> make_capsule_collider(const ColliderSpec& spec) {
  const Vec3 a = vec(spec.a), b = vec(spec.b);
  // A (nearly) zero-length axis has no direction: the capsule is a ball about its middle.
  if (!((b - a).norm() > 1e-12 * (spec.radius + a.norm() + b.norm())))
    return std::make_unique<SphereCollider>(spec, 0.5 * (a + b), spec.radius);
  return std::make_unique<CapsuleCollider>(spec, a, b);
}

}  // namespace hyperqn
