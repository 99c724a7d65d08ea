#include "model/load_kinds.hpp"

#include <algorithm>

namespace hyperqn {

// Each kind's file (src/terms/<kind>.cpp) defines one of these.
LoadKind traction_kind();
LoadKind pressure_kind();
LoadKind nodal_force_kind();
LoadKind body_force_kind();

const std::vector<LoadKind>& load_kinds() {
  static const std::vector<LoadKind> kinds = {traction_kind(), pressure_kind(), nodal_force_kind(), body_force_kind()};
  return kinds;
}

const LoadKind* find_load_kind(const std::string& type) {
  for (const LoadKind& k : load_kinds())
    if (type == k.type) return &k;
  return nullptr;
}

const std::vector<DeckKey<LoadSpec>>& load_keys() {
  using L = LoadSpec;
  static const std::vector<DeckKey<L>> keys = [] {
    std::vector<std::string> types;
    for (const LoadKind& k : load_kinds()) types.push_back(k.type);
    DeckKey<L> type{"type", std::monostate{}, "the kind of load (each kind's keys follow)"};
    type.choices = types;
    type.set = [](L& s, const std::string& word) { s.type = word; };
    type.get = [](const L& s) { return s.type; };
    std::vector<DeckKey<L>> k = {needed(type),
                                 map_key<L>("box", "the region: the boundary faces (or, for `force` and `body_force`, the "
                                                   "free vertices) in this axis-aligned box, inclusive (or give `face_tag`)",
                                            "none"),
                                 needed(DeckKey<L>{"box.min", &L::min, "the corner of least coordinates"}),
                                 needed(DeckKey<L>{"box.max", &L::max, "the opposite corner: `min` ≤ `max` on every axis"}),
                                 custom_key<L>("face_tag", "integer",
                                               "or the boundary faces (the free vertices) of the mesh file's triangles "
                                               "of this tag (a Medit reference, a Gmsh physical group; "
                                               "[loads.md](loads.md#face-tags)); with `box`, those in the box",
                                               "none"),
                                 {"normal", &L::normal,
                                  "faces only: those whose rest outward normal is within `angle` of this direction "
                                  "(none: every face in the box)", nonzero_vector(), {}, "", "none"},
                                 {"angle", &L::angle, "the cone of `normal`, degrees", between(0, 180)},
                                 curve_key<L>("the load's value in time: its value times c(t), at the time a step solves for",
                                              "none (constant)")};
    for (const LoadKind& kind : load_kinds())
      for (const DeckKey<L>& own : kind.keys) k.push_back(only_with(own, "type", {kind.type}, true));
    return k;
  }();
  return keys;
}

std::vector<std::unique_ptr<EnergyTerm>> load_terms(const DistributedMesh& mesh, const std::vector<LoadSpec>& loads) {
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  for (size_t k = 0; k < loads.size(); ++k) {
    const LoadKind& kind = *find_load_kind(loads[k].type);
    terms.push_back(kind.build(mesh, loads[k], (int)k, select_load_region(mesh, loads[k], kind.target)));
  }
  return terms;
}

}  // namespace hyperqn
