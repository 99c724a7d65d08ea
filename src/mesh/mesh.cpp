// Serial tet mesh: Medit reader, box generator, transform and cleaning.
#include "mesh/mesh.hpp"

#include "mesh/mesh_piece.hpp"

#include <algorithm>
#include <cerrno>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "mesh/input_error.hpp"
#include "mesh/text_tokens.hpp"

namespace hyperqn {

namespace {

// ---------------------------------------------------------------------------------------------
// Medit reader

class MeditReader {
 public:
  MeditReader(const std::string& path, const std::string& text, bool edges_as_strands, bool triangles_as_cloth,
              const std::vector<int32_t>& face_tags)
      : path_(path), tok_(text, '#'), skipped_(path), text_size_(text.size()), edges_as_strands_(edges_as_strands),
        triangles_as_cloth_(triangles_as_cloth), face_tags_(face_tags) {}

  TetMesh read() {
    TetMesh mesh;
    bool have_vertices = false, have_tets = false, have_edges = false, have_triangles = false;
    Token t;
    while (tok_.next(t)) {
      if (t.is("End")) break;
      if (t.is("MeshVersionFormatted")) {
        Token v;
        const long long version = header_int(t, &v);
        check_medit_version(path_, v, version);
      } else if (t.is("Dimension")) {
        Token v;
        if (header_int(t, &v) != 3)
          throw InputError(path_, v.line, "Dimension", "only 3D meshes are supported, found Dimension " + v.str());
      } else if (t.is("Vertices")) {
        if (have_vertices) throw InputError(path_, t.line, "Vertices", "second Vertices section");
        read_vertices(t, mesh);
        have_vertices = true;
      } else if (t.is("Triangles") && triangles_as_cloth_) {
        if (have_triangles) throw InputError(path_, t.line, "Triangles", "second Triangles section");
        if (!have_vertices)
          throw InputError(path_, t.line, "Triangles", "Triangles section comes before the Vertices section");
        read_elements(t, 3, "triangle", mesh.num_vertices(), mesh.triangles, mesh.triangle_tags, mesh.triangle_lines);
        have_triangles = true;
      } else if (t.is("Triangles") && !face_tags_.empty()) {
        if (have_triangles) throw InputError(path_, t.line, "Triangles", "second Triangles section");
        if (!have_vertices)
          throw InputError(path_, t.line, "Triangles", "Triangles section comes before the Vertices section");
        read_tagged_faces(t, mesh);
        have_triangles = true;
      } else if (t.is("Tetrahedra") && !triangles_as_cloth_) {
        if (have_tets) throw InputError(path_, t.line, "Tetrahedra", "second Tetrahedra section");
        if (!have_vertices)
          throw InputError(path_, t.line, "Tetrahedra", "Tetrahedra section comes before the Vertices section");
        read_elements(t, 4, "tet", mesh.num_vertices(), mesh.tets, mesh.tet_tags, mesh.tet_lines);
        have_tets = true;
      } else if (t.is("Edges") && edges_as_strands_) {
        if (have_edges) throw InputError(path_, t.line, "Edges", "second Edges section");
        if (!have_vertices) throw InputError(path_, t.line, "Edges", "Edges section comes before the Vertices section");
        read_elements(t, 2, "edge", mesh.num_vertices(), mesh.segments, mesh.segment_tags, mesh.segment_lines);
        have_edges = true;
      } else if (t.is("Hexahedra") || t.is("Prisms") || t.is("Pyramids")) {
        // Other 3-D elements are not skipped: the body would lose them (its vertices dropped as
        // unused). An error, as Gmsh's (mesh_gmsh.cpp), when the section holds records.
        const Section s = open_section(t);
        const int vertices = t.is("Hexahedra") ? 8 : t.is("Prisms") ? 6 : 5;
        if (s.count > 0)
          throw InputError(path_, s.line, s.name, s.name + " (" + std::to_string(vertices) + "-vertex elements, " +
                                                      std::to_string(s.count) + " in this section) are not supported: the "
                                                      "body must be made of 4-vertex tetrahedra (a Tetrahedra section)");
      } else if (const MeditRecord record = medit_record(t); record.size) {
        Section s = open_section(t);
        for (long long i = 0; i < s.count; ++i)
          for (int k = 0; k < record.size; ++k) {
            if (k < record.vertices) {
              long long v;
              const Token index = integer(s, i, v);
              skipped_.add(s.name, i + 1, index, v);
            } else {
              double unused;
              number(s, i, unused);
            }
          }
      } else {
        double unused;
        if (parse_double(t, unused) || !number_note(t).empty())
          throw InputError(path_, t.line, "", "unexpected number '" + t.str() +
                                                  "' outside any section (does a section count match its records?)");
        throw InputError(path_, t.line, "", "unknown keyword '" + t.str() + "'");
      }
    }
    if (!have_vertices) throw InputError(path_, 0, "Vertices", "no Vertices section in the mesh file");
    skipped_.check(mesh.num_vertices());
    if (edges_as_strands_ && !have_edges)
      throw InputError(path_, 0, "Edges", "no Edges section in the mesh file (the deck asks for its edges as strands)");
    if (triangles_as_cloth_) {
      if (!have_triangles)
        throw InputError(path_, 0, "Triangles", "no Triangles section in the mesh file (the deck reads its surface as cloth)");
      return mesh;
    }
    if (!have_tets && !have_edges) throw InputError(path_, 0, "Tetrahedra", "no Tetrahedra section in the mesh file");
    return mesh;
  }

