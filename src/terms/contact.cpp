#include "terms/contact.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>

#include "terms/smoothed_friction.hpp"

namespace hyperqn {

static constexpr double kStandardGravity = 9.80665;

ContactSpec resolved_contact(ContactSpec spec, double diagonal) {
  if (spec.distance <= 0) spec.distance = 1e-2 * diagonal;
  if (spec.friction_velocity <= 0) spec.friction_velocity = 1e-2 * diagonal;
  return spec;
}

ContactSpec self_contact_spec(ContactSpec spec, double diagonal) {
  spec = resolved_contact(spec, diagonal);
  if (spec.self_distance > 0) {
    spec.distance = spec.self_distance;
    spec.distance_line = spec.self_distance_line;
    spec.distance_key = "contact.self_distance";
  }
  return spec;
}

ContactTerm::ContactTerm(const DistributedMesh& mesh, std::vector<std::unique_ptr<Collider>> colliders,
                         const ContactSpec& spec, PetscLogEvent event, std::vector<std::string> bodies)
    : mesh_(mesh), colliders_(std::move(colliders)), spec_(spec), bodies_(std::move(bodies)),
      barrier_(spec.model == ContactModel::barrier), event_(event) {
  for (PetscInt v = 0; v < mesh.num_vertices; ++v)
    if (mesh.owned[v] && mesh.local_dof[v] >= 0) vertices_.push_back(v);
  stiffness_.assign(vertices_.size(), stiffness_per_mass());
  for (auto& collider : colliders_) collider->set_time(0);  // where the run starts (check_start)
}

double contact_stiffness_per_mass(const ContactSpec& spec) {
  const double d = spec.distance;
  return spec.stiffness * kStandardGravity / (spec.model == ContactModel::barrier ? d : d * d);
}

double ContactTerm::stiffness_per_mass() const { return contact_stiffness_per_mass(spec_); }

PetscErrorCode ContactTerm::set_masses(Vec mass) {
  const PetscScalar* m;
  PetscInt lo, hi;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(mass, &lo, &hi));
  PetscCall(VecGetArrayRead(mass, &m));
  for (size_t k = 0; k < vertices_.size(); ++k) stiffness_[k] = stiffness_per_mass() * m[mesh_.global_dof[vertices_[k]] - lo];
  PetscCall(VecRestoreArrayRead(mass, &m));
  PetscFunctionReturn(0);
}

static Mat3 clamp_psd(const Mat3& H) {
  Eigen::SelfAdjointEigenSolver<Mat3> eig(H);
  const Vec3 lambda = eig.eigenvalues().cwiseMax(0.0);
  return eig.eigenvectors() * lambda.asDiagonal() * eig.eigenvectors().transpose();
}

void contact_profile(const ContactSpec& spec, double phi, double* b, double* db, double* d2b) {
  const double d = spec.distance, gap = d - phi;
  if (spec.model == ContactModel::penalty) {
    *b = gap * gap * gap / 3;
    *db = -gap * gap;
    *d2b = 2 * gap;
  } else if (phi > 0) {
    const double log = std::log(phi / d);
    *b = -gap * gap * log;
    *db = 2 * gap * log - gap * gap / phi;
    *d2b = -2 * log + 4 * gap / phi + gap * gap / (phi * phi);
  } else {
    *b = *db = *d2b = HUGE_VAL;
  }
}

void ContactTerm::profile(double phi, double* b, double* db, double* d2b) const { contact_profile(spec_, phi, b, db, d2b); }

double ContactTerm::normal_energy(size_t k, size_t c, const Vec3& p, Vec3* grad, Mat3* hess, bool psd) const {
  Vec3 n;
  Mat3 curvature;
  const double phi = colliders_[c]->distance(p, grad || hess ? &n : nullptr, hess ? &curvature : nullptr);
  if (!(phi < spec_.distance)) {  // outside the activation layer
    if (grad) grad->setZero();
    if (hess) hess->setZero();
    return 0;
  }
  double b, db, d2b;
  profile(phi, &b, &db, &d2b);
  if (!std::isfinite(b)) {  // the barrier at or inside the obstacle: a rejected point
    if (grad) grad->setZero();
    if (hess) hess->setZero();
    return HUGE_VAL;
  }
  const double kk = stiffness_[k];
  if (grad) *grad = kk * db * n;
  if (hess) {
    *hess = kk * (d2b * n * n.transpose() + db * curvature);
    if (psd) *hess = clamp_psd(*hess);
  }
  return kk * b;
}

