// How text read from a file (a mesh's token, a curve table's row) is quoted in a message.
#pragma once
#include <cstddef>
#include <string>

namespace hyperqn {

// Text from a file (a mesh's token, a curve table's row) as a message quotes it: a control
// character as '?', and past 64 characters cut with "...", so that a binary or hostile file cannot
// write escapes or megabytes to the terminal.
inline std::string shown_text(const char* begin, const char* end) {
  constexpr std::ptrdiff_t kShown = 64;
  std::string s(begin, end - begin > kShown ? begin + kShown : end);
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return end - begin > kShown ? s + "..." : s;
}
inline std::string shown_text(const std::string& s) { return shown_text(s.data(), s.data() + s.size()); }

}  // namespace hyperqn
