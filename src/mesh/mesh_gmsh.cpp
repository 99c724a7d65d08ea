// Our own reader of Gmsh ASCII files (MSH 2.2 and 4.1) rather than PETSc's: every malformed file
// is then an InputError naming its section and line, and 4.1 files without $Entities (as meshio
// writes them) are read too.
#include "mesh/mesh_gmsh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "mesh/input_error.hpp"
#include "mesh/text_tokens.hpp"

namespace hyperqn {

namespace {

struct ElementType {
  int nodes;         // nodes per element
  int dim;           // 0 point, 1 line, 2 surface, 3 volume
  const char* name;  // for messages
};

// Gmsh element types 1..31 (the MSH format's numbering). Others are rejected as unknown.
const ElementType* element_type(long long type) {
  static const ElementType table[] = {
      {2, 1, "2-node line"},          {3, 2, "3-node triangle"},      {4, 2, "4-node quadrangle"},
      {4, 3, "4-node tetrahedron"},   {8, 3, "8-node hexahedron"},    {6, 3, "6-node prism"},
      {5, 3, "5-node pyramid"},       {3, 1, "3-node line"},          {6, 2, "6-node triangle"},
      {9, 2, "9-node quadrangle"},    {10, 3, "10-node tetrahedron"}, {27, 3, "27-node hexahedron"},
      {18, 3, "18-node prism"},       {14, 3, "14-node pyramid"},     {1, 0, "point"},
      {8, 2, "8-node quadrangle"},    {20, 3, "20-node hexahedron"},  {15, 3, "15-node prism"},
      {13, 3, "13-node pyramid"},     {9, 2, "9-node triangle"},      {10, 2, "10-node triangle"},
      {12, 2, "12-node triangle"},    {15, 2, "15-node triangle"},    {15, 2, "15-node triangle"},
      {21, 2, "21-node triangle"},    {4, 1, "4-node line"},          {5, 1, "5-node line"},
      {6, 1, "6-node line"},          {20, 3, "20-node tetrahedron"}, {35, 3, "35-node tetrahedron"},
      {56, 3, "56-node tetrahedron"}};
  const long long n = sizeof table / sizeof table[0];
  return type >= 1 && type <= n ? &table[type - 1] : nullptr;
}

constexpr long long kTet = 4;
constexpr long long kTriangle = 2;


class GmshReader {
 public:
  GmshReader(const std::string& path, const std::string& text, bool triangles_as_cloth, const std::vector<int32_t>& face_tags)
      : path_(path), tok_(text), kept_type_(triangles_as_cloth ? kTriangle : kTet),
        face_tags_(triangles_as_cloth ? std::vector<int32_t>{} : face_tags) {}

  TetMesh read() {
    read_format();
    TetMesh mesh;
    Token t;
    int nodes_line = 0, elements_line = 0;
    while (tok_.next(t)) {
      if (t.is("$MeshFormat")) throw InputError(path_, t.line, "$MeshFormat", "second $MeshFormat section");
      if (t.is("$Nodes")) {
        if (nodes_line) throw InputError(path_, t.line, "$Nodes", "second $Nodes section (the first is at line " + std::to_string(nodes_line) + ")");
        nodes_line = t.line;
        version4_ ? read_nodes_v4(t, mesh) : read_nodes_v2(t, mesh);
      } else if (t.is("$Elements")) {
        if (elements_line) throw InputError(path_, t.line, "$Elements", "second $Elements section (the first is at line " + std::to_string(elements_line) + ")");
        if (!nodes_line) throw InputError(path_, t.line, "$Elements", "$Elements comes before $Nodes");
        elements_line = t.line;
        version4_ ? read_elements_v4(t, mesh) : read_elements_v2(t, mesh);
      } else if (t.is("$Entities") && version4_) {
        if (have_entities_) throw InputError(path_, t.line, "$Entities", "second $Entities section");
        if (nodes_line) throw InputError(path_, t.line, "$Entities", "$Entities comes after $Nodes");
        read_entities(t);
        have_entities_ = true;
      } else if (t.is("$PhysicalNames")) {
        read_physical_names(t);
      } else if (t.is("$PartitionedEntities")) {
        throw InputError(path_, t.line, "$PartitionedEntities", "partitioned Gmsh files are not supported: save the mesh unpartitioned");
      } else if (*t.begin == '$' && t.end - t.begin > 1 && t.str().compare(0, 4, "$End") != 0) {
        skip_section(t);  // $NodeData, $Periodic, ...: not needed
      } else {
        throw InputError(path_, t.line, "", "unexpected '" + t.str() + "' outside any section (does a section's count match its records?)");
      }
    }
    if (!nodes_line) throw InputError(path_, 0, "$Nodes", "no $Nodes section in the Gmsh file");
    if (!elements_line) throw InputError(path_, 0, "$Elements", "no $Elements section in the Gmsh file");
    if (kept_type_ == kTriangle && mesh.triangles.empty())
      throw InputError(path_, elements_line, "$Elements", "no triangles (element type 2): the deck reads this file's surface as cloth");
    if (kept_type_ == kTet && mesh.tets.empty())
      throw InputError(path_, elements_line, "$Elements", "no tetrahedra (element type 4): a 3-D tetrahedral mesh is needed");
    return mesh;
  }

