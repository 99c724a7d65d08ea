#include "geometry/surface_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "mesh/input_error.hpp"
#include "mesh/text_tokens.hpp"

namespace hyperqn {

namespace {

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

// OBJ is line oriented: one statement per line, its keyword first.
class ObjReader {
 public:
  ObjReader(const std::string& path, const std::string& text) : path_(path), tok_(text, '#') {}

  TriangleSurface read() {
    std::vector<Token> line;
    Token t;
    while (tok_.next(t)) {
      if (!line.empty() && t.line != line.front().line) {
        statement(line);
        line.clear();
      }
      line.push_back(t);
    }
    if (!line.empty()) statement(line);
    // Positive indices may name vertices given later in the file: checked once all are read.
    const long long nv = (long long)surface_.vertices.size();
    for (size_t f = 0; f < surface_.triangles.size(); ++f)
      for (int k = 0; k < 3; ++k)
        if (surface_.triangles[f][k] >= nv)
          throw InputError(path_, surface_.triangle_lines[f], "f",
                           "vertex index " + std::to_string(surface_.triangles[f][k] + 1) + " is out of range 1.." +
                               std::to_string(nv));
    return std::move(surface_);
  }

 private:
  void statement(const std::vector<Token>& line) {
    if (line[0].is("v")) {
      if (line.size() < 4) throw InputError(path_, line[0].line, "v", "a vertex needs 3 coordinates");
      Eigen::Vector3d x;
      for (int k = 0; k < 3; ++k) {
        const Token& c = line[k + 1];
        if (!parse_double(c, x[k]) || !std::isfinite(x[k]))
          throw InputError(path_, c.line, "v", "expected a finite number, found '" + c.str() + "'" + number_note(c));
        check_coordinate(path_, "v", c, x[k], "the coordinate");
      }
      surface_.vertices.push_back(x);
    } else if (line[0].is("f")) {
      if (line.size() < 4) throw InputError(path_, line[0].line, "f", "a face needs at least 3 vertices");
      std::vector<int> ids;
      for (size_t k = 1; k < line.size(); ++k) ids.push_back(vertex_index(line[k]));
      // Fan triangulation keeps the polygon's orientation.
      for (size_t k = 1; k + 1 < ids.size(); ++k) {
        surface_.triangles.push_back({ids[0], ids[k], ids[k + 1]});
        surface_.triangle_lines.push_back(line[0].line);
      }
    }
    // Anything else (vt, vn, o, g, s, usemtl, mtllib, l, ...) does not shape the obstacle.
  }

  // "i", "i/t", "i//n" or "i/t/n"; 1-based, or negative: counted back from the last vertex read.
  // The texture and normal indices t and n are not used, but must be indices too.
  int vertex_index(const Token& t) {
    Token head = t;
    head.end = std::find(t.begin, t.end, '/');
    long long i;
    if (!parse_int(head, i) || i == 0)
      throw InputError(path_, t.line, "f", "expected a vertex index, found '" + t.str() + "'");
    int parts = 1;
    for (Token part = head; part.end != t.end; ++parts) {
      part.begin = part.end + 1;
      part.end = std::find(part.begin, t.end, '/');
      long long j;
      const bool empty_texture = parts == 1 && part.begin == part.end && part.end != t.end;  // i//n
      if (parts == 3 || (!empty_texture && (!parse_int(part, j) || j == 0)))
        throw InputError(path_, t.line, "f", "expected a vertex as i, i/t, i//n or i/t/n (nonzero integers), found '" +
                                                 t.str() + "'");
    }
    const long long nv = (long long)surface_.vertices.size();
    if (i < 0) {
      if (-i > nv)
        throw InputError(path_, t.line, "f", "relative vertex index " + head.str() + " reaches before the first vertex");
      return int(nv + i);
    }
    if (i > std::numeric_limits<int>::max())
      throw InputError(path_, t.line, "f", "vertex index " + head.str() + " is too large");
    return int(i - 1);
  }

  std::string path_;
  Tokenizer tok_;
  TriangleSurface surface_;
};

class MeditSurfaceReader {
 public:
  MeditSurfaceReader(const std::string& path, const std::string& text) : path_(path), tok_(text, '#'), skipped_(path) {}

