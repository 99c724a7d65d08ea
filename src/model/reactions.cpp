#include "model/reactions.hpp"

#include <map>

#include "geometry/motion.hpp"
#include "model/elastic_terms.hpp"
#include "model/load_kinds.hpp"

namespace hyperqn {

namespace {

// "fixed[j]" or "bodies[b].fixed[j]", j counting the scene's (or that body's) own in deck order.
template <typename Item>
void add_names(const std::vector<Item>& items, const BoxRegion& (*region)(const Item&), const char* key,
               std::vector<std::string>& out) {
  std::map<int, int> count;  // per body (-1: the scene's)
  for (const Item& item : items) {
    const int body = region(item).body;
    const std::string index = "[" + std::to_string(count[body]++) + "]";
    out.push_back((body < 0 ? "" : "bodies[" + std::to_string(body) + "].") + key + index);
  }
}

const BoxRegion& fixed_region(const BoxRegion& b) { return b; }
const BoxRegion& attachment_region(const AttachmentSpec& a) { return a.region; }

// The box's centre moved by its motion to time t: the point the moments are taken about.
Vec3 moment_point(const BoxRegion& b, double t) {
  const Vec3 centre = 0.5 * (Vec3(b.min.data()) + Vec3(b.max.data()));
  return moved(b.motion, centre, t);
}

void add_force(const Vec3& x, const Vec3& f, const Vec3& c, double* sums) {
  const Vec3 m = (x - c).cross(f);
  for (int d = 0; d < 3; ++d) {
    sums[d] += f[d];
    sums[3 + d] += m[d];
  }
}

}  // namespace

std::vector<std::string> Reactions::names(const SceneSpec& spec) {
  std::vector<std::string> out;
  add_names<BoxRegion>(spec.fixed, fixed_region, "fixed", out);
  add_names<AttachmentSpec>(spec.attachments, attachment_region, "attachments", out);
  return out;
}

std::vector<int> Reactions::lines(const SceneSpec& spec) {
  std::vector<int> out;
  for (const BoxRegion& b : spec.fixed) out.push_back(b.line);
  for (const AttachmentSpec& a : spec.attachments) out.push_back(a.region.line);
  return out;
}

PetscErrorCode mesh_with_every_vertex(const DistributedMesh& mesh, std::unique_ptr<DistributedMesh>& out) {
  PetscFunctionBeginUser;
  out = std::make_unique<DistributedMesh>(mesh);
  PetscCall(PetscObjectReference((PetscObject)out->dm));
  out->vertex_dm = nullptr;
  for (PetscInt v = 0; v < mesh.num_vertices; ++v) out->local_dof[v] = 3 * v;
  PetscFunctionReturn(0);
}

PetscErrorCode loads_over_every_vertex(const DistributedMesh& all, const SceneSpec& spec, const Body& body,
                                       std::vector<std::unique_ptr<EnergyTerm>>& out) {
  PetscFunctionBeginUser;
  for (size_t k = 0; k < spec.loads.size(); ++k) {
    const LoadKind& kind = *find_load_kind(spec.loads[k].type);
    out.push_back(kind.build(all, spec.loads[k], (int)k, select_load_region(all, spec.loads[k], kind.target)));
  }
  Vec mass;
  PetscCall(DMCreateGlobalVector(body.mesh().dm, &mass));
  PetscCall(body.lumped_mass(mass));
  for (size_t k = out.size() - spec.loads.size(); k < out.size(); ++k) PetscCall(out[k]->set_masses(mass));
  PetscCall(VecDestroy(&mass));
  PetscFunctionReturn(0);
}

PetscErrorCode Reactions::bind(const Body& body, const State& s) {
  const DistributedMesh& mesh = body.mesh();
  PetscFunctionBeginUser;
  body_ = &body;
  terms_.clear();
  PetscCall(mesh_with_every_vertex(mesh, all_));
  terms_ = scene_elastic_terms(*all_, spec_);
  first_load_ = terms_.size();
  // The loads, whose share at a fixed vertex or a roller's held component goes into its support
  // (the solver's terms drop it there). A load on vertices selects free vertices only (rollers'
  // among them): its share reaches a support through the rollers' held components alone.
  PetscCall(loads_over_every_vertex(*all_, spec_, body, terms_));
  mass_.assign(3 * mesh.num_vertices, 0.0);
  for (const auto& t : terms_) t->add_lumped_mass(mass_.data());
  attached_ = attached_vertex_sets(mesh, spec_.attachments, s.released_attachments);  // as attachment_term
  PetscFunctionReturn(0);
}

PetscErrorCode Reactions::begin_frame(const State& s) {
  PetscFunctionBeginUser;
  PetscCall(body_->local_velocities(s.v, vel_start_));
  // The face loads at the step's end time (their curves' factor c(t_{n+1}), as Body::begin_step
  // gives the solve's), and a term that takes its directions from the step's start (a pressure on
  // an open surface): x_n, the fixed vertices where they are at t_n.
  StepStart step;
  step.t_start = s.time;
  step.dt = spec_.time.dt;
  step.t = s.time + spec_.time.dt;
  step.x_start = s.x;
  for (size_t k = 0; k < terms_.size(); ++k) {
    EnergyTerm& term = *terms_[k];
    if (k < first_load_ && !term.needs_step_positions()) continue;
    if (term.needs_step_positions() && !step.start_positions) {
      PetscCall(body_->local_positions(s.x, pos_));
      step.start_positions = step.positions = &pos_;
    }
    PetscCall(term.begin_step(step));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode Reactions::end_frame(const State& s, std::vector<SupportForce>& out) {
  const DistributedMesh& mesh = body_->mesh();
  const size_t fixed = spec_.fixed.size(), supports = fixed + spec_.attachments.size();
  const double h = spec_.time.dt, t = s.time;
  const Vec3 g(spec_.gravity.data());
  PetscFunctionBeginUser;
  PetscCall(body_->local_positions(s.x, pos_));
  PetscCall(body_->local_velocities(s.v, vel_));
  grad_.assign(3 * mesh.num_vertices, 0.0);
  double energy = 0;
  // A term with history (a viscoelastic material) evaluates the body's state as the accepted step
  // left it, with no step begun: its stored stress, which equals the step's condensed one at x_{n+1}.
  for (const auto& term : terms_)
    if (ElementState* to = term->element_state())
      for (const ElementState* from : body_->element_states()) carry_values(*to, *from);
  for (const auto& term : terms_) PetscCall(term->add_energy(s.x, pos_, &energy, grad_.data()));
  std::vector<Vec3> points;
  for (const BoxRegion& b : spec_.fixed) points.push_back(moment_point(b, t));
  for (const AttachmentSpec& a : spec_.attachments) points.push_back(moment_point(a.region, t));
  // Force and moment per support from this rank's elements. A vertex shared by ranks gets each
  // rank's part of its gradient and mass (elements live on one rank each, a_i is known to all):
  // the sum over ranks is the whole, without an exchange of ghosts.
  // r_i = dE/dx_i + m_i (a_i - g): the step's residual at a vertex the solve leaves out. A static
  // step has no inertia (its velocities are the load path's, not the body's): r_i = dE/dx_i - m_i g.
  const bool inertia = spec_.time.integrator != TimeIntegrator::quasi_static;
  auto residual = [&](PetscInt i, int d) {
    return grad_[i] + mass_[i] * ((inertia ? (vel_[i] - vel_start_[i]) / h : 0.0) - g[d]);
  };
  std::vector<double> local(6 * supports, 0.0), sums(6 * supports, 0.0);
  for (PetscInt v = 0; v < mesh.num_vertices; ++v) {
    const int32_t k = mesh.fixed[v];
    if (k <= 0 || (size_t)k > fixed) continue;
    Vec3 r;
    for (int d = 0; d < 3; ++d) r[d] = residual(3 * v + d, d);
    add_force(Vec3(&pos_[3 * v]), r, points[k - 1], &local[6 * (k - 1)]);
  }
  // A roller's held component: the same residual, in that component only (its free ones are solved).
  if (mesh.rollers)
    for (PetscInt i = 0; i < 3 * mesh.num_vertices; ++i) {
      const int32_t k = mesh.held[i];
      if (k <= 0 || (size_t)k > fixed) continue;
      const int d = (int)(i % 3);
      Vec3 r = Vec3::Zero();
      r[d] = residual(i, d);
      add_force(Vec3(&pos_[i - d]), r, points[k - 1], &local[6 * (k - 1)]);
    }
  for (size_t a = 0; a < attached_.size(); ++a) {
    const AttachmentSpec& spec = spec_.attachments[a];
    for (PetscInt v : attached_[a]) {  // the spring's pull on the body: -dE/dx_i
      const Vec3 x(&pos_[3 * v]);
      const Vec3 f = -spec.stiffness * (x - moved(spec.region.motion, Vec3(&mesh.rest[3 * v]), t));
      add_force(x, f, points[fixed + a], &local[6 * (fixed + a)]);
    }
  }
  PetscCallMPI(MPI_Allreduce(local.data(), sums.data(), (int)local.size(), MPI_DOUBLE, MPI_SUM,
                             PetscObjectComm((PetscObject)mesh.dm)));
  out.assign(supports, {});
  for (size_t k = 0; k < supports; ++k)
    for (int d = 0; d < 3; ++d) {
      out[k].force[d] = sums[6 * k + d];
      out[k].moment[d] = sums[6 * k + 3 + d];
      out[k].point[d] = points[k][d];
    }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