 private:
  struct Section {
    std::string name;  // "$Nodes"
    int line;          // of its opening keyword
  };

  std::string end_of(const Section& s) const { return "$End" + s.name.substr(1); }

  // Next token inside section s, for `what` ("node 3 of 10: x"); the end of the file or of the
  // section there means the section is shorter than it declares.
  Token next(const Section& s, const std::string& what) {
    Token t;
    if (!tok_.next(t))
      throw InputError(path_, tok_.last_line(), s.name, "the file ends inside the section (line " + std::to_string(s.line) +
                                                            ") where " + what + " was expected");
    if (*t.begin == '$')
      throw InputError(path_, t.line, s.name, "section (line " + std::to_string(s.line) + ") ends at '" + t.str() +
                                                  "' where " + what + " was expected (a count larger than its records?)");
    return t;
  }
  long long integer(const Section& s, const std::string& what, int* line = nullptr) {
    Token t = next(s, what);
    long long v;
    if (!parse_int(t, v)) throw InputError(path_, t.line, s.name, "expected " + what + " (an integer), found '" + t.str() + "'");
    if (line) *line = t.line;
    return v;
  }
  // An integer in [lo, hi].
  long long integer(const Section& s, const std::string& what, long long lo, long long hi) {
    int line;
    const long long v = integer(s, what, &line);
    if (v < lo || v > hi)
      throw InputError(path_, line, s.name, what + " is " + std::to_string(v) + ", outside " + std::to_string(lo) + ".." + std::to_string(hi));
    return v;
  }
  // coordinate: a node's, within the limits of every coordinate (check_coordinate).
  double number(const Section& s, const std::string& what, bool coordinate = false) {
    Token t = next(s, what);
    double v;
    if (!parse_double(t, v))
      throw InputError(path_, t.line, s.name, "expected " + what + " (a number), found '" + t.str() + "'" + number_note(t));
    if (!std::isfinite(v)) throw InputError(path_, t.line, s.name, what + " is not finite: '" + t.str() + "'");
    if (coordinate) check_coordinate(path_, s.name, t, v, what);
    return v;
  }
  void expect_end(const Section& s, const std::string& after) {
    const std::string end = end_of(s);
    Token t;
    if (!tok_.next(t))
      throw InputError(path_, tok_.last_line(), s.name, "no " + end + ": the file ends inside the section (line " + std::to_string(s.line) + ")");
    if (!t.is(end.c_str()))
      throw InputError(path_, t.line, s.name, "expected " + end + " after " + after + ", found '" + t.str() +
                                                  "' (more records than the section declares?)");
  }
  void skip_section(const Token& key) {
    const Section s{key.str(), key.line};
    const std::string end = end_of(s);
    Token t;
    while (tok_.next(t))
      if (t.is(end.c_str())) return;
    throw InputError(path_, tok_.last_line(), s.name, "no " + end + ": the file ends inside the section (line " + std::to_string(s.line) + ")");
  }

