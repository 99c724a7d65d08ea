// Deck parsing and validation with yaml-cpp. Every problem becomes an InputError naming the
// deck file, the line and the dotted key, so a user can fix a deck without reading this code.
#include "app/deck.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <charconv>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <type_traits>
#include <variant>
#include <fstream>

#include "io/partition_file.hpp"
#include "mesh/input_error.hpp"
#include "materials/material_factory.hpp"
#include "model/material_params.hpp"
#include "solvers/solver_registry.hpp"
#include "materials/material.hpp"

namespace hyperqn {
namespace {

namespace fs = std::filesystem;
using Names = std::vector<std::string>;

// Solver names come from their registry (solvers/solver_registry.hpp).
const Names kSolverTypes = solver_names();
// Bounds that keep a deck from exhausting the machine or the floating-point range (each number's:
// number_limits_problem, params/key_range.hpp).
constexpr int kMaxIterations = 1000000;   // per frame
constexpr double kMaxBoxTets = 2147483647;  // the generator indexes tets and vertices with int32
constexpr int kContactHistory = 20;         // solver.history's default with colliders
constexpr std::uintmax_t kMaxDeckBytes = 10 << 20;
constexpr size_t kMaxNameLength = 100;
// A generated box's or sheet's cells: the shortest side (size / cells) at least this fraction of
// the longest. An element's stiffness across a side grows as 1 / side^2: past (1e8)^2 = 1e16 the
// rest of M + h^2 L is lost to round-off and its factorization fails (measured: box cells of
// 1.5e-8 do; 1e-6 leaves a margin).
constexpr double kFlattestCell = 1e-6;


std::string join(const Names& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

bool listed(const Names& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

int line_of(const YAML::Node& n) { return n.Mark().line >= 0 ? n.Mark().line + 1 : 0; }

// What a node holds, for "expected X, got Y" messages.
std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null: return "an empty value";
    case YAML::NodeType::Scalar:
      // yaml-cpp tags quoted scalars "!": say so, since "1.0" in quotes is text, not a number.
      return n.Tag() == "!" ? "the quoted string \"" + n.Scalar() + "\"" : "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list of " + std::to_string(n.size()) + " items";
    case YAML::NodeType::Map: return "a map";
    default: return "nothing";
  }
}

// A YAML value with its dotted key and the line to report. Map entries report the key's line:
// an empty value or a block map has no useful line of its own.
struct Value {
  YAML::Node node;
  std::string key;
  int line = 0;
};

// Typed reading of values; every failure throws InputError for this deck file.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(int line, const std::string& key, const std::string& msg) const {
    throw InputError(file_, line, key, msg);
  }
  [[noreturn]] void fail(const Value& v, const std::string& msg) const { fail(v.line, v.key, msg); }
  // Range checks: rule reads after "must be", e.g. "> 0".
  void check(bool ok, const Value& v, const std::string& rule) const {
    if (!ok) fail(v, "must be " + rule + ", got " + written(v.node));
  }
  // A value as the deck wrote it: a scalar, or a list as [a, b, c].
  static std::string written(const YAML::Node& n) {
    if (!n.IsSequence()) return n.Scalar();
    std::string s;
    for (const YAML::Node& item : n) s += (s.empty() ? "" : ", ") + (item.IsScalar() ? item.Scalar() : describe(item));
    return "[" + s + "]";
  }

  double number(const Value& v) const {
    double x = 0;
    if (!plain_scalar(v.node) || !YAML::convert<double>::decode(v.node, x) || !std::isfinite(x))
      fail(v, "expected a number, got " + describe(v.node));
    if (const std::string rule = number_limits_problem(x); !rule.empty()) fail(v, "must be " + rule + ", got " + v.node.Scalar());
    return x;
  }
  // Decimal only: yaml-cpp's own conversion would read "010" as octal 8.
  int integer(const Value& v) const {
    std::string s = plain_scalar(v.node) ? v.node.Scalar() : "";
    if (!s.empty() && s[0] == '+') s.erase(0, 1);
    int x = 0;
    auto [end, err] = std::from_chars(s.data(), s.data() + s.size(), x);
    if (s.empty() || err != std::errc() || end != s.data() + s.size())
      fail(v, "expected an integer, got " + describe(v.node));
    return x;
  }
  bool boolean(const Value& v) const {
    bool b = false;
    if (!plain_scalar(v.node) || !YAML::convert<bool>::decode(v.node, b))
      fail(v, "expected true or false, got " + describe(v.node));
    return b;
  }
  std::string text(const Value& v) const {
    if (!v.node.IsScalar()) fail(v, "expected a string, got " + describe(v.node));
    return v.node.Scalar();
  }
  std::string choice(const Value& v, const Names& allowed) const {
    std::string s = text(v);
    for (const auto& a : allowed)
      if (s == a) return s;
    fail(v, "unknown value '" + s + "'; allowed: " + join(allowed));
  }

  // The items of a list (an empty value is an empty list), each keyed "key[i]".
  std::vector<Value> items(const Value& v) const {
    if (v.node.IsNull()) return {};
    if (!v.node.IsSequence()) fail(v, "expected a list, got " + describe(v.node));
    std::vector<Value> out;
    for (std::size_t i = 0; i < v.node.size(); ++i) {
      YAML::Node n = v.node[i];
      out.push_back({n, v.key + "[" + std::to_string(i) + "]", n.IsNull() ? v.line : line_of(n)});
      untagged(n, out.back().line, out.back().key);
    }
    return out;
  }
  std::vector<Value> fixed_list(const Value& v, size_t n, const char* what) const {
    if (!v.node.IsSequence() || v.node.size() != n)
      fail(v, "expected a list of " + std::to_string(n) + " " + what + ", got " + describe(v.node));
    return items(v);
  }
  template <size_t N>
  std::array<double, N> numbers(const Value& v) const {
    std::array<double, N> out;
    auto it = fixed_list(v, N, "numbers");
    for (size_t i = 0; i < N; ++i) out[i] = number(it[i]);
    return out;
  }
  template <size_t N>
  std::array<int, N> integers(const Value& v) const {
    std::array<int, N> out;
    auto it = fixed_list(v, N, "integers");
    for (size_t i = 0; i < N; ++i) out[i] = integer(it[i]);
    return out;
  }
  std::array<double, 3> numbers3(const Value& v) const { return numbers<3>(v); }

