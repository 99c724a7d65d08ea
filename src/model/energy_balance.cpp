#include "model/energy_balance.hpp"

#include "geometry/motion.hpp"
#include "model/elastic_terms.hpp"
#include "model/load_kinds.hpp"
#include "model/reactions.hpp"

namespace hyperqn {

const char* EnergyBalance::columns() {
  return "kinetic,stored,dissipated,released,gravity_work,load_work,support_work,residual";
}

// Sums of this rank's parts over the ranks, in place.
static PetscErrorCode sum_over_ranks(const DistributedMesh& mesh, double* values, int n) {
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, values, n, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)mesh.dm)));
  PetscFunctionReturn(0);
}

PetscErrorCode EnergyBalance::bind(const Body& body, const State& s) {
  const DistributedMesh& mesh = body.mesh();
  PetscFunctionBeginUser;
  body_ = &body;
  terms_.clear();
  loads_.clear();
  PetscCall(mesh_with_every_vertex(mesh, all_));
  terms_ = scene_elastic_terms(*all_, spec_);
  PetscCall(loads_over_every_vertex(*all_, spec_, body, loads_));
  mass_.assign(3 * mesh.num_vertices, 0.0);
  for (const auto& t : terms_) t->add_lumped_mass(mass_.data());
  free_.assign(3 * mesh.num_vertices, 1);
  for (PetscInt v = 0; v < mesh.num_vertices; ++v)
    for (int d = 0; d < 3; ++d)
      if (mesh.fixed[v] > 0 || (mesh.rollers && mesh.held[3 * v + d] > 0)) free_[3 * v + d] = 0;
  attached_ = attached_vertex_sets(mesh, spec_.attachments, s.released_attachments);  // as attachment_term
  PetscFunctionReturn(0);
}

PetscErrorCode EnergyBalance::dissipated(const Body& body, double* total) const {
  PetscFunctionBeginUser;
  PetscCall(body.dissipated_energy(total));
  *total += dissipated_removed_;
  PetscFunctionReturn(0);
}

