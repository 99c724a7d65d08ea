#include "mesh/text_tokens.hpp"

#include <cerrno>
#include <cstdio>
#include <cstdlib>

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

bool parse_double(const Token& t, double& v) {
  char* e = nullptr;
  v = std::strtod(t.begin, &e);
  return e == t.end && e != t.begin;
}

bool parse_int(const Token& t, long long& v) {
  char* e = nullptr;
  errno = 0;
  v = std::strtoll(t.begin, &e, 10);
  return e == t.end && e != t.begin && errno == 0;
}

int medit_record_size(const Token& t) {
  static const struct { const char* name; int size; } table[] = {
      {"Triangles", 4},        {"Tetrahedra", 5},      {"Edges", 3},           {"Corners", 1},
      {"RequiredVertices", 1}, {"RequiredEdges", 1},   {"RequiredTriangles", 1}, {"Ridges", 1},
      {"Quadrilaterals", 5},   {"Hexahedra", 9},       {"Prisms", 7},          {"Normals", 3},
      {"Tangents", 3},         {"NormalAtVertices", 2}, {"TangentAtVertices", 2}};
  for (const auto& s : table)
    if (t.is(s.name)) return s.size;
  return 0;
}

}  // namespace hyperqn