  // An explicit tag (!!str, !!float, !foo, ...) would make yaml-cpp and the Python tools read a
  // value differently: refused wherever it is. Untagged nodes carry "?" (plain), "!" (quoted) or
  // "" (empty).
  void untagged(const YAML::Node& n, int line, const std::string& key) const {
    const std::string& tag = n.Tag();
    if (tag == "?" || tag == "!" || tag.empty()) return;
    const std::string core = "tag:yaml.org,2002:";
    const std::string shown = tag.compare(0, core.size(), core) == 0 ? "!!" + tag.substr(core.size()) : tag;
    fail(line, key, "YAML tags are not accepted, found " + shown + " (write the value alone; quote a string)");
  }

 private:
  static bool plain_scalar(const YAML::Node& n) { return n.IsScalar() && n.Tag() != "!"; }
  std::string file_;
};

// One YAML map of the deck. Construction rejects non-maps, unknown and duplicate keys
// (yaml-cpp would silently keep the first of two equal keys); an empty value is an empty map.
class Section {
 public:
  // allowed: the keys accepted here; empty means any key (the petsc section). shown: the keys an
  // unknown key's message lists, if not all of them (those of the collider type given).
  Section(const Reader& r, const Value& v, const Names& allowed, const Names& shown = {}) : r_(r), value_(v) {
    r.untagged(v.node, v.line, v.key);
    if (v.node.IsNull()) return;
    if (!v.node.IsMap()) r.fail(v, "expected a map of 'key: value' entries, got " + describe(v.node));
    for (auto it = v.node.begin(); it != v.node.end(); ++it) {
      if (!it->first.IsScalar()) r.fail(line_of(it->first), v.key, "keys must be plain names");
      std::string name = it->first.Scalar();
      Value entry{it->second, path(name), line_of(it->first)};
      r.untagged(it->first, entry.line, entry.key);
      r.untagged(it->second, entry.line, entry.key);
      if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), name) == allowed.end())
        r.fail(entry, "unknown key '" + name + "'" + (v.key.empty() ? "" : " in " + v.key) +
                          "; allowed: " + join(shown.empty() ? allowed : shown));
      if (find(name)) r.fail(entry, "duplicate key '" + name + "'");
      entries_.push_back({name, entry});
    }
  }

  const Value* find(const std::string& name) const {
    for (const auto& [n, v] : entries_)
      if (n == name) return &v;
    return nullptr;
  }
  const Value& need(const std::string& name) const {
    if (const Value* v = find(name)) return *v;
    r_.fail(value_.line, path(name), "missing required key '" + name + "'" +
                                         (value_.key.empty() ? "" : " in " + value_.key));
  }
  const std::vector<std::pair<std::string, Value>>& entries() const { return entries_; }
  const Value& value() const { return value_; }
  std::string path(const std::string& name) const {
    return value_.key.empty() ? name : value_.key + "." + name;
  }

 private:
  const Reader& r_;
  Value value_;
  std::vector<std::pair<std::string, Value>> entries_;
};

template <typename T>
struct is_array : std::false_type {};
template <typename T, size_t N>
struct is_array<std::array<T, N>> : std::true_type {};

// Reads x, the value of declared key k, into spec, with its type, range and choice checks.
template <typename Spec>
void read_value(const Reader& r, const DeckKey<Spec>& k, const Value& x, Spec& spec) {
  // One value (a list's item) of type T.
  const auto one = [&](auto type, const Value& item) {
    using T = decltype(type);
    if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int>) {
      const T value = std::is_same_v<T, double> ? T(r.number(item)) : T(r.integer(item));
      if (!k.range.rule().empty()) r.check(k.range.contains(value), item, k.range.rule());
      return value;
    } else if constexpr (std::is_same_v<T, bool>) {
      return r.boolean(item);
    } else if constexpr (is_array<T>::value) {  // a vec3, 2 numbers, 2 or 3 integers
      constexpr size_t N = std::tuple_size_v<T>;
      T value;
      if constexpr (std::is_same_v<typename T::value_type, double>) value = r.numbers<N>(item);
      else value = r.integers<N>(item);
      if constexpr (std::is_same_v<T, Array3>)
        if (k.range.nonzero) r.check(is_nonzero(value), item, k.range.rule());
      if (!k.range.nonzero && !k.range.rule().empty()) {
        const std::vector<Value> items = r.items(item);
        for (size_t i = 0; i < N; ++i) r.check(k.range.contains(value[i]), items[i], k.range.rule());
      }
      return value;
    } else {
      return k.choices.empty() ? r.text(item) : r.choice(item, k.choices);
    }
  };
  std::visit(
      [&](const auto& field) {
        using F = std::decay_t<decltype(field)>;
        if constexpr (std::is_same_v<F, std::monostate>) {
          if (k.set) k.set(spec, r.choice(x, k.choices));
        } else {
          using T = std::decay_t<decltype(field(spec))>;
          if constexpr (std::is_same_v<T, std::vector<int>> || std::is_same_v<T, std::vector<std::string>>) {
            T list;
            for (const Value& item : r.items(x)) list.push_back(one(typename T::value_type(), item));
            r.check(!list.empty(), x, std::string("a non-empty ") + type_name(list));
            field(spec) = list;
          } else {
            field(spec) = one(T(), x);
          }
        }
      },
      k.member.field);
}

