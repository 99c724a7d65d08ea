#include "io/study_writer.hpp"

#include <map>
#include <stdexcept>

namespace hyperqn {

namespace {

void write_dataset(hid_t group, const char* name, const std::vector<double>& v) {
  hsize_t n = v.size();
  hid_t space = H5Screate_simple(1, &n, nullptr);
  hid_t set = H5Dcreate2(group, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (set < 0) throw std::runtime_error(std::string("cannot write HDF5 dataset ") + name);
  if (n > 0) H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  H5Dclose(set);
  H5Sclose(space);
}

void write_attribute(hid_t obj, const char* name, double value) {
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(obj, name, H5T_NATIVE_DOUBLE, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attr, H5T_NATIVE_DOUBLE, &value);
  H5Aclose(attr);
  H5Sclose(space);
}

// Opens group `path` below `parent`, creating it if needed.
hid_t group(hid_t parent, const std::string& path) {
  hid_t g = H5Lexists(parent, path.c_str(), H5P_DEFAULT) > 0 ? H5Gopen2(parent, path.c_str(), H5P_DEFAULT)
                                                             : H5Gcreate2(parent, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (g < 0) throw std::runtime_error("cannot create HDF5 group " + path);
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
  open_csv(trajectory_csv_, outdir + "/trajectory.csv", "solver,frame,time_s,iterations,rms_error,rel_rms_error");
  h5_path_ = outdir + "/study.h5";
  h5_tmp_ = atomic_temporary(h5_path_);
  h5_ = H5Fcreate(h5_tmp_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (h5_ < 0) throw std::runtime_error("cannot create " + h5_path_);
}

void StudyWriter::add(const StudyCurve& c) {
  if (!active_) return;
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
  if (!active_) return;
  char line[512];
  std::snprintf(line, sizeof line, "%s,%d,%.9e,%lld,%.17g,%.17g\n", p.solver.c_str(), p.frame, p.time_s, p.iterations,
                p.rms_error, p.rel_rms_error);
  trajectory_csv_.add(line);
  trajectory_csv_.flush();
  trajectory_.push_back(p);
}

void StudyWriter::finish() {
  if (!active_) return;
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
  const herr_t closed = H5Fclose(h5_);
  h5_ = -1;
  active_ = false;
  if (closed < 0) throw std::runtime_error("cannot write " + h5_path_);
  commit_temporary(h5_tmp_, h5_path_);
}

StudyWriter::~StudyWriter() {
  if (h5_ >= 0) {  // finish() was not reached: the unfinished file never takes the name study.h5
    H5Fclose(h5_);
    std::remove(h5_tmp_.c_str());
  }
}

}  // namespace hyperqn