PetscErrorCode ContactTerm::limit_step(Vec x, Vec dir, double* alpha) const {
  const PetscScalar *a, *u;
  PetscInt lo, hi;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  PetscCall(VecGetOwnershipRange(x, &lo, &hi));
  PetscCall(VecGetArrayRead(x, &a));
  PetscCall(VecGetArrayRead(dir, &u));
  // The earliest impact over every vertex and collider along the whole step: a minimum, so the
  // bound does not depend on the order of the vertices nor on how the ranks share them
  // (Body::limit_step takes the minimum over ranks).
  double first = 1;
  for (PetscInt v : vertices_) {
    const PetscInt off = mesh_.global_dof[v] - lo;
    const Vec3 p0(&a[off]), p1 = p0 + *alpha * Vec3(&u[off]);
    for (const auto& collider : colliders_) first = std::min(first, collider->first_contact(p0, p1));
  }
  PetscCall(VecRestoreArrayRead(x, &a));
  PetscCall(VecRestoreArrayRead(dir, &u));
  // Stop short of the obstacle (IPC's 0.8 of the time of impact): the barrier is infinite on it.
  if (first < 1) *alpha *= 0.8 * first;
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

double ContactTerm::friction_energy(size_t f, const Vec3& p, Vec3* grad, Mat3* hess) const {
  const FrictionPoint& fp = friction_[f];
  const Eigen::Vector2d u = fp.T.transpose() * (p - fp.anchor);
  const SmoothedFriction sf = smoothed_friction(u.norm(), eps_h_);
  if (grad) *grad = fp.mu_lambda * sf.f1_over_s * (fp.T * u);
  if (hess) {
    Eigen::Matrix2d h2 = sf.f1_over_s * Eigen::Matrix2d::Identity();
    if (sf.slope != 0) h2 += sf.slope * u * u.transpose();
    *hess = fp.mu_lambda * fp.T * h2 * fp.T.transpose();  // positive semidefinite as it is
  }
  return fp.mu_lambda * sf.f0;
}

PetscErrorCode ContactTerm::add_energy(Vec, const std::vector<double>& pos, double* energy, PetscScalar* gradient) const {
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  double e = *energy;
  Vec3 g;
  active_set_ = 0;
  for (size_t k = 0; k < vertices_.size(); ++k) {
    const Vec3 p(&pos[3 * vertices_[k]]);
    for (size_t c = 0; c < colliders_.size(); ++c) {
      const double ek = normal_energy(k, c, p, gradient ? &g : nullptr, nullptr, false);
      if (ek > 0) {  // a sum of mixed ids: independent of the order and of the partition
        unsigned long long z = (unsigned long long)mesh_.vertex_ids[vertices_[k]] * 64 + c + 0x9e3779b97f4a7c15ULL;
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        active_set_ += z ^ (z >> 31);
      }
      e += ek;
      if (gradient) add_vertex_vector(mesh_, vertices_[k], g, gradient);
    }
  }
  for (size_t f = 0; f < friction_.size(); ++f) {
    const PetscInt v = vertices_[friction_[f].slot];
    e += friction_energy(f, Vec3(&pos[3 * v]), gradient ? &g : nullptr, nullptr);
    if (gradient) add_vertex_vector(mesh_, v, g, gradient);
  }
  *energy = e;
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode ContactTerm::add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const {
  PetscInt idx[3];
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> block;
  Mat3 h;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  for (size_t k = 0; k < vertices_.size(); ++k) {
    const Vec3 p(&pos[3 * vertices_[k]]);
    for (size_t c = 0; c < colliders_.size(); ++c) {
      if (normal_energy(k, c, p, nullptr, &h, psd) == 0) continue;
      block = scale * h;
      element_dofs<1>(mesh_, &vertices_[k], idx);
      PetscCall(MatSetValues(H, 3, idx, 3, idx, block.data(), ADD_VALUES));
    }
  }
  for (size_t f = 0; f < friction_.size(); ++f) {
    const PetscInt v = vertices_[friction_[f].slot];
    friction_energy(f, Vec3(&pos[3 * v]), nullptr, &h);
    block = scale * h;
    element_dofs<1>(mesh_, &v, idx);
    PetscCall(MatSetValues(H, 3, idx, 3, idx, block.data(), ADD_VALUES));
  }
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode ContactTerm::add_vertex_stiffness(const std::vector<double>& pos, std::vector<VertexStiffness>& out) const {
  Mat3 h;
  PetscFunctionBeginUser;
  const auto add = [&](PetscInt v) {
    VertexStiffness s;
    s.dof = mesh_.global_dof[v];
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s.K.data()) = h;
    out.push_back(s);
  };
  for (size_t k = 0; k < vertices_.size(); ++k) {
    const Vec3 p(&pos[3 * vertices_[k]]);
    for (size_t c = 0; c < colliders_.size(); ++c)
      if (normal_energy(k, c, p, nullptr, &h, true) != 0 && std::isfinite(h.sum())) add(vertices_[k]);
  }
  for (size_t f = 0; f < friction_.size(); ++f) {
    const PetscInt v = vertices_[friction_[f].slot];
    friction_energy(f, Vec3(&pos[3 * v]), nullptr, &h);
    add(v);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode ContactTerm::begin_step(const StepStart& step) {
  const PetscScalar* x;
  PetscInt lo, hi;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(event_, 0, 0, 0, 0));
  eps_h_ = spec_.friction_velocity * step.dt;
  friction_.clear();
  PetscCall(VecGetOwnershipRange(step.x_start, &lo, &hi));
  PetscCall(VecGetArrayRead(step.x_start, &x));
  for (size_t c = 0; c < colliders_.size(); ++c) {
    Collider& collider = *colliders_[c];
    collider.set_time(step.t - step.dt);
    const RigidPose start = collider.pose();
    collider.set_time(step.t);
    const double mu = collider.friction();
    if (!(mu > 0)) continue;
    const RigidPose end = collider.pose();
    // Frozen per step: the normal force and tangent plane at x_n, with the obstacle where it was.
    collider.set_time(step.t - step.dt);
    for (size_t k = 0; k < vertices_.size(); ++k) {
      const Vec3 p(&x[mesh_.global_dof[vertices_[k]] - lo]);
      Vec3 n;
      const double gap = spec_.distance - collider.distance(p, &n);
      if (!(gap > 0)) continue;
      FrictionPoint fp;
      fp.slot = k;
      fp.collider = c;
      double b, db, d2b;
      profile(spec_.distance - gap, &b, &db, &d2b);
      if (!std::isfinite(db)) continue;  // inside the obstacle: no tangent plane to speak of
      fp.mu_lambda = mu * stiffness_[k] * std::abs(db);
      fp.T = tangent_basis(end.rotation * start.rotation.transpose() * n);
      fp.anchor = end.apply(start.inverse(p));  // x_n carried along by the obstacle
      friction_.push_back(fp);
    }
    collider.set_time(step.t);
  }
  PetscCall(VecRestoreArrayRead(step.x_start, &x));
  PetscCall(PetscLogEventEnd(event_, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode ContactTerm::measure(const std::vector<double>& pos, ContactMeasure& out, Vec force) const {
  const size_t nc = colliders_.size();
  std::vector<double> sums(6 * nc, 0.0), penetration(nc, 0.0);  // per collider: normal, friction force vectors
  std::vector<long> active(nc, 0);
  PetscScalar* f = nullptr;
  PetscInt lo = 0, hi;
  PetscFunctionBeginUser;
  if (force) {
    PetscCall(VecSet(force, 0.0));
    PetscCall(VecGetOwnershipRange(force, &lo, &hi));
    PetscCall(VecGetArray(force, &f));
  }
  const auto add = [&](size_t c, int part, PetscInt v, const Vec3& g) {  // g: dE/dx, the force is -g
    for (int d = 0; d < 3; ++d) sums[6 * c + 3 * part + d] -= g[d];
    if (f)
      for (int d = 0; d < 3; ++d) f[mesh_.global_dof[v] - lo + d] -= g[d];
  };
  Vec3 g;
  for (size_t k = 0; k < vertices_.size(); ++k) {
    const PetscInt v = vertices_[k];
    const Vec3 p(&pos[3 * v]);
    for (size_t c = 0; c < nc; ++c) {
      const double phi = colliders_[c]->distance(p);
      penetration[c] = std::max(penetration[c], -phi);
      if (phi < spec_.distance) ++active[c];
      normal_energy(k, c, p, &g, nullptr, false);
      add(c, 0, v, g);
    }
  }
  for (size_t i = 0; i < friction_.size(); ++i) {
    const PetscInt v = vertices_[friction_[i].slot];
    friction_energy(i, Vec3(&pos[3 * v]), &g, nullptr);
    add(friction_[i].collider, 1, v, g);
  }
  if (force) PetscCall(VecRestoreArray(force, &f));
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, sums.data(), (int)sums.size(), MPI_DOUBLE, MPI_SUM, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, penetration.data(), (int)nc, MPI_DOUBLE, MPI_MAX, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, active.data(), (int)nc, MPI_LONG, MPI_SUM, comm));
  out.normal_force.resize(nc);
  out.friction_force.resize(nc);
  for (size_t c = 0; c < nc; ++c) {
    out.normal_force[c] = Vec3(&sums[6 * c]).norm();
    out.friction_force[c] = Vec3(&sums[6 * c + 3]).norm();
  }
  out.penetration = penetration;
  out.active = active;
  PetscFunctionReturn(0);
}

std::string ContactTerm::describe() const {
  char text[200];
  std::snprintf(text, sizeof text, "contact: %zu collider(s), %s, distance %.4g, stiffness %.4g, friction_velocity %.4g",
                colliders_.size(), kContactModelNames[size_t(spec_.model)].c_str(), spec_.distance, spec_.stiffness, spec_.friction_velocity);
  return text;
}

PetscErrorCode ContactTerm::report(const std::vector<double>& pos, TermReport& out) const {
  ContactMeasure m;
  PetscFunctionBeginUser;
  PetscCall(measure(pos, m, nullptr));
  double deepest = 0;
  long active = 0;
  for (size_t c = 0; c < m.normal_force.size(); ++c) {
    char row[160];
    std::snprintf(row, sizeof row, "%zu,%.17g,%.17g,%.17g,%ld", c, m.normal_force[c], m.friction_force[c],
                  m.penetration[c], m.active[c]);
    out.rows.push_back(row);
    deepest = std::max(deepest, m.penetration[c]);
    active += m.active[c];
  }
  out.maxima = {{"max_penetration", deepest}, {"max_active_contacts", (double)active}};
  // A moving collider that holds a vertex too deep pushed into the body faster than contact could
  // push back (the start was checked, and a static one cannot move into it).
  if (std::any_of(colliders_.begin(), colliders_.end(), [](const auto& c) { return c->moves(); })) {
    std::vector<HeldVertices> held;
    PetscCall(held_vertices(pos, true, [this](double phi) { return too_deep(phi); }, held));
    std::string text;
    for (size_t c = 0; c < held.size(); ++c)
      if (held[c].count > 0) text += (text.empty() ? "" : "; ") + held_sentence(c, held[c], too_deep_words());
    if (!text.empty()) out.flags.emplace_back("collider_intrusions", text + ": it moved into the body faster than contact pushed back, or (once it stops) contact "
                                                           "is too soft to push the body out (contact.stiffness)");
  }
  PetscFunctionReturn(0);
}

template <typename Test>
PetscErrorCode ContactTerm::held_vertices(const std::vector<double>& pos, bool moving_only, Test test,
                                          std::vector<HeldVertices>& out, int body) const {
  const size_t nc = colliders_.size();
  std::vector<long> count(nc, 0);
  std::vector<double> depth(nc, -HUGE_VAL), where(3 * nc, 0.0);  // the deepest's position
  std::vector<long long> id(nc, LLONG_MAX);
  PetscFunctionBeginUser;
  for (PetscInt v : vertices_) {
    if (body >= 0 && mesh_.vertex_body[v] != body) continue;
    const Vec3 p(&pos[3 * v]);
    const long long vid = mesh_.vertex_ids[v];
    for (size_t c = 0; c < nc; ++c) {
      if (moving_only && !colliders_[c]->moves()) continue;
      const double phi = colliders_[c]->distance(p);
      if (!test(phi)) continue;
      ++count[c];
      if (-phi > depth[c] || (-phi == depth[c] && vid < id[c])) {
        depth[c] = -phi;
        id[c] = vid;
        for (int d = 0; d < 3; ++d) where[3 * c + d] = p[d];
      }
    }
  }
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  std::vector<double> deepest(nc);
  std::vector<long long> deepest_id(nc);
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, count.data(), (int)nc, MPI_LONG, MPI_SUM, comm));
  PetscCallMPI(MPI_Allreduce(depth.data(), deepest.data(), (int)nc, MPI_DOUBLE, MPI_MAX, comm));
  for (size_t c = 0; c < nc; ++c)
    if (depth[c] != deepest[c]) id[c] = LLONG_MAX;  // a deeper one is on another rank
  PetscCallMPI(MPI_Allreduce(id.data(), deepest_id.data(), (int)nc, MPI_LONG_LONG, MPI_MIN, comm));
  for (size_t c = 0; c < nc; ++c)  // each vertex is on one rank: that rank sends its position
    if (id[c] != deepest_id[c] || count[c] == 0)
      for (int d = 0; d < 3; ++d) where[3 * c + d] = 0;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, where.data(), (int)where.size(), MPI_DOUBLE, MPI_SUM, comm));
  out.assign(nc, HeldVertices());
  for (size_t c = 0; c < nc; ++c) {
    if (count[c] == 0) continue;
    out[c].count = count[c];
    out[c].depth = deepest[c];
    out[c].vertex = deepest_id[c];
    out[c].position = Vec3(&where[3 * c]);
  }
  PetscFunctionReturn(0);
}