// Reads a section of declared keys (params/deck_keys.hpp) into spec, in their declared order, with
// the same messages as every other key: a wrong type, a value out of its range ("must be <rule>,
// got X"), an unknown choice, an unknown key, an empty list, a key of another model or type. A
// nested map's keys ("box.min") are read from its map, as a section of their own. `more`: keys the
// section also allows; they and the declared keys without member or `set` are read by the caller.
// Returns the section, for those and for checks that involve several keys.
template <typename Spec>
Section read_keys(const Reader& r, const Value& v, const std::vector<DeckKey<Spec>>& keys, Spec& spec,
                  const Names& more = {}) {
  const auto in_map = [](const std::string& key, const std::string& map) {
    return key.size() > map.size() && key.compare(0, map.size(), map) == 0 && key[map.size()] == '.';
  };
  const auto declared = [&](const std::string& name) -> const DeckKey<Spec>& {
    return *std::find_if(keys.begin(), keys.end(), [&](const DeckKey<Spec>& k) { return k.name == name; });
  };
  // The word of choice key `name` as read so far (its default if the deck leaves it out).
  const auto word = [&](const std::string& name) { return declared(name).get(spec); };
  // The choice keys that other keys belong to (only_with) are read first: the unknown-key message
  // then lists the keys of the choice given.
  Names chosen;
  for (const DeckKey<Spec>& k : keys) {
    if (!*k.selector || listed(chosen, k.selector)) continue;
    chosen.push_back(k.selector);
    const DeckKey<Spec>& choice = declared(k.selector);
    const Section probe(r, v, {});
    if (const Value* x = choice.required ? &probe.need(choice.name) : probe.find(choice.name))
      choice.set(spec, r.choice(*x, choice.choices));
  }
  Names names, shown;  // this map's own keys (a nested key is its map's), and those of its choices
  for (const DeckKey<Spec>& k : keys) {
    if (std::string(k.name).find('.') != std::string::npos) continue;
    names.push_back(k.name);
    if (k.only_for.empty() || listed(k.only_for, word(k.selector))) shown.push_back(k.name);
  }
  names.insert(names.end(), more.begin(), more.end());
  shown.insert(shown.end(), more.begin(), more.end());
  // A free map (any_key) allows any name: an empty list of names.
  const bool free = std::any_of(keys.begin(), keys.end(), [](const DeckKey<Spec>& k) { return k.any_name; });
  Section s(r, v, free ? Names{} : names, shown);
  for (const DeckKey<Spec>& k : keys) {
    if (std::string(k.name).find('.') != std::string::npos || k.any_name) continue;  // read with its map, or by the caller
    const bool applies = k.only_for.empty() || listed(k.only_for, word(k.selector));
    const Value* x = k.required && applies ? &s.need(k.name) : s.find(k.name);
    if (!x) continue;
    if (!applies)
      r.fail(*x, std::string("applies to ") + k.selector + " " + join(k.only_for) + " only (" + k.selector + " is " +
                     word(k.selector) + ")");
    std::vector<DeckKey<Spec>> nested;  // a map's keys, named within it
    for (const DeckKey<Spec>& n : keys)
      if (in_map(n.name, k.name)) {
        nested.push_back(n);
        nested.back().name = n.name + std::strlen(k.name) + 1;
      }
    if (!nested.empty()) {
      read_keys(r, *x, nested, spec);
      continue;
    }
    read_value(r, k, *x, spec);
  }
  return s;
}

// Relative paths of mesh and obstacle files are relative to the deck's directory (not the working
// directory), so a deck and its meshes can be moved together. extensions: what kinds are read.
std::string resolve_input_file(const Reader& r, const Value& v, const fs::path& deck_dir, const Names& extensions,
                               const std::string& kinds) {
  fs::path file = r.text(v);
  if (file.empty()) r.fail(v, "empty file name");
  if (std::find(extensions.begin(), extensions.end(), file.extension().string()) == extensions.end())
    r.fail(v, "unsupported file '" + file.string() + "': expected " + kinds);
  fs::path resolved = file.is_absolute() ? file : (deck_dir / file).lexically_normal();
  std::error_code ec;
  if (!fs::is_regular_file(resolved, ec)) {
    // The full path, whatever the working directory, and the deck's own spelling if it differs.
    const fs::path full = fs::absolute(resolved, ec).lexically_normal();
    r.fail(v, "file not found: '" + full.string() + "'" +
                  (full == file ? "" : " (the deck's '" + file.string() + "'" +
                                           (file.is_absolute() ? "" : ", relative to the deck's directory") + ")"));
  }
  return resolved.string();
}

// A partition file's header: what its mesh holds. The keys that shape a mesh belong to the deck
// the file was made from, and are applied in it already.
void read_partition_header(const Reader& r, const Value& file, const Section& s, MeshSpec& m) {
  for (const char* key : {"transform", "strands", "edges", "surface"})
    if (const Value* x = s.find(key))
      r.fail(*x, "shapes the mesh, and mesh.file is a partition file: give it in the deck given to hyperqn partition "
                 "(the file holds the mesh with it applied)");
  PartitionFileInfo info;
  try {
    info = read_partition_info(m.file);
  } catch (const InputError& e) {
    r.fail(file, e.what());
  }
  if (info.bodies.count > 0)
    r.fail(file, "holds the " + std::to_string(info.bodies.count) + " bodies of a deck's bodies: name it as partition: "
                 "beside those bodies");
  m.is_partition_file = true;
  m.file_tets = info.tets;
  m.file_segments = info.segments;
  m.file_triangles = info.triangles;
  m.surface_as_cloth = info.triangles > 0;
}

void read_mesh(const Reader& r, const Value& v, const fs::path& deck_dir, MeshSpec& m) {
  Names names;  // the section's keys: unknown keys are reported before which keys go together
  for (const DeckKey<MeshSpec>& k : mesh_keys())
    if (!std::strchr(k.name, '.')) names.push_back(k.name);
  const Section s(r, v, names);
  const Value *file = s.find("file"), *box = s.find("box"), *sheet = s.find("sheet"), *strands = s.find("strands");
  if ((file != nullptr) + (box != nullptr) + (sheet != nullptr) > 1) r.fail(v, "give one of file, box and sheet");
  if (!file && !box && !sheet && !strands)
    r.fail(v, "missing the mesh: give file (a .mesh, .msh or .obj path), box, sheet or strands");
  read_keys(r, v, mesh_keys(), m);
  if (file) {
    m.file = resolve_input_file(r, *file, deck_dir, {".mesh", ".msh", ".obj", ".h5"},
                                ".mesh (Medit), .msh (Gmsh), .obj (a cloth surface) or .h5 (a partition file of hyperqn partition)");
    m.line = file->line;
    m.surface_as_cloth = m.surface_as_cloth || fs::path(m.file).extension() == ".obj";
    if (fs::path(m.file).extension() == ".h5") read_partition_header(r, *file, s, m);
  }
  if (const Value* x = s.find("surface"); x && !file)
    r.fail(*x, "surface: cloth reads the triangles of mesh.file as a cloth; give a .mesh, .msh or .obj file");
  // A generated grid's cells: its line is the mesh's (the memory check names it), its size is capped.
  const auto cells = [&](const Value& grid) {
    const Value x = *Section(r, grid, {}).find("cells");
    m.line = x.line;
    return x;
  };
  // ... and its cells are not too flat (kFlattestCell).
  const auto not_flat = [&](const Value& grid, const double* size, const int* n, int dims, const char* elements) {
    double shortest = HUGE_VAL, longest = 0;
    std::string sides;
    for (int d = 0; d < dims; ++d) {
      const double side = size[d] / n[d];
      shortest = std::min(shortest, side);
      longest = std::max(longest, side);
      char text[32];
      std::snprintf(text, sizeof text, "%s%.3g", d ? " x " : "", side);
      sides += text;
    }
    if (shortest >= kFlattestCell * longest) return;
    char rule[40];
    std::snprintf(rule, sizeof rule, "%g", kFlattestCell);
    r.fail(*Section(r, grid, {}).find("size"),
           "its cells would be " + sides + " (size / cells): the shortest side is less than " + rule +
               " of the longest, and the " + elements + "' stiffness across so thin a cell (as 1 / side^2) would bury " +
               "the rest of M + h^2 L in round-off (it would not be positive definite). Check the size and its units; a " +
               "thin plate is a cloth (mesh.sheet)");
  };
  if (sheet) {
    m.is_sheet = true;
    const Value x = cells(*sheet);
    const double triangles = 2.0 * m.sheet_cells[0] * m.sheet_cells[1];
    if (3 * triangles > kMaxBoxTets)
      r.fail(x, "makes " + std::to_string((long long)triangles) + " triangles; the sheet generator takes at most 715827882");
    not_flat(*sheet, m.sheet_size.data(), m.sheet_cells.data(), 2, "triangles");
  }
  if (m.has_cloth() && strands) r.fail(*strands, "a cloth cannot share a mesh with strands");
  if (const Value* x = s.find("edges"))
    if (m.edges_as_strands && (!file || fs::path(m.file).extension() != ".mesh" || m.surface_as_cloth))
      r.fail(*x, "edges: strands reads the Edges section of a Medit .mesh file; give one as mesh.file");
  if (strands) {
    for (const Value& item : r.items(*strands)) {
      StrandLine line;
      const Section st = read_keys(r, item, strand_line_keys(), line);
      line.line = item.line;
      if (line.from == line.to) r.fail(*st.find("to"), "a strand needs distinct from and to points");
      m.strands.push_back(line);
    }
    if (m.strands.empty()) r.fail(*strands, "expected a non-empty list of strands {from, to, segments}");
  }
  if (box) {
    m.is_box = true;
    const Value x = cells(*box);
    const double tets = 6.0 * m.box_cells[0] * m.box_cells[1] * m.box_cells[2];
    if (tets > kMaxBoxTets)
      r.fail(x, "makes " + std::to_string((long long)tets) + " tets; the box generator takes at most 2147483647");
    not_flat(*box, m.box_size.data(), m.box_cells.data(), 3, "tets");
  }
}

