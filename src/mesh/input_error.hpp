// Errors in user input (decks, meshes, command-line options).
// Carries the place (file, optional line, optional key) so the message can name it.
#pragma once
#include <stdexcept>
#include <string>

namespace hyperqn {

class InputError : public std::runtime_error {
 public:
  // file: path of the offending file ("" for the command line); line: 1-based, 0 if unknown;
  // key: dotted deck key or mesh section ("" if none).
  InputError(const std::string& file, int line, const std::string& key, const std::string& what)
      : std::runtime_error(format(file, line, key, what)) {}
  // A message already formatted (e.g. received from another rank).
  explicit InputError(const std::string& message) : std::runtime_error(message) {}

 private:
  static std::string format(const std::string& file, int line, const std::string& key,
                            const std::string& what) {
    std::string s = file.empty() ? std::string("command line") : file;
    if (line > 0) s += ":" + std::to_string(line);
    s += ": ";
    if (!key.empty()) s += "'" + key + "': ";
    return s + what;
  }
};

}  // namespace hyperqn