 private:
  struct Section {
    std::string name;
    int line;          // of the keyword
    long long count;   // declared number of records
  };

  // Next token of record i of section s; running out of tokens or meeting a keyword means the
  // section holds fewer records than it declares.
  Token record_token(const Section& s, long long i) {
    Token t;
    if (!tok_.next(t))
      throw InputError(path_, tok_.last_line(), s.name, truncated(s, i) + " before the end of the file");
    return t;
  }
  std::string truncated(const Section& s, long long i) const {
    return "section (line " + std::to_string(s.line) + ") declares " + std::to_string(s.count) +
           " records but ends after " + std::to_string(i);
  }
  [[noreturn]] void bad_token(const Section& s, long long i, const Token& t, const char* expected) {
    const char c = *t.begin;
    const std::string note = number_note(t);
    // A word that is not even strtod's number ("nan" is one) is the next keyword: the section ended early.
    if (((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z')) && note.empty())
      throw InputError(path_, t.line, s.name, truncated(s, i) + " at '" + t.str() + "'");
    throw InputError(path_, t.line, s.name, std::string("expected ") + expected + ", found '" + t.str() + "'" + note);
  }
  Token number(const Section& s, long long i, double& v) {
    Token t = record_token(s, i);
    if (!parse_double(t, v)) bad_token(s, i, t, "a number");
    return t;
  }
  Token integer(const Section& s, long long i, long long& v) {
    Token t = record_token(s, i);
    if (!parse_int(t, v)) bad_token(s, i, t, "an integer");
    return t;
  }

  // "Keyword N" header line: returns N.
  long long header_int(const Token& key, Token* where = nullptr) {
    Token t;
    long long v;
    if (!tok_.next(t)) throw InputError(path_, tok_.last_line(), key.str(), "missing value at the end of the file");
    if (!parse_int(t, v)) throw InputError(path_, t.line, key.str(), "expected an integer, found '" + t.str() + "'");
    if (where) *where = t;
    return v;
  }
  Section open_section(const Token& key) {
    Section s{key.str(), key.line, 0};
    Token t;
    const long long n = header_int(key, &t);
    if (n < 0 || n > std::numeric_limits<int32_t>::max())
      throw InputError(path_, t.line, s.name, "invalid record count " + t.str());
    s.count = n;
    return s;
  }

  void read_vertices(const Token& key, TetMesh& mesh) {
    Section s = open_section(key);
    mesh.coords.reserve(3 * capacity(s, 4));
    for (long long i = 0; i < s.count; ++i) {
      for (int k = 0; k < 3; ++k) {
        double x;
        Token t = number(s, i, x);
        if (!std::isfinite(x))
          throw InputError(path_, t.line, s.name, "vertex " + std::to_string(i + 1) + " has a non-finite coordinate '" + t.str() + "'");
        check_coordinate(path_, s.name, t, x, "vertex " + std::to_string(i + 1) + ": its coordinate");
        mesh.coords.push_back(x);
      }
      double ref;  // vertex refs are not used
      number(s, i, ref);
    }
    mesh.vertex_ids.resize(size_t(s.count));
    for (long long i = 0; i < s.count; ++i) mesh.vertex_ids[i] = i;
  }

  // A section of elements of n vertices each plus a reference tag ("tet", "edge" in messages).
  void read_elements(const Token& key, int n, const char* what, long long nv, std::vector<int32_t>& vertices,
                     std::vector<int32_t>& tags, RecordLines& lines) {
    Section s = open_section(key);
    vertices.reserve(n * capacity(s, n + 1));
    tags.reserve(capacity(s, n + 1));
    for (long long i = 0; i < s.count; ++i) {
      const std::string element = std::string(what) + " " + std::to_string(i + 1);
      for (int k = 0; k < n; ++k) {
        long long v;
        Token t = integer(s, i, v);
        if (k == 0) lines.add(i, t.line);
        if (v < 1 || v > nv)
          throw InputError(path_, t.line, s.name, element + ": vertex index " + t.str() + " is out of range 1.." + std::to_string(nv));
        vertices.push_back(int32_t(v - 1));
      }
      long long ref;
      Token t = integer(s, i, ref);
      if (ref < std::numeric_limits<int32_t>::min() || ref > std::numeric_limits<int32_t>::max())
        throw InputError(path_, t.line, s.name, element + ": reference " + t.str() + " is too large");
      tags.push_back(int32_t(ref));
    }
  }

  // The Triangles of a tet mesh: only those of the deck's face tags are kept (TaggedFaces).
  void read_tagged_faces(const Token& key, TetMesh& mesh) {
    Section s = open_section(key);
    const long long nv = mesh.num_vertices();
    for (long long i = 0; i < s.count; ++i) {
      long long v[3];
      for (int k = 0; k < 3; ++k) {
        Token t = integer(s, i, v[k]);
        if (v[k] < 1 || v[k] > nv)
          throw InputError(path_, t.line, s.name, "triangle " + std::to_string(i + 1) + ": vertex index " + t.str() +
                                                      " is out of range 1.." + std::to_string(nv));
      }
      long long ref;
      Token t = integer(s, i, ref);
      if (ref < std::numeric_limits<int32_t>::min() || ref > std::numeric_limits<int32_t>::max())
        throw InputError(path_, t.line, s.name, "triangle " + std::to_string(i + 1) + ": reference " + t.str() + " is too large");
      // A vertex's id is its 0-based position in the file (read_vertices).
      mesh.tagged_faces.read(face_tags_, int32_t(ref), v[0] - 1, v[1] - 1, v[2] - 1);
    }
  }

  // Reserve no more records than the file could hold (a record takes >= 2 bytes per token), so
  // a corrupt count gives a truncation error rather than a huge allocation.
  size_t capacity(const Section& s, int tokens_per_record) const {
    return std::min(size_t(s.count), text_size_ / (2 * size_t(tokens_per_record)) + 1);
  }

  std::string path_;
  Tokenizer tok_;
  SkippedIndices skipped_;
  size_t text_size_;
  bool edges_as_strands_;
  bool triangles_as_cloth_;
  std::vector<int32_t> face_tags_;  // ascending; empty: Triangles skipped
};

// det[X1-X0, X2-X0, X3-X0] = 6 * signed volume.
double tet_det(const double* x0, const double* x1, const double* x2, const double* x3) {
  const double a[3] = {x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2]};
  const double b[3] = {x2[0] - x0[0], x2[1] - x0[1], x2[2] - x0[2]};
  const double c[3] = {x3[0] - x0[0], x3[1] - x0[1], x3[2] - x0[2]};
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
}

double distance(const double* p, const double* q) {
  return std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
}

// The sections clean_mesh's messages name, those of source's format (by its extension): a Gmsh
// file's elements are in $Elements, an OBJ's faces on its f lines; Medit's (or a generated
// mesh's) otherwise.
struct SectionNames {
  const char *tets, *segments, *triangles, *vertices;
};
SectionNames section_names(const std::string& source) {
  const auto ends_with = [&](const char* ext) {
    const size_t n = std::strlen(ext);
    return source.size() >= n && source.compare(source.size() - n, n, ext) == 0;
  };
  if (ends_with(".msh")) return {"$Elements", "$Elements", "$Elements", "$Nodes"};
  if (ends_with(".obj")) return {"f", "f", "f", "v"};
  return {"Tetrahedra", "Edges", "Triangles", "Vertices"};
}

}  // namespace

TetMesh read_medit(const std::string& path, bool edges_as_strands, bool triangles_as_cloth,
                   const std::vector<int32_t>& face_tags) {
  const std::string text = read_text_file(path);
  return MeditReader(path, text, edges_as_strands, triangles_as_cloth, triangles_as_cloth ? std::vector<int32_t>{} : face_tags)
      .read();
}

void TaggedFaces::read(const std::vector<int32_t>& wanted, int32_t tag, int64_t a, int64_t b, int64_t c) {
  auto seen = std::lower_bound(file_tags.begin(), file_tags.end(), tag);
  if (seen == file_tags.end() || *seen != tag) file_tags.insert(seen, tag);
  if (!std::binary_search(wanted.begin(), wanted.end(), tag)) return;
  std::array<int64_t, 3> ids{a, b, c};
  std::sort(ids.begin(), ids.end());
  vertices.insert(vertices.end(), ids.begin(), ids.end());
  tags.push_back(tag);
}

std::vector<int64_t> TaggedFaces::vertex_ids_of(int32_t tag) const {
  std::vector<int64_t> ids;
  for (size_t f = 0; f < tags.size(); ++f)
    if (tags[f] == tag) ids.insert(ids.end(), &vertices[3 * f], &vertices[3 * f] + 3);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

// ---------------------------------------------------------------------------------------------

int64_t box_tets(const std::array<int, 3>& cells) { return int64_t(6) * cells[0] * cells[1] * cells[2]; }

TetMesh generate_box(const std::array<double, 3>& size, const std::array<int, 3>& cells) {
  for (int d = 0; d < 3; ++d) {
    if (!(size[d] > 0) || !std::isfinite(size[d])) throw std::invalid_argument("generate_box: box size must be positive");
    if (cells[d] < 1) throw std::invalid_argument("generate_box: need at least one cell per axis");
  }
  const int64_t n[3] = {cells[0] + int64_t(1), cells[1] + int64_t(1), cells[2] + int64_t(1)};
  const int64_t nv = n[0] * n[1] * n[2];
  const int64_t nt = box_tets(cells);
  if (nv > std::numeric_limits<int32_t>::max() || 4 * nt > std::numeric_limits<int32_t>::max())
    throw std::invalid_argument("generate_box: too many cells");

  return box_piece(size, cells, 0, 1).mesh;
}

TetMesh generate_sheet(const std::array<double, 2>& size, const std::array<int, 2>& cells) {
  for (int d = 0; d < 2; ++d) {
    if (!(size[d] > 0) || !std::isfinite(size[d])) throw std::invalid_argument("generate_sheet: sheet size must be positive");
    if (cells[d] < 1) throw std::invalid_argument("generate_sheet: need at least one cell per axis");
  }
  const int64_t nx = cells[0] + int64_t(1), nz = cells[1] + int64_t(1);
  if (nx * nz > std::numeric_limits<int32_t>::max() || 6 * int64_t(cells[0]) * cells[1] > std::numeric_limits<int32_t>::max())
    throw std::invalid_argument("generate_sheet: too many cells");
  return sheet_piece(size, cells, 0, 1).mesh;
}

// ---------------------------------------------------------------------------------------------

void RecordLines::add(int64_t record, int line) {
  if (!runs_.empty()) {
    Run& last = runs_.back();
    if (record == last.first + last.count && line == last.line + last.count) {
      ++last.count;
      return;
    }
  }
  runs_.push_back({record, 1, line});
}

int RecordLines::line_of(int64_t record) const {
  auto run = std::upper_bound(runs_.begin(), runs_.end(), record, [](int64_t r, const Run& p) { return r < p.first; });
  if (run == runs_.begin()) return 0;
  --run;
  return record < run->first + run->count ? run->line + int(record - run->first) : 0;
}

void bounding_box(const std::vector<double>& coords, double lo[3], double hi[3]) {
  for (int d = 0; d < 3; ++d) {
    lo[d] = HUGE_VAL;
    hi[d] = -HUGE_VAL;
  }
  for (size_t v = 0; v + 2 < coords.size(); v += 3)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], coords[v + d]);
      hi[d] = std::max(hi[d], coords[v + d]);
    }
}

double bounding_box_diagonal(const TetMesh& mesh) {
  double lo[3], hi[3];
  bounding_box(mesh.coords, lo, hi);
  if (mesh.coords.empty()) return 0;
  return distance(lo, hi);
}

void add_strand(TetMesh& mesh, const StrandLine& strand) {
  const int n = strand.segments;
  if (n < 1) throw std::invalid_argument("add_strand: need at least one segment");
  const int64_t nv = mesh.num_vertices();
  if (mesh.vertex_ids.size() != size_t(nv)) {  // hand-built meshes: ids are the indices
    mesh.vertex_ids.resize(size_t(nv));
    for (int64_t v = 0; v < nv; ++v) mesh.vertex_ids[v] = v;
  }
  const double tol = 1e-9 * std::max(bounding_box_diagonal(mesh), distance(strand.from.data(), strand.to.data()));
  auto existing = [&](const double* x) -> int64_t {
    for (int64_t v = 0; v < nv; ++v)
      if (distance(&mesh.coords[3 * v], x) <= tol) return v;
    return -1;
  };
  const int64_t first = existing(strand.from.data()), last = existing(strand.to.data());
  int64_t next_id = 0;
  for (int64_t id : mesh.vertex_ids) next_id = std::max(next_id, id + 1);
  // The strand's points 0..n; reused ends keep their index, the others are appended.
  std::vector<int64_t> index(size_t(n) + 1);
  for (int i = 0; i <= n; ++i) {
    if ((i == 0 && first >= 0) || (i == n && last >= 0)) {
      index[i] = i == 0 ? first : last;
      continue;
    }
    const double s = double(i) / n;
    for (int d = 0; d < 3; ++d) mesh.coords.push_back((1 - s) * strand.from[d] + s * strand.to[d]);
    index[i] = mesh.num_vertices() - 1;
    mesh.vertex_ids.push_back(next_id++);
  }
  if (mesh.num_vertices() > std::numeric_limits<int32_t>::max()) throw std::invalid_argument("add_strand: too many vertices");
  for (int i = 0; i < n; ++i) {
    mesh.segments.push_back(int32_t(index[i]));
    mesh.segments.push_back(int32_t(index[i + 1]));
    mesh.segment_tags.push_back(0);
  }
}

// ---------------------------------------------------------------------------------------------

void apply_transform(TetMesh& mesh, const MeshTransform& t) {
  const double deg = std::acos(-1.0) / 180.0;
  const double cx = std::cos(t.rotate_deg[0] * deg), sx = std::sin(t.rotate_deg[0] * deg);
  const double cy = std::cos(t.rotate_deg[1] * deg), sy = std::sin(t.rotate_deg[1] * deg);
  const double cz = std::cos(t.rotate_deg[2] * deg), sz = std::sin(t.rotate_deg[2] * deg);
  const double Rx[3][3] = {{1, 0, 0}, {0, cx, -sx}, {0, sx, cx}};
  const double Ry[3][3] = {{cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy}};
  const double Rz[3][3] = {{cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1}};
  auto mul = [](const double A[3][3], const double B[3][3], double C[3][3]) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) C[r][c] = A[r][0] * B[0][c] + A[r][1] * B[1][c] + A[r][2] * B[2][c];
  };
  double RyRx[3][3], R[3][3];
  mul(Ry, Rx, RyRx);
  mul(Rz, RyRx, R);
  for (size_t v = 0; v + 2 < mesh.coords.size(); v += 3) {
    double* x = &mesh.coords[v];
    const double p[3] = {t.scale * x[0], t.scale * x[1], t.scale * x[2]};
    for (int r = 0; r < 3; ++r) x[r] = R[r][0] * p[0] + R[r][1] * p[1] + R[r][2] * p[2] + t.translate[r];
  }
}

