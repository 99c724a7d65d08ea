#include "app/deck_config.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>
#include <tuple>

#include "app/run_options.hpp"
#include "model/load_kinds.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn {

namespace {

// Values in YAML: the shortest decimal that reads back as the same double (so a value differs
// from the deck's only if the run's does), a word plain and any other text quoted.
std::string text_of(double x) {
  char s[40];
  if (x == std::floor(x) && std::fabs(x) < 1e15) {  // a whole number as one: 1000000, not 1e+06
    std::snprintf(s, sizeof s, "%.0f", x);
    return s;
  }
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(s, sizeof s, "%.*g", digits, x);
    if (std::strtod(s, nullptr) == x) break;
  }
  std::string t = s;  // 1e-06 -> 1e-6, 1e+20 -> 1e20
  if (const size_t e = t.find('e'); e != std::string::npos) {
    std::string exponent = t.substr(e + 1);
    const bool negative = exponent[0] == '-';
    exponent.erase(0, exponent.find_first_not_of("+-0"));
    t = t.substr(0, e + 1) + (negative ? "-" : "") + exponent;
  }
  return t;
}
std::string text_of(int x) { return std::to_string(x); }
std::string text_of(bool x) { return x ? "true" : "false"; }
std::string text_of(const std::string& x) {
  const bool plain = !x.empty() && (std::isalpha((unsigned char)x[0]) || x[0] == '/' || x[0] == '.' || x[0] == '_') &&
                     std::all_of(x.begin(), x.end(), [](char c) {
                       return std::isalnum((unsigned char)c) || std::string("_-./+").find(c) != std::string::npos;
                     }) &&
                     x != "true" && x != "false" && x != "null" && x != "yes" && x != "no";
  if (plain) return x;
  std::string q = "\"";
  for (char c : x) q += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return q + "\"";
}
template <typename T>
std::string list_text(const T& xs) {
  std::string s;
  for (const auto& x : xs) s += (s.empty() ? "" : ", ") + text_of(x);
  return "[" + s + "]";
}
template <typename T, size_t N>
std::string text_of(const std::array<T, N>& x) { return list_text(x); }
template <typename T>
std::string text_of(const std::vector<T>& x) { return list_text(x); }

