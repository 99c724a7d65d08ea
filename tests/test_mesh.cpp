// Unit test of the serial mesh code: Medit reader, box and sheet generators, transform, cleaning,
// strands, cloth surfaces (hinges, edges, Medit and Gmsh triangles).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "check.hpp"
#include "input_error_check.hpp"
#include "mesh/input_error.hpp"
#include "mesh/mesh.hpp"
#include "mesh/mesh_gmsh.hpp"

using namespace hyperqn;
namespace fs = std::filesystem;

namespace {

// det[X1-X0, X2-X0, X3-X0] of tet e (6 * signed volume).
double tet_det(const TetMesh& m, int64_t e) {
  const double* x[4];
  for (int k = 0; k < 4; ++k) x[k] = &m.coords[3 * size_t(m.tets[4 * e + k])];
  double a[3], b[3], c[3];
  for (int d = 0; d < 3; ++d) {
    a[d] = x[1][d] - x[0][d];
    b[d] = x[2][d] - x[0][d];
    c[d] = x[3][d] - x[0][d];
  }
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
}

// Compensated (Kahan) sum: a plain sum of 480k tet volumes drifts past the 1e-12 check.
double total_volume(const TetMesh& m) {
  double sum = 0, carry = 0;
  for (int64_t e = 0; e < m.num_tets(); ++e) {
    const double y = std::fabs(tet_det(m, e)) / 6 - carry;
    const double t = sum + y;
    carry = (t - sum) - y;
    sum = t;
  }
  return sum;
}

int64_t count_nonpositive(const TetMesh& m) {
  int64_t n = 0;
  for (int64_t e = 0; e < m.num_tets(); ++e) n += !(tet_det(m, e) > 0);
  return n;
}

bool indices_in_range(const TetMesh& m) {
  for (int32_t v : m.tets)
    if (v < 0 || v >= m.num_vertices()) return false;
  return true;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}


// ---------------------------------------------------------------------------------------------

// Every interior face is shared by exactly two tets, and the faces seen once are exactly the
// triangles of the box surface.
void check_conformity(const TetMesh& m, const std::array<double, 3>& size, const std::array<int, 3>& n) {
  std::vector<std::array<int32_t, 3>> faces;
  faces.reserve(4 * size_t(m.num_tets()));
  static const int face_of[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (int64_t e = 0; e < m.num_tets(); ++e)
    for (const auto& f : face_of) {
      std::array<int32_t, 3> t{m.tets[4 * e + f[0]], m.tets[4 * e + f[1]], m.tets[4 * e + f[2]]};
      std::sort(t.begin(), t.end());
      faces.push_back(t);
    }
  std::sort(faces.begin(), faces.end());

  int64_t boundary = 0, overused = 0, boundary_off_surface = 0;
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j] == faces[i]) ++j;
    if (j - i == 1) {
      ++boundary;
      // All three vertices on one of the six box planes.
      bool on_plane = false;
      for (int d = 0; d < 3; ++d)
        for (double plane : {0.0, size[d]}) {
          bool all = true;
          for (int32_t v : faces[i]) all = all && m.coords[3 * size_t(v) + d] == plane;
          on_plane = on_plane || all;
        }
      boundary_off_surface += !on_plane;
    } else if (j - i > 2) {
      ++overused;
    }
    i = j;
  }
  const int64_t expect_boundary = 4 * (int64_t(n[0]) * n[1] + int64_t(n[1]) * n[2] + int64_t(n[0]) * n[2]);
  CHECK_MSG(boundary == expect_boundary,
            std::to_string(boundary) + " boundary faces, expected " + std::to_string(expect_boundary));
  CHECK(overused == 0);
  CHECK(boundary_off_surface == 0);
}

void test_box(const std::array<double, 3>& size, const std::array<int, 3>& n, bool conformity) {
  const auto t0 = std::chrono::steady_clock::now();
  TetMesh m = generate_box(size, n);
  const double t_gen = seconds_since(t0);
  const int64_t nv = int64_t(n[0] + 1) * (n[1] + 1) * (n[2] + 1), nt = int64_t(6) * n[0] * n[1] * n[2];
  CHECK(m.num_vertices() == nv);
  CHECK(m.num_tets() == nt);
  CHECK((int64_t)m.tet_tags.size() == nt);
  CHECK((int64_t)m.vertex_ids.size() == nv);
  CHECK(indices_in_range(m));
  const double vol = size[0] * size[1] * size[2];
  CHECK_NEAR(total_volume(m), vol, 1e-12 * vol);
  CHECK(count_nonpositive(m) == 0);
  // All tets of a cube have the same volume.
  const double tet_vol = vol / nt;
  double worst = 0;
  for (int64_t e = 0; e < m.num_tets(); ++e) worst = std::max(worst, std::fabs(tet_det(m, e) / 6 - tet_vol));
  CHECK(worst <= 1e-12 * tet_vol);
  if (conformity) check_conformity(m, size, n);
  // Nothing to clean in a generated box.
  const CleanReport r = clean_mesh(m, "box");
  CHECK(r.dropped_vertices == 0 && r.reoriented_tets == 0);
  std::printf("box %dx%dx%d: %lld tets, generated in %.3f s\n", n[0], n[1], n[2], (long long)nt, t_gen);
}