// ---------------------------------------------------------------------------------------------

// Two tets on the same four vertices (a duplicated line doubles that element's mass and
// stiffness), or two used vertices at exactly the same point (the body is split there, or the file
// holds two copies of it), are almost surely mistakes: an InputError naming both (1-based).
// Two elements on the same vertex set (sorted), by the kind's name: an InputError naming both.
template <int N>
static void reject_same_vertices(const std::vector<int32_t>& elements, const RecordLines& lines, const char* section,
                                 const char* what, const std::string& source) {
  const int64_t n = (int64_t)elements.size() / N;
  std::vector<std::pair<std::array<int32_t, N>, int64_t>> sorted(static_cast<size_t>(n));
  for (int64_t e = 0; e < n; ++e) {
    std::array<int32_t, N> t;
    std::copy_n(&elements[N * e], N, t.begin());
    std::sort(t.begin(), t.end());
    sorted[e] = {t, e};
  }
  std::sort(sorted.begin(), sorted.end());
  for (size_t k = 1; k < sorted.size(); ++k)
    if (sorted[k].first == sorted[k - 1].first)
      throw InputError(source, lines.line_of(sorted[k].second), section,
                       std::string(what) + "s " + std::to_string(sorted[k - 1].second + 1) + " and " +
                                               std::to_string(sorted[k].second + 1) + " have the same " +
                                               std::to_string(N) + " vertices (a duplicated element)");
}

