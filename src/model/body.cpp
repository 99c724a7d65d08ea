#include "model/body.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include "geometry/motion.hpp"
#include "parallel/collectives.hpp"
#include "solvers/stop_request.hpp"
#include "terms/element_kernels.hpp"

namespace hyperqn {

Body::Body(const DistributedMesh& mesh, std::vector<std::unique_ptr<EnergyTerm>> terms)
    : mesh_(mesh), terms_(std::move(terms)) {
  double local_mass = 0;
  for (const auto& t : terms_) local_mass += t->local_mass();
  MPI_Allreduce(&local_mass, &total_mass_, 1, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)mesh.dm));
  fixed_pos_ = mesh.rest;
  fixed_vel_.assign(3 * mesh.num_vertices, 0.0);
  rest_measure_.reserve(mesh.num_cells + mesh.num_triangles);
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    rest_measure_.push_back(edge_matrix(mesh.rest.data(), &mesh.cells[4 * c]).determinant());
  for (PetscInt t = 0; t < mesh.num_triangles; ++t)
    rest_measure_.push_back(triangle_area(mesh.rest.data(), &mesh.triangles[3 * t]));
  if (!mesh.rollers) return;
  Vec layout;
  PetscInt start;
  DMGetGlobalVector(mesh.dm, &layout);
  VecGetOwnershipRange(layout, &start, nullptr);
  DMRestoreGlobalVector(mesh.dm, &layout);
  for (PetscInt v = 0; v < mesh.num_vertices; ++v)
    for (int d = 0; d < 3; ++d) {
      if (mesh.held[3 * v + d] == 0) continue;
      held_local_.push_back(3 * v + d);
      if (!mesh.owned[v]) continue;
      held_rows_.push_back(mesh.global_dof[v] + d);
      held_at_.push_back(mesh.global_dof[v] + d - start);
      held_entry_.push_back(3 * v + d);
    }
}

bool Body::projective_dynamics_exact() const {
  for (const auto& t : terms_)
    if (!t->projective_dynamics_exact()) return false;
  return true;
}

std::string Body::inexact_names() const {
  std::string s;
  for (const auto& t : terms_)
    if (!t->projective_dynamics_exact()) s += (s.empty() ? "" : ", ") + t->name();
  return s;
}

std::string Body::material_names() const {
  std::string s;
  for (const auto& t : terms_) s += (s.empty() ? "" : ", ") + t->name();
  return s;
}

const Motion* Body::prescribed_motion(PetscInt v) const {
  const int32_t region = mesh_.fixed[v];
  if (region == 0 || region > (int32_t)fixed_regions_.size() || !fixed_regions_[region - 1].motion.active) return nullptr;
  return &fixed_regions_[region - 1].motion;
}

const Motion* Body::region_motion(int32_t region) const {
  if (region == 0 || region > (int32_t)fixed_regions_.size() || !fixed_regions_[region - 1].motion.active) return nullptr;
  return &fixed_regions_[region - 1].motion;
}

