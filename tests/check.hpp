// Minimal assertion helpers for the unit-test programs: each failed check prints its place
// and the program exits non-zero at the end (ctest reports it failed).
#pragma once
#include <cmath>
#include <cstdio>
#include <string>

namespace check {
inline int& failures() { static int n = 0; return n; }
inline int& checks() { static int n = 0; return n; }

inline void report(bool ok, const char* file, int line, const std::string& what) {
  ++checks();
  if (!ok) {
    ++failures();
    std::fprintf(stderr, "%s:%d: FAILED: %s\n", file, line, what.c_str());
  }
}
// Prints the tally and returns the process exit code.
inline int summary(const char* name) {
  std::printf("%s: %d checks, %d failed\n", name, checks(), failures());
  return failures() == 0 && checks() > 0 ? 0 : 1;
}
}  // namespace check

#define CHECK(cond) check::report((cond), __FILE__, __LINE__, #cond)
#define CHECK_MSG(cond, msg) check::report((cond), __FILE__, __LINE__, std::string(#cond) + " -- " + (msg))
// |a - b| <= tol
#define CHECK_NEAR(a, b, tol)                                                                \
  do {                                                                                       \
    double a_ = (a), b_ = (b);                                                               \
    check::report(std::fabs(a_ - b_) <= (tol), __FILE__, __LINE__,                            \
                  std::string(#a " ~ " #b ": ") + std::to_string(a_) + " vs " + std::to_string(b_)); \
  } while (0)
