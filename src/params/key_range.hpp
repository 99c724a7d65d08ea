// A deck key's allowed numbers (KeyRange), in the lowest layer: the material registry
// (materials/material_factory.hpp) declares its models' keys with them, and params/deck_keys.hpp every
// other section's.
#pragma once
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

namespace hyperqn {

// Every number hyperqn reads, a deck's value or a mesh or surface file's coordinate, is finite and
// 0 or between these in magnitude: larger values overflow the energies, smaller ones (subnormal
// ones among them) underflow as they are multiplied. "" if x is one, else what it must be, to
// follow "must be" in a message.
constexpr double kLargestNumber = 1e100, kSmallestNumber = 1e-100;
// zero_allowed false: a key that refuses 0, whose message must not offer it.
inline std::string number_limits_problem(double x, bool zero_allowed = true) {
  if (!std::isfinite(x)) return "finite";
  if (std::fabs(x) > kLargestNumber) return "at most 1e100 in magnitude (larger values overflow the energies)";
  if (x != 0 && std::fabs(x) < kSmallestNumber)
    return std::string(zero_allowed ? "0 or " : "") +
           "at least 1e-100 in magnitude (smaller values, subnormal ones among them, underflow)";
  return "";
}

// A number's allowed values: lo .. hi, either end open or unbounded (infinite); `why` follows the
// rule in messages and docs. A vec3's range applies to each of its numbers, or (nonzero) to the
// vector as a whole.
struct KeyRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
  const char* why = "";
  bool nonzero = false;

  bool contains(double x) const {
    return (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  }
  // What a value must be, e.g. "> 0", ">= 1", "in [0, 1)", "<= 100000000", "" (anything).
  std::string rule(bool unicode = false) const {
    if (nonzero) return "a nonzero vector";
    const auto num = [](double x) {
      char s[32];
      std::snprintf(s, sizeof s, "%.15g", x);
      // A long power of ten reads better as one: 1e12, not 1000000000000.
      if (std::strlen(s) > 10 && x == std::pow(10.0, std::round(std::log10(x))))
        std::snprintf(s, sizeof s, "1e%d", (int)std::round(std::log10(x)));
      return std::string(s);
    };
    const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
    std::string r;
    if (has_lo && has_hi) {
      r = std::string("in ") + (lo_open ? "(" : "[") + num(lo) + ", " + num(hi) + (hi_open ? ")" : "]");
    } else if (has_lo) {
      r = std::string(lo_open ? "> " : unicode ? "≥ " : ">= ") + num(lo);
    } else if (has_hi) {
      r = std::string(hi_open ? "< " : unicode ? "≤ " : "<= ") + num(hi);
    }
    if (!r.empty() && *why) r += std::string(" (") + why + ")";
    return r;
  }
};

inline KeyRange at_least(double lo, const char* why = "") { return {lo, std::numeric_limits<double>::infinity(), false, false, why}; }
inline KeyRange above(double lo, const char* why = "") { return {lo, std::numeric_limits<double>::infinity(), true, false, why}; }
inline KeyRange between(double lo, double hi, const char* why = "") { return {lo, hi, false, false, why}; }
inline KeyRange nonzero_vector() {
  KeyRange r;
  r.nonzero = true;
  return r;
}

}  // namespace hyperqn
