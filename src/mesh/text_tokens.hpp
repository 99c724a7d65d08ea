// Whitespace-separated tokens of a text mesh file, with their line numbers: what the Medit and
// Gmsh readers share so that their errors can name the line.
#pragma once
#include <cstring>
#include <string>

namespace hyperqn {

// Whole file in memory: real meshes are a few MB, and scanning a buffer is much faster than
// iostream extraction per token. Throws InputError naming the file if it cannot be read.
std::string read_text_file(const std::string& path);

struct Token {
  const char* begin = nullptr;
  const char* end = nullptr;
  int line = 0;
  std::string str() const { return std::string(begin, end); }
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
// so they cannot read past the token; the buffer is also NUL-terminated).
bool parse_double(const Token& t, double& v);
bool parse_int(const Token& t, long long& v);

// Tokens per record of the Medit sections a reader may skip (Triangles, Tetrahedra, Edges,
// Corners, ...), 0 for any other keyword: a reader rejects what it neither reads nor skips, so
// that a typo or an unsupported section is reported instead of desynchronizing the stream.
// A reader checks the sections it reads first.
int medit_record_size(const Token& t);

}  // namespace hyperqn
