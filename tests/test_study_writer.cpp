// The study's files (io/study_writer.hpp): a trajectory point's status of any length is one CSV
// field on one row (a guardrail's reason of 900+ characters was cut at 767 characters, its newline
// lost, and the next row glued to it), and study.h5 appears only once the study finishes (held in
// memory: a full disk fails hyperqn's own write, not HDF5's close).
#include "io/study_writer.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "check.hpp"

static std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  namespace fs = std::filesystem;
  char name[] = "/tmp/hyperqn_study_XXXXXX";
  const std::string dir = mkdtemp(name);
  {
    hyperqn::StudyWriter out(dir, 0);
    std::string reason = "diverged: the load step moved a vertex far, static: either the load, a support, or";
    while (reason.size() < 1000) reason += " a, long, explanation";
    reason += "\nof two lines";
    hyperqn::TrajectoryPoint stopped{"lbfgs", 2, 0.5, 20, NAN, NAN, reason};
    hyperqn::TrajectoryPoint next{"newton", 2, 0.7, 6, 1e-9, 1e-10, "ok"};
    out.add(stopped);
    out.add(next);
    CHECK(!fs::exists(dir + "/study.h5"));  // in memory until finish
    out.finish();
    out.check(MPI_COMM_WORLD);
  }
  const std::vector<std::string> rows = lines_of(dir + "/trajectory.csv");
  CHECK(rows.size() == 3);  // the header and one row per point
  for (const std::string& row : rows) CHECK(std::count(row.begin(), row.end(), ',') == 6);
  CHECK(rows.size() == 3 && rows[1].size() > 1000 && rows[1].rfind("lbfgs,2,", 0) == 0);
  CHECK(rows.size() == 3 && rows[1].find("a; long; explanation") != std::string::npos &&
        rows[1].find(" of two lines") != std::string::npos);
  CHECK(rows.size() == 3 && rows[2].rfind("newton,2,", 0) == 0 && rows[2].substr(rows[2].size() - 3) == ",ok");
  CHECK(fs::exists(dir + "/study.h5") && fs::file_size(dir + "/study.h5") > 0);
  fs::remove_all(dir);
  const int status = check::summary("test_study_writer");
  MPI_Finalize();
  return status;
}