void read_strand_material(const Reader& r, const Value& v, StrandMaterial& m) {
  read_keys(r, v, strand_material_keys(), m);
}

void read_cloth(const Reader& r, const Value& v, ClothSpec& c) {
  const Section s = read_keys(r, v, cloth_keys(), c);
  if (const Value* x = s.find("thickness")) c.thickness_line = x->line;
  if (c.model == ClothModel::membrane) {
    const double e = c.youngs_modulus, n = c.poisson_ratio;
    c.mu = e / (2 * (1 + n));        // plane stress: the 2-D Lame constants of a thin sheet
    c.lambda = e * n / (1 - n * n);
  }
}

// A pair of keys that only make sense together: the missing one is reported at the other's line.
void need_both(const Reader& r, const Section& s, const char* a, const char* b) {
  const Value *va = s.find(a), *vb = s.find(b);
  if (va && !vb) r.fail(va->line, s.path(b), std::string("missing; ") + a + " is given, so " + b + " is needed too");
  if (vb && !va) r.fail(vb->line, s.path(a), std::string("missing; ") + b + " is given, so " + a + " is needed too");
}

// The elastic constants as read_keys read them: one pair, both of it; E and nu become mu and lambda.
void check_elastic_constants(const Reader& r, const Section& s, MaterialSpec& m) {
  const Value *E = s.find("youngs_modulus"), *nu = s.find("poisson_ratio");
  const Value *mu = s.find("mu"), *lambda = s.find("lambda");
  if ((E || nu) && (mu || lambda))
    r.fail(mu ? *mu : *lambda, "give either youngs_modulus and poisson_ratio, or mu and lambda, not both");
  if (!E && !nu && !mu && !lambda)
    r.fail(s.value(), "missing elastic constants: give youngs_modulus and poisson_ratio, or mu and lambda");
  if (E || nu) {
    need_both(r, s, "youngs_modulus", "poisson_ratio");
    m.mu = lame_mu(m.youngs_modulus, m.poisson_ratio);
    m.lambda = lame_lambda(m.youngs_modulus, m.poisson_ratio);
  } else {
    need_both(r, s, "mu", "lambda");
  }
}

// f: {polynomial: [c0, c1, ...]} or f: {spline: {x: [...], y: [...]}}
FunctionSpec read_function(const Reader& r, const Value& v) {
  Section s(r, v, {"polynomial", "spline"});
  const Value *poly = s.find("polynomial"), *spline = s.find("spline");
  if (!poly == !spline) r.fail(v, "give either polynomial or spline");
  FunctionSpec f;
  if (poly) {
    f.kind = "polynomial";
    for (const Value& c : r.items(*poly)) f.coefficients.push_back(r.number(c));
    r.check(!f.coefficients.empty(), *poly, "a non-empty list of coefficients of (x - 1)^k");
  } else {
    f.kind = "spline";
    Section sp(r, *spline, {"x", "y"});
    const Value &x = sp.need("x"), &y = sp.need("y");
    for (const Value& c : r.items(x)) f.x.push_back(r.number(c));
    for (const Value& c : r.items(y)) f.y.push_back(r.number(c));
    r.check(f.x.size() >= 2 && f.x.size() == f.y.size(), y, "as many values as x (at least 2)");
    for (size_t i = 1; i < f.x.size(); ++i) r.check(f.x[i] > f.x[i - 1], x, "strictly increasing");
  }
  return f;
}