static void reject_duplicates(const TetMesh& mesh, const std::vector<char>& used, const std::string& source) {
  const SectionNames names = section_names(source);
  reject_same_vertices<4>(mesh.tets, mesh.tet_lines, names.tets, "tet", source);
  reject_same_vertices<3>(mesh.triangles, mesh.triangle_lines, names.triangles, "triangle", source);
  std::vector<int64_t> points;
  for (int64_t v = 0; v < mesh.num_vertices(); ++v)
    if (used[v]) points.push_back(v);
  const auto at = [&](int64_t v) { return std::array<double, 3>{mesh.coords[3 * v], mesh.coords[3 * v + 1], mesh.coords[3 * v + 2]}; };
  std::sort(points.begin(), points.end(), [&](int64_t a, int64_t b) { return std::make_pair(at(a), a) < std::make_pair(at(b), b); });
  for (size_t k = 1; k < points.size(); ++k)
    if (at(points[k]) == at(points[k - 1])) {
      const int64_t a = std::min(points[k - 1], points[k]), b = std::max(points[k - 1], points[k]);
      throw InputError(source, 0, names.vertices, "vertices " + std::to_string(mesh.vertex_ids[a] + 1) + " and " +
                                                  std::to_string(mesh.vertex_ids[b] + 1) +
                                                  " are at the same point: the body is split there, or the mesh holds two "
                                                  "copies of it (merge them)");
    }
}