  void read_format() {
    Token t;
    if (!tok_.next(t)) throw InputError(path_, 1, "$MeshFormat", "the Gmsh file is empty");
    if (t.is("$NOD") || t.is("$NOE"))
      throw InputError(path_, t.line, "$MeshFormat", "MSH version 1 files are not supported: save the mesh as MSH 4.1 or 2.2 (ASCII)");
    if (!t.is("$MeshFormat")) throw InputError(path_, t.line, "$MeshFormat", "not a Gmsh file: it must begin with $MeshFormat, found '" + t.str() + "'");
    const Section s{"$MeshFormat", t.line};
    Token v = next(s, "the format version");
    double version;
    if (!parse_double(v, version)) throw InputError(path_, v.line, s.name, "expected the format version (a number), found '" + v.str() + "'");
    if (v.is("4.1")) {
      version4_ = true;
    } else if (!(version >= 2 && version < 3)) {
      throw InputError(path_, v.line, s.name, "MSH format version " + v.str() + " is not supported: save the mesh as MSH 4.1 or 2.2 (ASCII)");
    }
    int line;
    const long long file_type = integer(s, "the file type (0 ASCII, 1 binary)", &line);
    if (file_type == 1)
      throw InputError(path_, line, s.name, "binary Gmsh files are not supported: save the mesh as ASCII (Gmsh: Mesh.Binary = 0; meshio: binary=False)");
    if (file_type != 0) throw InputError(path_, line, s.name, "file type is " + std::to_string(file_type) + ", expected 0 (ASCII)");
    integer(s, "the data size");  // of binary files only
    expect_end(s, "the version, file type and data size");
  }

  // $PhysicalNames: not used (a tag is the group's number), but checked as declared: a count, then
  // per line a dimension, a tag and a name in double quotes (it may hold spaces).
  void read_physical_names(const Token& key) {
    const Section s{key.str(), key.line};
    const long long n = integer(s, "the number of physical names", 0, std::numeric_limits<int32_t>::max());
    for (long long i = 0; i < n; ++i) {
      const std::string what = "physical name " + std::to_string(i + 1) + " of " + std::to_string(n);
      integer(s, what + ": its dimension", 0, 3);
      integer(s, what + ": its tag");
      Token t = next(s, what + ": its name");
      if (*t.begin != '"')
        throw InputError(path_, t.line, s.name, what + ": expected its name in double quotes, found '" + t.str() + "'");
      const int line = t.line;
      const char* open = t.begin;
      while (!(t.end[-1] == '"' && t.end - 1 != open)) {  // the closing quote ends a token of the same line
        if (!tok_.next(t) || t.line != line)
          throw InputError(path_, line, s.name, what + ": its name's double quote is not closed on its line");
      }
    }
    expect_end(s, "the " + std::to_string(n) + " physical names it declares");
  }

  // $Entities (4.1): the first physical tag of each volume (0 for none) becomes its tets' tag.
  void read_entities(const Token& key) {
    const Section s{key.str(), key.line};
    const long long max_count = std::numeric_limits<int32_t>::max();
    long long count[4];
    for (int d = 0; d < 4; ++d) count[d] = integer(s, "the number of entities of dimension " + std::to_string(d), 0, max_count);
    for (int d = 0; d < 4; ++d)
      for (long long i = 0; i < count[d]; ++i) {
        const std::string what = "entity " + std::to_string(i + 1) + " of dimension " + std::to_string(d);
        int line;
        const long long tag = integer(s, what + ": its tag", &line);
        for (int k = 0; k < (d == 0 ? 3 : 6); ++k) number(s, what + ": a coordinate of its box");
        const long long nphys = integer(s, what + ": its number of physical tags", 0, max_count);
        long long first = 0;
        std::vector<int32_t> groups;
        for (long long p = 0; p < nphys; ++p) {
          const long long phys = integer(s, what + ": a physical tag", std::numeric_limits<int32_t>::min(), max_count);
          if (p == 0) first = phys;
          if (!face_tags_.empty()) groups.push_back(int32_t(phys));
        }
        if (d == 2 && !face_tags_.empty()) surface_groups_[tag] = groups;
        if (d > 0) {
          const long long nbound = integer(s, what + ": its number of bounding entities", 0, max_count);
          for (long long b = 0; b < nbound; ++b) integer(s, what + ": a bounding entity");
        }
        if (d == 3 && !volume_tag_.emplace(tag, int32_t(first)).second)
          throw InputError(path_, line, s.name, what + ": volume tag " + std::to_string(tag) + " appears twice");
      }
    expect_end(s, "the entities it declares");
  }