// The keys, ranges and models of material_keys() (from the material registry), then the rules
// that involve several keys, then the model's own checks.
void read_material(const Reader& r, const Value& v, MaterialSpec& m) {
  {
    // A model without elastic constants names the keys it takes instead (read_keys would name the
    // models that take elastic constants).
    const Section probe(r, v, {});
    const Value* word = probe.find("model");
    const MaterialModel& model = *find_material_model(word ? r.choice(*word, material_keys()[0].choices) : m.model);
    for (const MaterialKey& k : elastic_constant_keys())
      if (const Value* x = probe.find(k.name); x && !model.elastic_constants) {
        std::string own;
        for (const MaterialKey& key : model.keys) own += (own.empty() ? "" : ", ") + std::string(key.name);
        r.fail(*x, model.name + " takes " + own + " instead of elastic constants");
      }
  }
  const Section s = read_keys(r, v, material_keys(), m);
  const MaterialModel& model = *find_material_model(m.model);
  if (model.elastic_constants) check_elastic_constants(r, s, m);
  if (const Value* x = s.find("f")) m.f = read_function(r, *x);
  if (const Value* x = s.find("g")) m.g = read_function(r, *x);
  if (const Value* x = s.find("h")) m.h = read_function(r, *x);
  // A model of functions (principal-stretch) needs one of them.
  const bool of_functions = std::any_of(model.keys.begin(), model.keys.end(),
                                        [](const MaterialKey& k) { return std::string(k.type) == "function"; });
  if (of_functions && m.f.kind.empty() && m.g.kind.empty() && m.h.kind.empty())
    r.fail(v, m.model + " needs f, g or h");
  m.has_fiber = s.find("fiber") != nullptr;

  const Value *density = s.find("density"), *total = s.find("total_mass");
  if (density && total) r.fail(*total, "give either density or total_mass, not both");
  if (!density && !total) r.fail(v, "missing the mass: give density or total_mass");
  m.has_density = density != nullptr;

  // The material's own checks (e.g. spline shapes) with the deck's place in the message.
  try {
    if (model.create) make_material(m);
  } catch (const std::invalid_argument& e) {
    r.fail(v, e.what());
  }
}

// A box of fixed:, attachments: or regions:, read by read_keys (box_keys): min <= max on every axis.
void check_box(const Reader& r, const Section& s, const BoxRegion& b) {
  const Value* box = s.find("box");
  if (!box) return;
  const Section corners(r, *box, {});
  for (int i = 0; i < 3; ++i)
    if (b.min[i] > b.max[i])
      r.fail(*box, std::string("min > max along ") + "xyz"[i] + ": " + r.items(*corners.find("min"))[i].node.Scalar() +
                       " > " + r.items(*corners.find("max"))[i].node.Scalar());
}

Motion read_motion(const Reader& r, const Value& v) {
  Motion m;
  const Section s = read_keys(r, v, motion_keys(), m);
  m.active = true;
  if (const Value* x = s.find("end")) r.check(m.end >= m.start, *x, ">= motion.start");
  return m;
}

// bodies[k].fixed and bodies[k].attachments: (k, the list), read after the scene's own.
struct BodyRegions {
  std::vector<std::pair<int, Value>> fixed, attachments;
};

// body >= 0: bodies[body].fixed, which selects that body's vertices only.
void read_fixed(const Reader& r, const Value& v, std::vector<BoxRegion>& fixed, int body = -1) {
  for (const Value& item : r.items(v)) {
    BoxRegion b;
    const Section s = read_keys(r, item, fixed_keys(), b);
    check_box(r, s, b);
    b.line = item.line;
    b.body = body;
    if (const Value* x = s.find("motion")) b.motion = read_motion(r, *x);
    fixed.push_back(b);
  }
}

// bodies: a list of bodies, each a mesh (tets, a cloth, strands, or tets with strands, with its
// transform) with the material of each of its parts, an initial velocity and its own fixed regions
// and attachments (returned in regions, read after the scene's).
void read_bodies(const Reader& r, const Value& v, const fs::path& deck_dir, Deck& deck, BodyRegions& regions) {
  for (const Value& item : r.items(v)) {
    const int k = (int)deck.bodies.size();
    BodySpec b;
    b.line = item.line;
    b.name = "body" + std::to_string(k);
    const Section s = read_keys(r, item, body_keys(), b);
    if (const Value* x = s.find("name"))
      for (const BodySpec& other : deck.bodies)
        if (other.name == b.name) r.fail(*x, "another body is named " + b.name + " (line " + std::to_string(other.line) + ")");
    const Value& mesh = *s.find("mesh");
    read_mesh(r, mesh, deck_dir, b.mesh);
    const MeshSpec& m = b.mesh;
    if (m.is_partition_file)
      r.fail(mesh, "a body's mesh is not a partition file: name the partition file of all the bodies as partition: "
                   "beside bodies: (written by hyperqn partition DECK -n N)");
    // Each part of the body's mesh takes its own material, read as for a scene of one body. A
    // Medit file read for its edges may hold no tets (load_scene_input checks).
    const struct {
      const char* key;
      bool has;
      bool required;
      const char* part;
    } parts[] = {{"material", m.has_solid(), m.has_solid() && !m.edges_as_strands, "tetrahedra (a box or a .mesh or .msh file)"},
                 {"cloth", m.has_cloth(), m.has_cloth(), "a cloth (a sheet, an .obj file, or a file with surface: cloth)"},
                 {"strand_material", m.has_strands(), m.has_strands(), "strands (mesh.strands, or edges: strands)"}};
    for (const auto& part : parts) {
      const Value* x = s.find(part.key);
      if (x && !part.has) r.fail(*x, std::string(part.key) + " describes " + part.part + ", and the body's mesh has none");
      if (part.required) s.need(part.key);
    }
    if (const Value* x = s.find("material")) {
      read_material(r, *x, b.material);
      b.has_material = true;
    }
    if (const Value* x = s.find("cloth")) read_cloth(r, *x, b.cloth);
    if (const Value* x = s.find("strand_material")) read_strand_material(r, *x, b.strand_material);
    if (const Value* x = s.find("fixed")) regions.fixed.emplace_back(k, *x);
    if (const Value* x = s.find("attachments")) regions.attachments.emplace_back(k, *x);
    deck.bodies.push_back(b);
  }
  r.check(!deck.bodies.empty(), v, "a non-empty list");
  for (const BodySpec& b : deck.bodies)
    if (b.has_material) {  // the scene's material (what the study names): the first body's with tets
      deck.material = b.material;
      deck.has_material = true;
      break;
    }
  deck.mesh.line = deck.bodies[0].mesh.line;
}

// partition: the file `hyperqn partition` writes of the joined bodies. It need not exist yet (the
// command writes it from this deck); the run checks it against the bodies (load_scene_input).
void read_bodies_partition(const Reader& r, const Value& v, const fs::path& deck_dir, Deck& deck) {
  const fs::path file = r.text(v);
  if (file.extension() != ".h5")
    r.fail(v, "'" + file.string() + "': a partition file's name ends in .h5 (hyperqn partition DECK -n N writes it)");
  deck.partition_file = (file.is_absolute() ? file : (deck_dir / file).lexically_normal()).string();
  deck.partition_line = v.line;
}

