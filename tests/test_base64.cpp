// Base64 of the .vtu pieces (io/base64.hpp): RFC 4648's test vectors; and the vectorized encoder
// (append_base64) and the 3-bytes-at-a-time one against a bit-by-bit reference, for every length
// from 0 to 300 at every start offset 0-7 of random bytes (so every tail of the 24-byte steps and
// every alignment), on a string that already holds text, and for all 256 byte values.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "check.hpp"
#include "io/base64.hpp"

using namespace hyperqn;

namespace {

// Bit by bit: 6 bits at a time from the front, '=' to a multiple of 4 characters.
std::string reference(const unsigned char* d, size_t n) {
  const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string s;
  for (size_t bit = 0; bit < 8 * n; bit += 6) {
    int v = 0;
    for (size_t b = bit; b < bit + 6; ++b) v = 2 * v + (b < 8 * n ? (d[b / 8] >> (7 - b % 8)) & 1 : 0);
    s += table[v];
  }
  while (s.size() % 4) s += '=';
  return s;
}

std::string encoded(const std::string& text, bool scalar) {
  std::string out;
  (scalar ? append_base64_scalar : append_base64)(out, text.data(), text.size());
  return out;
}

}  // namespace

int main() {
  const std::vector<std::pair<std::string, std::string>> rfc = {
      {"", ""}, {"f", "Zg=="}, {"fo", "Zm8="}, {"foo", "Zm9v"}, {"foob", "Zm9vYg=="}, {"fooba", "Zm9vYmE="},
      {"foobar", "Zm9vYmFy"}, {"foobarfoobarfoobarfoobarfoobar!", "Zm9vYmFyZm9vYmFyZm9vYmFyZm9vYmFyZm9vYmFyIQ=="}};
  for (const auto& [text, b64] : rfc) {
    CHECK_MSG(encoded(text, false) == b64, text);
    CHECK_MSG(encoded(text, true) == b64, text);
  }

  std::mt19937 rng(42);
  std::vector<unsigned char> bytes(320);
  for (unsigned char& b : bytes) b = static_cast<unsigned char>(rng());
  int mismatches = 0;
  for (size_t start = 0; start < 8; ++start)
    for (size_t n = 0; n <= 300; ++n) {
      const std::string want = "<x>" + reference(&bytes[start], n);
      for (bool scalar : {false, true}) {
        std::string out = "<x>";  // appended after text already there
        (scalar ? append_base64_scalar : append_base64)(out, reinterpret_cast<const char*>(&bytes[start]), n);
        mismatches += out != want;
      }
    }
  CHECK_MSG(mismatches == 0, std::to_string(mismatches) + " of 4816 encodings differ from the reference");

  std::vector<unsigned char> all(3 * 256);  // every byte value in each of the 3 positions of a group
  for (int v = 0; v < 256; ++v) all[v] = all[256 + (v + 85) % 256] = all[512 + (v + 170) % 256] = static_cast<unsigned char>(v);
  std::string out;
  append_base64(out, reinterpret_cast<const char*>(all.data()), all.size());
  CHECK(out == reference(all.data(), all.size()));
  return check::summary("test_base64");
}
