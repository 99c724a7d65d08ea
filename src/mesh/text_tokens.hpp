// Whitespace-separated tokens of a text mesh file, with their line numbers: what the Medit and
// Gmsh readers share so that their errors can name the line.
#pragma once
#include <cstring>
#include <string>
#include <utility>

#include "params/shown_text.hpp"

namespace hyperqn {

// Whole file in memory: real meshes are a few MB, and scanning a buffer is much faster than
// iostream extraction per token. Throws InputError naming the file if it cannot be read.
std::string read_text_file(const std::string& path);

struct Token {
  const char* begin = nullptr;
  const char* end = nullptr;
  int line = 0;
  // The token as messages quote it (shown_text).
  std::string str() const { return shown_text(begin, end); }
  bool is(const char* s) const {
    const size_t n = std::strlen(s);
    return size_t(end - begin) == n && std::memcmp(begin, s, n) == 0;
  }
};

// Splits the text into whitespace-separated tokens, counting lines; with a comment character
// ('#' for Medit), the rest of a line from it is skipped.
class Tokenizer {
 public:
  explicit Tokenizer(const std::string& text, char comment = '\0')
      : p_(text.data()), end_(text.data() + text.size()), comment_(comment) {}

  bool next(Token& t);
  // Line of the last token read: where an unexpected end of file is reported.
  int last_line() const { return last_line_; }

 private:
  void skip_blank();
  bool is_comment(char c) const { return comment_ != '\0' && c == comment_; }
  const char* p_;
  const char* end_;
  char comment_;
  int line_ = 1;
  int last_line_ = 1;
};

// The token is a whole number (strtod/strtoll stop at whitespace or at the comment character,
// so they cannot read past the token; the buffer is also NUL-terminated). Numbers are plain
// decimals (-1.5, 2e-3): strtod alone would also take "0x10" for 16, and inf and nan.
bool parse_double(const Token& t, double& v);
bool parse_int(const Token& t, long long& v);
// For a token parse_double refused that strtod reads (hexadecimal, inf, nan): why, as a note to
// append to a message; "" for any other token.
std::string number_note(const Token& t);
// A coordinate x read from t must be a number hyperqn takes (number_limits_problem,
// params/key_range.hpp: finite, 0 or between 1e-100 and 1e100 in magnitude); else an InputError
// naming path, t's line and section: "<what> '<t>' must be ...".
void check_coordinate(const std::string& path, const std::string& section, const Token& t, double x,
                      const std::string& what);

// A Medit section a reader may skip (Triangles, Tetrahedra, Edges, Corners, ...): tokens per
// record, the first `vertices` of them vertex indices; size 0 for any other keyword. A reader
// rejects what it neither reads nor skips, so that a typo or an unsupported section is reported
// instead of desynchronizing the stream. A reader checks the sections it reads first.
struct MeditRecord {
  int size = 0;
  int vertices = 0;
};
MeditRecord medit_record(const Token& t);

// MeshVersionFormatted: the ASCII Medit versions (1 to 4 differ only in the binary sizes);
// anything else is an InputError naming the file and the value's line.
void check_medit_version(const std::string& path, const Token& value, long long version);

// The vertex indices of the sections a Medit reader skips: each an integer >= 1 (checked as it is
// read) and at most the vertex count (checked at the end: Vertices may come later in the file).
class SkippedIndices {
 public:
  explicit SkippedIndices(std::string path) : path_(std::move(path)) {}
  void add(const std::string& section, long long record, const Token& t, long long index);
  void check(long long vertices) const;

 private:
  std::string path_, section_, text_;
  long long largest_ = 0, record_ = 0;
  int line_ = 0;
};

}  // namespace hyperqn
