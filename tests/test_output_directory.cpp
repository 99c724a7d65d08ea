// Clearing an earlier run's output (io/output_directory.hpp): a series' index goes before what it
// lists, so that a run killed while it clears leaves no index of files already gone (the fault
// suite's reuse trial found a .pvd listing frames removed before it). And the lock that keeps
// a second run out of a directory in use (OutputLock): two runs at once removed each other's files.
#include "io/output_directory.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "check.hpp"

using hyperqn::removal_order;

// Two locks of one directory in one process conflict as two processes' do (flock: one per open file).
static void check_lock() {
  namespace fs = std::filesystem;
  char name[] = "/tmp/hyperqn_lock_XXXXXX";
  const std::string dir = mkdtemp(name);
  const std::string file = dir + "/" + hyperqn::OutputLock::kFileName;
  CHECK(hyperqn::output_directory_in_use(MPI_COMM_WORLD, dir).empty());  // no lock file yet: none made
  CHECK(!fs::exists(file));
  auto first = std::make_unique<hyperqn::OutputLock>();
  CHECK(first->take(MPI_COMM_WORLD, dir, "deck first.yaml").empty());
  CHECK(fs::exists(file));
  const std::string pid = "(pid " + std::to_string(getpid()) + " on host ";
  hyperqn::OutputLock second;
  const std::string refused = second.take(MPI_COMM_WORLD, dir, "deck second.yaml");
  CHECK(refused.find("the output directory " + dir + " is in use by another run " + pid) == 0);
  CHECK(refused.find("deck first.yaml") != std::string::npos);
  CHECK(hyperqn::output_directory_in_use(MPI_COMM_WORLD, dir) == refused);
  first.reset();  // released, its file removed
  CHECK(!fs::exists(file));
  CHECK(hyperqn::output_directory_in_use(MPI_COMM_WORLD, dir).empty());
  CHECK(second.take(MPI_COMM_WORLD, dir, "deck second.yaml").empty());
  CHECK(fs::exists(file));
  fs::remove_all(dir);
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  check_lock();
  for (const char* index : {"bar.pvd", "bar.xdmf", "bar_00003.pvtu"})
    for (const char* listed : {"bar_00003.vtu", "bar_00003_1.vtu", "bar.h5", "iterations.csv", "config.yaml"})
      CHECK(removal_order(index) < removal_order(listed));
  CHECK(removal_order("bar.pvd") < removal_order("bar_00003.pvtu"));  // the .pvd lists the .pvtu
  CHECK(removal_order("bar.xdmf") < removal_order("bar.h5"));
  // As clear_previous_run sorts a directory's listing: every index first, whatever the listing's order.
  std::vector<std::string> names{"bar_00001.vtu", "bar_00000.pvtu", "bar.pvd", "run.h5", "run.xdmf", "summary.json"};
  std::stable_sort(names.begin(), names.end(),
                   [](const std::string& a, const std::string& b) { return removal_order(a) < removal_order(b); });
  CHECK(names[0] == "bar.pvd" && names[1] == "run.xdmf" && names[2] == "bar_00000.pvtu");
  // Frames of 100000 and on (time.frames goes to 1e8) are frames too: a rerun left them behind.
  for (const char* frame : {"bar_00007.vtu", "bar_100000.vtu", "bar_100000000.pvtu", "bar_123456_1.vtu"})
    CHECK(hyperqn::is_run_output(".", frame));
  for (const char* other : {"bar_1234.vtu", "bar_1000000000.vtu", "bar.vtu", "notes.csv"}) CHECK(!hyperqn::is_run_output(".", other));
  const int status = check::summary("test_output_directory");
  MPI_Finalize();
  return status;
}
