// Base64 (RFC 4648, '+' '/', '=' padding) of a .vtu piece's inline binary arrays (io/vtk_writer.cpp):
// an output frame's arrays are tens of MB, so the encoding is a measurable part of an output
// frame (docs/records/2026-12-03-field-cost.md). No PETSc; unit-tested in tests/test_base64.cpp.
#pragma once
#include <cstddef>
#include <string>

namespace hyperqn {

// Appends the base64 of data[0, n) to out. With AVX2 (checked at run time: the binary stays
// portable) 24 bytes at a time, else 3 at a time through a table; the same characters either way.
void append_base64(std::string& out, const char* data, size_t n);

// The same, 3 bytes at a time only (the reference the vectorized path is tested against).
void append_base64_scalar(std::string& out, const char* data, size_t n);

}  // namespace hyperqn