  // A node: its tag (unique, >= 1) and coordinates.
  void add_node_tag(const Section& s, long long tag, int line, TetMesh& mesh, long long index) {
    if (tag < 1) throw InputError(path_, line, s.name, "node tag " + std::to_string(tag) + " is not a positive integer");
    if (!node_index_.emplace(tag, int32_t(index)).second)
      throw InputError(path_, line, s.name, "node tag " + std::to_string(tag) + " appears twice");
    mesh.vertex_ids.push_back(index);
  }
  void read_coordinates(const Section& s, const std::string& what, TetMesh& mesh) {
    for (int k = 0; k < 3; ++k) mesh.coords.push_back(number(s, what + ": coordinate " + "xyz"[k], true));
  }

  void read_nodes_v2(const Token& key, TetMesh& mesh) {
    const Section s{key.str(), key.line};
    const long long n = integer(s, "the number of nodes", 0, std::numeric_limits<int32_t>::max());
    for (long long i = 0; i < n; ++i) {
      const std::string what = "node " + std::to_string(i + 1) + " of " + std::to_string(n);
      int line;
      const long long tag = integer(s, what + ": its tag", &line);
      add_node_tag(s, tag, line, mesh, i);
      read_coordinates(s, what, mesh);
    }
    expect_end(s, "the " + std::to_string(n) + " nodes it declares");
  }

  // A 4.1 $Nodes or $Elements section is a header (blocks, items, smallest and largest tag) and
  // blocks, each with its own count of items ("node" or "element").
  struct Blocks {
    long long blocks = 0, total = 0;
  };
  Blocks read_blocks_header(const Section& s, const std::string& item) {
    const long long max_count = std::numeric_limits<int32_t>::max();
    Blocks b;
    b.blocks = integer(s, "the number of " + item + " blocks", 0, max_count);
    b.total = integer(s, "the number of " + item + "s", 0, max_count);
    integer(s, "the smallest " + item + " tag");
    integer(s, "the largest " + item + " tag");
    return b;
  }
  std::string block_name(const std::string& item, long long b, const Blocks& h) {
    return item + " block " + std::to_string(b + 1) + " of " + std::to_string(h.blocks);
  }
  // The block's count of items, which must fit in what the header leaves after `read`.
  long long block_count(const Section& s, const std::string& item, const std::string& block, const Blocks& h,
                        long long read) {
    int line;
    const long long count = integer(s, block + ": its number of " + item + "s", &line);
    if (count < 0 || count > h.total - read)
      throw InputError(path_, line, s.name, block + " holds " + std::to_string(count) + " " + item + "s, more than the " +
                                                std::to_string(h.total) + " the section declares in all");
    return count;
  }
  // After the last block: the blocks held what the header declared, and the section ends.
  void end_blocks(const Section& s, const std::string& item, const Blocks& h, long long read) {
    if (read != h.total)
      throw InputError(path_, s.line, s.name, "declares " + std::to_string(h.total) + " " + item +
                                                  "s but its blocks hold " + std::to_string(read));
    expect_end(s, "the " + std::to_string(h.blocks) + " " + item + " blocks it declares");
  }

  void read_nodes_v4(const Token& key, TetMesh& mesh) {
    const Section s{key.str(), key.line};
    const Blocks h = read_blocks_header(s, "node");
    long long read = 0;
    for (long long b = 0; b < h.blocks; ++b) {
      const std::string block = block_name("node", b, h);
      const long long dim = integer(s, block + ": its entity dimension", 0, 3);
      integer(s, block + ": its entity tag");
      const long long parametric = integer(s, block + ": its parametric flag", 0, 1);
      int line;
      const long long count = block_count(s, "node", block, h, read);
      // The block lists its node tags, then their coordinates (plus u, v, w when parametric).
      for (long long i = 0; i < count; ++i) {
        const long long tag = integer(s, block + ": node tag " + std::to_string(i + 1), &line);
        add_node_tag(s, tag, line, mesh, read + i);
      }
      for (long long i = 0; i < count; ++i) {
        const std::string what = block + ": node " + std::to_string(i + 1);
        read_coordinates(s, what, mesh);
        for (long long k = 0; k < parametric * dim; ++k) number(s, what + ": a parametric coordinate");
      }
      read += count;
    }
    end_blocks(s, "node", h, read);
  }

