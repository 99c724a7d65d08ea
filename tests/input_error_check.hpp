// A check for the unit tests of input readers: f must throw an InputError whose message names
// every given part (the file, line, key, ...).
#pragma once
#include <string>
#include <vector>

#include "check.hpp"
#include "mesh/input_error.hpp"

inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

template <class F>
void expect_input_error(const std::string& name, F f, const std::vector<std::string>& parts) {
  try {
    f();
    CHECK_MSG(false, name + ": no InputError thrown");
  } catch (const hyperqn::InputError& e) {
    const std::string what = e.what();
    for (const auto& p : parts) CHECK_MSG(contains(what, p), name + ": '" + p + "' not in: " + what);
  } catch (const std::exception& e) {
    CHECK_MSG(false, name + ": wrong exception type: " + e.what());
  }
}
