#include "mesh/text_tokens.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "params/key_range.hpp"
#include "mesh/input_error.hpp"

namespace hyperqn {

std::string read_text_file(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw InputError(path, 0, "", std::string("cannot open mesh file: ") + std::strerror(errno));
  std::string text;
  char chunk[1 << 16];
  size_t n;
  while ((n = std::fread(chunk, 1, sizeof chunk, f)) > 0) text.append(chunk, n);
  const bool failed = std::ferror(f);
  const int err = errno;
  std::fclose(f);
  if (failed) throw InputError(path, 0, "", std::string("cannot read mesh file: ") + std::strerror(err));
  return text;
}

static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

bool Tokenizer::next(Token& t) {
  skip_blank();
  if (p_ == end_) return false;
  t.begin = p_;
  t.line = line_;
  while (p_ != end_ && !is_space(*p_) && !is_comment(*p_)) ++p_;
  t.end = p_;
  last_line_ = line_;
  return true;
}

void Tokenizer::skip_blank() {
  while (p_ != end_) {
    if (*p_ == '\n') {
      ++line_;
      ++p_;
    } else if (is_space(*p_)) {
      ++p_;
    } else if (is_comment(*p_)) {
      while (p_ != end_ && *p_ != '\n') ++p_;
    } else {
      return;
    }
  }
}

// [+-] digits [. digits] [(e|E) [+-] digits], with digits on at least one side of the point.
static bool is_decimal(const char* p, const char* end) {
  auto digits = [&] {
    const char* start = p;
    while (p != end && *p >= '0' && *p <= '9') ++p;
    return p != start;
  };
  if (p != end && (*p == '+' || *p == '-')) ++p;
  bool mantissa = digits();
  if (p != end && *p == '.') {
    ++p;
    mantissa = digits() || mantissa;
  }
  if (!mantissa) return false;
  if (p != end && (*p == 'e' || *p == 'E')) {
    ++p;
    if (p != end && (*p == '+' || *p == '-')) ++p;
    if (!digits()) return false;
  }
  return p == end;
}

static bool strtod_reads(const Token& t, double& v) {
  char* e = nullptr;
  v = std::strtod(t.begin, &e);
  return e == t.end && e != t.begin;
}

bool parse_double(const Token& t, double& v) { return is_decimal(t.begin, t.end) && strtod_reads(t, v); }

std::string number_note(const Token& t) {
  double v;
  if (is_decimal(t.begin, t.end) || !strtod_reads(t, v)) return "";
  return std::isfinite(v) ? " (hexadecimal: numbers in mesh files are plain decimals)"
                          : " (not finite: numbers in mesh files are plain decimals)";
}

void check_coordinate(const std::string& path, const std::string& section, const Token& t, double x,
                      const std::string& what) {
  const std::string rule = number_limits_problem(x);
  if (!rule.empty()) throw InputError(path, t.line, section, what + " '" + t.str() + "' must be " + rule);
}

bool parse_int(const Token& t, long long& v) {
  char* e = nullptr;
  errno = 0;
  v = std::strtoll(t.begin, &e, 10);
  return e == t.end && e != t.begin && errno == 0;
}

MeditRecord medit_record(const Token& t) {
  static const struct { const char* name; MeditRecord record; } table[] = {
      {"Triangles", {4, 3}},        {"Tetrahedra", {5, 4}},       {"Edges", {3, 2}},
      {"Corners", {1, 1}},          {"RequiredVertices", {1, 1}}, {"RequiredEdges", {1, 0}},
      {"RequiredTriangles", {1, 0}}, {"Ridges", {1, 0}},           {"Quadrilaterals", {5, 4}},
      {"Hexahedra", {9, 8}},        {"Prisms", {7, 6}},           {"Normals", {3, 0}},
      {"Tangents", {3, 0}},         {"NormalAtVertices", {2, 1}}, {"TangentAtVertices", {2, 1}}};
  for (const auto& s : table)
    if (t.is(s.name)) return s.record;
  return {};
}

void check_medit_version(const std::string& path, const Token& value, long long version) {
  if (version < 1 || version > 4)
    throw InputError(path, value.line, "MeshVersionFormatted",
                     "unknown version " + value.str() + " (Medit ASCII files are versions 1, 2, 3 or 4)");
}

void SkippedIndices::add(const std::string& section, long long record, const Token& t, long long index) {
  if (index < 1)
    throw InputError(path_, t.line, section, "record " + std::to_string(record) + ": vertex index " + t.str() +
                                                 " is out of range (indices start at 1)");
  if (index > largest_) {
    largest_ = index;
    section_ = section;
    text_ = t.str();
    record_ = record;
    line_ = t.line;
  }
}

void SkippedIndices::check(long long vertices) const {
  if (largest_ > vertices)
    throw InputError(path_, line_, section_, "record " + std::to_string(record_) + ": vertex index " + text_ +
                                                 " is out of range 1.." + std::to_string(vertices));
}

}  // namespace hyperqn
