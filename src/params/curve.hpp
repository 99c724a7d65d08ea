// A time curve c(t): a scalar function of time with its derivative, declared once with its deck keys
// (curve_keys()) for everything that varies in time: a motion's progress (geometry/motion.hpp: the
// motions of fixed regions, attachments' targets and colliders) and a load's magnitude. Three types
// cover a ramp, a hold, a sine and a table:
//   ramp:  0 until start, linear to 1 at end, held at 1 afterwards (a ramp then a hold);
//   sine:  offset + amplitude sin(2 pi frequency t + phase);
//   table: piecewise linear through points (t_i, v_i), t strictly increasing, holding v_0 before
//          t_0 and v_n after t_n (inline, or read from a CSV file by read_curve_table).
// A section's `curve` key is curve_key(); the deck reader's read_curve (app/deck_sections.hpp)
// reads its map. Pure math and a file reader: no PETSc, no MPI.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "params/deck_keys.hpp"

namespace hyperqn {

enum class CurveType { ramp, sine, table };
inline const std::vector<std::string> kCurveTypeNames = {"ramp", "sine", "table"};  // in the enum's order

struct Curve {
  bool given = false;                         // the deck gave one (read_curve sets it)
  CurveType type = CurveType::ramp;
  double start = 0, end = 0;                  // ramp: end > start
  double amplitude = 0, frequency = 0;        // sine: frequency > 0, in cycles per unit time
  double phase_deg = 0, offset = 0;           // sine
  std::vector<std::array<double, 2>> points;  // table: (t, v), at least 2, t strictly increasing
  std::string file;                           // table: the CSV file it was read from (resolved), or ""

  // c(t).
  double value(double t) const;
  // dc/dt as c reaches t (the derivative from the left): at a ramp's start or a table's first time
  // 0, at a ramp's end or a table's last time the slope that reached it, 0 after.
  double derivative(double t) const;
  // A bound of |c| over all times (ramp 1, sine |amplitude| + |offset|, table max |v_i|): the scale
  // of round-off in c.
  double magnitude() const;
};

// "" if points make a table (at least 2 points, times strictly increasing), else what is wrong
// with points[at], to follow the point's name in a message.
std::string curve_table_problem(const std::vector<std::array<double, 2>>& points, size_t& at);

// The points of a table in a CSV file: a row per point, "t, v" (spaces around the numbers
// allowed, blank lines skipped); the first line may be a header (any line that is not two
// numbers). Numbers are plain decimals within the limits of every number (params/key_range.hpp).
// Throws std::runtime_error naming the file and its line: unreadable, a row that is not two
// numbers, a table curve_table_problem refuses, more than kMaxCurveRows rows.
constexpr size_t kMaxCurveRows = 1000000;
std::vector<std::array<double, 2>> read_curve_table(const std::string& path);

// The keys of a curve's map (params/deck_keys.hpp): its type, then each type's own. `points` is
// read by read_curve, which also checks end > start and reads `file`.
inline const std::vector<DeckKey<Curve>>& curve_keys() {
  using C = Curve;
  const auto of = [](DeckKey<C> k, std::vector<std::string> types, bool required) {
    return only_with(k, "type", types, required);
  };
  static const std::vector<DeckKey<C>> keys = {
      needed(enum_key<C>("type", &C::type, kCurveTypeNames,
                         "`ramp`: 0 until `start`, linear to 1 at `end`, held at 1 after; `sine`: `offset` + "
                         "`amplitude`·sin(360°·`frequency`·t + `phase`); `table`: linear between its points, its "
                         "first value before them and its last after")),
      of({"start", &C::start, "the ramp leaves 0 at this time", at_least(0, "a time")}, {"ramp"}, false),
      of({"end", &C::end, "the ramp reaches 1 at this time, after `start`, and holds it", above(0, "a time")}, {"ramp"},
         true),
      of({"amplitude", &C::amplitude, "the sine's amplitude"}, {"sine"}, true),
      of({"frequency", &C::frequency, "cycles per unit time", above(0)}, {"sine"}, true),
      of({"phase", &C::phase_deg, "the sine's phase at t = 0", {}, {}, "degrees"}, {"sine"}, false),
      of({"offset", &C::offset, "the value the sine oscillates about"}, {"sine"}, false),
      of(custom_key<C>("points", "list of [t, v]",
                       "the table's points: at least 2, times strictly increasing (or give `file`)", "none"),
         {"table"}, false),
      of({"file", &C::file,
          "or a CSV file of the points, relative to the deck's directory: a row `t, v` per point, the first line "
          "may be a header",
          {}, {}, "", "none"},
         {"table"}, false),
  };
  return keys;
}

// The key `curve` of a section whose value is a curve's map (read_curve in app/deck_sections.hpp
// reads it): one table of the curve's keys, on docs/deck-scene.md, linked from every section that takes one.
template <typename Spec>
DeckKey<Spec> curve_key(const char* doc, const char* default_text) {
  return custom_key<Spec>("curve", "map: [`curve`](deck-scene.md#curve)", doc, default_text);
}

}  // namespace hyperqn
