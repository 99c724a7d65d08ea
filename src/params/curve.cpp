#include "params/curve.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include "params/shown_text.hpp"
#include "params/key_range.hpp"

namespace hyperqn {

namespace {

bool before(const std::array<double, 2>& p, double t) { return p[0] < t; }
bool after(double t, const std::array<double, 2>& p) { return t < p[0]; }

// The shortest decimal that reads back as x: 0.1, not 0.10000000000000001.
std::string shortest(double x) {
  char s[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(s, sizeof s, "%.*g", digits, x);
    if (std::strtod(s, nullptr) == x) break;
  }
  return s;
}

}  // namespace

double Curve::value(double t) const {
  switch (type) {
    case CurveType::ramp:
      if (t <= start) return 0;
      if (t >= end) return 1;
      return (t - start) / (end - start);
    case CurveType::sine:
      return offset + amplitude * std::sin(2 * M_PI * frequency * t + phase_deg * M_PI / 180.0);
    case CurveType::table: {
      if (t <= points.front()[0]) return points.front()[1];
      if (t >= points.back()[0]) return points.back()[1];
      // The segment [t_i, t_i+1] with t_i <= t < t_i+1; (1 - s) a + s b is a at s = 0, b at s = 1.
      const auto next = std::upper_bound(points.begin(), points.end(), t, after);
      const std::array<double, 2>&a = next[-1], &b = next[0];
      const double s = (t - a[0]) / (b[0] - a[0]);
      return (1 - s) * a[1] + s * b[1];
    }
  }
  return 0;
}

double Curve::derivative(double t) const {
  switch (type) {
    case CurveType::ramp:
      return t > start && t <= end ? 1 / (end - start) : 0;
    case CurveType::sine: {
      const double w = 2 * M_PI * frequency;
      return amplitude * w * std::cos(w * t + phase_deg * M_PI / 180.0);
    }
    case CurveType::table: {
      if (t <= points.front()[0] || t > points.back()[0]) return 0;
      // The segment (t_i, t_i+1] that reaches t.
      const auto next = std::lower_bound(points.begin(), points.end(), t, before);
      const std::array<double, 2>&a = next[-1], &b = next[0];
      return (b[1] - a[1]) / (b[0] - a[0]);
    }
  }
  return 0;
}

double Curve::magnitude() const {
  switch (type) {
    case CurveType::ramp:
      return 1;
    case CurveType::sine:
      return std::fabs(amplitude) + std::fabs(offset);
    case CurveType::table: {
      double m = 0;
      for (const auto& p : points) m = std::max(m, std::fabs(p[1]));
      return m;
    }
  }
  return 0;
}

std::string curve_table_problem(const std::vector<std::array<double, 2>>& points, size_t& at) {
  at = 0;
  if (points.size() < 2)
    return "is a table of " + std::to_string(points.size()) + " point" + (points.size() == 1 ? "" : "s") +
           ": a table needs at least 2 (a constant is a table of 2 equal values)";
  for (at = 1; at < points.size(); ++at)
    if (!(points[at][0] > points[at - 1][0]))
      return "has the time " + shortest(points[at][0]) + ", not after the previous point's " +
             shortest(points[at - 1][0]) + ": a table's times increase strictly";
  return "";
}

std::vector<std::array<double, 2>> read_curve_table(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read the curve's table file '" + path + "'");
  const auto fail = [&](int line, const std::string& what) {
    throw std::runtime_error("'" + path + "' line " + std::to_string(line) + ": " + what);
  };
  const auto trim = [](const std::string& s) {
    const size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
    return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
  };
  // A plain decimal (no hexadecimal), all of the field; nan and inf parse, and are refused below.
  const auto number = [](std::string field, double& x) {
    if (!field.empty() && field[0] == '+') field.erase(0, 1);
    const auto [end, err] = std::from_chars(field.data(), field.data() + field.size(), x);
    return !field.empty() && err == std::errc() && end == field.data() + field.size();
  };
  std::vector<std::array<double, 2>> points;
  std::vector<int> lines;
  std::string text;
  bool first = true;
  for (int line = 1; std::getline(in, text); ++line) {
    text = trim(text);
    if (text.empty()) continue;
    const size_t comma = text.find(',');
    std::array<double, 2> p{0, 0};
    const bool two_numbers = comma != std::string::npos && text.find(',', comma + 1) == std::string::npos &&
                             number(trim(text.substr(0, comma)), p[0]) && number(trim(text.substr(comma + 1)), p[1]);
    if (!two_numbers) {
      if (first) {  // a header
        first = false;
        continue;
      }
      fail(line, "expected a row 't, v' of two numbers, got '" + shown_text(text) + "'");
    }
    first = false;
    for (int i = 0; i < 2; ++i)
      if (const std::string rule = number_limits_problem(p[i]); !rule.empty())
        fail(line, std::string(i ? "the value" : "the time") + " must be " + rule + ", got '" +
                       shown_text(trim(i ? text.substr(comma + 1) : text.substr(0, comma))) + "'");
    if (points.size() == kMaxCurveRows) fail(line, "more than " + std::to_string(kMaxCurveRows) + " rows");
    points.push_back(p);
    lines.push_back(line);
  }
  if (in.bad()) throw std::runtime_error("cannot read the curve's table file '" + path + "'");
  size_t at = 0;
  if (const std::string problem = curve_table_problem(points, at); !problem.empty()) {
    if (points.size() < 2) throw std::runtime_error("'" + path + "' " + problem);
    fail(lines[at], "the row " + problem);
  }
  return points;
}

}  // namespace hyperqn