// colliders: a list of obstacles, each of one type with that type's keys (collider_keys()).
void read_colliders(const Reader& r, const Value& v, const fs::path& deck_dir, std::vector<ColliderSpec>& colliders) {
  for (const Value& item : r.items(v)) {
    ColliderSpec c;
    const Section s = read_keys(r, item, collider_keys(), c);
    c.line = item.line;
    if (c.type == ColliderType::box)
      for (int i = 0; i < 3; ++i)
        if (!(c.min[i] < c.max[i]))
          r.fail(*s.find("max"), std::string("must exceed min along ") + "xyz"[i] + " (a solid box of positive size)");
    if (c.type == ColliderType::mesh)
      c.file = resolve_input_file(r, *s.find("file"), deck_dir, {".obj", ".mesh"},
                                  ".obj (Wavefront) or .mesh (Medit, its Triangles)");
    if (const Value* x = s.find("motion")) c.motion = read_motion(r, *x);
    colliders.push_back(c);
  }
}

void read_contact(const Reader& r, const Value& v, ContactSpec& c) {
  const Section s = read_keys(r, v, contact_keys(), c);
  c.line = v.line;
  if (const Value* x = s.find("distance")) c.distance_line = x->line;
  if (const Value* x = s.find("self_friction"); x && !c.self)
    r.fail(*x, "self_friction is the friction between surfaces in self-contact, which is off (self: true turns it on); "
               "each collider has its own friction");
}

// attachments: [{box, stiffness, motion, release}]: box, motion and release as for fixed regions.
void read_attachments(const Reader& r, const Value& v, std::vector<AttachmentSpec>& attachments) {
  for (const Value& item : r.items(v)) {
    AttachmentSpec a;
    const Section s = read_keys(r, item, attachment_keys(), a);
    check_box(r, s, a.region);
    a.region.line = item.line;
    if (const Value* x = s.find("motion")) a.region.motion = read_motion(r, *x);
    attachments.push_back(a);
  }
}

// Each body's own fixed regions and attachments (BoxRegion::body), after the scene's.
void read_body_regions(const Reader& r, const BodyRegions& regions, Deck& deck) {
  for (const auto& [k, item] : regions.fixed) read_fixed(r, item, deck.fixed, k);
  for (const auto& [k, item] : regions.attachments) {
    std::vector<AttachmentSpec> own;
    read_attachments(r, item, own);
    for (AttachmentSpec& a : own) {
      a.region.body = k;
      deck.attachments.push_back(a);
    }
  }
}

void read_initial(const Reader& r, const Value& v, InitialSpec& in) {
  const Section s(r, v, {"squash", "collapse", "random", "invert"});
  if (s.entries().size() != 1) r.fail(v, "give exactly one of squash, collapse, random, invert");
  read_keys(r, v, initial_keys(), in);
  const auto& [form, x] = s.entries()[0];
  if (form == "squash") in.kind = InitialKind::squash;
  if (form == "collapse" && r.boolean(x)) in.kind = InitialKind::collapse;
  if (form == "random") in.kind = InitialKind::random;
  if (form == "invert") in.kind = InitialKind::invert;
}

void read_regions(const Reader& r, const Value& v, const MaterialSpec& base, std::vector<MaterialRegion>& regions) {
  for (const Value& item : r.items(v)) {
    MaterialRegion region;
    const Section s = read_keys(r, item, region_keys(), region);
    region.line = item.line;
    const Value *box = s.find("box"), *tags = s.find("tags");
    if (!box == !tags) r.fail(item, "give either box or tags");
    check_box(r, s, region.box);
    region.by_box = box != nullptr;
    if (box) region.box.line = box->line;
    const Value& mat = *s.find("material");
    read_material(r, mat, region.material);
    // Masses are per unit volume when the body has several materials.
    if (!region.material.has_density || !base.has_density)
      r.fail(mat, "with regions, every material (the default one too) gives density, not total_mass");
    regions.push_back(region);
  }
}

// An integrator's name (study.integrators; time.integrator is read by time_keys()).
TimeIntegrator read_integrator(const Reader& r, const Value& v) {
  return integrator_named(r.choice(v, integrator_names()))->kind;
}

void read_time(const Reader& r, const Value& v, TimeSpec& t) {
  const Section s = read_keys(r, v, time_keys(), t);
  if (const Value* x = s.find("dt")) r.check(t.dt >= 1e-100, *x, ">= 1e-100 (h^2 must not underflow)");
}

void read_solver(const Reader& r, const Value& v, SolverSpec& sv) {
  const Section s = read_keys(r, v, solver_keys(), sv);
  // lbfgs only, like the other solvers' own keys (pd is defined by M + h^2 L). amg would not
  // be ignored by pd but break it: its steps are exact solves with M + h^2 L.
  if (const Value* x = s.find("h0"); x && sv.type == "pd" && sv.h0 == H0::amg)
    r.fail(*x, "amg is for lbfgs: pd's steps need the exact solve with M + h^2 L, which a V-cycle only "
               "approximates (give laplacian, or leave h0 out)");
  // adaptive: the fallback chain as the keys above set it; fixed: none of it, and then
  // those keys would say nothing, so giving one is an error rather than silently overruled.
  if (const Value* x = s.find("budget"); x && x->node.Scalar() == "fixed")
    for (const char* key : {"max_iterations", "max_halvings", "newton_fallback", "keep_substeps"})
      if (const Value* stage = s.find(key))
        r.fail(*stage, std::string("budget: fixed turns off the fallback chain (") + key +
                           " among it): leave " + key + " out, or use budget: adaptive");
}

void read_study(const Reader& r, const Value& v, int scene_frames, StudySpec& st) {
  const Section s = read_keys(r, v, study_keys(), st);
  if (const Value* x = s.find("frames"))
    for (const Value& item : r.items(*x))
      r.check(r.integer(item) >= 1 && r.integer(item) <= scene_frames, item, "a frame in [1, time.frames = " + std::to_string(scene_frames) + "]");
  if (const Value* x = s.find("integrators")) {
    for (const Value& item : r.items(*x)) {
      const TimeIntegrator kind = read_integrator(r, item);
      r.check(std::find(st.integrators.begin(), st.integrators.end(), kind) == st.integrators.end(), item,
              "each integrator once");
      st.integrators.push_back(kind);
    }
    r.check(!st.integrators.empty(), *x, "a non-empty list");
  }
  if (const Value* x = s.find("trajectory_iterations")) {
    Section t(r, *x, kSolverTypes);
    for (const auto& [name, item] : t.entries()) {
      st.trajectory_iterations[name] = r.integer(item);
      r.check(st.trajectory_iterations[name] >= 1, item, ">= 1");
    }
  }
}