PetscErrorCode Body::hold(Vec x) const {
  PetscScalar* a;
  PetscFunctionBeginUser;
  if (!mesh_.rollers) PetscFunctionReturn(0);
  PetscCall(VecGetArray(x, &a));
  for (size_t i = 0; i < held_at_.size(); ++i) a[held_at_[i]] = fixed_pos_[held_entry_[i]];
  PetscCall(VecRestoreArray(x, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::zero_held(Vec g) const {
  PetscScalar* a;
  PetscFunctionBeginUser;
  if (!mesh_.rollers) PetscFunctionReturn(0);
  PetscCall(VecGetArray(g, &a));
  for (PetscInt i : held_at_) a[i] = 0;
  PetscCall(VecRestoreArray(g, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::identity_at_held(Mat M) const {
  PetscFunctionBeginUser;
  if (!mesh_.rollers) PetscFunctionReturn(0);
  // Keeps the pattern (zeros stay stored): a factorization's symbolic analysis does not change.
  PetscCall(MatSetOption(M, MAT_KEEP_NONZERO_PATTERN, PETSC_TRUE));
  PetscCall(MatZeroRowsColumns(M, (PetscInt)held_rows_.size(), held_rows_.data(), 1.0, nullptr, nullptr));
  PetscFunctionReturn(0);
}

Vec3 Body::placed(const Motion& motion, const Vec3& X, double t) const {
  const auto [t0, t1] = step_;
  if (!(t0 < t && t < t1)) return moved(motion, X, t);
  const Vec3 p0 = moved(motion, X, t0);
  return p0 + (t - t0) / (t1 - t0) * (moved(motion, X, t1) - p0);
}

void Body::set_time(double t) {
  if (t == time_) return;  // the velocities stay those of the step that reached t
  const double dt = t - time_;
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v) {
    const Motion* motion = prescribed_motion(v);
    if (!motion) continue;
    const Vec3 X(&mesh_.rest[3 * v]);
    const Vec3 p = placed(*motion, X, t);
    for (int d = 0; d < 3; ++d) {
      fixed_vel_[3 * v + d] = dt > 0 ? (p[d] - fixed_pos_[3 * v + d]) / dt : 0.0;
      fixed_pos_[3 * v + d] = p[d];
    }
  }
  for (PetscInt e : held_local_) {  // a roller's held components follow its motion
    const Motion* motion = region_motion(mesh_.held[e]);
    if (!motion) continue;
    const double p = placed(*motion, Vec3(&mesh_.rest[3 * (e / 3)]), t)[e % 3];
    fixed_vel_[e] = dt > 0 ? (p - fixed_pos_[e]) / dt : 0.0;
    fixed_pos_[e] = p;
  }
  time_ = t;
}

void Body::keep_motion(MotionState& m) const {
  m.time = time_;
  m.velocities = fixed_vel_;
}

void Body::restore_motion(const MotionState& m) {
  set_time(m.time);
  fixed_vel_ = m.velocities;
}

void Body::prescribed_state(double t, std::vector<double>& pos, std::vector<double>& vel) const {
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v) {
    if (mesh_.local_dof[v] >= 0) continue;
    const Vec3 X(&mesh_.rest[3 * v]);
    const Motion* motion = prescribed_motion(v);
    const Vec3 p = motion ? moved(*motion, X, t) : X;
    const Vec3 u = motion ? velocity_at(*motion, X, t) : Vec3::Zero();
    for (int d = 0; d < 3; ++d) {
      pos[3 * v + d] = p[d];
      vel[3 * v + d] = u[d];
    }
  }
  for (PetscInt e : held_local_) {
    const Vec3 X(&mesh_.rest[3 * (e / 3)]);
    const Motion* motion = region_motion(mesh_.held[e]);
    pos[e] = motion ? moved(*motion, X, t)[e % 3] : X[e % 3];
    vel[e] = motion ? velocity_at(*motion, X, t)[e % 3] : 0.0;
  }
}

PetscErrorCode Body::resume(double t, const std::vector<double>& pos, const std::vector<double>& vel, Vec x, Vec v) {
  PetscFunctionBeginUser;
  time_ = t;
  for (PetscInt i = 0; i < mesh_.num_vertices; ++i) {
    if (mesh_.local_dof[i] >= 0) continue;
    for (int d = 0; d < 3; ++d) {
      fixed_pos_[3 * i + d] = pos[3 * i + d];
      fixed_vel_[3 * i + d] = vel[3 * i + d];
    }
  }
  for (PetscInt e : held_local_) {
    fixed_pos_[e] = pos[e];
    fixed_vel_[e] = vel[e];
  }
  PetscCall(free_values(pos, x));
  PetscCall(free_values(vel, v));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::free_values(const std::vector<double>& values, Vec global) const {
  Vec local;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(mesh_.dm, &local));
  PetscCall(VecGetArray(local, &a));
  for (PetscInt i = 0; i < mesh_.num_vertices; ++i) {
    const PetscInt off = mesh_.local_dof[i];
    if (off >= 0)
      for (int d = 0; d < 3; ++d) a[off + d] = values[3 * i + d];
  }
  PetscCall(VecRestoreArray(local, &a));
  PetscCall(DMLocalToGlobal(mesh_.dm, local, INSERT_VALUES, global));  // ghosts carry the same values
  PetscCall(DMRestoreLocalVector(mesh_.dm, &local));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::set_masses(Vec mass) {
  PetscFunctionBeginUser;
  for (auto& t : terms_) PetscCall(t->set_masses(mass));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::begin_step(const StepStart& step) {
  PetscFunctionBeginUser;
  StepStart full = step;
  if (any_term(&EnergyTerm::needs_step_positions)) {
    // The moving fixed vertices jump from where they were at t_start to where set_time put them:
    // a term that couples surfaces checks that path (SelfContactTerm::begin_step).
    PetscCall(local_positions(step.x_start, step_positions_));
    step_start_ = step_positions_;
    for (PetscInt v = 0; v < mesh_.num_vertices; ++v)
      if (const Motion* motion = prescribed_motion(v)) {
        const Vec3 p = placed(*motion, Vec3(&mesh_.rest[3 * v]), step.t_start);
        for (int d = 0; d < 3; ++d) step_start_[3 * v + d] = p[d];
      }
    for (PetscInt e : held_local_)
      if (const Motion* motion = region_motion(mesh_.held[e]))
        step_start_[e] = placed(*motion, Vec3(&mesh_.rest[3 * (e / 3)]), step.t_start)[e % 3];
    full.start_positions = &step_start_;
    full.positions = &step_positions_;
  }
  for (auto& term : terms_) PetscCall(term->begin_step(full));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::scatter_to_local(Vec global, const std::vector<double>& fixed_values, std::vector<double>& out) const {
  const PetscScalar* xl;
  PetscFunctionBeginUser;
  if (!local_) PetscCall(DMCreateLocalVector(mesh_.dm, &local_));
  PetscCall(DMGlobalToLocal(mesh_.dm, global, INSERT_VALUES, local_));
  PetscCall(VecGetArrayRead(local_, &xl));
  out = fixed_values;
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v) {
    const PetscInt off = mesh_.local_dof[v];
    if (off >= 0)
      for (int d = 0; d < 3; ++d) out[3 * v + d] = xl[off + d];
  }
  PetscCall(VecRestoreArrayRead(local_, &xl));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::local_positions(Vec x, std::vector<double>& pos) const {
  PetscFunctionBeginUser;
  PetscCall(scatter_to_local(x, fixed_pos_, pos));
  for (PetscInt e : held_local_) pos[e] = fixed_pos_[e];
  PetscFunctionReturn(0);
}

PetscErrorCode Body::local_values(Vec global, std::vector<double>& out) const {
  PetscFunctionBeginUser;
  zeros_.assign(3 * mesh_.num_vertices, 0.0);
  PetscCall(scatter_to_local(global, zeros_, out));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::local_velocities(Vec v, std::vector<double>& vel) const {
  PetscFunctionBeginUser;
  PetscCall(scatter_to_local(v, fixed_vel_, vel));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::energy_gradient(Vec x, PetscReal* energy, Vec grad, bool with_contact) const {
  PetscScalar *array = nullptr, *gl = nullptr, no_dofs = 0;
  PetscFunctionBeginUser;
  PetscCall(local_positions(x, pos_));
  if (grad) {
    PetscCall(VecSet(local_, 0.0));
    PetscCall(VecGetArray(local_, &array));
    // A rank without free dofs (all its vertices fixed) gets no array, but the terms must see a
    // gradient asked for on every rank alike: self-contact's gradient exchange is collective.
    gl = array ? array : &no_dofs;
  }
  // The energies and the ranks' stop votes in one reduction (solvers/stop_request.hpp): a signal
  // that reached any rank is known to all at this evaluation, at no cost of its own.
  double local[2] = {0, stop_vote()}, global[2];
  for (const auto& term : terms_)
    if (with_contact || !term->is_contact()) PetscCall(term->add_energy(x, pos_, &local[0], gl));
  PetscCallMPI(MPI_Allreduce(local, global, 2, MPIU_REAL, MPI_SUM, PetscObjectComm((PetscObject)mesh_.dm)));
  *energy = global[0];
  count_stop_votes(global[1]);
  if (grad) {
    PetscCall(VecRestoreArray(local_, &array));
    PetscCall(VecSet(grad, 0.0));
    PetscCall(DMLocalToGlobal(mesh_.dm, local_, ADD_VALUES, grad));
  }
  PetscFunctionReturn(0);
}

void Body::cell_jacobians(const std::vector<double>& pos, std::vector<double>& J) const {
  J.resize(mesh_.num_cells + mesh_.num_triangles);
  for (PetscInt c = 0; c < mesh_.num_cells; ++c)  // det(Ds Dm^{-1}) = det Ds / det Dm
    J[c] = edge_matrix(pos.data(), &mesh_.cells[4 * c]).determinant() / rest_measure_[c];
  for (PetscInt t = 0; t < mesh_.num_triangles; ++t)  // a membrane's J: its area ratio (>= 0; it folds, never inverts)
    J[mesh_.num_cells + t] = triangle_area(pos.data(), &mesh_.triangles[3 * t]) / rest_measure_[mesh_.num_cells + t];
}

PetscErrorCode Body::volume_ratios(Vec x, double* min_J, double* max_abs_J) const {
  PetscFunctionBeginUser;
  PetscCall(local_positions(x, pos_));
  cell_jacobians(pos_, J_);
  double local[2] = {HUGE_VAL, -0.0}, global[2];  // {min det F, -max |det F|}: one MIN reduction
  for (double j : J_) {
    local[0] = std::fmin(local[0], j);
    local[1] = std::fmin(local[1], -std::fabs(j));
  }
  PetscCallMPI(MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_MIN, PetscObjectComm((PetscObject)x)));
  *min_J = global[0];
  *max_abs_J = -global[1];
  PetscFunctionReturn(0);
}

unsigned long long Body::active_set() const {
  unsigned long long local = 0, global = 0;
  for (const auto& t : terms_) local += t->active_set();
  MPI_Allreduce(&local, &global, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, PetscObjectComm((PetscObject)mesh_.dm));
  return global;
}


void Body::begin_element_states(bool substep) {
  for (const auto& t : terms_)
    if (ElementState* state = t->element_state()) substep ? state->begin_substep() : state->begin();
}

PetscErrorCode Body::accept_element_states(Vec x) {
  PetscFunctionBeginUser;
  bool any = false;
  for (const auto& t : terms_) any = any || t->element_state();
  if (!any) PetscFunctionReturn(0);
  PetscCall(local_positions(x, pos_));
  for (const auto& t : terms_)
    if (t->element_state()) PetscCall(t->update_state(pos_));
  PetscFunctionReturn(0);
}

void Body::undo_element_states(bool substep) {
  for (const auto& t : terms_)
    if (ElementState* state = t->element_state()) substep ? state->undo_substep() : state->undo();
}

std::vector<ElementState*> Body::element_states() const {
  std::vector<ElementState*> states;
  for (const auto& t : terms_)
    if (ElementState* state = t->element_state()) states.push_back(state);
  return states;
}

PetscErrorCode Body::dissipated_energy(double* total) const {
  double local = 0;
  PetscFunctionBeginUser;
  for (const auto& t : terms_) local += t->dissipated_energy();
  PetscCallMPI(MPI_Allreduce(&local, total, 1, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)mesh_.dm)));
  PetscFunctionReturn(0);
}

std::vector<ElementState> Body::copy_element_states() const {
  std::vector<ElementState> copies;
  for (const ElementState* state : element_states()) copies.push_back(*state);
  return copies;
}

void Body::set_element_states(const std::vector<ElementState>& copies) {
  const std::vector<ElementState*> states = element_states();
  for (size_t i = 0; i < states.size() && i < copies.size(); ++i) *states[i] = copies[i];
}

void carry_values(ElementState& to, const ElementState& from) {
  if (from.name() != to.name() || from.per_element() != to.per_element()) return;
  std::unordered_map<int64_t, size_t> at;  // global id -> from's element
  for (size_t e = 0; e < from.elements(); ++e) at[from.ids()[e]] = e;
  std::vector<double> values = to.current_values();
  const int n = to.per_element();
  for (size_t e = 0; e < to.elements(); ++e)
    if (const auto it = at.find(to.ids()[e]); it != at.end())
      std::copy_n(&from.current_values()[n * it->second], n, &values[n * e]);
  to.restore(std::move(values));
}

// The elements of `to` that carry on one of `from`'s (pairs: new id, old id) take its first
// to.inherited() values, the rest 0; the old element may be on any rank (a torn edge's two sides
// on two ranks), so what the ranks hold of the pairs' old elements is gathered. *found: the pairs
// whose old element this state holds on some rank; *wanted: those whose new element this rank's
// `to` holds. Collective.
static void inherit_values(MPI_Comm comm, ElementState& to, const ElementState& from,
                           const std::vector<std::array<int64_t, 2>>& pairs, std::vector<bool>* found,
                           std::vector<int>* wanted) {
  const int n = to.inherited(), w = to.per_element();
  std::unordered_map<int64_t, size_t> at;  // global id -> from's element
  for (size_t e = 0; e < from.elements(); ++e) at[from.ids()[e]] = e;
  std::vector<int64_t> ids;
  std::vector<double> values;
  for (const auto& pair : pairs)
    if (const auto it = at.find(pair[1]); it != at.end()) {
      ids.push_back(pair[1]);
      const double* v = &from.current_values()[size_t(w) * it->second];
      values.insert(values.end(), v, v + n);
    }
  const std::vector<int64_t> all_ids = all_gathered(comm, ids, MPI_INT64_T);
  const std::vector<double> all_values = all_gathered(comm, values, MPI_DOUBLE);
  std::unordered_map<int64_t, size_t> held;  // old id -> its values in all_values
  for (size_t i = 0; i < all_ids.size(); ++i)
    if (!held.emplace(all_ids[i], i).second) throw std::logic_error("carry_element_states: an element is held by two ranks");
  std::unordered_map<int64_t, size_t> pair_of;  // new id -> its pair
  for (size_t k = 0; k < pairs.size(); ++k) {
    pair_of[pairs[k][0]] = k;
    (*found)[k] = (*found)[k] || held.count(pairs[k][1]);
  }
  std::vector<double> v = to.current_values();
  for (size_t e = 0; e < to.elements(); ++e) {
    const auto k = pair_of.find(to.ids()[e]);
    if (k == pair_of.end()) continue;
    (*wanted)[k->second] = 1;
    if (const auto it = held.find(pairs[k->second][1]); it != held.end()) {
      std::copy_n(&all_values[size_t(n) * it->second], n, &v[size_t(w) * e]);
      std::fill(&v[size_t(w) * e + n], &v[size_t(w) * (e + 1)], 0.0);
    }
  }
  to.restore(std::move(v));
}

void Body::carry_element_states(const Body& from) {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  std::vector<bool> found(inherited_elements_.size(), false);
  std::vector<int> wanted(inherited_elements_.size(), 0);
  bool inherits = false;
  for (ElementState* to : element_states())
    for (const ElementState* old : from.element_states()) {
      carry_values(*to, *old);
      if (!inherited_elements_.empty() && to->inherited() > 0 && to->name() == old->name() &&
          to->per_element() == old->per_element()) {
        inherit_values(comm, *to, *old, inherited_elements_, &found, &wanted);
        inherits = true;
      }
    }
  if (!inherits) return;  // no state takes history from another (the same on every rank)
  // A new element of a state that inherits must have found its old one (a cloth that does not
  // yield has no such state; its tears' pairs are not wanted). Every rank decides alike.
  MPI_Allreduce(MPI_IN_PLACE, wanted.data(), (int)wanted.size(), MPI_INT, MPI_MAX, comm);
  for (size_t k = 0; k < wanted.size(); ++k)
    if (wanted[k] && !found[k]) throw std::logic_error("carry_element_states: an element carries on one that no rank holds");
}


PetscErrorCode Body::limit_step(Vec x, Vec dir, double* alpha) const {
  PetscFunctionBeginUser;
  // Each term bounds the step the ranks agreed on so far: self-contact tests the path alpha dir
  // between the ranks' surfaces, so an alpha that a collider had cut on some ranks only made the
  // bound depend on the rank count. One reduction per bounding term (one without contact).
  for (const auto& t : terms_)
    if (t->bounds_steps()) {
      double local = *alpha;
      PetscCall(t->limit_step(x, dir, &local));
      PetscCallMPI(MPI_Allreduce(&local, alpha, 1, MPI_DOUBLE, MPI_MIN, PetscObjectComm((PetscObject)mesh_.dm)));
    }
  PetscFunctionReturn(0);
}

PetscErrorCode Body::lumped_mass(Vec mass) const {
  Vec ml;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(mesh_.dm, &ml));
  PetscCall(VecSet(ml, 0.0));
  PetscCall(VecGetArray(ml, &a));
  for (const auto& term : terms_) term->add_lumped_mass(a);
  PetscCall(VecRestoreArray(ml, &a));
  PetscCall(VecSet(mass, 0.0));
  PetscCall(DMLocalToGlobal(mesh_.dm, ml, ADD_VALUES, mass));
  PetscCall(DMRestoreLocalVector(mesh_.dm, &ml));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::add_laplacian(Mat A, PetscReal scale, int components) const {
  PetscFunctionBeginUser;
  for (const auto& term : terms_) PetscCall(term->add_laplacian(A, scale, components));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::add_hessian(Vec x, Mat H, PetscReal scale, bool psd) const {
  PetscFunctionBeginUser;
  PetscCall(local_positions(x, pos_));
  for (const auto& term : terms_) PetscCall(term->add_hessian(pos_, H, scale, psd));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::hessian_couplings(Vec x, std::vector<std::array<PetscInt, 2>>* out,
                                       unsigned long long* generation) const {
  PetscFunctionBeginUser;
  if (out) out->clear();
  *generation = 0;
  PetscCall(local_positions(x, pos_));
  for (const auto& term : terms_) PetscCall(term->add_couplings(pos_, out, generation));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::vertex_stiffness(Vec x, PetscReal scale, std::vector<VertexStiffness>& out) const {
  std::vector<VertexStiffness> blocks;
  PetscFunctionBeginUser;
  PetscCall(local_positions(x, pos_));
  for (const auto& term : terms_) PetscCall(term->add_vertex_stiffness(pos_, blocks));
  std::stable_sort(blocks.begin(), blocks.end(), [](const VertexStiffness& a, const VertexStiffness& b) { return a.dof < b.dof; });
  if (mesh_.rollers) {  // no stiffness at a held slot: H0's update keeps its identity row (ContactH0)
    std::unordered_map<PetscInt, int> held;  // global x dof -> held components' bits
    for (PetscInt e : held_local_) held[mesh_.global_dof[e / 3]] |= 1 << (e % 3);
    for (VertexStiffness& b : blocks)
      if (const auto it = held.find(b.dof); it != held.end())
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            if (it->second & (1 << i | 1 << j)) b.K[3 * i + j] = 0;
  }
  out.clear();
  for (const VertexStiffness& b : blocks) {
    if (out.empty() || out.back().dof != b.dof) {
      out.push_back(b);
      for (double& k : out.back().K) k *= scale;
    } else {
      for (int i = 0; i < 9; ++i) out.back().K[i] += scale * b.K[i];
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode Body::add_rest_hessian(Mat H, PetscReal scale) const {
  PetscFunctionBeginUser;
  for (const auto& term : terms_) PetscCall(term->add_rest_stiffness(mesh_.rest, H, scale));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::add_volumetric_h0(Mat A, PetscReal scale) const {
  PetscFunctionBeginUser;
  for (const auto& term : terms_) PetscCall(term->add_volumetric_h0(A, scale));
  PetscFunctionReturn(0);
}

PetscErrorCode Body::rest_positions(Vec x) const {
  Vec xl;
  PetscScalar* a;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalVector(mesh_.dm, &xl));
  PetscCall(VecGetArray(xl, &a));
  for (PetscInt v = 0; v < mesh_.num_vertices; ++v)
    if (mesh_.local_dof[v] >= 0)
      for (int d = 0; d < 3; ++d) a[mesh_.local_dof[v] + d] = mesh_.rest[3 * v + d];
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(DMLocalToGlobal(mesh_.dm, xl, INSERT_VALUES, x));
  PetscCall(DMRestoreLocalVector(mesh_.dm, &xl));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
