#include "app/deck_reader.hpp"

namespace hyperqn::deck_reading {

std::string join(const Names& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

bool listed(const Names& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

// What a node holds, for "expected X, got Y" messages.
std::string describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null: return "an empty value";
    case YAML::NodeType::Scalar:
      // yaml-cpp tags quoted scalars "!": say so, since "1.0" in quotes is text, not a number.
      return n.Tag() == "!" ? "the quoted string \"" + n.Scalar() + "\"" : "'" + n.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list of " + std::to_string(n.size()) + " items";
    case YAML::NodeType::Map: return "a map";
    default: return "nothing";
  }
}

// Relative paths of mesh and obstacle files are relative to the deck's directory (not the working
// directory), so a deck and its meshes can be moved together. extensions: what kinds are read.
std::string resolve_input_file(const Reader& r, const Value& v, const fs::path& deck_dir, const Names& extensions,
                               const std::string& kinds) {
  fs::path file = r.text(v);
  if (file.empty()) r.fail(v, "empty file name");
  if (std::find(extensions.begin(), extensions.end(), file.extension().string()) == extensions.end())
    r.fail(v, "unsupported file '" + file.string() + "': expected " + kinds);
  fs::path resolved = file.is_absolute() ? file : (deck_dir / file).lexically_normal();
  std::error_code ec;
  if (!fs::is_regular_file(resolved, ec)) {
    // The full path, whatever the working directory, and the deck's own spelling if it differs.
    const fs::path full = fs::absolute(resolved, ec).lexically_normal();
    const bool there = fs::exists(resolved, ec);  // a directory, a FIFO: not a file to read
    r.fail(v, std::string(there ? "not a regular file: '" : "file not found: '") + full.string() + "'" +
                  (full == file ? "" : " (the deck's '" + file.string() + "'" +
                                           (file.is_absolute() ? "" : ", relative to the deck's directory") + ")"));
  }
  r.note_input(resolved.string(), v);
  return resolved.string();
}

}  // namespace hyperqn::deck_reading