bool listed(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

class Config {
 public:
  explicit Config(const Deck& deck) : deck_(deck) {}

  // One setting; a key the deck gives is marked shown, so the list of other keys leaves it out.
  void line(const std::string& key, const std::string& value, const std::string& source) {
    out_ << key << ": " << value << "  # " << source << "\n";
    shown_.insert(key);
  }
  // Where the value of key `path` came from, if not from `fallback`.
  std::string source(const std::string& path, const std::string& fallback = "default") const {
    if (const auto at = deck_.key_places.find(path); at != deck_.key_places.end())
      return "deck line " + std::to_string(at->second.line);
    if (const auto at = deck_.rule_sources.find(path); at != deck_.rule_sources.end()) return "rule: " + at->second;
    return fallback;
  }
  bool given(const std::string& path) const { return deck_.key_places.count(path) > 0; }
  const KeyPlace* place(const std::string& path) const {
    const auto at = deck_.key_places.find(path);
    return at == deck_.key_places.end() ? nullptr : &at->second;
  }

  // Every declared key of a section that applies (its model's, its type's; a nested map's if the
  // deck gives the map), with spec's value. rules: keys whose value another key implies (-> why);
  // skip: keys that do not apply for reasons the declarations do not say.
  template <typename Spec>
  void keys(const std::string& prefix, const std::vector<DeckKey<Spec>>& keys, const Spec& spec,
            const std::map<std::string, std::string>& rules = {}, const std::set<std::string>& skip = {}) {
    const auto declared = [&](const std::string& name) -> const DeckKey<Spec>* {
      for (const DeckKey<Spec>& k : keys)
        if (k.name == name) return &k;
      return nullptr;
    };
    for (const DeckKey<Spec>& k : keys) {
      const std::string name = k.name, path = prefix + name;
      if (k.any_name || skip.count(name)) continue;
      const size_t dot = name.rfind('.');
      const std::string map = dot == std::string::npos ? "" : name.substr(0, dot + 1);  // "box." or ""
      if (!map.empty() && !given(prefix + name.substr(0, dot))) continue;
      if (!k.only_for.empty()) {  // the selector is the key of that name in the same map
        const DeckKey<Spec>* selector = declared(map + k.selector);
        if (!selector) selector = declared(k.selector);
        if (!selector || !selector->get || !listed(k.only_for, selector->get(spec))) continue;
      }
      std::string value;
      bool has_value = true;
      std::visit(
          [&](const auto& field) {
            if constexpr (std::is_same_v<std::decay_t<decltype(field)>, std::monostate>) {
              if (k.get) {
                value = k.get(spec);
              } else if (const KeyPlace* p = place(path)) {  // a custom key: as written, if a leaf
                has_value = p->leaf;
                value = p->written;
              } else if (std::string(k.type_text) == "number" && *k.default_text && !k.required) {
                value = k.default_text;  // a custom number left out (a plastic map's hardening moduli)
              } else {  // a map, a part or a list the deck leaves out: nothing to list
                has_value = false;
              }
            } else {
              Spec copy = spec;
              value = text_of(field(copy));
            }
          },
          k.member.field);
      if (!has_value) continue;
      const auto rule = rules.find(name);
      // A key left out whose default is a word (none, never, auto) or a list: that, not its member's
      // stand-in (0, -1, 1e300 or [], which the key refuses or reads otherwise).
      const std::string text = k.default_text;
      std::string word;
      if (!text.empty() && text[0] == '[' && text.find(']') != std::string::npos) {
        word = text.substr(0, text.find(']') + 1);
      } else {
        const std::string w = text.substr(0, text.find_first_of(" :;,("));
        if (w == "none" || w == "never" || w == "auto") word = w;
      }
      // A default worked out as the scene is built (contact.distance, a laplacian_weight): its
      // member holds 0 until then, which the key refuses.
      if (word.empty() && value == "0" && !text.empty()) {
        char* end = nullptr;
        const double number = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || number != 0) word = "auto";  // "0 (never ...)" is the value itself
      }
      if (!given(path) && rule == rules.end() && !word.empty()) value = word;
      const std::string fallback = text.empty() || value == text || word == "none" ? "default" : "default (" + text + ")";
      line(path, value, rule != rules.end() && !given(path) ? "rule: " + rule->second : source(path, fallback));
    }
  }

  // A material: its pair of elastic constants the deck gives, the other from it; its mass.
  void material(const std::string& prefix, const MaterialSpec& m) {
    std::map<std::string, std::string> rules;
    std::set<std::string> skip{m.has_density ? "total_mass" : "density"};
    if (given(prefix + "youngs_modulus")) {
      rules["mu"] = rules["lambda"] = "from youngs_modulus and poisson_ratio";
    } else {
      skip.insert("youngs_modulus");
      skip.insert("poisson_ratio");
    }
    keys(prefix, material_keys(), m, rules, skip);
    if (m.fracture.given) keys(prefix + "fracture.", fracture_keys(), m.fracture);
  }

  void motion(const std::string& prefix, const Motion& m) {
    if (!m.active) return;
    // A curve replaces start and end (read_motion refuses them beside it).
    keys(prefix + "motion.", motion_keys(), m, {}, m.curve.given ? std::set<std::string>{"start", "end"} : std::set<std::string>{});
    curve(prefix + "motion.", m.curve);
  }
  // The curve a section gives as prefix + "curve" (params/curve.hpp), if it gives one.
  void curve(const std::string& prefix, const Curve& c) {
    if (c.given) keys(prefix + "curve.", curve_keys(), c);
  }

  // The deck's mesh and the materials of its parts (a scene's or a body's).
  void mesh_and_materials(const std::string& prefix, const MeshSpec& mesh, bool has_material,
                          const MaterialSpec& material, const ClothSpec& cloth, const StrandMaterial& strands) {
    keys(prefix + "mesh.", mesh_keys(), mesh, {}, given(prefix + "mesh.file") ? std::set<std::string>{} : std::set<std::string>{"file"});
    if (has_material) this->material(prefix + "material.", material);
    if (mesh.has_cloth()) keys(prefix + "cloth.", cloth_keys(), cloth);
    if (mesh.has_strands()) keys(prefix + "strand_material.", strand_material_keys(), strands);
  }

  // Every other key the deck gives (a leaf: not a map, nor a list of maps), as written, in the
  // deck's order.
  void others() {
    std::vector<std::pair<int, std::string>> rest;
    for (const auto& [key, p] : deck_.key_places)
      if (p.leaf && !shown_.count(key)) rest.push_back({p.line, key});
    std::sort(rest.begin(), rest.end());
    if (!rest.empty()) out_ << "# read by their sections' own readers, as written\n";
    for (const auto& [line, key] : rest) this->line(key, place(key)->written.empty() ? "null" : place(key)->written,
                                                    "deck line " + std::to_string(line));
  }

  std::string text() const { return out_.str(); }

 private:
  const Deck& deck_;
  std::ostringstream out_;
  std::set<std::string> shown_;
};

