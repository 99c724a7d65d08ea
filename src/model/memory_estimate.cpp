#include "model/memory_estimate.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "mesh/input_error.hpp"

namespace hyperqn {

double estimated_run_bytes(int64_t vertices, int ranks, bool factored) {
  const double mb = 1024.0 * 1024.0, v = double(vertices);
  return 50 * mb * ranks + 5300 * v + (factored ? 125 * std::pow(v, 4.0 / 3.0) : 0.0);
}

double memory_limit_bytes(std::string* source) {
  if (const char* env = std::getenv("HYPERQN_MEMORY_LIMIT_MB")) {
    char* end = nullptr;
    const double limit = std::strtod(env, &end);
    if (end == env || *end != '\0' || !(limit > 0) || !std::isfinite(limit))
      throw InputError("environment variable HYPERQN_MEMORY_LIMIT_MB: must be a number of MB > 0, got '" +
                       std::string(env) + "'");
    *source = "HYPERQN_MEMORY_LIMIT_MB";
    return limit * 1024 * 1024;
  }
  std::FILE* f = std::fopen("/proc/meminfo", "r");
  if (!f) return 0;
  char line[256];
  double kb = 0;
  while (std::fgets(line, sizeof line, f))
    if (std::sscanf(line, "MemAvailable: %lf kB", &kb) == 1) break;
  std::fclose(f);
  *source = "MemAvailable in /proc/meminfo";
  return kb * 1024;
}

}  // namespace hyperqn
