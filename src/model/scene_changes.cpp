// A live scene's changes during a run: fixed regions and attachments released, faces separated by
// cuts and fracture, strand segments snapped and cloth edges torn. Each change builds the scene
// again from its kept input (LiveScene::rebuild) and carries the state over (carry_state); the
// restore_* functions replay a checkpoint's changes so a restart builds the same scene.
#include <cstdio>
#include "model/scene.hpp"

#include <algorithm>
#include <numeric>

#include "io/log_events.hpp"
#include "model/cuts.hpp"
#include "model/fracture.hpp"
#include "model/tearing.hpp"
#include "model/regions.hpp"
#include "mesh/cloth_separation.hpp"
#include "mesh/strand_separation.hpp"

namespace hyperqn {
// x, v of scene `from` at time t as new vectors of scene `to` (same local vertices): every vertex
// keeps its position and velocity; a vertex freed in `to` the prescribed ones at t (Body::
// prescribed_state: the motion's velocity at t, not the mean over the last step that set_time holds).
// source (a cut): per local vertex of `to`, the local vertex of `from` whose state it takes (none on
// a rank the change left without vertices); null: the same local vertices. shift (a crack opened for self-contact): 3 per local vertex of `to`,
// added to its position.
static PetscErrorCode carry_state(const Scene& from, const Scene& to, double t, State& s,
                                  const std::vector<int32_t>* source = nullptr, const std::vector<double>& shift = {}) {
  std::vector<double> pos, vel;
  Vec xl, vl, x_to, v_to;
  PetscScalar *a, *b;
  PetscFunctionBeginUser;
  // The partition is the same, so the local vertices are too; check rather than assume.
  PetscCheck(!source ? to.mesh.vertex_ids == from.mesh.vertex_ids : (PetscInt)source->size() == to.mesh.num_vertices,
             PETSC_COMM_SELF, PETSC_ERR_PLIB, "the local vertices changed when fixed regions were released");
  PetscCall(from.body->local_positions(s.x, pos));
  PetscCall(from.body->local_velocities(s.v, vel));
  from.body->prescribed_state(t, pos, vel);
  PetscCall(DMGetLocalVector(to.mesh.dm, &xl));
  PetscCall(DMGetLocalVector(to.mesh.dm, &vl));
  PetscCall(VecGetArray(xl, &a));
  PetscCall(VecGetArray(vl, &b));
  for (PetscInt i = 0; i < to.mesh.num_vertices; ++i) {
    const PetscInt off = to.mesh.local_dof[i];
    if (off < 0) continue;
    const size_t j = !source ? size_t(i) : size_t((*source)[i]);
    for (int d = 0; d < 3; ++d) {
      a[off + d] = shift.empty() ? pos[3 * j + d] : pos[3 * j + d] + shift[3 * size_t(i) + d];
      b[off + d] = vel[3 * j + d];
    }
  }
  PetscCall(VecRestoreArray(xl, &a));
  PetscCall(VecRestoreArray(vl, &b));
  PetscCall(DMCreateGlobalVector(to.mesh.dm, &x_to));
  PetscCall(VecDuplicate(x_to, &v_to));
  PetscCall(DMLocalToGlobal(to.mesh.dm, xl, INSERT_VALUES, x_to));
  PetscCall(DMLocalToGlobal(to.mesh.dm, vl, INSERT_VALUES, v_to));
  PetscCall(DMRestoreLocalVector(to.mesh.dm, &xl));
  PetscCall(DMRestoreLocalVector(to.mesh.dm, &vl));
  s.replace(x_to, v_to);
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::rebuild(const std::vector<char>& regions, const std::vector<char>& attachments,
                                  std::unique_ptr<Scene>& fresh, Scene* before, bool* corrected) const {
  PetscFunctionBeginUser;
  SceneInput input = kept_;
  for (int32_t& f : input.fixed)
    if (f > 0 && regions[f - 1]) f = 0;
  for (int32_t& h : input.held)
    if (h > 0 && regions[h - 1]) h = 0;
  if (!input.held.empty()) fixed_of_held(input.held, input.fixed);  // what the regions left still hold
  input.rollers = false;  // decided by the deck, the same on every rank
  for (size_t k = 0; k < spec_->fixed.size(); ++k) input.rollers = input.rollers || (is_roller(spec_->fixed[k]) && !regions[k]);
  if (!input.rollers) input.held.clear();  // no roller left: the scene runs as one without
  fresh = std::make_unique<Scene>();
  PetscCall(build(std::move(input), attachments, *fresh, before, corrected));
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::restore_released(const std::vector<char>& regions, const std::vector<char>& attachments) {
  PetscFunctionBeginUser;
  PetscCheck(regions.size() == spec_->fixed.size() && attachments.size() == spec_->attachments.size(), comm_,
             PETSC_ERR_ARG_SIZ, "the checkpoint's released flags do not match the deck's fixed regions and attachments");
  bool any = kept_changed_;
  kept_changed_ = false;
  for (char r : regions) any = any || r;
  for (char a : attachments) any = any || a;
  if (any) PetscCall(rebuild(regions, attachments, scene_));
  // The batches the run followed by corrections, each as the run did (every release was before
  // them: a release factors again), cuts and breaks in the run's order.
  if (replay_.empty()) PetscFunctionReturn(0);
  PetscCall(event_begin(&LogEvents::topology));
  for (const Replay& r : replay_) {
    replay(r);
    std::unique_ptr<Scene> fresh;
    PetscCall(rebuild(regions, attachments, fresh, scene_.get()));
    scene_ = std::move(fresh);
  }
  replay_.clear();
  PetscCall(event_end(&LogEvents::topology));
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::release_due(State& main, const std::vector<State*>& others, const Rebind& rebind,
                                      bool* released) {
  const double h = spec_->time.dt;
  PetscFunctionBeginUser;
  *released = false;
  // Marks what is due at the step that starts at t = main.frame h (release <= t, up to a millionth
  // of a step: decks write h = 1/30 as 0.0333333333, and frame 45 then starts at 1.4999999985,
  // which release: 1.5 means): fixed regions and attachments alike.
  const double t = main.frame * h;
  auto mark_due = [&](double release, char& done) {
    if (!done && release > 0 && release <= t + 1e-6 * h) {
      done = 1;
      *released = true;
    }
  };
  main.released.resize(spec_->fixed.size(), 0);
  main.released_attachments.resize(spec_->attachments.size(), 0);
  for (size_t k = 0; k < spec_->fixed.size(); ++k) mark_due(spec_->fixed[k].release, main.released[k]);
  for (size_t k = 0; k < spec_->attachments.size(); ++k)
    mark_due(spec_->attachments[k].region.release, main.released_attachments[k]);
  if (!*released) PetscFunctionReturn(0);

  std::unique_ptr<Scene> fresh;
  PetscCall(rebuild(main.released, main.released_attachments, fresh));
  fresh->body->set_time(t);
  fresh->body->carry_element_states(*scene_->body);
  PetscCall(carry_state(*scene_, *fresh, t, main));
  PetscCall(fresh->body->hold(main.x));  // rollers: what the regions left hold, at t
  for (State* s : others) {
    PetscCall(carry_state(*scene_, *fresh, t, *s));
    PetscCall(fresh->body->hold(s->x));
    s->released = main.released;
    s->released_attachments = main.released_attachments;
  }
  last_change_cut_ = false;
  last_change_break_ = false;
  last_cut_corrected_ = false;  // a release factors again (or, with newton, factors nothing)
  last_change_factored_ = !fresh->constant_matrices.empty();
  factored_batches_ = counts_.batches;
  factored_breaks_ = break_counts_.batches;
  PetscCall(rebind(*scene_, *fresh));
  scene_ = std::move(fresh);
  PetscFunctionReturn(0);
}

// Positions (3 per local vertex before a change) carried through it: each local vertex after it
// takes its source's, moved by the change's opening (if any).
static std::vector<double> carried(const std::vector<double>& positions, const SeparationResult& change) {
  std::vector<double> out(3 * change.source.size());
  for (size_t i = 0; i < change.source.size(); ++i)
    for (int d = 0; d < 3; ++d)
      out[3 * i + d] = positions[3 * size_t(change.source[i]) + d] + (change.shift.empty() ? 0.0 : change.shift[3 * i + d]);
  return out;
}

SeparationResult LiveScene::separate(int64_t frame, const std::vector<TetPair>& batch, const CrackOpening& opening) {
  std::vector<TetPair> faces;  // a pair (t, t) is tet t removed (docs/removal.md)
  std::vector<int64_t> tets;
  for (const TetPair& f : batch) {
    history_.push_back({frame, f[0], f[1]});
    if (f[0] == f[1]) {
      tets.push_back(f[0]);
    } else {
      separated_.insert(f);
      faces.push_back(f);
    }
  }
  std::vector<VertexArray> arrays = {{&kept_.fixed, 1}, {&kept_.held, 3}, {&kept_.vertex_body, 1}};
  SeparationResult r;
  if (tets.empty() || !faces.empty()) r = separate_faces(comm_, kept_.piece, faces, separated_, id_offset_, arrays, opening);
  if (!tets.empty()) {  // after the faces: their opening's positions are where the removal starts
    std::vector<double> between;  // the positions per local vertex after the faces
    CrackOpening then = opening;
    if (opening.positions && !faces.empty()) {
      between = carried(*opening.positions, r);
      then.positions = &between;
    }
    SeparationResult q = remove_tets(comm_, kept_.piece, tets, separated_, id_offset_, arrays, {&kept_.cell_material}, then);
    if (!faces.empty()) {
      // Both moves: each vertex's own and, through q.source (a vertex after the faces), the faces'
      if (!r.shift.empty()) {
        if (q.shift.empty()) q.shift.assign(3 * q.source.size(), 0.0);
        for (size_t i = 0; i < q.source.size(); ++i)
          for (int d = 0; d < 3; ++d) q.shift[3 * i + d] += r.shift[3 * size_t(q.source[i]) + d];
      }
      for (int32_t& v : q.source) v = r.source[v];
      q.new_vertices += r.new_vertices;
    }
    r = std::move(q);
    counts_.removed += (long long)tets.size();
  }
  counts_.faces += (long long)faces.size();
  counts_.vertices += r.new_vertices;
  counts_.batches += 1;
  batch_sizes_.push_back((int64_t)batch.size());
  return r;
}

PetscErrorCode LiveScene::resolve_breaks(const State& main, std::vector<TetPair>& batch, std::vector<int64_t>& segments,
                                         std::vector<std::array<int64_t, 2>>& edges) {
  PetscFunctionBeginUser;
  batch.clear();
  segments.clear();
  edges.clear();
  if (resolved_.first != main.frame - 1) resolved_ = {main.frame - 1, 0};
  const bool faces = resolved_.second < fracture_resolve_, tears = resolved_.second < tear_resolve_,
             snaps = resolved_.second < snap_resolve_;
  if (!faces && !tears && !snaps) PetscFunctionReturn(0);
  PetscCall(event_begin(&LogEvents::topology));
  if (faces) {
    if (!scene_->fracture_faces) scene_->fracture_faces = std::make_shared<TetFaces>(tet_faces(scene_->mesh));
    PetscCall(overloaded_faces(comm_, scene_->mesh, *scene_->fracture_faces, *scene_->body, main.x, fracture_, separated_, batch));
  }
  if (tears || snaps) {  // the segment and the edge most over their thresholds, as snap_due would break at the next step's start
    std::vector<double> pos;
    PetscCall(scene_->body->local_positions(main.x, pos));
    if (snaps) segments = segments_to_snap(comm_, kept_.piece, pos, snap_strains_, snapped_);
    if (tears) edges = edges_to_tear(comm_, kept_.piece, pos, tear_strains_, kept_.vertex_body);
  }
  PetscCall(event_end(&LogEvents::topology));
  if (!batch.empty() || !segments.empty() || !edges.empty()) ++resolved_.second;
  note_broken(main.frame - 1, (long long)batch.size());
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::break_due(const std::vector<int64_t>& segments, const std::vector<std::array<int64_t, 2>>& edges,
                                    State& main, const std::vector<State*>& others, const Rebind& rebind) {
  PetscFunctionBeginUser;
  std::vector<double> pos;
  PetscCall(scene_->body->local_positions(main.x, pos));
  PetscCall(break_apart(segments, edges, pos, main, others, rebind, false));
  PetscFunctionReturn(0);
}

void LiveScene::note_broken(int64_t frame, long long faces) {
  if (faces == 0) return;
  counts_.broken += faces;
  if (counts_.first_broken < 0) counts_.first_broken = frame;
}

PetscErrorCode LiveScene::cut_due(State& main, const std::vector<State*>& others, const Rebind& rebind, bool* cut) {
  const double h = spec_->time.dt;
  PetscFunctionBeginUser;
  *cut = false;
  if ((spec_->cuts.empty() && fracture_.empty()) || main.frame == 0) PetscFunctionReturn(0);
  PetscCall(event_begin(&LogEvents::topology));
  const double t = main.frame * h;
  std::vector<double> pos;
  PetscCall(scene_->body->local_positions(main.x, pos));
  PetscCheck(pos.size() == kept_.piece.mesh.coords.size(), PETSC_COMM_SELF, PETSC_ERR_PLIB,
             "the scene's local vertices are not its kept piece's");
  std::vector<CutSpec> by_frame[2], removing[2];  // the blades that meet the body now, and its rest shape
  for (const CutSpec& c : spec_->cuts) (c.remove ? removing : by_frame)[int(c.frame)].push_back(c);
  std::vector<TetPair> batch;
  std::vector<TrianglePair> cloth_edges;  // a cloth's edges the blades crossed: they separate as torn ones do
  std::vector<int64_t> segments;          // strand segments the blades crossed: they snap
  for (int f = 0; f < 2; ++f) {
    const std::vector<double>& at = f == int(CutFrame::world) ? pos : kept_.piece.mesh.coords;
    if (!by_frame[f].empty()) {
      const std::vector<TetPair> crossed = faces_crossed(comm_, kept_.piece, at, by_frame[f], t - h, t, separated_);
      batch.insert(batch.end(), crossed.begin(), crossed.end());
      if (cuts_cloth_) {
        const std::vector<TrianglePair> e = cloth_edges_crossed(comm_, kept_.piece, at, by_frame[f], t - h, t);
        cloth_edges.insert(cloth_edges.end(), e.begin(), e.end());
      }
      if (cuts_strands_) {
        const std::vector<int64_t> c = segments_crossed(comm_, kept_.piece, at, by_frame[f], t - h, t, snapped_);
        segments.insert(segments.end(), c.begin(), c.end());
      }
    }
    if (!removing[f].empty())  // removed tets as pairs (t, t) (docs/removal.md)
      for (int64_t tet : tets_crossed(comm_, kept_.piece, at, removing[f], t - h, t)) batch.push_back({tet, tet});
  }
  std::sort(batch.begin(), batch.end());
  batch.erase(std::unique(batch.begin(), batch.end()), batch.end());
  const size_t by_blades = batch.size();  // (a face also overloaded counts as cut)
  const auto removed = std::count_if(batch.begin(), batch.end(), [](const TetPair& f) { return f[0] == f[1]; });
  const DistributedMesh& m = scene_->mesh;
  if (removed > 0 && removed >= (long long)m.global_cells && m.global_triangles == 0 && m.global_segments == 0) {
    char when[64];
    std::snprintf(when, sizeof when, "%g", t);
    nothing_left_ = "the blades with remove: true would take every tet left (" + std::to_string(removed) +
                    ", crossed over the step to t = " + when + " s): nothing would be left to simulate";
    PetscCall(event_end(&LogEvents::topology));
    PetscFunctionReturn(0);
  }
  if (!fracture_.empty()) {  // the faces the step before overloaded (model/fracture.hpp)
    std::vector<TetPair> broken;
    if (!scene_->fracture_faces) scene_->fracture_faces = std::make_shared<TetFaces>(tet_faces(scene_->mesh));
    PetscCall(overloaded_faces(comm_, scene_->mesh, *scene_->fracture_faces, *scene_->body, main.x, fracture_, separated_, broken));
    batch.insert(batch.end(), broken.begin(), broken.end());
    std::sort(batch.begin(), batch.end());
    batch.erase(std::unique(batch.begin(), batch.end()), batch.end());
  }
  std::sort(cloth_edges.begin(), cloth_edges.end());
  cloth_edges.erase(std::unique(cloth_edges.begin(), cloth_edges.end()), cloth_edges.end());
  std::sort(segments.begin(), segments.end());
  segments.erase(std::unique(segments.begin(), segments.end()), segments.end());
  *cut = !batch.empty() || !cloth_edges.empty() || !segments.empty();
  if (!batch.empty()) {
    note_broken(main.frame, (long long)(batch.size() - by_blades));
    PetscCall(separate_due(batch, main, others, rebind));
  }
  if (!cloth_edges.empty() || !segments.empty()) {  // after the tets' separation (its own rebuild): the positions as they are now
    PetscCall(scene_->body->local_positions(main.x, pos));
    PetscCall(break_apart(segments, cloth_edges, pos, main, others, rebind, true));
  }
  PetscCall(event_end(&LogEvents::topology));
  PetscFunctionReturn(0);
}

std::string LiveScene::last_change(long long dofs) const {
  const std::string dofs_now = "; " + std::to_string(dofs) + " dofs now, ";
  const std::string matrix = dofs_now + (last_cut_corrected_ || last_change_factored_ ? "constant matrix " : "");
  const std::string followed = last_cut_corrected_     ? "corrected (TopologyH0)"
                               : last_change_factored_ ? "factored again"
                                                       : "no constant matrix (the solver factors none)";
  if (last_change_cut_) {
    const bool blades = !spec_->cuts.empty();
    bool removes = false;  // a blade removes tets (docs/removal.md): the line says how many
    for (const CutSpec& k : spec_->cuts) removes = removes || k.remove;
    return std::string(!blades ? "fracture" : fracture() ? "cut or fracture" : "cut") + ": " +
           std::to_string(counts_.faces) + " faces separated" +
           (removes ? ", " + std::to_string(counts_.removed) + " tets removed" : "") + ", " +
           std::to_string(counts_.vertices) + " vertices added so far" + matrix + followed;
  }
  if (last_change_break_) {
    const BreakCounts& c = break_counts_;
    if (last_break_by_blade_)  // what the deck's blades cut: a cloth, strands or both
      return "cut: " + (cuts_cloth_ ? std::to_string(c.edges) + " cloth edges cut or torn, " : std::string()) +
             (cuts_strands_ ? std::to_string(c.segments) + " strand segments cut or snapped, " : std::string()) +
             std::to_string(c.vertices) + " vertices added so far" + matrix + followed;
    return (c.edges == 0 ? "snap: " : "tear: " + std::to_string(c.edges) + " cloth edges torn, ") +
           std::to_string(c.segments) + " strand segments snapped, " + std::to_string(c.vertices) +
           " vertices added so far" + matrix + followed;
  }
  return "fixed region(s) released or attachment(s) gone (from this step on)" + matrix + followed;
}

PetscErrorCode LiveScene::separate_due(const std::vector<TetPair>& batch, State& main, const std::vector<State*>& others,
                                       const Rebind& rebind) {
  PetscFunctionBeginUser;
  bool corrected = false;
  last_change_cut_ = true;  // before the move: the rebind reports the change from these flags
  last_change_break_ = false;
  // With self-contact the crack opens (CrackOpening): its two sides start coincident, where the
  // barrier is infinite. The positions' part of the opening is carried in the state.
  std::vector<double> pos;
  if (opening_width_ > 0) PetscCall(scene_->body->local_positions(main.x, pos));
  const CrackOpening opening{opening_width_ > 0 ? &pos : nullptr, opening_width_};
  const SeparationResult r = separate(main.frame, batch, opening);
  PetscCall(move_to_rebuilt(main, others, rebind, main.frame * spec_->time.dt, r.source, &corrected, r.shift));
  if (corrected) {
    ++counts_.corrections;
  } else {
    if (last_change_factored_) ++counts_.refactorizations;
    factored_batches_ = counts_.batches;  // the factor holds every break so far too
    factored_breaks_ = break_counts_.batches;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::move_to_rebuilt(State& main, const std::vector<State*>& others, const Rebind& rebind,
                                          double t, const std::vector<int32_t>& source, bool* corrected,
                                          const std::vector<double>& shift,
                                          const std::vector<std::array<int64_t, 2>>& inherited) {
  PetscFunctionBeginUser;
  std::unique_ptr<Scene> fresh;
  PetscCall(rebuild(main.released, main.released_attachments, fresh, scene_.get(), corrected));
  last_cut_corrected_ = *corrected;  // known now, read by the rebind below
  last_change_factored_ = !*corrected && !fresh->constant_matrices.empty();  // newton's scenes hold none
  fresh->body->set_time(t);
  fresh->body->set_inherited_elements(inherited);
  fresh->body->carry_element_states(*scene_->body);
  PetscCall(carry_state(*scene_, *fresh, t, main, &source, shift));
  PetscCall(fresh->body->hold(main.x));
  for (State* s : others) {
    PetscCall(carry_state(*scene_, *fresh, t, *s, &source, shift));
    PetscCall(fresh->body->hold(s->x));
  }
  PetscCall(rebind(*scene_, *fresh));
  scene_ = std::move(fresh);
  PetscFunctionReturn(0);
}

// A torn edge's element in the break history: its two triangle numbers t1 < t2 as t1 * 2^32 + t2.
static int64_t edge_element(const std::array<int64_t, 2>& pair) { return (pair[0] << 32) + pair[1]; }
static std::array<int64_t, 2> edge_of_element(int64_t element) { return {element >> 32, element & 0xffffffffLL}; }

SeparationResult LiveScene::snap(int64_t frame, const std::vector<int64_t>& batch,
                                 const std::vector<std::array<int64_t, 2>>& edges, const std::vector<double>* positions) {
  std::vector<VertexArray> arrays = {{&kept_.fixed, 1}, {&kept_.held, 3}, {&kept_.vertex_body, 1}};
  std::vector<int32_t> source(kept_.piece.mesh.num_vertices());
  std::iota(source.begin(), source.end(), 0);
  std::vector<double> shift;
  std::vector<std::array<int64_t, 2>> inherited;
  if (!batch.empty()) {
    for (int64_t s : batch) {
      snapped_.insert(s);
      breaks_.push_back({frame, 0, s});
    }
    SeparationResult r = snap_segments(comm_, kept_.piece, batch, snapped_, id_offset_, arrays);
    break_counts_.segments += (long long)batch.size();
    break_counts_.vertices += r.new_vertices;
    source = std::move(r.source);
  }
  if (!edges.empty()) {
    for (const auto& e : edges) {
      torn_.insert(e);
      breaks_.push_back({frame, 1, edge_element(e)});
    }
    SeparationResult snaps;
    snaps.source = source;
    const std::vector<double> between = positions ? carried(*positions, snaps) : std::vector<double>();  // after the snaps
    SeparationResult r = tear_edges(comm_, kept_.piece, edges, torn_, id_offset_, arrays,
                                    {positions && tear_opening_ > 0 ? &between : nullptr, tear_opening_});
    break_counts_.edges += (long long)edges.size();
    break_counts_.vertices += r.new_vertices;
    for (int32_t& v : r.source) v = source[v];  // through the snaps before it
    source = std::move(r.source);
    shift = std::move(r.shift);
    inherited = std::move(r.inherited);
  }
  break_counts_.batches += 1;
  break_batch_sizes_.push_back((int64_t)(batch.size() + edges.size()));
  SeparationResult result;
  result.inherited = std::move(inherited);
  result.source = std::move(source);
  result.shift = std::move(shift);
  return result;
}

PetscErrorCode LiveScene::snap_due(State& main, const std::vector<State*>& others, const Rebind& rebind, bool* snapped) {
  PetscFunctionBeginUser;
  *snapped = false;
  if ((snap_strains_.empty() && tear_strains_.empty()) || main.frame == 0) PetscFunctionReturn(0);
  PetscCall(event_begin(&LogEvents::topology));
  std::vector<double> pos;
  PetscCall(scene_->body->local_positions(main.x, pos));
  PetscCheck(pos.size() == kept_.piece.mesh.coords.size(), PETSC_COMM_SELF, PETSC_ERR_PLIB,
             "the scene's local vertices are not its kept piece's");
  std::vector<int64_t> batch;
  std::vector<TrianglePair> edges;
  if (!snap_strains_.empty()) batch = segments_to_snap(comm_, kept_.piece, pos, snap_strains_, snapped_);
  if (!tear_strains_.empty()) edges = edges_to_tear(comm_, kept_.piece, pos, tear_strains_, kept_.vertex_body);
  *snapped = !batch.empty() || !edges.empty();
  if (*snapped) PetscCall(break_apart(batch, edges, pos, main, others, rebind, false));
  PetscCall(event_end(&LogEvents::topology));
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::break_apart(const std::vector<int64_t>& segments, const std::vector<TrianglePair>& edges,
                                      std::vector<double>& pos, State& main, const std::vector<State*>& others,
                                      const Rebind& rebind, bool by_blade) {
  PetscFunctionBeginUser;
  last_change_cut_ = false;
  last_change_break_ = true;
  last_break_by_blade_ = by_blade;
  bool corrected = false;  // its constant matrix followed by a TopologyH0 correction (else factored again)
  // With self-contact a torn edge opens (tear_opening_): the positions' part is carried in the state.
  const SeparationResult r = snap(main.frame, segments, edges, tear_opening_ > 0 ? &pos : nullptr);
  PetscCall(move_to_rebuilt(main, others, rebind, main.frame * spec_->time.dt, r.source, &corrected, r.shift,
                            r.inherited));
  if (corrected) {
    ++break_counts_.corrections;
  } else {
    if (last_change_factored_) ++break_counts_.refactorizations;
    factored_breaks_ = break_counts_.batches;  // the factor holds every cut so far too
    factored_batches_ = counts_.batches;
  }
  PetscFunctionReturn(0);
}

// A batch of the break history as its snapped segments and torn edges.
void LiveScene::split_breaks(const std::vector<Break>& batch, std::vector<int64_t>& segments,
                             std::vector<std::array<int64_t, 2>>& edges) {
  for (const Break& b : batch) {
    if (b[1] == 0)
      segments.push_back(b[2]);
    else
      edges.push_back(edge_of_element(b[2]));
  }
}

// A batch of a checkpoint's history on the kept pieces: a cut's faces (the opening's rest part; its
// positions are the checkpoint's) or a break batch.
void LiveScene::replay(const Replay& r) {
  if (r.breaks.empty()) {
    separate(r.frame, r.faces, {nullptr, opening_width_});
    return;
  }
  std::vector<int64_t> segments;
  std::vector<TrianglePair> edges;
  split_breaks(r.breaks, segments, edges);
  snap(r.frame, segments, edges);
}

PetscErrorCode LiveScene::restore_changes(const std::vector<SeparatedFace>& cuts, long long cuts_factored,
                                          const std::vector<int64_t>& cut_batches, const std::vector<Break>& breaks,
                                          long long breaks_factored, const std::vector<int64_t>& break_batches) {
  PetscFunctionBeginUser;
  if (cuts.empty() && breaks.empty()) PetscFunctionReturn(0);
  PetscCheck(cuts.empty() || !spec_->cuts.empty() || !fracture_.empty(), comm_, PETSC_ERR_ARG_WRONG,
             "the checkpoint has separated faces and the deck has neither cuts nor fracture");
  for (const Break& b : breaks) {
    PetscCheck(b[1] == 0 || b[1] == 1, comm_, PETSC_ERR_ARG_WRONG, "the checkpoint has a break of an unknown kind");
    PetscCheck(b[1] == 1 || !snap_strains_.empty() || cuts_strands_, comm_, PETSC_ERR_ARG_WRONG,
               "the checkpoint has snapped strands and the deck's strands neither snap nor are cut");
    PetscCheck(b[1] == 0 || !tear_strains_.empty() || cuts_cloth_, comm_, PETSC_ERR_ARG_WRONG,
               "the checkpoint has torn cloth and the deck's cloth neither tears nor is cut");
  }
  // Each history cut into its batches: by the sizes, within a frame (no sizes: a batch per frame).
  auto batches_of = [&](const auto& history, const std::vector<int64_t>& sizes, const char* what, const char* whole_of) {
    std::vector<std::pair<size_t, size_t>> ranges;
    int64_t total = 0;
    for (int64_t n : sizes) total += n;
    for (size_t i = 0; i < history.size();) {
      const size_t end = sizes.empty() ? history.size() : std::min(history.size(), i + (size_t)sizes[ranges.size()]);
      size_t j = i;
      while (j < end && history[j][0] == history[i][0]) ++j;
      ranges.push_back({i, j});
      i = j;
      if (!sizes.empty() && ranges.size() == sizes.size()) break;
    }
    const bool whole = sizes.empty() || (total == (int64_t)history.size() && ranges.size() == sizes.size() &&
                                         (ranges.empty() || ranges.back().second == history.size()));
    return std::make_pair(ranges, whole ? std::string()
                                        : std::string("the checkpoint's ") + what + " batches do not add up to its " + whole_of);
  };
  const auto [cut_ranges, cut_error] = batches_of(cuts, cut_batches, "cut", "separated faces");
  const auto [break_ranges, break_error] = batches_of(breaks, break_batches, "break", "breaks");
  PetscCheck(cut_error.empty() && break_error.empty(), comm_, PETSC_ERR_ARG_WRONG, "%s",
             (cut_error + break_error).c_str());
  PetscCall(event_begin(&LogEvents::topology));
  // The run's order: by frame, a frame's cut batches before its break batches.
  size_t c = 0, k = 0;
  while (c < cut_ranges.size() || k < break_ranges.size()) {
    const bool cut = k == break_ranges.size() ||
                     (c < cut_ranges.size() && cuts[cut_ranges[c].first][0] <= breaks[break_ranges[k].first][0]);
    Replay r;
    bool factored;
    if (cut) {
      for (size_t i = cut_ranges[c].first; i < cut_ranges[c].second; ++i) r.faces.push_back({cuts[i][1], cuts[i][2]});
      r.frame = cuts[cut_ranges[c].first][0];
      factored = cuts_factored < 0 || (long long)c < cuts_factored;
      ++c;
    } else {
      r.breaks.assign(breaks.begin() + break_ranges[k].first, breaks.begin() + break_ranges[k].second);
      r.frame = breaks[break_ranges[k].first][0];
      factored = breaks_factored < 0 || (long long)k < breaks_factored;
      ++k;
    }
    if (!factored) {
      replay_.push_back(std::move(r));
      continue;
    }
    replay(r);
    kept_changed_ = true;
  }
  factored_batches_ = cuts_factored < 0 ? (long long)c : std::min<long long>(cuts_factored, c);
  factored_breaks_ = breaks_factored < 0 ? (long long)k : std::min<long long>(breaks_factored, k);
  PetscCall(event_end(&LogEvents::topology));
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
