// Time curves (params/curve.hpp) and motions that follow one (geometry/motion.hpp): each type's
// values against its formula, its derivative against finite differences (central inside a piece,
// backward at a kink: the derivative is the one from the left), a table's interpolation, its ends and
// its holds, the CSV reader and its errors; a motion with a curve against moved() with tau = c(t),
// its velocity against finite differences and its pose.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>

#include "check.hpp"
#include "geometry/motion.hpp"
#include "params/curve.hpp"

using namespace hyperqn;
namespace fs = std::filesystem;
using Vec3 = Eigen::Vector3d;

namespace {

const double kStep = 1e-6;

// Central difference at t, or (backward) the second-order one-sided one from the left.
double central(const Curve& c, double t) { return (c.value(t + kStep) - c.value(t - kStep)) / (2 * kStep); }
double backward(const Curve& c, double t) {
  return (3 * c.value(t) - 4 * c.value(t - kStep) + c.value(t - 2 * kStep)) / (2 * kStep);
}

Curve ramp(double start, double end) {
  Curve c;
  c.given = true;
  c.type = CurveType::ramp;
  c.start = start;
  c.end = end;
  return c;
}
Curve table(std::vector<std::array<double, 2>> points) {
  Curve c;
  c.given = true;
  c.type = CurveType::table;
  c.points = std::move(points);
  return c;
}

void test_ramp() {
  const Curve c = ramp(0.5, 2.5);
  CHECK(c.value(0) == 0 && c.value(0.5) == 0 && c.value(2.5) == 1 && c.value(7) == 1);
  CHECK_NEAR(c.value(1.0), 0.25, 1e-15);
  CHECK(c.derivative(0.5) == 0 && c.derivative(2.5) == 0.5 && c.derivative(2.6) == 0 && c.derivative(0.2) == 0);
  for (double t : {0.7, 1.3, 2.4}) CHECK_NEAR(c.derivative(t), central(c, t), 1e-8);
  CHECK_NEAR(c.derivative(2.5), backward(c, 2.5), 1e-8);
  CHECK(c.magnitude() == 1);
}

void test_sine() {
  Curve c;
  c.given = true;
  c.type = CurveType::sine;
  c.amplitude = 0.3;
  c.frequency = 2.5;
  c.phase_deg = 30;
  c.offset = -0.1;
  for (double t : {0.0, 0.13, 0.4, 1.7}) {
    CHECK_NEAR(c.value(t), -0.1 + 0.3 * std::sin(2 * M_PI * 2.5 * t + M_PI / 6), 1e-15);
    CHECK_NEAR(c.derivative(t), central(c, t), 1e-7);
  }
  CHECK_NEAR(c.magnitude(), 0.4, 1e-16);
  // offset = amplitude, phase -90: 0 at t = 0, as a motion's curve must be (to round-off).
  c.offset = c.amplitude;
  c.phase_deg = -90;
  CHECK(std::fabs(c.value(0)) <= 1e-12 * c.magnitude());
  CHECK_NEAR(c.value(0.2), 0.6, 1e-15);  // half a period: the peak
}

void test_table() {
  const Curve c = table({{0, 0}, {1, 2}, {1.5, 2}, {3, -1}});
  // At its points exactly, held before and after.
  CHECK(c.value(-1) == 0 && c.value(0) == 0 && c.value(1) == 2 && c.value(1.5) == 2 && c.value(3) == -1 && c.value(9) == -1);
  CHECK_NEAR(c.value(0.25), 0.5, 1e-15);
  CHECK_NEAR(c.value(1.2), 2, 1e-15);
  CHECK_NEAR(c.value(2.0), 1, 1e-14);
  // The derivative from the left: the slope that reached t.
  CHECK(c.derivative(0) == 0 && c.derivative(-1) == 0 && c.derivative(3.5) == 0);
  CHECK(c.derivative(1) == 2 && c.derivative(1.5) == 0 && c.derivative(3) == -2);
  for (double t : {0.5, 1.2, 2.2}) CHECK_NEAR(c.derivative(t), central(c, t), 1e-8);
  for (double t : {1.0, 1.5, 3.0}) CHECK_NEAR(c.derivative(t), backward(c, t), 1e-8);
  CHECK(c.magnitude() == 2);
  // Bad tables.
  size_t at = 9;
  CHECK(curve_table_problem(c.points, at).empty());
  CHECK(curve_table_problem({{0, 1}}, at).find("at least 2") != std::string::npos && at == 0);
  const std::string equal = curve_table_problem({{0, 1}, {1, 1}, {1, 2}}, at);
  CHECK_MSG(at == 2 && equal.find("has the time 1, not after the previous point's 1") != std::string::npos, equal);
  const std::string back = curve_table_problem({{0, 1}, {0.1, 1}, {0.05, 2}}, at);
  CHECK_MSG(at == 2 && back.find("0.05, not after the previous point's 0.1") != std::string::npos, back);
}

// The message of read_curve_table(path) holds every fragment, or "" if it reads.
void expect_table_error(const fs::path& path, const std::string& text, const std::vector<std::string>& fragments) {
  std::ofstream(path) << text;
  std::string message;
  try {
    read_curve_table(path.string());
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  for (const std::string& f : fragments)
    CHECK_MSG(message.find(f) != std::string::npos, path.filename().string() + ": '" + f + "' not in '" + message + "'");
}

void test_csv(const fs::path& dir) {
  const fs::path good = dir / "good.csv";
  std::ofstream(good) << "time, value\r\n0, 0\r\n\r\n 0.5 ,1e-1\r\n+2,-3.25\r\n";
  const std::vector<std::array<double, 2>> points = read_curve_table(good.string());
  CHECK(points.size() == 3 && points[1][0] == 0.5 && points[1][1] == 0.1 && points[2][0] == 2 && points[2][1] == -3.25);
  std::ofstream(good) << "0,1\n1,2\n";  // no header
  CHECK(read_curve_table(good.string()).size() == 2);
  expect_table_error(dir / "one.csv", "t,v\n0,1\n", {"one.csv", "a table of 1 point"});
  expect_table_error(dir / "empty.csv", "t,v\n", {"empty.csv", "a table of 0 points"});
  expect_table_error(dir / "equal.csv", "t,v\n0,1\n1,2\n1,3\n", {"equal.csv' line 4", "not after the previous point's 1"});
  expect_table_error(dir / "words.csv", "t,v\n0,1\n1,x\n", {"words.csv' line 3", "expected a row 't, v' of two numbers", "'1,x'"});
  expect_table_error(dir / "three.csv", "0,1,2\n0,1,2\n", {"three.csv' line 2", "two numbers"});
  expect_table_error(dir / "nan.csv", "0,1\n1,nan\n", {"nan.csv' line 2", "the value must be finite, got 'nan'"});
  expect_table_error(dir / "inf.csv", "0,1\ninf,1\n", {"inf.csv' line 2", "the time must be finite, got 'inf'"});
  expect_table_error(dir / "huge.csv", "0,1\n1,1e200\n", {"huge.csv' line 2", "at most 1e100"});
  expect_table_error(dir / "hex.csv", "0,1\n0x1,2\n", {"hex.csv' line 2", "two numbers"});
  std::string message;
  try {
    read_curve_table((dir / "missing.csv").string());
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  CHECK_MSG(message.find("cannot read") != std::string::npos && message.find("missing.csv") != std::string::npos, message);
}

// A motion with a curve: tau = c(t) in moved() and pose_at(), its velocity c'(t) times the motion's
// velocity at tau, against finite differences of moved().
void test_motion_with_curve() {
  Motion m;
  m.active = true;
  m.axis = {1, 2, 3};
  m.center = {0.5, 0, -0.2};
  m.rate_deg = 90;
  m.velocity = {0.1, -0.2, 0.3};
  m.curve = table({{0, 0}, {0.5, 1}, {1, -0.5}, {2, -0.5}});
  Motion plain = m;  // tau = t on [0, 10]
  plain.curve = Curve();
  plain.end = 10;
  const Vec3 X(0.3, -0.7, 1.1);
  CHECK((moved(m, X, 0) - X).norm() == 0);
  // At t the motion is where the plain one is at tau = c(t).
  for (double t : {0.25, 0.5, 0.8, 1.0, 3.0}) {
    const double tau = m.curve.value(t);
    if (tau < 0) continue;  // the plain motion does not go back
    CHECK_NEAR((moved(m, X, t) - moved(plain, X, tau)).norm(), 0, 1e-15);
  }
  double worst = 0, pose = 0;
  for (double t : {0.25, 0.7, 1.5}) {
    worst = std::max(worst, (velocity_at(m, X, t) - (moved(m, X, t + kStep) - moved(m, X, t - kStep)) / (2 * kStep)).norm());
    pose = std::max(pose, (pose_at(m, t).apply(X) - moved(m, X, t)).norm());
  }
  CHECK_MSG(pose < 1e-14, "pose_at against moved: " + std::to_string(pose));
  for (double t : {0.5, 1.0}) {  // kinks: from the left
    const Vec3 back = (3 * moved(m, X, t) - 4 * moved(m, X, t - kStep) + moved(m, X, t - 2 * kStep)) / (2 * kStep);
    worst = std::max(worst, (velocity_at(m, X, t) - back).norm());
  }
  CHECK_MSG(worst < 1e-6, "velocity_at against finite differences of moved: " + std::to_string(worst));
  CHECK(velocity_at(m, X, 1.5).norm() == 0 && velocity_at(m, X, 0).norm() == 0);
  CHECK(velocity_at(m, X, 1.0).norm() > 0.1);
}

}  // namespace

int main() {
  test_ramp();
  test_sine();
  test_table();
  test_motion_with_curve();
  const fs::path dir = fs::temp_directory_path() / ("hyperqn_test_curve_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  try {
    test_csv(dir);
  } catch (const std::exception& e) {
    CHECK_MSG(false, std::string("unexpected exception: ") + e.what());
  }
  fs::remove_all(dir);
  return check::summary("test_curve");
}
