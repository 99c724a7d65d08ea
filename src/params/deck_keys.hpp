// A deck section's keys declared once, beside the struct they fill: name, type, range, unit, one
// line of documentation and the allowed choices. From these declarations the deck reader reads
// the section (app/deck_reader.hpp, read_keys: every check and message alike), `hyperqn --help-deck`
// prints them, `hyperqn registry` exports them, and the tables of those sections on
// docs/deck-scene.md and docs/deck-run.md are generated (scripts/deck_tables.py;
// tests/python/test_deck_tables.py fails when they differ).
// The default is the struct's own (a default-constructed one), so it is stated once too.
#pragma once
#include <algorithm>
#include <array>
#include <cstdio>
#include <functional>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "params/key_range.hpp"

namespace hyperqn {

using Array3 = std::array<double, 3>;

inline bool is_nonzero(const Array3& v) { return v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > 0; }

// Where a key's value goes in its section's struct Spec: a member (written as a member pointer),
// or a member of a member (written as a function, e.g. an attachment's region.min).
template <typename Spec, typename T>
using Field = std::function<T&(Spec&)>;
template <typename Spec>
struct KeyMember {
  std::variant<std::monostate, Field<Spec, double>, Field<Spec, int>, Field<Spec, bool>, Field<Spec, std::string>,
               Field<Spec, Array3>, Field<Spec, std::array<double, 2>>, Field<Spec, std::array<int, 2>>,
               Field<Spec, std::array<int, 3>>, Field<Spec, std::vector<int>>, Field<Spec, std::vector<std::string>>>
      field;
  KeyMember() = default;
  KeyMember(std::monostate) {}
  template <typename T>
  KeyMember(T Spec::*member) : field(Field<Spec, T>([member](Spec& s) -> T& { return s.*member; })) {}
  template <typename T>
  KeyMember(Field<Spec, T> f) : field(std::move(f)) {}
};

// One key of section Spec: a member of Spec (a list member: a non-empty list, the range and
// choices applying to each item), or (std::monostate) a choice that `set` applies and `get` names
// for the default (an enum member, or a key that sets several members), or (std::monostate
// without `set`) a key the section's reader reads itself, declared for the docs with `type_text`.
// A dotted name ("box.min") is a key of a nested map, declared after the map's own entry
// (map_key, "box"); both fill the same Spec.
template <typename Spec>
struct DeckKey {
  const char* name;
  KeyMember<Spec> member;
  const char* doc;
  KeyRange range = {};
  // (The lists' initializers are not `{}`: on a key that leaves them out, GCC 12 crashes on that.)
  std::vector<std::string> choices = std::vector<std::string>(0);  // a string member (or an enum's names): allowed values
  const char* unit = "";
  const char* default_text = "";          // instead of the struct's default, e.g. "1/30"
  std::function<void(Spec&, const std::string&)> set = nullptr;  // for std::monostate
  std::function<std::string(const Spec&)> get = nullptr;
  const char* type_text = "";             // a key without member or `set`: its type as docs show it
  bool required = false;                  // the section must give it (its default is never used)
  // Only for these values of the choice key `selector` of the same map, an enum_key declared before
  // it (the model's, the type's own keys): given with another value it is an error naming these;
  // `required` then means required with these.
  const char* selector = "";
  std::vector<std::string> only_for = std::vector<std::string>(0);
  bool any_name = false;                  // stands for every key of a free map (any_key)
};

// The key, required.
template <typename Spec>
DeckKey<Spec> needed(DeckKey<Spec> k) {
  k.required = true;
  return k;
}
// The key, of these values of choice key `choice_key` only (required with them if `required`).
template <typename Spec>
DeckKey<Spec> only_with(DeckKey<Spec> k, const char* choice_key, std::vector<std::string> values, bool required) {
  k.selector = choice_key;
  k.only_for = std::move(values);
  k.required = required;
  return k;
}

// A key whose value the section's reader reads itself (a map, a list of enums, ...).
template <typename Spec>
DeckKey<Spec> custom_key(const char* name, const char* type_text, const char* doc, const char* default_text) {
  DeckKey<Spec> k{name, std::monostate{}, doc};
  k.default_text = default_text;
  k.type_text = type_text;
  return k;
}

// A free map's keys (the petsc section's options): any name is allowed, and the section's reader
// reads them; `name` is how docs show such a key, e.g. "<option>".
template <typename Spec>
DeckKey<Spec> any_key(const char* name, const char* type_text, const char* doc) {
  DeckKey<Spec> k = custom_key<Spec>(name, type_text, doc, "none");
  k.any_name = true;
  return k;
}

// A nested map's own entry: its keys are declared after it as "name.key".
template <typename Spec>
DeckKey<Spec> map_key(const char* name, const char* doc, const char* default_text, bool required = false) {
  DeckKey<Spec> k = custom_key<Spec>(name, "map", doc, default_text);
  k.required = required;
  return k;
}

// A key whose member is an enum E, its values named by `names` in the enum's order: the deck's
// word becomes the enum when the deck is read, and nothing downstream compares strings.
template <typename Spec, typename E>
DeckKey<Spec> enum_key(const char* name, E Spec::*member, const std::vector<std::string>& names, const char* doc,
                       const char* default_text = "") {
  DeckKey<Spec> k{name, std::monostate{}, doc};
  k.choices = names;
  k.default_text = default_text;
  k.set = [member, names](Spec& s, const std::string& word) {
    s.*member = E(std::find(names.begin(), names.end(), word) - names.begin());
  };
  k.get = [member, names](const Spec& s) { return names.at(size_t(s.*member)); };
  return k;
}

// What --help-deck, the registry and the docs show of a key, whatever its section's type.
// type: "choice" (one of choices), "list" (a list of them), or a type name with its range rule.
struct KeyInfo {
  std::string section, name, type, default_value, unit, doc;
  std::vector<std::string> choices;
};

// The default of a member as docs show it.
inline std::string default_text(double x) {
  char s[40];
  std::snprintf(s, sizeof s, "%g", x);
  std::string t = s;  // 1e-06 -> 1e-6
  for (const char* e : {"e-0", "e+0"})
    if (const size_t at = t.find(e); at != std::string::npos) t.erase(at + 2, 1);
  return t;
}
inline std::string default_text(int x) { return std::to_string(x); }
inline std::string default_text(bool x) { return x ? "true" : "false"; }
inline std::string default_text(const std::string& x) { return x; }
template <typename T, size_t N>
std::string default_text(const std::array<T, N>& x);
template <typename T>
std::string default_text(const std::vector<T>& xs) {
  std::string t;
  for (const T& x : xs) t += (t.empty() ? "" : ", ") + default_text(x);
  return "[" + t + "]";
}
template <typename T, size_t N>
std::string default_text(const std::array<T, N>& x) {
  return default_text(std::vector<T>(x.begin(), x.end()));
}
inline const char* type_name(double) { return "number"; }
inline const char* type_name(int) { return "integer"; }
inline const char* type_name(bool) { return "bool"; }
inline const char* type_name(const std::string&) { return "string"; }
inline const char* type_name(const Array3&) { return "vec3"; }
inline const char* type_name(const std::array<double, 2>&) { return "2 numbers"; }
inline const char* type_name(const std::array<int, 2>&) { return "2 integers"; }
inline const char* type_name(const std::array<int, 3>&) { return "3 integers"; }
inline const char* type_name(const std::vector<int>&) { return "list of integers"; }
inline const char* type_name(const std::vector<std::string>&) { return "list of strings"; }

template <typename Spec>
std::vector<KeyInfo> key_infos(const std::string& section, const std::vector<DeckKey<Spec>>& keys) {
  const Spec defaults = Spec();  // not `defaults{}`: GCC 12 then warns of a nested string (a region's curve.file) maybe uninitialized
  std::vector<KeyInfo> out;
  for (const DeckKey<Spec>& k : keys) {
    KeyInfo i{section, k.name, *k.type_text ? k.type_text : "choice", k.default_text, k.unit, k.doc, k.choices};
    std::string value = k.get ? k.get(defaults) : "";
    bool several = false;  // a list or a fixed number of values: the range applies to each
    std::visit(
        [&](const auto& field) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(field)>, std::monostate>) {
            Spec copy = defaults;
            const auto& member = field(copy);
            value = default_text(member);
            using T = std::decay_t<decltype(member)>;
            several = !std::is_same_v<T, std::string> && !std::is_arithmetic_v<T>;
            if (k.choices.empty()) i.type = type_name(member);
            else if (std::is_same_v<T, std::vector<std::string>>) i.type = "list";  // of the choices
          }
        },
        k.member.field);
    std::string only;  // "`a`, `b`": the choices it is a key of, or the map it is in
    for (const std::string& w : k.only_for) only += (only.empty() ? "`" : ", `") + w + "`";
    const std::string name = k.name;
    if (only.empty() && name.find('.') != std::string::npos) only = "`" + name.substr(0, name.rfind('.')) + "`";
    if (i.default_value.empty()) i.default_value = k.required ? only.empty() ? "required" : "required with " + only : value;
    if (!k.only_for.empty() && !k.required) i.doc = "with " + only + " only: " + i.doc;
    const std::string rule = k.range.rule(true);
    if (!rule.empty()) i.type += k.range.nonzero ? ", nonzero" : (several ? ", each " : " ") + rule;
    out.push_back(i);
  }
  return out;
}

// Every declared section's keys, in the deck's order (app/deck_keys.cpp).
std::vector<KeyInfo> declared_deck_keys();

}  // namespace hyperqn
