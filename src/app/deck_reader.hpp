// The generic YAML reader of decks: typed values with their dotted key and line (Reader), maps
// that refuse unknown and duplicate keys (Section), and the reading of declared keys
// (params/deck_keys.hpp: read_keys, read_value). Every problem becomes an InputError naming the deck
// file, the line and the dotted key. Used by the section readers (app/deck_sections.cpp), the
// cross-section rules (app/deck_rules.cpp) and the deck's top level (app/deck.cpp).
#pragma once
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "app/deck.hpp"
#include "params/deck_keys.hpp"
#include "mesh/input_error.hpp"

namespace hyperqn::deck_reading {

namespace fs = std::filesystem;
using Names = std::vector<std::string>;

std::string join(const Names& names);
bool listed(const Names& names, const std::string& name);
inline int line_of(const YAML::Node& n) { return n.Mark().line >= 0 ? n.Mark().line + 1 : 0; }
// What a node holds, for "expected X, got Y" messages.
std::string describe(const YAML::Node& n);

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
  // places: where every key the deck gives is noted (Deck::key_places), or null.
  // inputs: where every file the deck names is noted (Deck::input_files, by resolve_input_file), or null.
  explicit Reader(std::string file, std::map<std::string, KeyPlace>* places = nullptr,
                  std::vector<Deck::InputFile>* inputs = nullptr)
      : file_(std::move(file)), places_(places), inputs_(inputs) {}
  // Notes a file the deck names (resolved), at v's line and key.
  void note_input(const std::string& path, const Value& v) const {
    if (inputs_) inputs_->push_back({path, v.line, v.key});
  }
  // Notes a map's entry (Section does, for each key it holds).
  void note(const Value& entry) const {
    if (!places_) return;
    bool leaf = !entry.node.IsMap();
    if (entry.node.IsSequence())
      for (const YAML::Node& item : entry.node) leaf = leaf && !item.IsMap();
    // As written, for a leaf only (config.yaml lists no map): a map's text would expand every alias
    // in it (an alias bomb's 9^7 nodes took 15 s to copy), and a leaf too large for any key is
    // refused by its reader anyway.
    std::string written;
    if (leaf && !entry.node.IsNull() && nodes_within(entry.node, kMaxWrittenNodes)) {
      // On one line (config.yaml's `key: value  # source`): a list the deck wrote as a block
      // keeps its block style in the node, which the emitter would follow.
      YAML::Node flow = YAML::Clone(entry.node);
      set_flow_style(flow);
      YAML::Emitter text;
      text << YAML::Flow << flow;
      written = text.c_str();
    }
    (*places_)[entry.key] = {entry.line, written, leaf};
  }
  // Whether n holds at most `budget` nodes (counting stops past it).
  static bool nodes_within(const YAML::Node& n, int budget) { return count_nodes(n, budget) <= budget; }
  static int count_nodes(const YAML::Node& n, int budget) {
    int count = 1;
    if (n.IsSequence() || n.IsMap())
      for (auto it = n.begin(); it != n.end() && count <= budget; ++it)
        count += count_nodes(n.IsMap() ? it->second : *it, budget - count);
    return count;
  }
  static constexpr int kMaxWrittenNodes = 100000;
  static void set_flow_style(YAML::Node n) {
    if (!n.IsSequence() && !n.IsMap()) return;
    n.SetStyle(YAML::EmitterStyle::Flow);
    for (auto it = n.begin(); it != n.end(); ++it) set_flow_style(n.IsMap() ? it->second : *it);
  }

  // Relative paths of input files are relative to this (resolve_input_file).
  fs::path deck_dir() const { return fs::path(file_).parent_path(); }

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

  // zero_allowed: the key takes 0 (a key whose range does not: a tiny value's message must not offer it).
  double number(const Value& v, bool zero_allowed = true) const {
    double x = 0;
    if (!plain_scalar(v.node) || !YAML::convert<double>::decode(v.node, x) || !std::isfinite(x))
      fail(v, "expected a number, got " + describe(v.node));
    if (const std::string rule = number_limits_problem(x, zero_allowed); !rule.empty())
      fail(v, "must be " + rule + ", got " + v.node.Scalar());
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
  // YAML 1.2's booleans (true, True, TRUE, false, ...): not 1.1's y, yes, on, no, off, which yaml-cpp
  // would take too (docs/decks.md: a bool is true or false).
  bool boolean(const Value& v) const {
    bool b = false;
    const std::string s = plain_scalar(v.node) ? v.node.Scalar() : std::string();
    const bool word = s == "true" || s == "True" || s == "TRUE" || s == "false" || s == "False" || s == "FALSE";
    if (!word || !YAML::convert<bool>::decode(v.node, b)) fail(v, "expected true or false, got " + describe(v.node));
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
  std::array<double, N> numbers(const Value& v, bool zero_allowed = true) const {
    std::array<double, N> out;
    auto it = fixed_list(v, N, "numbers");
    for (size_t i = 0; i < N; ++i) out[i] = number(it[i], zero_allowed);
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
  std::map<std::string, KeyPlace>* places_;
  std::vector<Deck::InputFile>* inputs_;
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
      r.note(entry);
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
      const T value = std::is_same_v<T, double> ? T(r.number(item, k.range.contains(0.0))) : T(r.integer(item));
      if (!k.range.rule().empty()) r.check(k.range.contains(value), item, k.range.rule());
      return value;
    } else if constexpr (std::is_same_v<T, bool>) {
      return r.boolean(item);
    } else if constexpr (is_array<T>::value) {  // a vec3, 2 numbers, 2 or 3 integers
      constexpr size_t N = std::tuple_size_v<T>;
      T value;
      // A range per number that refuses 0 (not a nonzero vector's, whose numbers may be 0).
      if constexpr (std::is_same_v<typename T::value_type, double>) value = r.numbers<N>(item, k.range.nonzero || k.range.contains(0.0));
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
                               const std::string& kinds);

}  // namespace hyperqn::deck_reading
