#include "io/base64.hpp"

#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define HYPERQN_BASE64_AVX2 1
#endif

namespace hyperqn {

namespace {

const char kTable[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

// Writes the base64 of n bytes at o (4 * ceil(n / 3) characters): a group of 3 bytes at a time,
// each 12 bits through a table of character pairs, then the padded tail.
void encode_scalar(char* o, const unsigned char* d, size_t n) {
  static const std::vector<char> pairs = [] {  // 4096 pairs: the characters of 12 bits
    std::vector<char> p(2 * 4096);
    for (int v = 0; v < 4096; ++v) {
      p[2 * v] = kTable[v >> 6];
      p[2 * v + 1] = kTable[v & 63];
    }
    return p;
  }();
  size_t i = 0;
  for (; i + 3 <= n; i += 3, o += 4) {
    const uint32_t v = (uint32_t(d[i]) << 16) | (uint32_t(d[i + 1]) << 8) | d[i + 2];
    std::memcpy(o, &pairs[2 * (v >> 12)], 2);
    std::memcpy(o + 2, &pairs[2 * (v & 4095)], 2);
  }
  if (i < n) {  // 1 or 2 bytes left: padded with '='
    const uint32_t v = (uint32_t(d[i]) << 16) | (i + 1 < n ? uint32_t(d[i + 1]) << 8 : 0);
    o[0] = kTable[(v >> 18) & 63];
    o[1] = kTable[(v >> 12) & 63];
    o[2] = i + 1 < n ? kTable[(v >> 6) & 63] : '=';
    o[3] = '=';
  }
}

#ifdef HYPERQN_BASE64_AVX2
// 24 bytes -> 32 characters per step (W. Muła and D. Lemire, "Faster Base64 Encoding and Decoding
// Using AVX2 Instructions", ACM TOW 2018): each 128-bit lane takes 12 bytes, spreads every 3 of
// them over 4 bytes, moves the four 6-bit values into the low bits of those bytes by two
// multiplies, and turns each value into its character by one table lookup of the offset to add.
// Returns the bytes encoded (a multiple of 24; the caller encodes the rest).
__attribute__((target("avx2"))) size_t encode_avx2(char* o, const unsigned char* d, size_t n) {
  const __m256i spread = _mm256_setr_epi8(1, 0, 2, 1, 4, 3, 5, 4, 7, 6, 8, 7, 10, 9, 11, 10,  //
                                          1, 0, 2, 1, 4, 3, 5, 4, 7, 6, 8, 7, 10, 9, 11, 10);
  const __m256i offsets = _mm256_setr_epi8('a' - 26, '0' - 52, '0' - 52, '0' - 52, '0' - 52, '0' - 52, '0' - 52,
                                           '0' - 52, '0' - 52, '0' - 52, '0' - 52, '+' - 62, '/' - 63, 'A', 0, 0,
                                           'a' - 26, '0' - 52, '0' - 52, '0' - 52, '0' - 52, '0' - 52, '0' - 52,
                                           '0' - 52, '0' - 52, '0' - 52, '0' - 52, '+' - 62, '/' - 63, 'A', 0, 0);
  size_t i = 0;
  // Each step reads 16 bytes at d + i + 12: 28 bytes from i, 4 beyond the 24 it encodes.
  for (; i + 28 <= n; i += 24, o += 32) {
    const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(d + i));
    const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(d + i + 12));
    __m256i in = _mm256_inserti128_si256(_mm256_castsi128_si256(lo), hi, 1);
    in = _mm256_shuffle_epi8(in, spread);  // per 3 bytes a b c: b a c b
    // The 6-bit values: bits of "b a c b" to the low 6 bits of each byte.
    const __m256i t0 = _mm256_and_si256(in, _mm256_set1_epi32(0x0fc0fc00));
    const __m256i t1 = _mm256_mulhi_epu16(t0, _mm256_set1_epi32(0x04000040));
    const __m256i t2 = _mm256_and_si256(in, _mm256_set1_epi32(0x003f03f0));
    const __m256i t3 = _mm256_mullo_epi16(t2, _mm256_set1_epi32(0x01000010));
    const __m256i values = _mm256_or_si256(t1, t3);
    // The offset to add: 0-25 'A', 26-51 'a' - 26, 52-61 '0' - 52, 62 '+' - 62, 63 '/' - 63; the
    // lookup index is value - 51 (saturated at 0), 13 for values below 26.
    __m256i index = _mm256_subs_epu8(values, _mm256_set1_epi8(51));
    const __m256i below26 = _mm256_cmpgt_epi8(_mm256_set1_epi8(26), values);
    index = _mm256_or_si256(index, _mm256_and_si256(below26, _mm256_set1_epi8(13)));
    const __m256i chars = _mm256_add_epi8(_mm256_shuffle_epi8(offsets, index), values);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(o), chars);
  }
  return i;
}

bool has_avx2() {
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
}
#endif

}  // namespace

void append_base64_scalar(std::string& out, const char* data, size_t n) {
  const size_t at = out.size();
  out.resize(at + 4 * ((n + 2) / 3));
  encode_scalar(&out[at], reinterpret_cast<const unsigned char*>(data), n);
}

void append_base64(std::string& out, const char* data, size_t n) {
  const size_t at = out.size();
  out.resize(at + 4 * ((n + 2) / 3));
  char* o = &out[at];
  const auto* d = reinterpret_cast<const unsigned char*>(data);
  size_t done = 0;
#ifdef HYPERQN_BASE64_AVX2
  if (has_avx2()) done = encode_avx2(o, d, n);
#endif
  encode_scalar(o + done / 3 * 4, d + done, n - done);
}

}  // namespace hyperqn