  // The element's type; a 3-D element other than a first-order tet is an error.
  const ElementType& checked_type(const Section& s, long long type, int line) {
    const ElementType* et = element_type(type);
    if (!et) throw InputError(path_, line, s.name, "unknown element type " + std::to_string(type) + " (Gmsh types are 1..31)");
    if (et->dim == 3 && type != kTet) {
      if (std::string(et->name).find("tetrahedron") != std::string::npos)
        throw InputError(path_, line, s.name, std::string("higher-order tetrahedra (") + et->name + ", type " + std::to_string(type) +
                                                  ") are not supported: save a first-order mesh (Gmsh: Mesh.ElementOrder = 1)");
      throw InputError(path_, line, s.name, std::string("element type ") + std::to_string(type) + " (" + et->name +
                                                ") is not supported: the body must be made of 4-node tetrahedra (type 4)");
    }
    return *et;
  }

  // The nodes of an element; those of the kept type (tets, or triangles for a cloth) are kept
  // with the element's tag, the others skipped; a tet mesh's triangle of one of the deck's face
  // tags (groups: its physical groups) goes to tagged_faces.
  void read_element_nodes(const Section& s, const std::string& what, long long type, int nodes, int32_t tag, TetMesh& mesh,
                          const std::vector<int32_t>* groups = nullptr) {
    const bool face = groups && type == kTriangle && kept_type_ == kTet;
    int32_t v[4];
    int first_line = 0;
    for (int k = 0; k < nodes; ++k) {
      int line;
      const long long node = integer(s, what + ": a node tag", &line);
      if (k == 0) first_line = line;
      auto it = node_index_.find(node);
      if (it == node_index_.end())
        throw InputError(path_, line, s.name, what + ": node " + std::to_string(node) + " is not in $Nodes");
      if (type == kept_type_ || face) v[k] = it->second;
    }
    if (face)  // a vertex's id is its node's 0-based position in the file (add_node_tag)
      for (int32_t group : *groups) mesh.tagged_faces.read(face_tags_, group, v[0], v[1], v[2]);
    if (type != kept_type_) return;
    if (type == kTet) {
      mesh.tet_lines.add(mesh.num_tets(), first_line);
      mesh.tets.insert(mesh.tets.end(), v, v + 4);
      mesh.tet_tags.push_back(tag);
    } else {
      mesh.triangle_lines.add(mesh.num_triangles(), first_line);
      mesh.triangles.insert(mesh.triangles.end(), v, v + 3);
      mesh.triangle_tags.push_back(tag);
    }
  }

  void read_elements_v2(const Token& key, TetMesh& mesh) {
    const Section s{key.str(), key.line};
    const long long n = integer(s, "the number of elements", 0, std::numeric_limits<int32_t>::max());
    for (long long i = 0; i < n; ++i) {
      const std::string what = "element " + std::to_string(i + 1) + " of " + std::to_string(n);
      integer(s, what + ": its number");
      int line;
      const long long type = integer(s, what + ": its type", &line);
      const ElementType& et = checked_type(s, type, line);
      // Tags: physical group, elementary entity, then partitions; the first is the tet's tag.
      const long long ntags = integer(s, what + ": its number of tags", 0, 1000);
      int32_t tag = 0;
      for (long long k = 0; k < ntags; ++k) {
        const long long v = integer(s, what + ": a tag", std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max());
        if (k == 0) tag = int32_t(v);
      }
      if (face_tags_.empty()) {
        read_element_nodes(s, what, type, et.nodes, tag, mesh);
      } else {
        const std::vector<int32_t> groups{tag};  // 2.2 writes a triangle once per physical group
        read_element_nodes(s, what, type, et.nodes, tag, mesh, &groups);
      }
    }
    expect_end(s, "the " + std::to_string(n) + " elements it declares");
  }