  TriangleSurface read() {
    Token t;
    bool have_vertices = false;
    std::vector<std::array<long long, 3>> raw;  // triangles, checked once the vertices are known
    std::vector<std::array<Token, 3>> where;
    while (tok_.next(t)) {
      if (t.is("End")) break;
      if (t.is("MeshVersionFormatted")) {
        Token v;
        const long long version = count(t, &v);
        check_medit_version(path_, v, version);
      } else if (t.is("Dimension")) {
        Token v;
        if (count(t, &v) != 3) throw InputError(path_, v.line, "Dimension", "only 3D surfaces are supported");
      } else if (t.is("Vertices")) {
        if (have_vertices) throw InputError(path_, t.line, "Vertices", "second Vertices section");
        have_vertices = true;
        const long long n = count(t);
        for (long long i = 0; i < n; ++i) {
          Eigen::Vector3d x;
          for (int k = 0; k < 3; ++k) {
            const Token c = number(t, x[k]);
            if (!std::isfinite(x[k]))
              throw InputError(path_, c.line, "Vertices", "non-finite coordinate '" + c.str() + "'");
            check_coordinate(path_, "Vertices", c, x[k], "the coordinate");
          }
          double ref;
          number(t, ref);
          surface_.vertices.push_back(x);
        }
      } else if (t.is("Triangles")) {
        const long long n = count(t);
        for (long long i = 0; i < n; ++i) {
          std::array<long long, 3> ids;
          std::array<Token, 3> at;
          for (int k = 0; k < 3; ++k) at[k] = integer(t, ids[k]);
          long long ref;
          integer(t, ref);
          raw.push_back(ids);
          where.push_back(at);
        }
      } else if (const MeditRecord record = medit_record(t); record.size) {
        const long long n = count(t);
        for (long long i = 0; i < n; ++i)
          for (int k = 0; k < record.size; ++k) {
            if (k < record.vertices) {
              long long v;
              const Token index = integer(t, v);
              skipped_.add(t.str(), i + 1, index, v);
            } else {
              double unused;
              number(t, unused);
            }
          }
      } else {
        throw InputError(path_, t.line, "", "unknown keyword '" + t.str() + "'");
      }
    }
    const long long nv = (long long)surface_.vertices.size();
    skipped_.check(nv);
    for (size_t f = 0; f < raw.size(); ++f) {
      for (int k = 0; k < 3; ++k)
        if (raw[f][k] < 1 || raw[f][k] > nv)
          throw InputError(path_, where[f][k].line, "Triangles",
                           "vertex index " + where[f][k].str() + " is out of range 1.." + std::to_string(nv));
      surface_.triangles.push_back({int(raw[f][0] - 1), int(raw[f][1] - 1), int(raw[f][2] - 1)});
      surface_.triangle_lines.push_back(where[f][0].line);
    }
    return std::move(surface_);
  }

 private:
  Token next(const Token& key) {
    Token t;
    if (!tok_.next(t))
      throw InputError(path_, tok_.last_line(), key.str(), "section (line " + std::to_string(key.line) +
                                                               ") ends early at the end of the file");
    return t;
  }
  Token number(const Token& key, double& v) {
    const Token t = next(key);
    if (!parse_double(t, v))
      throw InputError(path_, t.line, key.str(), "expected a number, found '" + t.str() + "'" + number_note(t));
    return t;
  }
  Token integer(const Token& key, long long& v) {
    const Token t = next(key);
    if (!parse_int(t, v)) throw InputError(path_, t.line, key.str(), "expected an integer, found '" + t.str() + "'");
    return t;
  }
  // The count after a section keyword; bounded so that a corrupt count fails on the records.
  long long count(const Token& key, Token* where = nullptr) {
    long long n;
    const Token t = integer(key, n);
    if (n < 0 || n > std::numeric_limits<int>::max())
      throw InputError(path_, t.line, key.str(), "invalid count " + t.str());
    if (where) *where = t;
    return n;
  }

  std::string path_;
  Tokenizer tok_;
  SkippedIndices skipped_;
  TriangleSurface surface_;
};

}  // namespace

TriangleSurface parse_obj(const std::string& path, const std::string& text) { return ObjReader(path, text).read(); }

TriangleSurface parse_medit_surface(const std::string& path, const std::string& text) {
  return MeditSurfaceReader(path, text).read();
}

TriangleSurface read_triangle_surface(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".mesh")
    throw InputError(path, 0, "", "unknown surface format '" + ext + "': expected .obj or .mesh");
  const std::string text = read_text_file(path);
  return ext == ".obj" ? parse_obj(path, text) : parse_medit_surface(path, text);
}

}  // namespace hyperqn