// The hinges (interior edges with the two vertices opposite them) and which triangle carries
// each edge (its first triangle), from the triangles; an edge of three or more triangles is an
// InputError naming its vertices (1-based ids of the input).
void connect_surface(TetMesh& mesh, const std::string& source, std::vector<int64_t>* hinge_triangles) {
  const int64_t nf = mesh.num_triangles();
  mesh.hinges.clear();
  if (hinge_triangles) hinge_triangles->clear();
  mesh.triangle_edges.assign(size_t(nf), 0);
  // (low vertex, high vertex, triangle, edge slot) per triangle edge, sorted by edge.
  std::vector<std::array<int64_t, 4>> edges;
  edges.reserve(3 * size_t(nf));
  for (int64_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const int32_t a = mesh.triangles[3 * f + k], b = mesh.triangles[3 * f + (k + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), f, k});
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1]) ++j;
    if (j - i > 2)
      throw InputError(source, 0, section_names(source).triangles, "the edge between vertices " + std::to_string(mesh.vertex_ids[edges[i][0]] + 1) +
                                                   " and " + std::to_string(mesh.vertex_ids[edges[i][1]] + 1) + " is shared by " +
                                                   std::to_string(j - i) + " triangles: a cloth must be a manifold surface");
    mesh.triangle_edges[edges[i][2]] |= uint8_t(1u << edges[i][3]);
    if (j - i == 2) {
      const int64_t f = edges[i][2], g = edges[i + 1][2];
      const int k = int(edges[i][3]), l = int(edges[i + 1][3]);
      const int32_t* t = &mesh.triangles[3 * f];
      const int32_t* u = &mesh.triangles[3 * g];
      mesh.hinges.insert(mesh.hinges.end(), {t[k], t[(k + 1) % 3], t[(k + 2) % 3], u[(l + 2) % 3]});
      if (hinge_triangles) hinge_triangles->push_back(f);
    }
    i = j;
  }
}

