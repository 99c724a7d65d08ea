// The deck's rules between sections: checks that a key makes sense given other sections, and the
// defaults that other sections change. The deck's top level (app/deck.cpp) calls each where its
// sections have been read.
#include "app/deck_rules.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "geometry/motion.hpp"

namespace hyperqn::deck_reading {

bool has_contact(const Deck& deck) { return !deck.colliders.empty() || deck.contact.self; }

void check_contact_has_surfaces(const Reader& r, const Value& contact, const Deck& deck) {
  const Section keys(r, contact, {});  // (kept: find points into it)
  const Value* self = keys.find("self");
  if (deck.colliders.empty() && !(self && r.boolean(*self)))
    r.fail(contact, "contact describes how the body touches colliders, and there are none (or self-contact: self: true)");
}

void check_thickness_in_self_contact(const Reader& r, const Deck& deck) {
  if (deck.contact.self) return;
  std::vector<std::pair<std::string, const ClothSpec*>> cloths{{"cloth", &deck.cloth}};
  for (size_t k = 0; k < deck.bodies.size(); ++k)
    cloths.push_back({"bodies[" + std::to_string(k) + "].cloth", &deck.bodies[k].cloth});
  for (const auto& [key, cloth] : cloths)
    if (cloth->thickness_line > 0)
      r.fail(cloth->thickness_line, key + ".thickness",
             "a cloth's thickness acts in self-contact only, and the deck has none: leave thickness out, or turn "
             "self-contact on (contact: {self: true})");
}

void check_face_tags_have_a_file(const Reader& r, const Deck& deck) {
  const std::vector<SceneSpec::NamedFaceTag> named = deck.named_face_tags();
  if (named.empty()) return;
  const std::string& key = named[0].key;
  const int line = named[0].line;
  const MeshSpec& m = deck.mesh;
  const std::string ext = m.file.size() >= 4 ? m.file.substr(m.file.size() - 4) : "";
  std::string why;
  if (!deck.bodies.empty())
    why = "face tags are those of one mesh file (mesh.file), and a scene of bodies has several: select by box";
  else if (m.is_box || m.is_sheet)
    why = std::string("the mesh is generated (mesh.") + (m.is_box ? "box" : "sheet") + "): it has no tagged faces; select by box";
  else if (m.has_cloth())
    why = "the mesh is a cloth surface: face_tag selects boundary faces of tetrahedra (a .mesh or .msh file of tets)";
  else if (m.is_partition_file)
    why = "a partition file keeps no face tags: give the .mesh or .msh file as mesh.file";
  else if (ext != "mesh" && ext != ".msh")
    why = "face tags are read from a Medit .mesh or Gmsh .msh file";
  if (!why.empty()) r.fail(line, key, why);
}

void check_integrator_takes_contact(const Reader& r, const Value& time, const Deck& deck) {
  const IntegratorInfo& integrator = integrator_info(deck.time.integrator);
  if (!integrator.with_colliders && has_contact(deck))
    r.fail(*Section(r, time, {}).find("integrator"),
           std::string(integrator.name) + " does not take colliders or self-contact yet: its end-of-step map can carry "
           "vertices through an obstacle or a surface that the solve's z rests on (use implicit-euler)");
}

void check_energy_output(const Reader& r, const Value& output, const Deck& deck) {
  if (deck.output.energy && has_contact(deck))
    r.fail(*Section(r, output, {}).find("energy"),
           "energy.csv does not count the work of colliders or self-contact yet (leave out output.energy)");
}

// Element fields are arrays of the frames: with output.vtk false there are none to hold them.
void check_fields_have_frames(const Reader& r, const Value& output, const Deck& deck) {
  if (!deck.output.fields.empty() && !deck.output.vtk)
    r.fail(*Section(r, output, {}).find("fields"),
           "are written into the frames, and output.vtk is false: no frame is written (leave out fields, or vtk)");
  const Section keys(r, output, {});
  if (const Value* x = keys.find("field_precision"); x && deck.output.fields.empty())
    r.fail(*x, "is the precision of output.fields, and the deck asks for none (leave it out, or give fields)");
}

// A blade separates tets along their faces, a cloth along its edges (docs/snapping.md#a-blade-through-a-cloth)
// and strands at the segments it crosses (docs/snapping.md#a-blade-through-strands): a mesh of tets
// may have strands, not a cloth too; a blade removes tets only.
void check_cuts(const Reader& r, const Value& cuts, const Deck& deck) {
  std::vector<const MeshSpec*> meshes;
  if (deck.bodies.empty()) meshes.push_back(&deck.mesh);
  for (const BodySpec& b : deck.bodies) meshes.push_back(&b.mesh);
  bool cuttable = false, cloth = false, strands = false;
  for (const MeshSpec* m : meshes) {
    if (m->has_solid() && m->has_cloth())
      r.fail(cuts, "a blade cuts a mesh of tets or a cloth, not one mesh with both (docs/topology.md)");
    cuttable = cuttable || m->has_solid() || m->has_cloth() || m->has_strands();
    cloth = cloth || m->has_cloth();
    strands = strands || m->has_strands();
  }
  if (!cuttable)
    r.fail(cuts, "a cut separates tets along their faces, a cloth along its edges or strands at their segments, and the "
                 "mesh has none of them");
  for (size_t k = 0; (cloth || strands) && k < deck.cuts.size(); ++k)
    if (deck.cuts[k].remove)
      r.fail(deck.cuts[k].line, "cuts[" + std::to_string(k) + "].remove",
             std::string("a blade removes tets, and the deck has ") + (cloth ? "a cloth, whose triangles" : "strands, whose segments") +
                 " it does not remove: leave out remove");
  // A turning blade's sweep is sampled every degree of its turn in a step (geometry/blade.hpp): past
  // a whole turn a step it sweeps its full circle whatever the rate, in millions of samples.
  const std::vector<Value> items = r.items(cuts);
  for (size_t k = 0; k < deck.cuts.size() && k < items.size(); ++k) {
    const Motion& m = deck.cuts[k].motion;
    if (!m.active || m.rate_deg == 0) continue;
    const double h = deck.time.dt, rate = std::fabs(m.rate_deg);
    double most = rate * std::min(h, m.end - m.start);  // degrees in one step
    if (m.curve.given) {
      most = 0;
      for (int f = 0; f < deck.time.frames && most <= 360; ++f)
        most = std::max(most, rate * std::fabs(motion_progress(m, (f + 1) * h) - motion_progress(m, f * h)));
    }
    if (most <= 360) continue;
    int line = deck.cuts[k].line;  // the rate's own line (its Sections alive while read)
    const Section cut(r, items[k], {});
    if (const Value* motion = cut.find("motion")) {
      const Section moves(r, *motion, {});
      if (const Value* rotate = moves.find("rotate")) {
        const Section turn(r, *rotate, {});
        if (const Value* rate = turn.find("rate")) line = rate->line;
      }
    }
    char degrees[32];
    std::snprintf(degrees, sizeof degrees, "%.4g", most);
    r.fail(line, "cuts[" + std::to_string(k) + "].motion.rotate.rate",
           std::string("the blade turns up to ") + degrees + " degrees in one step of time.dt; at most 360 (a whole turn a "
           "step sweeps the blade's full circle): a smaller rate or time.dt");
  }
}

// Materials with fracture (material.fracture, docs/topology.md#fracture): their faces separate as
// cuts' do (with self-contact they open as a cut's crack does), so the same scenes are refused.
void check_fracture(const Reader& r, const Deck& deck) {
  std::vector<std::pair<const MaterialSpec*, std::string>> materials;
  if (deck.bodies.empty()) materials.push_back({&deck.material, "material.fracture"});
  for (size_t k = 0; k < deck.regions.size(); ++k)
    materials.push_back({&deck.regions[k].material, "regions[" + std::to_string(k) + "].material.fracture"});
  for (size_t k = 0; k < deck.bodies.size(); ++k)
    materials.push_back({&deck.bodies[k].material, "bodies[" + std::to_string(k) + "].material.fracture"});
  for (const auto& [m, key] : materials) {
    if (!m->fracture.given) continue;
    bool others = deck.bodies.empty() && (deck.mesh.has_strands() || deck.mesh.has_cloth());
    for (const BodySpec& b : deck.bodies) others = others || b.mesh.has_strands() || b.mesh.has_cloth();
    if (others)
      r.fail(m->fracture.line, key, "fracture acts on meshes of tets alone for now: the deck also has strands or a cloth "
                                    "(docs/topology.md#fracture)");
  }
}

void check_static_has_support(const Reader& r, const Value& time, const Deck& deck) {
  if (deck.time.integrator != TimeIntegrator::quasi_static) return;
  for (size_t k = 0; k < deck.bodies.size(); ++k) {
    const BodySpec& b = deck.bodies[k];
    const std::string key = "bodies[" + std::to_string(k) + "]";
    if (b.velocity_line)
      r.fail(b.velocity_line, key + ".velocity", "integrator: static has no velocities (each frame is an equilibrium): "
                                                 "leave velocity out");
    // Held by a region of its own or of any body, or resting on a collider or on another body.
    bool held = has_contact(deck);
    for (const BoxRegion& f : deck.fixed) held = held || f.body == (int)k || f.body < 0;
    for (const AttachmentSpec& a : deck.attachments) held = held || a.region.body == (int)k || a.region.body < 0;
    if (!held)
      r.fail(b.line, key, "static finds an equilibrium, and nothing holds body " + b.name + ": give it a fixed region or "
                          "an attachment (" + key + ".fixed, .attachments), or a collider or contact: {self: true, model: "
                          "barrier} to rest on (penalty self-contact, the default model, cannot hold a body in a "
                          "static step)");
  }
  if (!deck.fixed.empty() || !deck.attachments.empty() || !deck.colliders.empty()) return;
  r.fail(*Section(r, time, {}).find("integrator"),
         "static finds an equilibrium, and nothing holds the body: add a fixed region (fixed:), an attachment "
         "(attachments:) or a collider (colliders:)");
}

void check_study_integrators_take_contact(const Reader& r, const Value& study, const Deck& deck) {
  for (TimeIntegrator kind : deck.study.integrators) {
    if (kind == TimeIntegrator::quasi_static && deck.fixed.empty() && deck.attachments.empty() && deck.colliders.empty())
      r.fail(*Section(r, study, {}).find("integrators"),
             "static finds an equilibrium, and nothing holds the body (see time.integrator)");
    if (kind == TimeIntegrator::quasi_static && deck.time.damping > 0)
      r.fail(*Section(r, study, {}).find("integrators"),
             "static has no velocities to damp, and time.damping is given (see time.integrator)");
    if (!integrator_info(kind).with_colliders && has_contact(deck))
      r.fail(*Section(r, study, {}).find("integrators"),
             std::string(integrator_info(kind).name) + " does not take colliders yet (see time.integrator)");
  }
}

void apply_contact_solver_defaults(const Reader& r, const Value* solver, Deck& deck) {
  if (!has_contact(deck)) return;
  for (const RuleDefault& rule : kContactSolverDefaults) {
    if (solver && Section(r, *solver, {}).find(rule.key)) continue;
    const std::string key = std::string("solver.") + rule.key;
    const auto& keys = solver_keys();
    const auto declared = std::find_if(keys.begin(), keys.end(), [&](const DeckKey<SolverSpec>& k) { return k.name == std::string(rule.key); });
    read_value(r, *declared, Value{YAML::Node(rule.value), key, 0}, deck.solver);
    deck.rule_sources[key] = kContactRule;
  }
}

void apply_roller_solver_rules(const Reader& r, const Value* solver, Deck& deck) {
  const auto roller = std::find_if(deck.fixed.begin(), deck.fixed.end(), is_roller);
  if (roller == deck.fixed.end()) return;
  const std::string where = "the fixed region with components at line " + std::to_string(roller->components_line);
  if (deck.solver.h0 == H0::amg)
    r.fail(*Section(r, *solver, {}).find("h0"),
           "amg is one V-cycle of M + h^2 L for x, y and z alike, and " + where +
               " holds some components only: use laplacian or rest-stiffness (factored, with the held rows the identity's)");
  if (deck.solver.h0 == H0::automatic) {
    deck.solver.h0 = H0::laplacian;
    deck.rule_sources["solver.h0"] = "rollers (fixed: components)";
  }
}

}  // namespace hyperqn::deck_reading
