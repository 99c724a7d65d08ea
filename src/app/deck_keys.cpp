// Every deck section declared with params/deck_keys.hpp, in the deck's order: what `hyperqn
// --help-deck` prints, `hyperqn registry` exports and scripts/deck_tables.py turns into
// the tables of docs/deck-scene.md and docs/deck-run.md.
#include "app/deck.hpp"
#include "materials/material_factory.hpp"
#include "model/load_kinds.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn {

namespace {

// A key of the registry as a deck key of the models that take it.
DeckKey<MaterialSpec> material_key(const MaterialKey& key) {
  using M = MaterialSpec;
  std::vector<std::string> owners;
  for (const MaterialModel& model : material_models())
    for (const MaterialKey& k : model_keys(model))
      if (std::string(k.name) == key.name) owners.push_back(model.name);
  KeyMember<M> member;
  std::visit([&](auto m) { if constexpr (!std::is_same_v<decltype(m), std::monostate>) member = m; }, key.member);
  DeckKey<M> k{key.name, member, key.doc, key.range};
  k.default_text = key.default_text;
  k.type_text = key.type;
  k.required = key.required;
  // A map's keys are its map's (only_with is the map's); a key of every model is not a choice's.
  if (std::string(key.name).find('.') == std::string::npos && owners.size() < material_models().size())
    k = only_with(k, "model", owners, key.required);
  return k;
}

}  // namespace

const std::vector<DeckKey<MaterialSpec>>& material_keys() {
  using M = MaterialSpec;
  static const std::vector<DeckKey<M>> keys = [] {
    std::vector<std::string> models;
    for (const MaterialModel& m : material_models()) models.push_back(m.name);
    std::vector<DeckKey<M>> k = {
        {"model", std::monostate{}, "hyperelastic energy (formulas and L weights: [materials.md](materials.md))", {},
         models, "", "", [](M& m, const std::string& name) { m.model = name; },
         [](const M& m) { return m.model; }}};
    // The registry's keys, each once: the elastic constants, each model's own, the fibre term, the
    // inelastic blocks.
    std::vector<MaterialKey> registry = elastic_constant_keys();
    for (const MaterialModel& m : material_models()) registry.insert(registry.end(), m.keys.begin(), m.keys.end());
    registry.insert(registry.end(), fiber_keys().begin(), fiber_keys().end());
    for (const InelasticKind& kind : inelastic_kinds()) registry.insert(registry.end(), kind.keys.begin(), kind.keys.end());
    for (const MaterialKey& key : registry) k.push_back(material_key(key));
    const std::vector<DeckKey<M>> every = {
        {"density", &M::density, "mass per unit rest volume; give it or `total_mass`", above(0), {}, "", "—"},
        {"total_mass", &M::total_mass, "mass of the whole body, spread evenly over its rest volume", above(0), {},
         "", "—"},
        {"laplacian_weight", &M::laplacian_weight,
         "overrides the weight of the constant matrix L. Omit this key to use the material's own weight. For "
         "`mass-spring` it is the k of each spring in L (own: `spring_stiffness`).",
         above(0, "omit the key for the material's own weight"), {}, "", "the material's own"},
    };
    k.insert(k.end(), every.begin(), every.end());
    return k;
  }();
  return keys;
}

const std::vector<DeckKey<StudySpec>>& study_keys() {
  using S = StudySpec;
  static const std::vector<DeckKey<S>> keys = {
      // (the range depends on time.frames: read_study checks it)
      {"frames", &S::frames, "frames at which every solver starts from the same state, each in [1, `time.frames`] and once"},
      {"solvers", &S::solvers, "the solvers compared, each once", {}, solver_names(), "",
       "every solver (`hyperqn registry`)"},
      {"iterations", &S::iterations, "iteration cap per solver and frame in the per-frame comparison", between(1, 1e6)},
      {"time_limit", &S::time_limit, "per solver and frame", above(0), {}, "s"},
      {"reference_rtol", &S::reference_rtol,
       "the reference Newton (exact Hessian) stops at ‖∇g‖ ≤ reference_rtol·‖∇g(x₀)‖", {0, 1, true, true}},
      {"trajectory", &S::trajectory, "also run every solver over all frames against the converged trajectory"},
      custom_key<S>("trajectory_iterations", "map solver → integer ≥ 1",
                    "per-frame budget of each solver in the trajectory mode (solvers among `study.solvers`)", "`solver.iterations`"),
      custom_key<S>("integrators", "list of `time.integrator` names, each once",
                    "the integrator axis: the whole study once per integrator (its own factor and converged "
                    "reference), into `OUTDIR/<integrator>/`; the report script takes `OUTDIR` for all of them. Not "
                    "`implicit-midpoint` with `colliders`",
                    "(none: `time.integrator` alone)"),
  };
  return keys;
}

std::vector<KeyInfo> declared_deck_keys() {
  std::vector<KeyInfo> all;
  for (const std::vector<KeyInfo>& section :
       {key_infos("mesh", mesh_keys()), key_infos("bodies", body_keys()),
       key_infos("strand_material", strand_material_keys()), key_infos("cloth", cloth_keys()),
       key_infos("material", material_keys()), key_infos("fracture", fracture_keys()),
       key_infos("fixed", fixed_keys()), key_infos("motion", motion_keys()),
       key_infos("curve", curve_keys()),
       key_infos("attachments", attachment_keys()), key_infos("loads", load_keys()),
       key_infos("colliders", collider_keys()), key_infos("cuts", cut_keys()),
       key_infos("contact", contact_keys()), key_infos("regions", region_keys()),
       key_infos("initial", initial_keys()), key_infos("gravity", gravity_keys()), key_infos("time", time_keys()),
       key_infos("solver", solver_keys()), key_infos("guardrails", guardrail_keys()),
       key_infos("output", output_keys()),
       key_infos("checkpoint", checkpoint_keys()), key_infos("study", study_keys()),
       key_infos("petsc", petsc_keys())})
    all.insert(all.end(), section.begin(), section.end());
  return all;
}

}  // namespace hyperqn