CleanReport clean_mesh(TetMesh& mesh, const std::string& source) {
  const int64_t nv = mesh.num_vertices(), nt = mesh.num_tets(), ns = mesh.num_segments(), nf = mesh.num_triangles();
  const SectionNames names = section_names(source);
  if (nt == 0 && ns == 0 && nf == 0 && names.triangles == std::string("f"))
    throw InputError(source, 0, "f", "the file has no faces (f lines of 3 or more vertices): a cloth needs triangles");
  if (nt == 0 && ns == 0 && nf == 0)
    throw InputError(source, 0, names.tets, "the mesh has no tetrahedra (and no strand segments or cloth triangles)");
  if (nf > 0 && nt + ns > 0)
    throw InputError(source, 0, names.triangles, "a cloth surface cannot share a mesh with tetrahedra or strands");
  if ((int64_t)mesh.vertex_ids.size() != nv) {  // e.g. hand-built meshes: ids are the indices
    mesh.vertex_ids.resize(size_t(nv));
    for (int64_t v = 0; v < nv; ++v) mesh.vertex_ids[v] = v;
  }
  if ((int64_t)mesh.tet_tags.size() != nt) mesh.tet_tags.resize(size_t(nt), 0);
  if ((int64_t)mesh.segment_tags.size() != ns) mesh.segment_tags.resize(size_t(ns), 0);
  if ((int64_t)mesh.triangle_tags.size() != nf) mesh.triangle_tags.resize(size_t(nf), 0);

  // Validate everything before changing anything, so a throw leaves the mesh untouched.
  std::vector<char> flip(size_t(nt), 0);
  std::vector<char> used(size_t(nv), 0);
  const double* X = mesh.coords.data();
  for (int64_t e = 0; e < nt; ++e) {
    const int32_t* t = &mesh.tets[4 * e];
    for (int k = 0; k < 4; ++k) {
      if (t[k] < 0 || t[k] >= nv)
        throw InputError(source, mesh.tet_lines.line_of(e), names.tets, "tet " + std::to_string(e + 1) + " has vertex index " +
                                                      std::to_string(t[k] + 1) + " out of range 1.." + std::to_string(nv));
      used[t[k]] = 1;
    }
    const double* x[4] = {X + 3 * t[0], X + 3 * t[1], X + 3 * t[2], X + 3 * t[3]};
    const double det = tet_det(x[0], x[1], x[2], x[3]);
    const double h = (distance(x[0], x[1]) + distance(x[0], x[2]) + distance(x[0], x[3]) + distance(x[1], x[2]) +
                      distance(x[1], x[3]) + distance(x[2], x[3])) / 6;
    // Scale-free test; written as !(a > b) so NaN coordinates are rejected too.
    if (!(std::fabs(det) > 1e-12 * h * h * h * 6)) {
      char msg[160];
      std::snprintf(msg, sizeof msg, "tet %lld (1-based, as in the input) is degenerate: volume %.3g, mean edge length %.3g",
                    (long long)(e + 1), det / 6, h);
      throw InputError(source, mesh.tet_lines.line_of(e), names.tets, msg);
    }
    flip[e] = det < 0;
  }
  const double min_length = 1e-12 * bounding_box_diagonal(mesh);
  for (int64_t e = 0; e < ns; ++e) {
    const int32_t* seg = &mesh.segments[2 * e];
    for (int k = 0; k < 2; ++k) {
      if (seg[k] < 0 || seg[k] >= nv)
        throw InputError(source, mesh.segment_lines.line_of(e), names.segments, "segment " + std::to_string(e + 1) + " has vertex index " +
                                                 std::to_string(seg[k] + 1) + " out of range 1.." + std::to_string(nv));
      used[seg[k]] = 1;
    }
    const double length = distance(X + 3 * seg[0], X + 3 * seg[1]);
    if (!(length > min_length)) {
      char msg[160];
      std::snprintf(msg, sizeof msg, "segment %lld (1-based, as in the input) is degenerate: length %.3g",
                    (long long)(e + 1), length);
      throw InputError(source, mesh.segment_lines.line_of(e), names.segments, msg);
    }
  }

  for (int64_t e = 0; e < nf; ++e) {
    const int32_t* f = &mesh.triangles[3 * e];
    for (int k = 0; k < 3; ++k) {
      if (f[k] < 0 || f[k] >= nv)
        throw InputError(source, mesh.triangle_lines.line_of(e), names.triangles, "triangle " + std::to_string(e + 1) + " has vertex index " +
                                                     std::to_string(f[k] + 1) + " out of range 1.." + std::to_string(nv));
      used[f[k]] = 1;
    }
    const double *a = X + 3 * f[0], *b = X + 3 * f[1], *c = X + 3 * f[2];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    const double area = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double h = (distance(a, b) + distance(b, c) + distance(c, a)) / 3;
    if (!(area > 1e-12 * h * h)) {  // NaN coordinates fail too
      char msg[160];
      std::snprintf(msg, sizeof msg, "triangle %lld (1-based, as in the input) is degenerate: area %.3g, mean edge length %.3g",
                    (long long)(e + 1), area, h);
      throw InputError(source, mesh.triangle_lines.line_of(e), names.triangles, msg);
    }
  }

  reject_duplicates(mesh, used, source);

  CleanReport report;
  std::vector<int32_t> new_index(size_t(nv), -1);
  int32_t kept = 0;
  for (int64_t v = 0; v < nv; ++v) {
    if (!used[v]) continue;
    new_index[v] = kept;
    for (int k = 0; k < 3; ++k) mesh.coords[3 * kept + k] = mesh.coords[3 * v + k];
    mesh.vertex_ids[kept] = mesh.vertex_ids[v];
    ++kept;
  }
  report.dropped_vertices = nv - kept;
  mesh.coords.resize(3 * size_t(kept));
  mesh.vertex_ids.resize(size_t(kept));

  for (int32_t& v : mesh.segments) v = new_index[v];
  for (int32_t& v : mesh.triangles) v = new_index[v];
  for (int64_t e = 0; e < nt; ++e) {
    int32_t* t = &mesh.tets[4 * e];
    for (int k = 0; k < 4; ++k) t[k] = new_index[t[k]];
    if (flip[e]) {
      std::swap(t[2], t[3]);
      ++report.reoriented_tets;
    }
  }
  connect_surface(mesh, source, nullptr);
  return report;
}

}  // namespace hyperqn