void read_output(const Reader& r, const Value& v, OutputSpec& o) { read_keys(r, v, output_keys(), o); }

void read_checkpoint(const Reader& r, const Value& v, CheckpointSpec& c) { read_keys(r, v, checkpoint_keys(), c); }

// The sections that define the physics as YAML text (time without frames, which only says how
// long to run): what a checkpoint's physics hash is made of. A section the deck leaves out is "".
// Not `mesh`: the mesh is recognised by the hash of the mesh as built (piece_hash_sums), so a run
// started from a mesh file may continue from its partition file, and a changed mesh is still refused.
std::vector<std::pair<std::string, std::string>> physics_sections(const YAML::Node& root) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const char* key : {"material", "strand_material", "regions", "fixed", "attachments", "colliders",
                          "contact", "initial", "gravity", "time", "cloth", "bodies"}) {
    const YAML::Node found = root.IsMap() ? root[key] : YAML::Node();
    if (!found || found.IsNull()) {
      if (std::string(key) == "cloth" || std::string(key) == "bodies") continue;  // added later: decks without one keep their hash
      out.emplace_back(key, "");
      continue;
    }
    YAML::Node node = YAML::Clone(found);
    if (std::string(key) == "time" && node.IsMap()) node.remove("frames");
    out.emplace_back(key, YAML::Dump(node));
  }
  return out;
}

// petsc: {a: {b: 1}} -> ("-a_b", "1"). Values go to PETSc as written, except that booleans are
// spelled true/false and an empty value is "" (an option without argument).
void read_petsc(const Reader& r, const Value& v, const std::string& prefix, Deck& deck, int depth = 0) {
  auto& out = deck.petsc_options;
  if (depth > kMaxPetscDepth) r.fail(v, "nested more than " + std::to_string(kMaxPetscDepth) + " levels deep");
  const Section s = read_keys(r, v, petsc_keys(), deck);
  for (const auto& [name, x] : s.entries()) {
    if ((int)out.size() >= kMaxPetscOptions)
      r.fail(x, "more than " + std::to_string(kMaxPetscOptions) + " PETSc options (YAML aliases repeating maps?)");
    if (name.empty() || name[0] == '-')
      r.fail(x, "PETSc option names are written without the leading '-'");
    // PETSc would take anything else as the end of the name, or as another option.
    const bool plain = std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum((unsigned char)c) || c == '_'; });
    if (!plain || (prefix.empty() && !std::isalpha((unsigned char)name[0])))
      r.fail(x, "not a PETSc option name: letters, digits and '_' only, starting with a letter");
    std::string option = prefix.empty() ? name : prefix + "_" + name;
    if (x.node.IsMap()) {
      read_petsc(r, x, option, deck, depth + 1);
      continue;
    }
    std::string value;
    if (x.node.IsScalar()) {
      value = x.node.Scalar();
      bool b = false;
      if (x.node.Tag() != "!" && YAML::convert<bool>::decode(x.node, b)) value = b ? "true" : "false";
      // PETSc splits a value at whitespace: "unit -tao_type x" would set a second option.
      if (std::any_of(value.begin(), value.end(), [](char c) { return std::isspace((unsigned char)c) || std::iscntrl((unsigned char)c); }))
        r.fail(x, "a PETSc option value is one word: no spaces or control characters, got " + describe(x.node));
    } else if (!x.node.IsNull()) {
      r.fail(x, "expected a single value or a nested map, got " + describe(x.node) +
                    " (write PETSc lists as a comma-separated string)");
    }
    if (const auto seen = deck.petsc_option_places.find("-" + option); seen != deck.petsc_option_places.end())
      r.fail(x, "option -" + option + " is also given at line " + std::to_string(seen->second.line) +
                    " (as '" + seen->second.key + "')");
    out.emplace_back("-" + option, value);
    deck.petsc_option_places["-" + option] = {x.line, x.key};
  }
}