void test_boxes() {
  test_box({1, 1, 1}, {1, 1, 1}, true);
  test_box({2.0, 0.5, 1.5}, {3, 4, 5}, true);
  test_box({7, 1, 3}, {7, 2, 1}, true);
  test_box({10, 1, 1}, {200, 20, 20}, false);  // the big benchmark box
}

// ---------------------------------------------------------------------------------------------

void check_point(const TetMesh& m, int64_t v, std::array<double, 3> expect, const char* what) {
  for (int d = 0; d < 3; ++d)
    CHECK_MSG(std::fabs(m.coords[3 * v + d] - expect[d]) <= 1e-12,
              std::string(what) + ": component " + std::to_string(d) + " = " + std::to_string(m.coords[3 * v + d]));
}

void test_transform() {
  // Three points, transformed one at a time with known results.
  TetMesh p;
  p.coords = {1, 0, 0, 0, 1, 0, 0, 0, 1};

  TetMesh a = p;
  MeshTransform t;
  t.scale = 2;
  t.rotate_deg = {0, 0, 90};
  t.translate = {1, 2, 3};
  apply_transform(a, t);
  check_point(a, 0, {1, 4, 3}, "scale 2, Rz 90, translate");  // (1,0,0) -> (2,0,0) -> (0,2,0) -> (1,4,3)

  // Order: x first, then y, then z. (0,1,0) -Rx90-> (0,0,1) -Ry90-> (1,0,0) -Rz90-> (0,1,0);
  // any other order gives a different point.
  TetMesh b = p;
  MeshTransform r;
  r.rotate_deg = {90, 90, 0};
  apply_transform(b, r);
  check_point(b, 1, {1, 0, 0}, "Rx90 then Ry90");
  b = p;
  r.rotate_deg = {90, 90, 90};
  apply_transform(b, r);
  check_point(b, 1, {0, 1, 0}, "Rx90 Ry90 Rz90");
  check_point(b, 0, {0, 0, -1}, "Rx90 Ry90 Rz90 of e_x");  // e_x -Rx-> e_x -Ry-> -e_z -Rz-> -e_z

  // Identity leaves the points alone.
  TetMesh c = p;
  apply_transform(c, MeshTransform{});
  CHECK(c.coords == p.coords);

  // Volume scales by scale^3, rotations keep the orientation.
  TetMesh box = generate_box({1, 2, 3}, {2, 3, 4});
  MeshTransform s;
  s.scale = 0.5;
  s.rotate_deg = {30, -45, 120};
  s.translate = {-3, 7, 0.25};
  apply_transform(box, s);
  CHECK_NEAR(total_volume(box), 6 * 0.125, 1e-12);
  CHECK(count_nonpositive(box) == 0);
}

// ---------------------------------------------------------------------------------------------

// The cleaned mesh maps back to the raw one: coordinates through vertex_ids, and each tet to
// the same vertex set (the order may be swapped by reorientation) with the same tag.
void check_maps_back(const TetMesh& raw, const TetMesh& m, const std::string& name) {
  bool coords_ok = (int64_t)m.vertex_ids.size() == m.num_vertices(), tets_ok = m.num_tets() == raw.num_tets();
  for (int64_t v = 0; coords_ok && v < m.num_vertices(); ++v) {
    const int64_t id = m.vertex_ids[v];
    coords_ok = id >= 0 && id < raw.num_vertices() && (v == 0 || id > m.vertex_ids[v - 1]);
    for (int d = 0; coords_ok && d < 3; ++d) coords_ok = m.coords[3 * v + d] == raw.coords[3 * id + d];
  }
  for (int64_t e = 0; tets_ok && e < m.num_tets(); ++e) {
    std::array<int64_t, 4> a, b;
    for (int k = 0; k < 4; ++k) {
      a[k] = m.vertex_ids[m.tets[4 * e + k]];
      b[k] = raw.tets[4 * e + k];
    }
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    tets_ok = a == b && m.tet_tags[e] == raw.tet_tags[e];
  }
  CHECK_MSG(coords_ok, name + ": vertex_ids do not map back to the input coordinates");
  CHECK_MSG(tets_ok, name + ": cleaned tets do not map back to the input tets");
}

// Flips every other tet of a real mesh; cleaning must flip exactly those back.
void test_reorient_real(const TetMesh& raw) {
  TetMesh m = raw;
  for (int64_t e = 0; e < m.num_tets(); e += 2) std::swap(m.tets[4 * e], m.tets[4 * e + 1]);
  const TetMesh flipped = m;
  const CleanReport r = clean_mesh(m, "bar990 flipped");
  CHECK(r.reoriented_tets == (raw.num_tets() + 1) / 2);
  CHECK(count_nonpositive(m) == 0);
  CHECK_NEAR(total_volume(m), 3.0, 3e-6);
  check_maps_back(flipped, m, "bar990 flipped");
}

struct Expected {
  const char* file;
  int64_t vertices, tets;  // as in the file header
  int64_t dropped;         // -1: not checked
  double volume, rel_tol;
};