  void read_elements_v4(const Token& key, TetMesh& mesh) {
    const Section s{key.str(), key.line};
    const Blocks h = read_blocks_header(s, "element");
    long long read = 0;
    for (long long b = 0; b < h.blocks; ++b) {
      const std::string block = block_name("element", b, h);
      const long long dim = integer(s, block + ": its entity dimension", 0, 3);
      int line;
      const long long entity = integer(s, block + ": its entity tag", &line);
      const int entity_line = line;
      const long long type = integer(s, block + ": its element type", &line);
      const ElementType& et = checked_type(s, type, line);
      if (et.dim != dim)
        throw InputError(path_, line, s.name, block + ": element type " + std::to_string(type) + " (" + et.name + ") is " +
                                                  std::to_string(et.dim) + "-D but the block's entity is " + std::to_string(dim) + "-D");
      // Tets take their volume's first physical tag; without $Entities (meshio writes none) the
      // volume's own tag is the only region label the file has.
      int32_t tag = 0;
      if (type == kTet && kept_type_ == kTet) {
        if (have_entities_) {
          auto it = volume_tag_.find(entity);
          if (it == volume_tag_.end())
            throw InputError(path_, entity_line, s.name, block + ": volume " + std::to_string(entity) + " is not in $Entities");
          tag = it->second;
        } else {
          if (entity < std::numeric_limits<int32_t>::min() || entity > std::numeric_limits<int32_t>::max())
            throw InputError(path_, entity_line, s.name, block + ": entity tag " + std::to_string(entity) + " is too large");
          tag = int32_t(entity);
        }
      } else if (type == kTriangle && kept_type_ == kTriangle) {
        if (entity < std::numeric_limits<int32_t>::min() || entity > std::numeric_limits<int32_t>::max())
          throw InputError(path_, entity_line, s.name, block + ": entity tag " + std::to_string(entity) + " is too large");
        tag = int32_t(entity);
      }
      // A tet mesh's triangles: their surface's physical groups, for the deck's face tags.
      std::vector<int32_t> groups;
      const bool faces = type == kTriangle && kept_type_ == kTet && !face_tags_.empty();
      if (faces && have_entities_) {
        auto it = surface_groups_.find(entity);
        if (it == surface_groups_.end())
          throw InputError(path_, entity_line, s.name, block + ": surface " + std::to_string(entity) + " is not in $Entities");
        groups = it->second;
      } else if (faces) {
        if (entity < std::numeric_limits<int32_t>::min() || entity > std::numeric_limits<int32_t>::max())
          throw InputError(path_, entity_line, s.name, block + ": entity tag " + std::to_string(entity) + " is too large");
        groups = {int32_t(entity)};
      }
      const long long count = block_count(s, "element", block, h, read);
      for (long long i = 0; i < count; ++i) {
        const std::string what = block + ": element " + std::to_string(i + 1);
        integer(s, what + ": its tag");
        read_element_nodes(s, what, type, et.nodes, tag, mesh, faces ? &groups : nullptr);
      }
      read += count;
    }
    end_blocks(s, "element", h, read);
  }

  std::string path_;
  Tokenizer tok_;
  bool version4_ = false;
  long long kept_type_;  // kTet, or kTriangle for a cloth
  bool have_entities_ = false;
  std::vector<int32_t> face_tags_;  // the deck's face tags, ascending (empty: triangles skipped)
  std::unordered_map<long long, int32_t> volume_tag_;  // 4.1 volume entity -> its tets' tag
  std::unordered_map<long long, std::vector<int32_t>> surface_groups_;  // 4.1 surface entity -> its physical tags
  std::unordered_map<long long, int32_t> node_index_;  // node tag -> 0-based position in the file
};

}  // namespace

TetMesh read_gmsh(const std::string& path, bool triangles_as_cloth, const std::vector<int32_t>& face_tags) {
  const std::string text = read_text_file(path);
  return GmshReader(path, text, triangles_as_cloth, face_tags).read();
}

}  // namespace hyperqn