Deck parse(const Reader& r, const YAML::Node& root, const std::string& path) {
  Deck deck;
  deck.path = path;
  deck.study.solvers = solver_names();
  deck.name = fs::path(path).stem().string();

  Section s(r, Value{root, "", line_of(root)},
            {"name", "mesh", "bodies", "partition", "material", "strand_material", "cloth", "regions", "fixed", "attachments",
             "colliders", "contact", "initial", "gravity", "time", "solver", "output", "checkpoint", "study", "petsc"});
  if (const Value* x = s.find("name")) {
    deck.name = r.text(*x);
    // The name becomes a directory and file names (output/<name>/<name>_00001.vtu).
    if (deck.name.empty() || deck.name.find_first_of("/\\") != std::string::npos)
      r.fail(*x, "must be a non-empty name without '/' or '\\'");
    const bool safe = std::all_of(deck.name.begin(), deck.name.end(), [](char c) {
      return std::isalnum((unsigned char)c) || c == '_' || c == '-' || c == '.' || c == '+';
    });
    if (!safe || deck.name.size() > kMaxNameLength || deck.name[0] == '.' || deck.name[0] == '-')
      r.fail(*x, "must be a file name of at most 100 letters, digits and _ - . + (not starting with . or -)");
  }
  BodyRegions body_regions;  // read after the scene's own fixed regions and attachments
  if (const Value* x = s.find("bodies")) {
    for (const char* key : {"mesh", "material", "regions", "strand_material", "cloth"})
      if (const Value* y = s.find(key))
        r.fail(*y, std::string("with bodies, each body has its own mesh and material: ") + key +
                       " is a key of bodies[k] (or leave out bodies for a scene of one body)");
    read_bodies(r, *x, fs::path(path).parent_path(), deck, body_regions);
    if (const Value* y = s.find("partition")) read_bodies_partition(r, *y, fs::path(path).parent_path(), deck);
  } else {
    if (const Value* y = s.find("partition"))
      r.fail(*y, "names the partition file of a scene of bodies (bodies:); a deck of one mesh names its partition file "
                 "as mesh.file");
    const Value& mesh = s.need("mesh");
    read_mesh(r, mesh, fs::path(path).parent_path(), deck.mesh);
    // material (and regions) describe the tets, strand_material the strand segments: each is
    // required exactly when the mesh has that kind of element. Whether a Medit file read for its
    // edges also has tets is only known once it is read (load_scene_mesh checks).
    const bool may_be_strands_only = deck.mesh.edges_as_strands;
    if (const Value* x = s.find("material"); x && deck.mesh.has_solid()) {
      read_material(r, *x, deck.material);
      deck.has_material = true;
    } else if (deck.mesh.has_solid() && !may_be_strands_only) {
      s.need("material");
    } else if (!deck.mesh.has_solid() && !deck.mesh.has_cloth()) {
      for (const char* key : {"material", "regions"})
        if (const Value* x = s.find(key))
          r.fail(*x, "the mesh is strands only (no file or box): " + std::string(key) +
                         " describes tets; the strands take strand_material");
    }
    if (deck.mesh.has_strands()) {
      if (!s.find("strand_material"))
        r.fail(mesh.line, "strand_material", "missing required key 'strand_material': the mesh has strands");
      read_strand_material(r, *s.find("strand_material"), deck.strand_material);
    } else if (const Value* x = s.find("strand_material")) {
      r.fail(*x, "the mesh has no strands (give mesh.strands, or mesh.edges: strands with a Medit file)");
    }
    if (deck.mesh.has_cloth()) {
      if (!s.find("cloth")) r.fail(mesh.line, "cloth", "missing required key 'cloth': the mesh is a cloth surface");
      read_cloth(r, *s.find("cloth"), deck.cloth);
      for (const char* key : {"material", "regions"})
        if (const Value* x = s.find(key))
          r.fail(*x, "the mesh is a cloth surface: " + std::string(key) + " describes tets; the cloth takes cloth");
    } else if (const Value* x = s.find("cloth")) {
      r.fail(*x, "the mesh is not a cloth (give mesh.sheet, an .obj file, or mesh.surface: cloth with a .mesh or .msh file)");
    }
  }
  if (const Value* x = s.find("regions")) read_regions(r, *x, deck.material, deck.regions);
  if (const Value* x = s.find("initial")) read_initial(r, *x, deck.initial);
  if (const Value* x = s.find("fixed")) read_fixed(r, *x, deck.fixed);
  if (const Value* x = s.find("colliders")) read_colliders(r, *x, fs::path(path).parent_path(), deck.colliders);
  if (const Value* x = s.find("contact")) {
    const Value* self = Section(r, *x, {}).find("self");
    if (deck.colliders.empty() && !(self && r.boolean(*self)))
      r.fail(*x, "contact describes how the body touches colliders, and there are none (or self-contact: self: true)");
    read_contact(r, *x, deck.contact);
    if (self) deck.contact.self_line = self->line;
  }
  // A cloth's thickness acts in self-contact only: without it the key would say nothing.
  if (!deck.contact.self) {
    std::vector<std::pair<std::string, const ClothSpec*>> cloths{{"cloth", &deck.cloth}};
    for (size_t k = 0; k < deck.bodies.size(); ++k)
      cloths.push_back({"bodies[" + std::to_string(k) + "].cloth", &deck.bodies[k].cloth});
    for (const auto& [key, cloth] : cloths)
      if (cloth->thickness_line > 0)
        r.fail(cloth->thickness_line, key + ".thickness",
               "a cloth's thickness acts in self-contact only, and the deck has none: leave thickness out, or turn "
               "self-contact on (contact: {self: true})");
  }
  // Self-contact, like colliders, needs an integrator whose end of step is the solve's z (which
  // the barrier kept free of intersections).
  const bool contact = !deck.colliders.empty() || deck.contact.self;
  if (const Value* x = s.find("attachments")) read_attachments(r, *x, deck.attachments);
  read_body_regions(r, body_regions, deck);
  if (const Value* x = s.find("gravity")) read_value(r, gravity_keys()[0], *x, static_cast<SceneSpec&>(deck));
  if (const Value* x = s.find("time")) {
    read_time(r, *x, deck.time);
    const IntegratorInfo& integrator = integrator_info(deck.time.integrator);
    if (!integrator.with_colliders && contact)
      r.fail(*Section(r, *x, {}).find("integrator"),
             std::string(integrator.name) + " does not take colliders or self-contact yet: its end-of-step map can carry "
             "vertices through an obstacle or a surface that the solve's z rests on (use implicit-euler)");
  }
  if (const Value* x = s.find("solver")) read_solver(r, *x, deck.solver);
  // The solver's defaults with colliders (docs/contact.md#defaults): contact's stiff, lagged
  // friction is learnt from more (s, y) pairs; y often lies deep inside an obstacle while x_n rests on it.
  if (contact) {
    const Value* solver = s.find("solver");
    const auto given = [&](const char* key) { return solver && Section(r, *solver, {}).find(key); };
    if (!given("history")) deck.solver.history = kContactHistory;
    if (!given("warm_start")) deck.solver.warm_start = WarmStart::lower;
  }
  if (const Value* x = s.find("output")) read_output(r, *x, deck.output);
  if (const Value* x = s.find("checkpoint")) read_checkpoint(r, *x, deck.checkpoint);
  deck.physics = physics_sections(root);
  if (const Value* x = s.find("study")) {
    read_study(r, *x, deck.time.frames, deck.study);
    for (TimeIntegrator kind : deck.study.integrators)
      if (!integrator_info(kind).with_colliders && contact)
        r.fail(*Section(r, *x, {}).find("integrators"),
               std::string(integrator_info(kind).name) + " does not take colliders yet (see time.integrator)");
  }
  if (const Value* x = s.find("petsc")) read_petsc(r, *x, "", deck);
  return deck;
}

}  // namespace

const Deck::OptionPlace* deck_option_place(const Deck& deck, const std::string& name, const std::string& value) {
  const auto place = deck.petsc_option_places.find(name);
  if (place == deck.petsc_option_places.end()) return nullptr;
  for (const auto& [n, v] : deck.petsc_options)
    if (n == name) return v == value ? &place->second : nullptr;
  return nullptr;
}

Deck load_deck(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, 0, "", "deck file not found");
  if (fs::is_directory(path, ec)) throw InputError(path, 0, "", "is a directory, not a deck file");
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "", "cannot read the deck file");
  if (fs::file_size(path, ec) > kMaxDeckBytes) throw InputError(path, 0, "", "larger than 10 MB: not a deck");

  Reader r(path);
  try {
    std::vector<YAML::Node> docs = YAML::LoadAll(in);
    if (docs.size() > 1) r.fail(line_of(docs[1]), "", "a deck holds one YAML document (found a second one)");
    return parse(r, docs.empty() ? YAML::Node() : docs[0], path);
  } catch (const YAML::ParserException& e) {
    throw InputError(path, e.mark.line + 1, "", "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    // Anything yaml-cpp rejects that the checks above did not foresee.
    throw InputError(path, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", e.msg);
  }
}

}  // namespace hyperqn