void test_shared_meshes() {
  const fs::path dir = HYPERQN_SHARED_MESHES;
  if (!fs::is_directory(dir)) {
    std::printf("SKIP: shared meshes not found at %s\n", dir.string().c_str());
    return;
  }
  // Counts and (rounded) volumes from reference-implementation.md section 7.1. bar4099 and
  // bar66792 are 3 only to 1e-4 (2.99967 and 2.99996; checked with an independent script).
  const Expected expected[] = {
      {"bar990.mesh", 369, 990, 8, 3.0, 1e-6},          {"bar4099.mesh", 1430, 4099, 8, 3.0, 1e-3},
      {"bar16660.mesh", 5650, 16600, 8, 3.0, 1e-6},     {"bar66792.mesh", 22490, 66792, 8, 3.0, 1e-3},
      {"bunny.mesh", 6308, 26096, -1, 1.496, 1e-3},     {"bunny_small.mesh", 1839, 5891, -1, 199.7, 1e-3},
      {"cube.mesh", 792, 2911, -1, 1000, 1e-6},         {"sphere_uniform.mesh", 2340, 10671, -1, 4.155, 1e-3},
      {"torus.mesh", 469, 1396, 27, 4.775, 1e-3},       {"tet.mesh", 4, 1, 0, 1.0, 1e-12},
  };
  for (const Expected& x : expected) {
    const std::string path = (dir / x.file).string();
    if (!fs::exists(path)) {
      std::printf("SKIP: %s not found\n", path.c_str());
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    TetMesh m = read_medit(path);
    const TetMesh raw = m;
    const CleanReport r = clean_mesh(m, path);
    const double t = seconds_since(t0);
    const std::string name = x.file;
    CHECK_MSG(raw.num_vertices() == x.vertices, name + ": " + std::to_string(raw.num_vertices()) + " vertices");
    CHECK_MSG(raw.num_tets() == x.tets, name + ": " + std::to_string(raw.num_tets()) + " tets");
    if (x.dropped >= 0)
      CHECK_MSG(r.dropped_vertices == x.dropped, name + ": dropped " + std::to_string(r.dropped_vertices));
    CHECK(m.num_vertices() == raw.num_vertices() - r.dropped_vertices);
    CHECK(m.num_tets() == raw.num_tets());
    CHECK(indices_in_range(m));
    CHECK_MSG(count_nonpositive(m) == 0, name + ": non-positive tets after cleaning");
    const double vol = total_volume(m);
    CHECK_MSG(std::fabs(vol - x.volume) <= x.rel_tol * x.volume, name + ": volume " + std::to_string(vol));
    check_maps_back(raw, m, name);
    // Cleaning is idempotent.
    TetMesh again = m;
    const CleanReport r2 = clean_mesh(again, path);
    CHECK(r2.dropped_vertices == 0 && r2.reoriented_tets == 0 && again.coords == m.coords && again.tets == m.tets);
    std::printf("%s: %lld vertices (%lld dropped), %lld tets (%lld reoriented), volume %.6g, read+clean %.3f s\n", x.file,
                (long long)raw.num_vertices(), (long long)r.dropped_vertices, (long long)raw.num_tets(),
                (long long)r.reoriented_tets, vol, t);
    // The shipped meshes have det[X1-X4, X2-X4, X3-X4] < 0 (reference section 6.2), which is
    // det[X1-X0, X2-X0, X3-X0] > 0 in our numbering: nothing to flip.
    CHECK_MSG(r.reoriented_tets == 0, name + ": reoriented " + std::to_string(r.reoriented_tets));
    if (name == "bar990.mesh") test_reorient_real(raw);
  }
}

// ---------------------------------------------------------------------------------------------

void test_project_meshes() {
  const fs::path dir = fs::path(HYPERQN_SOURCE_DIR) / "input" / "meshes";

  TetMesh one = read_medit((dir / "tet.mesh").string());
  CHECK(one.num_vertices() == 4 && one.num_tets() == 1);
  CHECK(one.tet_tags == std::vector<int32_t>{1});
  CHECK(one.vertex_ids == (std::vector<int64_t>{0, 1, 2, 3}));
  CleanReport r1 = clean_mesh(one, "tet.mesh");
  CHECK(r1.dropped_vertices == 0 && r1.reoriented_tets == 0);
  CHECK_NEAR(total_volume(one), 1.0 / 6, 1e-15);

  const TetMesh raw = read_medit((dir / "two_tets.mesh").string());
  CHECK(raw.num_vertices() == 6 && raw.num_tets() == 2);
  CHECK(raw.tets == (std::vector<int32_t>{0, 1, 3, 4, 0, 1, 3, 5}));
  CHECK(raw.tet_tags == (std::vector<int32_t>{1, 2}));
  CHECK(raw.coords[3 * 2] == 9 && raw.coords[3 * 5 + 2] == -1);
  CHECK(tet_det(raw, 0) > 0 && tet_det(raw, 1) < 0);
  TetMesh two = raw;
  CleanReport r2 = clean_mesh(two, "two_tets.mesh");
  CHECK(r2.dropped_vertices == 1 && r2.reoriented_tets == 1);
  CHECK(two.num_vertices() == 5);
  CHECK(two.vertex_ids == (std::vector<int64_t>{0, 1, 3, 4, 5}));
  CHECK(count_nonpositive(two) == 0);
  CHECK_NEAR(total_volume(two), 1.0 / 3, 1e-15);
  check_maps_back(raw, two, "two_tets.mesh");
}

// ---------------------------------------------------------------------------------------------

// Writes text to dir/name and returns the path.
std::string write(const fs::path& dir, const std::string& name, const std::string& text) {
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

void test_errors(const fs::path& dir) {
  const std::string head = "MeshVersionFormatted 2\nDimension 3\n";  // lines 1-2
  const std::string verts = "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";  // lines 3-8

  const std::string missing = (dir / "does_not_exist.mesh").string();
  expect_input_error("missing file", [&] { read_medit(missing); }, {missing, "cannot open"});

  // "Tetrahedra" on line 8 where the 4th vertex should be.
  std::string p = write(dir, "truncated.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\nTetrahedra\n1\n1 2 3 4 0\nEnd\n");
  expect_input_error("truncated Vertices", [&] { read_medit(p); }, {p + ":8:", "'Vertices'", "declares 4", "after 3", "'Tetrahedra'"});

  // File ends (line 6) inside the Vertices section.
  p = write(dir, "truncated_eof.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 0\n\n");
  expect_input_error("truncated at end of file", [&] { read_medit(p); }, {p + ":6:", "'Vertices'", "end of the file"});

  // Tet 2, on line 12, names vertex 5 of 4.
  p = write(dir, "range.mesh", head + verts + "Tetrahedra\n2\n1 2 3 4 0\n1 2 5 4 0\nEnd\n");
  expect_input_error("index out of range", [&] { read_medit(p); }, {p + ":12:", "tet 2", "index 5", "1..4"});
  p = write(dir, "zero_index.mesh", head + verts + "Tetrahedra\n1\n0 1 2 3 0\n");
  expect_input_error("index 0", [&] { read_medit(p); }, {p + ":11:", "tet 1", "index 0"});

  // Non-numeric coordinate on line 6.
  p = write(dir, "text.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 x1 0\n0 1 0 0\n0 0 1 0\n");
  expect_input_error("non-numeric token", [&] { read_medit(p); }, {p + ":6:", "'x1'"});
  // A fractional vertex index on line 11.
  p = write(dir, "fraction.mesh", head + verts + "Tetrahedra\n1\n1 2.5 3 4 0\n");
  expect_input_error("fractional index", [&] { read_medit(p); }, {p + ":11:", "integer", "'2.5'"});

  // Numbers are plain decimals: what strtod reads beyond them (hexadecimal, inf, nan) is refused
  // at its line (line 7: the third vertex), whatever the case or sign.
  const std::vector<std::pair<std::string, std::string>> odd_numbers = {
      {"nan", "not finite"}, {"NaN", "not finite"}, {"nan(1)", "not finite"}, {"-inf", "not finite"},
      {"INFINITY", "not finite"}, {"0x10", "hexadecimal"}, {"0X1p3", "hexadecimal"}, {"-0x1.8p1", "hexadecimal"}};
  for (const auto& [number, why] : odd_numbers) {
    p = write(dir, "odd.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 0 0\n" + number + " 1 0 0\n0 0 1 0\n");
    expect_input_error("coordinate " + number, [&] { read_medit(p); }, {p + ":7:", "'Vertices'", "'" + number + "'", why});
  }
  p = write(dir, "hex_ref.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0x0\n0 0 1 0\n");
  expect_input_error("hexadecimal vertex ref", [&] { read_medit(p); }, {p + ":7:", "'0x0'", "hexadecimal"});
  // A decimal too large for a double is read as inf: refused as non-finite.
  p = write(dir, "huge.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 0 0\n1e999 1 0 0\n0 0 1 0\n");
  expect_input_error("overflowing coordinate", [&] { read_medit(p); }, {p + ":7:", "non-finite", "'1e999'"});
  // Every decimal form is read.
  p = write(dir, "decimals.mesh", head + "Vertices\n4\n+0 -0. .0 0\n1E+0 0 0 0\n0 1.0e0 0 0\n0 0 1e-0 +1\n"
                                         "Tetrahedra\n1\n1 2 3 4 0\n");
  const TetMesh decimals = read_medit(p);
  CHECK(decimals.coords[3] == 1 && decimals.coords[7] == 1 && decimals.coords[11] == 1);

  // MeshVersionFormatted: the ASCII versions 1 to 4 only, at the value's line.
  for (int version : {1, 2, 3, 4}) {
    p = write(dir, "version.mesh", "MeshVersionFormatted " + std::to_string(version) + "\nDimension 3\n" + verts +
                                       "Tetrahedra\n1\n1 2 3 4 0\n");
    CHECK(read_medit(p).num_tets() == 1);
  }
  for (const char* version : {"0", "5", "99", "-1"}) {
    p = write(dir, "version.mesh", "MeshVersionFormatted\n" + std::string(version) + "\nDimension 3\n" + verts +
                                       "Tetrahedra\n1\n1 2 3 4 0\n");
    expect_input_error(std::string("version ") + version, [&] { read_medit(p); },
                       {p + ":2:", "'MeshVersionFormatted'", std::string("version ") + version, "1, 2, 3 or 4"});
  }

  // Vertex indices of the sections the reader skips are checked like those it reads: Triangles
  // (the 999 in a mesh of 4 vertices), Edges (edges: ignore), Quadrilaterals, Corners
  // (before Vertices: checked at the end), 0.
  const std::string tet = "Tetrahedra\n1\n1 2 3 4 0\n";  // lines 9-11
  const std::vector<std::tuple<std::string, std::string, std::string>> skipped = {
      {"Triangles", head + verts + tet + "Triangles\n2\n1 2 3 0\n1 999 3 0\nEnd\n", ":15:"},
      {"Edges", head + verts + tet + "Edges\n1\n1 5 0\nEnd\n", ":14:"},
      {"Quadrilaterals", head + verts + tet + "Quadrilaterals\n1\n1 2 3 7 0\nEnd\n", ":14:"},
      {"Corners", head + "Corners\n2\n1\n9\n" + verts + tet, ":6:"},
      {"RequiredVertices", head + verts + "RequiredVertices 1 0\n" + tet, ":9:"},
  };
  for (const auto& [section, text, line] : skipped) {
    p = write(dir, "skipped.mesh", text);
    expect_input_error("skipped " + section, [&] { read_medit(p); }, {p + line, "'" + section + "'", "vertex index", "out of range"});
  }
  // A cloth read skips the tetrahedra: their indices are checked too.
  p = write(dir, "skipped_tets.mesh", head + verts + "Tetrahedra\n1\n1 2 3 8 0\nTriangles\n1\n1 2 3 0\nEnd\n");
  expect_input_error("skipped tets", [&] { read_medit(p, false, true); }, {p + ":11:", "'Tetrahedra'", "index 8", "1..4"});
  p = write(dir, "skipped_fraction.mesh", head + verts + tet + "Edges\n1\n1 2.0 0\nEnd\n");
  expect_input_error("fractional skipped index", [&] { read_medit(p); }, {p + ":14:", "'Edges'", "integer", "'2.0'"});

  // Degenerate tet 2: four coplanar points.
  p = write(dir, "flat.mesh", head + "Vertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 0 0\n"
                                     "Tetrahedra\n2\n1 2 3 4 0\n1 2 3 5 0\n");
  TetMesh flat = read_medit(p);
  const TetMesh flat_copy = flat;
  expect_input_error("degenerate tet", [&] { clean_mesh(flat, p); }, {p + ":13:", "tet 2 ", "degenerate"});
  CHECK(flat.coords == flat_copy.coords && flat.tets == flat_copy.tets);  // untouched on error
  // A tiny but well-shaped tet is not degenerate: the test is relative to its size.
  TetMesh tiny = read_medit((fs::path(HYPERQN_SOURCE_DIR) / "input" / "meshes" / "tet.mesh").string());
  apply_transform(tiny, MeshTransform{1e-9, {0, 0, 0}, {0, 0, 0}});
  CHECK(clean_mesh(tiny, "tiny").reoriented_tets == 0);

  p = write(dir, "dim2.mesh", "MeshVersionFormatted 2\nDimension 2\nVertices\n3\n0 0 0\n1 0 0\n0 1 0\n");
  expect_input_error("Dimension 2", [&] { read_medit(p); }, {p + ":2:", "Dimension 2"});

  p = write(dir, "unknown.mesh", head + verts + "Foo\n1\n1\nTetrahedra\n1\n1 2 3 4 0\n");
  expect_input_error("unknown keyword", [&] { read_medit(p); }, {p + ":9:", "'Foo'"});
  p = write(dir, "no_tets.mesh", head + verts + "End\n");
  expect_input_error("no Tetrahedra", [&] { read_medit(p); }, {p, "no Tetrahedra"});
  p = write(dir, "no_verts.mesh", head + "End\n");
  expect_input_error("no Vertices", [&] { read_medit(p); }, {p, "no Vertices"});
  // A count larger than the records, but the next keyword is a number: it shows up as a
  // stray number after the section.
  p = write(dir, "extra.mesh", head + verts + "Tetrahedra\n1\n1 2 3 4 0\n1 2 3 4 0\n");
  expect_input_error("extra record", [&] { read_medit(p); }, {p + ":12:", "outside any section"});
  // An empty Tetrahedra section reads, and cleaning rejects it.
  p = write(dir, "zero_tets.mesh", head + verts + "Tetrahedra\n0\nEnd\n");
  TetMesh empty = read_medit(p);
  CHECK(empty.num_tets() == 0);
  expect_input_error("no tets to clean", [&] { clean_mesh(empty, p); }, {p, "no tetrahedra"});

  // Comments anywhere, CRLF line ends, counts on the keyword line, no End, text after End.
  p = write(dir, "quirks.mesh",
            "# header\r\nMeshVersionFormatted 1 # trailing\r\nDimension\r\n3\r\nVertices 4\r\n0 0 0 0#x\r\n"
            "1 0 0 0\r\n0 1 0 0\r\n0 0 1 0\r\nCorners 2 1 2\r\nEdges 1\r\n1 2 0\r\nTetrahedra 1\r\n1 2 3 4 7\r\n");
  TetMesh q = read_medit(p);
  CHECK(q.num_vertices() == 4 && q.num_tets() == 1 && q.tet_tags[0] == 7);
  p = write(dir, "after_end.mesh", head + verts + "Tetrahedra\n1\n1 2 3 4 0\nEnd\nanything goes here\n");
  CHECK(read_medit(p).num_tets() == 1);
}

// Strand segments: Medit Edges (only when asked for), generated strands, their cleaning.
void test_strands(const fs::path& dir) {
  const std::string head = "MeshVersionFormatted 2\nDimension 3\n";                         // lines 1-2
  const std::string verts = "Vertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 2 0\n";  // lines 3-9
  // A tet with a strand hanging off vertex 4 (lines 10-12: Edges), plus an unused vertex 6.
  std::string p = write(dir, "tet_and_edge.mesh", head + "Vertices\n6\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 2 0\n9 9 9 0\n" +
                                                      "Edges\n2\n4 5 3\n2 1 4\nTetrahedra\n1\n1 2 3 4 7\n");
  CHECK(read_medit(p).num_segments() == 0);  // Edges of a tet mesh are feature lines unless asked for
  TetMesh m = read_medit(p, true);
  CHECK(m.num_segments() == 2 && m.num_tets() == 1);
  CHECK(m.segments == std::vector<int32_t>({3, 4, 1, 0}) && m.segment_tags == std::vector<int32_t>({3, 4}));
  const CleanReport r = clean_mesh(m, p);
  CHECK(r.dropped_vertices == 1 && m.num_vertices() == 5);  // vertex 6 only; vertex 5 is on a segment
  CHECK(m.segments == std::vector<int32_t>({3, 4, 1, 0}));

  // Strands only: no Tetrahedra section at all.
  p = write(dir, "strand_only.mesh", head + verts + "Edges\n2\n4 5 0\n5 1 0\n");
  expect_input_error("strand-only file read as a tet mesh", [&] { read_medit(p); }, {p, "no Tetrahedra"});
  TetMesh only = read_medit(p, true);
  clean_mesh(only, p);
  CHECK(only.num_tets() == 0 && only.num_segments() == 2 && only.num_vertices() == 3);

  p = write(dir, "no_edges.mesh", head + verts + "Tetrahedra\n1\n1 2 3 4 0\n");
  expect_input_error("strands asked, no Edges", [&] { read_medit(p, true); }, {p, "no Edges section"});
  p = write(dir, "edge_range.mesh", head + verts + "Edges\n1\n4 6 0\n");
  expect_input_error("edge index out of range", [&] { read_medit(p, true); }, {p + ":12:", "edge 1", "index 6", "1..5"});
  p = write(dir, "edge_degenerate.mesh", head + verts + "Edges\n2\n4 5 0\n5 5 0\n");
  TetMesh degenerate = read_medit(p, true);
  expect_input_error("degenerate segment", [&] { clean_mesh(degenerate, p); }, {p, "segment 2 ", "degenerate"});

  // Generated strands: an end on an existing vertex is joined to it, the points are equally spaced.
  TetMesh box = generate_box({1, 1, 1}, {1, 1, 1});
  const int64_t nv = box.num_vertices();
  add_strand(box, {{1, 1, 1}, {1, 3, 1}, 4, 0});  // starts at the box's corner vertex 7
  CHECK(box.num_vertices() == nv + 4 && box.num_segments() == 4);
  CHECK(box.segments[0] == 7 && box.segments[1] == nv && box.segments[7] == nv + 3);
  CHECK_NEAR(box.coords[3 * nv + 1], 1.5, 1e-15);
  CHECK(box.vertex_ids[nv] == nv && box.vertex_ids[nv + 3] == nv + 3);
  add_strand(box, {{5, 5, 5}, {1, 3, 1}, 2, 0});  // a second strand ending on the first one's end
  CHECK(box.num_vertices() == nv + 6 && box.segments.back() == nv + 3);
  clean_mesh(box, "box with strands");
  CHECK(box.num_segments() == 6 && box.num_vertices() == nv + 6);
}

// The sheet generator and connect_surface: counts, orientation, hinges and carried edges.
void test_sheet() {
  const int nx = 4, nz = 3;
  TetMesh m = generate_sheet({2.0, 1.5}, {nx, nz});
  CHECK(m.num_vertices() == (nx + 1) * (nz + 1) && m.num_triangles() == 2 * nx * nz);
  CHECK_NEAR(m.coords[3 * ((nx + 1) * (nz + 1) - 1)], 2.0, 0);      // far corner at (2, 0, 1.5)
  CHECK_NEAR(m.coords[3 * ((nx + 1) * (nz + 1) - 1) + 2], 1.5, 0);
  double area = 0;
  bool down = true;
  for (int64_t f = 0; f < m.num_triangles(); ++f) {
    const double* a = &m.coords[3 * m.triangles[3 * f]];
    const double* b = &m.coords[3 * m.triangles[3 * f + 1]];
    const double* c = &m.coords[3 * m.triangles[3 * f + 2]];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double ny = u[2] * w[0] - u[0] * w[2];  // y component of u x w
    down = down && ny < 0;
    area += -0.5 * ny;
  }
  CHECK_MSG(down, "every sheet triangle has normal -y");
  CHECK_NEAR(area, 3.0, 1e-12);
  const CleanReport r = clean_mesh(m, "sheet");
  CHECK(r.dropped_vertices == 0);
  const int64_t edges = int64_t(nx) * (nz + 1) + int64_t(nx + 1) * nz + int64_t(nx) * nz;
  const int64_t boundary = 2 * (nx + nz);
  CHECK(m.num_hinges() == edges - boundary);
  int64_t carried = 0;
  for (uint8_t bits : m.triangle_edges) carried += (bits & 1) + ((bits >> 1) & 1) + ((bits >> 2) & 1);
  CHECK_MSG(carried == edges, "every edge carried once: " + std::to_string(carried) + " of " + std::to_string(edges));
  // A hinge (a, b, c, d): a-b an edge of both triangles (a, b, c) and (., ., d), c != d.
  bool hinges_ok = true;
  for (int64_t h = 0; h < m.num_hinges(); ++h) {
    const int32_t* v = &m.hinges[4 * h];
    auto has = [&](int32_t x, int32_t y, int32_t z) {
      for (int64_t f = 0; f < m.num_triangles(); ++f) {
        std::array<int32_t, 3> t{m.triangles[3 * f], m.triangles[3 * f + 1], m.triangles[3 * f + 2]}, q{x, y, z};
        std::sort(t.begin(), t.end());
        std::sort(q.begin(), q.end());
        if (t == q) return true;
      }
      return false;
    };
    hinges_ok = hinges_ok && v[2] != v[3] && has(v[0], v[1], v[2]) && has(v[0], v[1], v[3]);
  }
  CHECK_MSG(hinges_ok, "every hinge is two triangles on its edge");
}

void test_surface_errors(const fs::path& dir) {
  const std::string head = "MeshVersionFormatted 1\nDimension 3\n";
  const std::string verts = "Vertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 1 0\n";
  // Three triangles on the edge 1-2: not a manifold.
  std::string p = write(dir, "fan.mesh", head + verts + "Triangles\n3\n1 2 3 0\n1 2 4 0\n2 1 5 0\nEnd\n");
  TetMesh m = read_medit(p, false, true);
  CHECK(m.num_triangles() == 3 && m.num_tets() == 0);
  expect_input_error("non-manifold cloth", [&] { clean_mesh(m, p); }, {p, "vertices 1 and 2", "3 triangles", "manifold"});
  // A degenerate (collinear) triangle, named 1-based.
  p = write(dir, "flat.mesh", head + "Vertices\n4\n0 0 0 0\n1 0 0 0\n2 0 0 0\n0 1 0 0\nTriangles\n2\n1 2 4 0\n1 2 3 0\nEnd\n");
  m = read_medit(p, false, true);
  expect_input_error("degenerate triangle", [&] { clean_mesh(m, p); }, {p, "triangle 2", "degenerate"});
  // The same triangle twice.
  p = write(dir, "twice.mesh", head + verts + "Triangles\n2\n1 2 3 0\n3 1 2 0\nEnd\n");
  m = read_medit(p, false, true);
  expect_input_error("duplicated triangle", [&] { clean_mesh(m, p); }, {p, "triangles 1 and 2", "duplicated"});
  // No Triangles section when the deck asks for a cloth; a tet file read as cloth skips its tets.
  p = write(dir, "tets.mesh", head + verts + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n");
  expect_input_error("no triangles", [&] { read_medit(p, false, true); }, {p, "Triangles", "cloth"});
  p = write(dir, "both.mesh", head + verts + "Tetrahedra\n1\n1 2 3 4 0\nTriangles\n2\n1 2 3 0\n2 1 5 0\nEnd\n");
  m = read_medit(p, false, true);
  const CleanReport r = clean_mesh(m, p);
  CHECK(m.num_tets() == 0 && m.num_triangles() == 2 && m.num_hinges() == 1 && r.dropped_vertices == 1);
  // Cloth and tets in one mesh are refused.
  TetMesh mixed = generate_box({1, 1, 1}, {1, 1, 1});
  mixed.triangles = {0, 1, 2};
  expect_input_error("cloth with tets", [&] { clean_mesh(mixed, "mixed"); }, {"mixed", "cloth", "tetrahedra"});
}

// The triangles of a tet mesh kept for the deck's face tags (TaggedFaces): Medit references, Gmsh
// physical groups (2.2's first tag; 4.1's surface groups, every one of them; without $Entities
// the surface's tag); nothing without face tags.
void test_tagged_faces(const fs::path& dir) {
  const std::string head = "MeshVersionFormatted 1\nDimension 3\n";
  const std::string verts = "Vertices\n5\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n1 1 1 0\n";
  const std::string tris = "Triangles\n3\n3 2 1 4\n1 2 4 6\n2 3 4 4\n";
  std::string p = write(dir, "tagged.mesh", head + verts + tris + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n");
  TetMesh m = read_medit(p);
  CHECK(m.tagged_faces.empty() && m.tagged_faces.file_tags.empty() && m.num_triangles() == 0);
  m = read_medit(p, false, false, {4, 9});
  CHECK(m.tagged_faces.size() == 2 && m.num_triangles() == 0 && m.num_tets() == 1);
  CHECK((m.tagged_faces.vertices == std::vector<int64_t>{0, 1, 2, 1, 2, 3}));  // ascending ids per triangle
  CHECK((m.tagged_faces.tags == std::vector<int32_t>{4, 4}));
  CHECK((m.tagged_faces.file_tags == std::vector<int32_t>{4, 6}));
  CHECK((m.tagged_faces.vertex_ids_of(4) == std::vector<int64_t>{0, 1, 2, 3}));
  clean_mesh(m, p);  // drops vertex 5 (no tet), keeps the ids the faces name
  CHECK(m.num_vertices() == 4 && m.tagged_faces.size() == 2);
  // A cloth reads its triangles as the cloth, no face tags.
  CHECK(read_medit(p, false, true, {4}).tagged_faces.empty());
  p = write(dir, "tagged_early.mesh", head + "Triangles\n1\n1 2 3 4\n" + verts + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n");
  CHECK(read_medit(p).num_tets() == 1);  // skipped as before without face tags
  expect_input_error("face tags before Vertices", [&] { read_medit(p, false, false, {4}); },
                     {p + ":3:", "'Triangles'", "before the Vertices"});
  p = write(dir, "tagged_bad.mesh", head + verts + "Triangles\n1\n1 2 6 4\nTetrahedra\n1\n1 2 3 4 0\nEnd\n");
  expect_input_error("face tag index", [&] { read_medit(p, false, false, {4}); }, {p + ":12:", "triangle 1", "index 6", "1..5"});

  const std::string nodes22 = "$Nodes\n4\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n$EndNodes\n";
  p = write(dir, "tagged22.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n" + nodes22 +
                                     "$Elements\n4\n1 2 2 3 1 10 20 30\n2 2 2 5 1 10 20 30\n3 2 2 3 2 20 30 40\n"
                                     "4 4 2 1 1 10 20 30 40\n$EndElements\n");
  CHECK(read_gmsh(p).tagged_faces.empty());
  m = read_gmsh(p, false, {3, 5});
  CHECK(m.num_tets() == 1 && m.tagged_faces.size() == 3);
  CHECK((m.tagged_faces.tags == std::vector<int32_t>{3, 5, 3}));
  CHECK((m.tagged_faces.vertex_ids_of(3) == std::vector<int64_t>{0, 1, 2, 3}));  // node positions, not tags
  // 4.1: surface 1 is in physical groups 3 and 5, surface 2 in none.
  const std::string nodes41 = "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n";
  const std::string elements41 = "$Elements\n3 3 1 3\n2 1 2 1\n1 1 2 3\n2 2 2 1\n2 2 3 4\n3 1 4 1\n3 1 2 3 4\n$EndElements\n";
  p = write(dir, "tagged41.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 2 1\n"
                                     "1 0 0 0 1 1 0 2 3 5 0\n2 0 0 0 1 1 1 0 0\n1 0 0 0 1 1 1 1 7 0\n$EndEntities\n" +
                                     nodes41 + elements41);
  m = read_gmsh(p, false, {5});
  CHECK(m.num_tets() == 1 && m.tet_tags[0] == 7 && m.tagged_faces.size() == 1);
  CHECK((m.tagged_faces.vertices == std::vector<int64_t>{0, 1, 2}) && m.tagged_faces.tags[0] == 5);
  CHECK((m.tagged_faces.file_tags == std::vector<int32_t>{3, 5}));
  p = write(dir, "tagged41_bare.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n" + nodes41 + elements41);
  m = read_gmsh(p, false, {2});
  CHECK(m.tagged_faces.size() == 1 && (m.tagged_faces.vertices == std::vector<int64_t>{1, 2, 3}));
}

}  // namespace

// RecordLines: runs of records on consecutive lines; a record on another line starts a run; a
// record past the runs (a strand the deck added) has no line.
void test_record_lines() {
  RecordLines lines;
  CHECK(lines.line_of(0) == 0);
  for (int64_t r = 0; r < 3; ++r) lines.add(r, 10 + int(r));  // lines 10, 11, 12
  lines.add(3, 14);                                             // a blank line before it
  lines.add(4, 14);                                             // two records on one line
  lines.add(5, 15);
  const int expected[] = {10, 11, 12, 14, 14, 15};
  for (int64_t r = 0; r < 6; ++r) CHECK_MSG(lines.line_of(r) == expected[r], "record " + std::to_string(r));
  CHECK(lines.line_of(6) == 0 && lines.line_of(-1) == 0);
}

int main() {
  test_boxes();
  test_transform();
  test_record_lines();
  test_project_meshes();
  test_shared_meshes();

  // Error files go to a private temp directory, removed at the end.
  const fs::path dir = fs::temp_directory_path() / ("hyperqn_test_mesh_" + std::to_string(std::random_device{}()));
  fs::create_directories(dir);
  try {
    test_errors(dir);
    test_strands(dir);
    test_sheet();
    test_surface_errors(dir);
    test_tagged_faces(dir);
  } catch (const std::exception& e) {
    CHECK_MSG(false, std::string("unexpected exception: ") + e.what());
  }
  fs::remove_all(dir);

  return check::summary("test_mesh");
}