PetscErrorCode EnergyBalance::rebind(const Body& body, const State& s, bool topology_changed) {
  PetscFunctionBeginUser;
  PetscCall(bind(body, s));
  if (topology_changed) {
    changed_ = true;
  } else if (!changed_) {
    double e[2], dissipated = 0;
    PetscCall(energies(s, &e[0], &e[1]));
    PetscCall(sum_over_ranks(body.mesh(), e, 2));
    PetscCall(this->dissipated(body, &dissipated));
    last_energy_ = e[0] + e[1] + dissipated;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode EnergyBalance::energies(const State& s, double* kinetic, double* stored) {
  const PetscInt n = 3 * body_->mesh().num_vertices;
  PetscFunctionBeginUser;
  PetscCall(body_->local_positions(s.x, pos_));
  PetscCall(body_->local_velocities(s.v, vel_));
  *kinetic = 0;
  for (PetscInt i = 0; i < n; ++i)
    if (free_[i]) *kinetic += 0.5 * mass_[i] * vel_[i] * vel_[i];
  // The element states as the accepted step left them, with no step begun: the stored energy.
  for (const auto& term : terms_)
    if (ElementState* to = term->element_state()) {
      for (const ElementState* from : body_->element_states()) carry_values(*to, *from);
      PetscCall(term->begin_step({s.time, 0, s.x, nullptr, s.time}));
    }
  *stored = 0;
  for (const auto& term : terms_) PetscCall(term->add_energy(s.x, pos_, stored, nullptr));
  PetscFunctionReturn(0);
}

PetscErrorCode EnergyBalance::start(const State& s, EnergyRow& out) {
  double e[2];
  PetscFunctionBeginUser;
  PetscCall(energies(s, &e[0], &e[1]));
  PetscCall(sum_over_ranks(body_->mesh(), e, 2));
  out = EnergyRow{};
  out.kinetic = e[0];
  out.stored = e[1];
  PetscCall(dissipated(*body_, &out.dissipated));
  start_energy_ = e[0] + e[1];
  last_energy_ = e[0] + e[1] + out.dissipated;
  gravity_work_ = load_work_ = support_work_ = released_ = 0;
  PetscFunctionReturn(0);
}

void EnergyBalance::resume(const EnergyRow& at_restart, double start_energy) {
  start_energy_ = start_energy;
  gravity_work_ = at_restart.gravity_work;
  load_work_ = at_restart.load_work;
  support_work_ = at_restart.support_work;
  released_ = at_restart.released;
  last_energy_ = at_restart.kinetic + at_restart.stored + at_restart.dissipated;
  changed_ = true;  // the checkpoint may hold the changes of the frame after it (a frame given up)
}

PetscErrorCode EnergyBalance::begin_frame(const State& s) {
  PetscFunctionBeginUser;
  if (changed_) {
    double e[2];
    PetscCall(energies(s, &e[0], &e[1]));
    PetscCall(sum_over_ranks(body_->mesh(), e, 2));
    double dissipated = 0;
    PetscCall(this->dissipated(*body_, &dissipated));
    released_ += last_energy_ - (e[0] + e[1] + dissipated);
    last_energy_ = e[0] + e[1] + dissipated;
    changed_ = false;
  }
  PetscCall(body_->local_positions(s.x, pos_n_));
  start_states_ = body_->copy_element_states();
  start_time_ = s.time;
  PetscFunctionReturn(0);
}

PetscErrorCode EnergyBalance::end_frame(const State& s, EnergyRow& out) {
  const DistributedMesh& mesh = body_->mesh();
  const PetscInt n = 3 * mesh.num_vertices;
  const double h = s.time - start_time_, tz = start_time_ + c_ * h;
  const Vec3 g(spec_.gravity.data());
  PetscFunctionBeginUser;
  // The frame's displacement and z = x_n + c dx, the fixed vertices (and a roller's held components)
  // too, on the step's chord as the solve had them (Body::set_step); with c = 1 where their supports
  // are at t_{n+1}.
  PetscCall(body_->local_positions(s.x, pos_));
  dx_.resize(n);
  for (PetscInt i = 0; i < n; ++i) dx_[i] = pos_[i] - pos_n_[i];
  std::vector<double> z(n);
  for (PetscInt i = 0; i < n; ++i) z[i] = pos_n_[i] + c_ * dx_[i];
  fixed_vel_.resize(n);
  if (c_ == 1) body_->prescribed_state(tz, z, fixed_vel_);
  // The solve's forces at z: the elastic terms from the frame's start with the history it began with
  // (the inelastic ones' condensed stress over c h), the loads at their curves' t_n + c h.
  // A load that takes its directions from the step's start (a pressure on an open surface): x_n.
  const StepStart step{tz, c_ * h, s.x, nullptr, start_time_, &pos_n_, &pos_n_};
  for (const auto& term : terms_)
    if (ElementState* to = term->element_state()) {
      for (const ElementState& from : start_states_) carry_values(*to, from);
      PetscCall(term->begin_step(step));
    }
  for (const auto& load : loads_) PetscCall(load->begin_step(step));
  double unused = 0;
  grad_.assign(n, 0.0);
  load_grad_.assign(n, 0.0);
  for (const auto& term : terms_) PetscCall(term->add_energy(s.x, z, &unused, grad_.data()));
  for (const auto& load : loads_) PetscCall(load->add_energy(s.x, z, &unused, load_grad_.data()));
  // This rank's parts: [gravity, loads, supports].
  double w[3] = {0, 0, 0};
  for (PetscInt i = 0; i < n; ++i) {
    w[1] -= load_grad_[i] * dx_[i];
    if (free_[i])
      w[0] += mass_[i] * g[i % 3] * dx_[i];
    else
      w[2] += (grad_[i] + load_grad_[i]) * dx_[i];
  }
  for (size_t a = 0; a < attached_.size(); ++a) {
    const AttachmentSpec& spec = spec_.attachments[a];
    for (PetscInt v : attached_[a]) {  // the spring's pull on the body at z: -dE/dx_i
      const Vec3 f = -spec.stiffness * (Vec3(&z[3 * v]) - moved(spec.region.motion, Vec3(&mesh.rest[3 * v]), tz));
      for (int d = 0; d < 3; ++d) w[2] += f[d] * dx_[3 * v + d];
    }
  }
  double e[5] = {w[0], w[1], w[2], 0, 0};
  PetscCall(energies(s, &e[3], &e[4]));
  PetscCall(sum_over_ranks(mesh, e, 5));
  gravity_work_ += e[0];
  load_work_ += e[1];
  support_work_ += e[2];
  out = EnergyRow{};
  out.kinetic = e[3];
  out.stored = e[4];
  PetscCall(dissipated(*body_, &out.dissipated));
  out.gravity_work = gravity_work_;
  out.load_work = load_work_;
  out.support_work = support_work_;
  out.released = released_;
  last_energy_ = out.kinetic + out.stored + out.dissipated;
  out.residual = out.kinetic + out.stored + out.dissipated + out.released - (gravity_work_ + load_work_ + support_work_) -
                 start_energy_;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
