#include "io/study_writer.hpp"

#include <algorithm>

#include "io/hdf5_file.hpp"

#include <map>
#include <stdexcept>

namespace hyperqn {

namespace {

// The file's path, for messages (rank 0 writes one study.h5).
std::string g_h5_path;

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("cannot write " + g_h5_path + ": " + what + ": " + hdf5_error_reason());
}

void write_dataset(hid_t group, const char* name, const std::vector<double>& v) {
  hsize_t n = v.size();
  hid_t space = H5Screate_simple(1, &n, nullptr);
  hid_t set = space < 0 ? -1 : H5Dcreate2(group, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const bool ok = set >= 0 && (n == 0 || H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) >= 0);
  if (set >= 0) H5Dclose(set);
  if (space >= 0) H5Sclose(space);
  if (!ok) fail(name);
}

void write_attribute(hid_t obj, const char* name, double value) {
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = space < 0 ? -1 : H5Acreate2(obj, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
  const bool ok = attr >= 0 && H5Awrite(attr, H5T_NATIVE_DOUBLE, &value) >= 0;
  if (attr >= 0) H5Aclose(attr);
  if (space >= 0) H5Sclose(space);
  if (!ok) fail(name);
}

// Opens group `path` below `parent`, creating it if needed.
hid_t group(hid_t parent, const std::string& path) {
  hid_t g = H5Lexists(parent, path.c_str(), H5P_DEFAULT) > 0 ? H5Gopen2(parent, path.c_str(), H5P_DEFAULT)
                                                             : H5Gcreate2(parent, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) fail("group " + path);
  return g;
}

void open_csv(LineFile& file, const std::string& path, const char* header) {
  file.open(path);
  file.add(std::string(header) + "\n");
  file.flush();
}

}  // namespace

StudyWriter::StudyWriter(const std::string& outdir, int rank) {
  if (rank != 0) return;
  active_ = true;
  open_csv(study_csv_, outdir + "/study.csv", "solver,frame,iteration,time_s,energy,grad_norm,rel_error,evaluations");
  open_csv(trajectory_csv_, outdir + "/trajectory.csv", "solver,frame,time_s,iterations,rms_error,rel_rms_error,status");
  h5_path_ = outdir + "/study.h5";
  g_h5_path = h5_path_;
  silence_hdf5();
  // In memory until finish() writes its image (as Hdf5File does): a full disk fails our write, not
  // HDF5's, which left a file it could not close, and crashed at MPI_Finalize closing it again.
  const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  // STRONG: closing the file closes the groups an interrupted add left open.
  if (fapl >= 0 && H5Pset_fapl_core(fapl, 1 << 20, false) >= 0 && H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG) >= 0)
    h5_ = H5Fcreate(h5_path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
  if (fapl >= 0) H5Pclose(fapl);
  if (h5_ < 0) throw std::runtime_error("cannot write " + h5_path_ + ": " + hdf5_error_reason());
}

void StudyWriter::add(const StudyCurve& c) {
  if (!active_ || !error_.empty()) return;
  try {
    add_curve(c);
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

void StudyWriter::check(MPI_Comm comm) const { throw_if_any_failed(comm, error_); }

void StudyWriter::add_curve(const StudyCurve& c) {
  std::vector<double> it, t, e, gn, rel, ev;
  char line[512];
  for (const IterationRecord& r : c.iterations) {
    std::snprintf(line, sizeof line, "%s,%d,%d,%.9e,%.17g,%.17g,%.17g,%d\n", c.solver.c_str(), c.frame,
                  (int)r.iteration, r.time_s, r.energy, r.grad_norm, c.rel_error(r), (int)r.evaluations);
    study_csv_.add(line);
    it.push_back(r.iteration);
    t.push_back(r.time_s);
    e.push_back(r.energy);
    gn.push_back(r.grad_norm);
    rel.push_back(c.rel_error(r));
    ev.push_back(r.evaluations);
  }
  study_csv_.flush();
  char frame[32];
  std::snprintf(frame, sizeof frame, "frame_%05d", c.frame);
  hid_t frames = group(h5_, "frames"), f = group(frames, frame), g = group(f, c.solver);
  write_attribute(g, "g0", c.g0);
  write_attribute(g, "g_star", c.g_star);
  write_dataset(g, "iteration", it);
  write_dataset(g, "time_s", t);
  write_dataset(g, "energy", e);
  write_dataset(g, "grad_norm", gn);
  write_dataset(g, "rel_error", rel);
  write_dataset(g, "evaluations", ev);
  H5Gclose(g);
  H5Gclose(f);
  H5Gclose(frames);
}

void StudyWriter::add(const TrajectoryPoint& p) {
  if (!active_ || !error_.empty()) return;
  std::string status = p.status;
  std::replace(status.begin(), status.end(), ',', ';');  // one CSV field, on one line
  std::replace(status.begin(), status.end(), '\n', ' ');
  char numbers[256];  // the status after them at any length (a guardrail's reason runs to 800 characters)
  std::snprintf(numbers, sizeof numbers, "%s,%d,%.9e,%lld,%.17g,%.17g,", p.solver.c_str(), p.frame, p.time_s,
                p.iterations, p.rms_error, p.rel_rms_error);
  trajectory_csv_.add(numbers + status + "\n");
  try {
    trajectory_csv_.flush();
  } catch (const std::exception& e) {
    error_ = e.what();
  }
  trajectory_.push_back(p);
}

void StudyWriter::finish() {
  if (!active_ || !error_.empty()) return;
  try {
    finish_file();
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

void StudyWriter::finish_file() {
  std::map<std::string, std::vector<const TrajectoryPoint*>> by_solver;
  for (const TrajectoryPoint& p : trajectory_) by_solver[p.solver].push_back(&p);
  if (!by_solver.empty()) {
    hid_t traj = group(h5_, "trajectory");
    for (const auto& [solver, points] : by_solver) {
      std::vector<double> frame, t, its, rms, rel;
      for (const TrajectoryPoint* p : points) {
        frame.push_back(p->frame);
        t.push_back(p->time_s);
        its.push_back((double)p->iterations);
        rms.push_back(p->rms_error);
        rel.push_back(p->rel_rms_error);
      }
      hid_t g = group(traj, solver);
      write_dataset(g, "frame", frame);
      write_dataset(g, "time_s", t);
      write_dataset(g, "iterations", its);
      write_dataset(g, "rms_error", rms);
      write_dataset(g, "rel_rms_error", rel);
      H5Gclose(g);
    }
    H5Gclose(traj);
  }
  std::string image;
  const ssize_t size = H5Fflush(h5_, H5F_SCOPE_GLOBAL) < 0 ? -1 : H5Fget_file_image(h5_, nullptr, 0);
  if (size > 0) image.resize((size_t)size);
  const bool imaged = size > 0 && H5Fget_file_image(h5_, &image[0], image.size()) == size;
  const std::string reason = imaged ? "" : hdf5_error_reason();
  const herr_t closed = H5Fclose(h5_);  // in memory: it cannot fail for want of space
  h5_ = -1;
  active_ = false;
  if (!imaged || closed < 0) throw std::runtime_error("cannot write " + h5_path_ + ": " + reason);
  write_file_atomically(h5_path_, image);
}

StudyWriter::~StudyWriter() {
  if (h5_ >= 0) H5Fclose(h5_);  // finish() was not reached: nothing of study.h5 is written
}

}  // namespace hyperqn