// Where an option's value came from: the deck's petsc: section (same value) or the command line.
std::string option_source(const Deck& deck, const std::string& name, const std::string& value) {
  if (const Deck::OptionPlace* place = deck_option_place(deck, name, value)) return "deck line " + std::to_string(place->line);
  return "command line";
}

}  // namespace

std::string effective_config(const Deck& deck, const RunOptions& options, const std::string& outdir) {
  Config c(deck);
  c.line("name", text_of(deck.name), c.source("name", "default (the deck file's name)"));
  if (!deck.bodies.empty()) {
    for (size_t k = 0; k < deck.bodies.size(); ++k) {
      const BodySpec& b = deck.bodies[k];
      const std::string prefix = "bodies[" + std::to_string(k) + "].";
      c.keys(prefix, body_keys(), b);
      c.mesh_and_materials(prefix, b.mesh, b.has_material, b.material, b.cloth, b.strand_material);
    }
    if (!deck.partition_file.empty()) c.line("partition", text_of(deck.partition_file), c.source("partition"));
  } else {
    c.mesh_and_materials("", deck.mesh, deck.has_material, deck.material, deck.cloth, deck.strand_material);
  }
  for (size_t k = 0; k < deck.regions.size(); ++k) {
    const std::string prefix = "regions[" + std::to_string(k) + "].";
    c.keys(prefix, region_keys(), deck.regions[k]);
    c.material(prefix + "material.", deck.regions[k].material);
  }
  if (c.given("initial")) c.keys("initial.", initial_keys(), deck.initial);
  // The scene's fixed regions and attachments (a body's are listed as the deck gives them).
  int fixed = 0, attached = 0;
  for (const BoxRegion& b : deck.fixed)
    if (b.body < 0) {
      const std::string prefix = "fixed[" + std::to_string(fixed++) + "].";
      c.keys(prefix, fixed_keys(), b);
      c.motion(prefix, b.motion);
    }
  for (const AttachmentSpec& a : deck.attachments)
    if (a.region.body < 0) {
      const std::string prefix = "attachments[" + std::to_string(attached++) + "].";
      c.keys(prefix, attachment_keys(), a);
      c.motion(prefix, a.region.motion);
    }
  for (size_t k = 0; k < deck.loads.size(); ++k) {
    const std::string prefix = "loads[" + std::to_string(k) + "].";
    // normal and angle choose among faces: a load on vertices refuses them (read_loads)
    const bool on_faces = find_load_kind(deck.loads[k].type)->target == LoadTarget::faces;
    c.keys(prefix, load_keys(), deck.loads[k], {}, on_faces ? std::set<std::string>{} : std::set<std::string>{"normal", "angle"});
    c.curve(prefix, deck.loads[k].curve);
  }
  for (size_t k = 0; k < deck.colliders.size(); ++k) {
    const std::string prefix = "colliders[" + std::to_string(k) + "].";
    c.keys(prefix, collider_keys(), deck.colliders[k]);
    c.motion(prefix, deck.colliders[k].motion);
  }
  for (size_t k = 0; k < deck.cuts.size(); ++k) {  // the rectangle's keys or the surface's, whichever it is
    const std::string prefix = "cuts[" + std::to_string(k) + "].";
    const CutSpec& cut = deck.cuts[k];
    c.keys(prefix, cut_keys(), cut, {},
           cut.surface.empty() ? std::set<std::string>{"surface", "surface_scale", "surface_offset"}
                               : std::set<std::string>{"center", "normal", "axis", "size"});
    c.motion(prefix, cut.motion);
  }
  if (!deck.colliders.empty() || deck.contact.self) c.keys("contact.", contact_keys(), deck.contact);
  c.keys("", gravity_keys(), static_cast<const SceneSpec&>(deck));
  c.keys("time.", time_keys(), deck.time);
  {
    // budget: fixed turns the fallback chain's stages off (use_fixed_budget).
    std::map<std::string, std::string> rules;
    if (const KeyPlace* p = c.place("solver.budget"); p && p->written == "fixed")
      for (const char* key : {"max_iterations", "max_halvings", "newton_fallback"}) rules[key] = "budget: fixed";
    // TAO's options, given, set these keys' values (the solvers set the deck's, then TAO reads its options).
    std::vector<std::pair<std::string, std::string>> overridden;  // key, option
    for (const auto& [key, option] : {std::pair<const char*, const char*>{"history", "-tao_lmvm_mat_lmvm_hist_size"},
                                      {"line_search", "-tao_ls_type"}, {"iterations", "-tao_max_it"},
                                      {"grad_atol", "-tao_gatol"}, {"grad_rtol", "-tao_grtol"}}) {
      PetscBool set = PETSC_FALSE;
      PetscOptionsHasName(nullptr, nullptr, option, &set);
      if (set) overridden.emplace_back(key, option);
    }
    std::set<std::string> skip;
    for (const auto& o : overridden) skip.insert(o.first);
    c.keys("solver.", solver_keys(), deck.solver, rules, skip);
    for (const auto& [key, option] : overridden) {
      char value[256] = "";
      PetscOptionsGetString(nullptr, nullptr, option.c_str(), value, sizeof value, nullptr);
      c.line("solver." + key, value, "option " + option + ", " + option_source(deck, option, value));
    }
  }
  {
    OutputSpec output = deck.output;
    output.directory = outdir;
    const bool from_deck = c.given("output.directory") && deck.output.directory == outdir;
    const bool default_dir = !c.given("output.directory") && outdir == "output/" + deck.name;
    c.keys("output.", output_keys(), output, {}, {"directory"});
    c.line("output.directory", text_of(outdir),
           from_deck ? c.source("output.directory") : default_dir ? "default (output/<name>)" : "command line");
  }
  c.keys("checkpoint.", checkpoint_keys(), deck.checkpoint);
  if (c.given("study")) c.keys("study.", study_keys(), deck.study);

  // hyperqn's own options (-hyperqn_*; the test hooks below, if given); the guardrails' limits
  // under their deck keys, from the deck or from their options.
  const std::vector<std::pair<std::string, std::string>> database = all_options();
  const auto find = [&](const std::string& name) {
    return std::find_if(database.begin(), database.end(), [&](const auto& o) { return o.first == name; });
  };
  std::set<std::string> seen;
  const auto option = [&](const char* name, const std::string& value) {
    const auto at = find(name);
    c.line(std::string("options.") + (name + 1), value, at == database.end() ? "default" : option_source(deck, name, at->second));
    seen.insert(name);
  };
  for (const auto& [key, name, value] : {std::tuple<std::string, std::string, double>{
           "divergence_limit", "-hyperqn_divergence_limit", options.divergence_limit},
       {"element_limit", "-hyperqn_element_limit", options.element_limit}}) {
    const auto at = find(name);
    const std::string path = "guardrails." + key;
    c.line(path, text_of(value), at == database.end() ? c.source(path) : option_source(deck, name, at->second));
    seen.insert(name);
  }
  option("-hyperqn_progress_seconds", text_of(double(options.progress_seconds)));
  option("-hyperqn_h0_package", factor_package_name(options.h0_package));
  // The PETSc options: the deck's (under their deck key), then those of the command line alone.
  const auto shown = [](const std::string& value) { return value.empty() ? std::string("\"\"") : text_of(value); };
  for (const auto& [name, place] : deck.petsc_option_places) {
    const auto at = find(name);
    const std::string value = at == database.end() ? "" : at->second;
    c.line(place.key, shown(value), option_source(deck, name, value));
    seen.insert(name);
  }
  for (const auto& [name, value] : database) {
    if (seen.count(name) || name == "-o" || name == "-restart" || name == "--restart") continue;  // -o: output.directory
    c.line("options." + name.substr(1), shown(value), "command line");
    seen.insert(name);
  }
  c.others();
  return c.text();
}

}  // namespace hyperqn