std::string ContactTerm::too_deep_words() const {
  char text[120];
  if (barrier_) return "inside it (the barrier's energy is infinite there)";
  std::snprintf(text, sizeof text, "deeper than the activation distance %.4g (contact.distance)", spec_.distance);
  return text;
}

std::string ContactTerm::held_sentence(size_t c, const HeldVertices& held, const std::string& what) const {
  char text[400];
  const Vec3& p = held.position;
  std::snprintf(text, sizeof text, "colliders[%zu] (%s, deck line %d) holds %ld free %s %s (the deepest: vertex %lld at (%.6g, %.6g, %.6g), %.4g inside)",
                c, colliders_[c]->type_name().c_str(), colliders_[c]->line(), held.count, held.count == 1 ? "vertex" : "vertices", what.c_str(), held.vertex, p[0], p[1], p[2], held.depth);
  return text;
}

PetscErrorCode ContactTerm::check_start(const std::vector<double>& pos, InputProblem& out) const {
  std::vector<HeldVertices> held;
  PetscFunctionBeginUser;
  const auto deep = [this](double phi) { return too_deep(phi); };
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscCall(held_vertices(pos, false, deep, held));
  long others = 0;
  for (size_t c = 0; c < held.size(); ++c) {
    if (held[c].count == 0) continue;
    if (!out.what.empty()) {
      ++others;
      continue;
    }
    // In a scene of bodies: the body of the deepest vertex, and its own vertices counted.
    int body = -1;
    std::string who = "the body";
    if (!bodies_.empty()) {
      for (PetscInt v : vertices_)
        if (mesh_.vertex_ids[v] == held[c].vertex) body = mesh_.vertex_body[v];
      PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &body, 1, MPI_INT, MPI_MAX, comm));
      std::vector<HeldVertices> own;
      PetscCall(held_vertices(pos, false, deep, own, body));
      held[c] = own[c];
      who = bodies_[body];
    }
    long free_vertices = 0;
    for (PetscInt v : vertices_) free_vertices += body < 0 || mesh_.vertex_body[v] == body;
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &free_vertices, 1, MPI_LONG, MPI_SUM, comm));
    const HeldVertices& h = held[c];
    char text[700];
    std::snprintf(text, sizeof text, "%s starts inside this %s: %ld of its %ld free vertices are %s at frame 0; the deepest, vertex %lld at (%.6g, %.6g, %.6g), is %.4g inside. Move the body or the obstacle",
                  who.c_str(), colliders_[c]->type_name().c_str(), h.count, free_vertices, too_deep_words().c_str(), h.vertex, h.position[0], h.position[1], h.position[2], h.depth);
    out.line = colliders_[c]->line();
    out.key = "colliders[" + std::to_string(c) + "]";
    out.what = text;
  }
  if (others > 0) out.what += " (and " + std::to_string(others) + " other collider(s) hold vertices too)";
  PetscFunctionReturn(0);
}

PetscErrorCode ContactTerm::explain_rejection(const std::vector<double>& pos, std::string& why) const {
  std::vector<HeldVertices> held;
  PetscFunctionBeginUser;
  if (!barrier_) PetscFunctionReturn(0);
  PetscCall(held_vertices(pos, false, [](double phi) { return phi <= 0; }, held));
  for (size_t c = 0; c < held.size(); ++c)
    if (held[c].count > 0)
      why += (why.empty() ? "" : "; ") + held_sentence(c, held[c], "at or inside its surface, where the barrier is infinite");
  PetscFunctionReturn(0);
}

PetscErrorCode ContactTerm::point_field(const std::string& name, const std::vector<double>& pos, Vec out) const {
  ContactMeasure m;
  PetscFunctionBeginUser;
  PetscCheck(name == "contact_force", PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "the contact term has no field %s",
             name.c_str());
  PetscCall(measure(pos, m, out));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
