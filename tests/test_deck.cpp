// Unit test of the deck parser: valid decks give the values as written (or the defaults),
// and each validation rule rejects a bad deck with an InputError naming file, line and key.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "check.hpp"
#include "app/deck.hpp"
#include "mesh/input_error.hpp"

namespace fs = std::filesystem;
using hyperqn::Deck;
using hyperqn::InputError;
using hyperqn::load_deck;
using hyperqn::TimeIntegrator;

namespace {

fs::path g_dir;  // a fresh temporary directory for all decks and meshes of this run

fs::path write_file(const fs::path& rel, const std::string& text) {
  fs::path p = g_dir / rel;
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
  return p;
}

// Lines 1-2 of a valid deck; decks that test another section append to it from line 3.
const std::string kHead =
    "mesh: {box: {size: [1, 1, 1], cells: [1, 1, 1]}}\n"
    "material: {youngs_modulus: 1.0e5, poisson_ratio: 0.3, density: 1000}\n";
const std::string kMesh = "mesh: {box: {size: [1, 1, 1], cells: [1, 1, 1]}}\n";
const std::string kMaterial = "material: {youngs_modulus: 1.0e5, poisson_ratio: 0.3, density: 1000}\n";

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// Writes the deck and checks that load_deck rejects it with an InputError whose message names
// the file and line ("path:7:"), the dotted key ("'time.dt':") and, if given, a further text.
void expect_error(const std::string& name, const std::string& text, const std::string& key, int line,
                  const std::string& also = "") {
  fs::path p = write_file(name + ".yaml", text);
  try {
    load_deck(p.string());
    CHECK_MSG(false, name + ": the deck was accepted");
  } catch (const InputError& e) {
    std::string what = e.what();
    std::string place = p.string() + ":" + (line > 0 ? std::to_string(line) + ":" : "");
    CHECK_MSG(contains(what, place), name + ": expected '" + place + "' in: " + what);
    if (!key.empty()) CHECK_MSG(contains(what, "'" + key + "':"), name + ": expected key '" + key + "' in: " + what);
    if (!also.empty()) CHECK_MSG(contains(what, also), name + ": expected '" + also + "' in: " + what);
  } catch (const std::exception& e) {
    CHECK_MSG(false, name + ": not an InputError: " + e.what());
  }
}

Deck load_ok(const std::string& name, const std::string& text) {
  fs::path p = write_file(name + ".yaml", text);
  try {
    return load_deck(p.string());
  } catch (const std::exception& e) {
    CHECK_MSG(false, name + ": rejected: " + e.what());
    return Deck();
  }
}

void test_full_deck() {
  Deck d = load_ok("full", R"(# every key, none at its default
name: full_bar
mesh:
  file: meshes/bar.mesh
  transform: {scale: 2.0, rotate: [0, 0, 90], translate: [1, 2, 3]}
material:
  model: neohookean
  youngs_modulus: 1.0e5
  poisson_ratio: 0.3
  density: 1200
  J0: 0.2
  laplacian_weight: 5.0e4
fixed:
  - box: {min: [-1, -1, -1], max: [0.01, 2, 2]}
  - box:
      min: [3.99, -1, -1]
      max: [5, 2, 2]
gravity: [0, 0, -9.81]
time: {dt: 0.01, frames: 250, damping: 0.05}
solver:
  type: lbfgs
  iterations: 20
  grad_atol: 1.0e-8
  grad_rtol: 1.0e-5
  history: 7
  line_search: armijo
  warm_start: previous
output: {directory: out/full, every: 5, vtk: false, iterations_csv: false}
petsc:
  tao_ls_type: armijo
  tao:
    max_it: 50
    view:
  ksp_monitor: True
  pc_type: "none"
)");
  CHECK(d.path == (g_dir / "full.yaml").string());
  CHECK(d.name == "full_bar");
  CHECK(!d.mesh.is_box);
  CHECK(d.mesh.file == (g_dir / "meshes/bar.mesh").string());
  CHECK(d.mesh.transform.scale == 2.0);
  CHECK((d.mesh.transform.rotate_deg == std::array<double, 3>{0, 0, 90}));
  CHECK((d.mesh.transform.translate == std::array<double, 3>{1, 2, 3}));
  CHECK(d.material.model == "neohookean");
  CHECK_NEAR(d.material.mu, 1.0e5 / 2.6, 1e-9);
  CHECK_NEAR(d.material.lambda, 1.0e5 * 0.3 / (1.3 * 0.4), 1e-9);
  CHECK(d.material.has_density);
  CHECK(d.material.density == 1200);
  CHECK(d.material.J0 == 0.2);
  CHECK(d.material.laplacian_weight == 5.0e4);
  CHECK(d.fixed.size() == 2);
  if (d.fixed.size() == 2) {
    CHECK((d.fixed[0].min == std::array<double, 3>{-1, -1, -1}));
    CHECK((d.fixed[0].max == std::array<double, 3>{0.01, 2, 2}));
    CHECK(d.fixed[0].line == 14);
    CHECK((d.fixed[1].min == std::array<double, 3>{3.99, -1, -1}));
    CHECK((d.fixed[1].max == std::array<double, 3>{5, 2, 2}));
    CHECK(d.fixed[1].line == 15);
  }
  CHECK((d.gravity == std::array<double, 3>{0, 0, -9.81}));
  CHECK(d.time.dt == 0.01);
  CHECK(d.time.frames == 250);
  CHECK(d.time.damping == 0.05);
  CHECK(d.solver.type == "lbfgs");
  CHECK(d.solver.iterations == 20);
  CHECK(d.solver.grad_atol == 1.0e-8);
  CHECK(d.solver.grad_rtol == 1.0e-5);
  CHECK(d.solver.history == 7);
  CHECK(d.solver.line_search == "armijo");
  CHECK(d.solver.warm_start == hyperqn::WarmStart::previous);
  CHECK(d.output.directory == "out/full");
  CHECK(d.output.every == 5);
  CHECK(!d.output.vtk);
  CHECK(!d.output.iterations_csv);
  // Nested maps join with '_', in deck order; true passes the option alone, as empty values do.
  using Opts = std::vector<std::pair<std::string, std::string>>;
  Opts expected = {{"-tao_ls_type", "armijo"}, {"-tao_max_it", "50"}, {"-tao_view", ""},
                   {"-ksp_monitor", ""}, {"-pc_type", "none"}};
  CHECK(d.petsc_options == expected);
}

void test_defaults() {
  Deck d = load_ok("minimal", kMesh + "material: {mu: 10, lambda: 0, total_mass: 2.5}\n");
  CHECK(d.name == "minimal");
  CHECK(d.mesh.is_box);
  CHECK(d.mesh.file.empty());
  CHECK((d.mesh.box_size == std::array<double, 3>{1, 1, 1}));
  CHECK(d.mesh.transform.scale == 1.0);
  CHECK((d.mesh.transform.rotate_deg == std::array<double, 3>{0, 0, 0}));
  CHECK(d.material.model == "corotated");
  CHECK(d.material.mu == 10);
  CHECK(d.material.lambda == 0);  // lambda = 0 is allowed when given directly
  CHECK(!d.material.has_density);
  CHECK(d.material.total_mass == 2.5);
  CHECK(d.material.J0 == hyperqn::MaterialSpec().J0);
  CHECK(d.material.laplacian_weight == 0);
  CHECK(d.fixed.empty());
  CHECK((d.gravity == std::array<double, 3>{0, -9.81, 0}));
  const hyperqn::TimeSpec t;
  CHECK(d.time.dt == t.dt && d.time.frames == t.frames && d.time.damping == t.damping);
  const hyperqn::SolverSpec s;
  CHECK(d.solver.type == s.type && d.solver.iterations == s.iterations);
  CHECK(d.solver.grad_atol == s.grad_atol && d.solver.grad_rtol == s.grad_rtol);
  CHECK(d.solver.history == s.history && d.solver.line_search == s.line_search);
  CHECK(d.solver.warm_start == s.warm_start);
  CHECK(d.output.directory.empty() && d.output.every == 1 && d.output.vtk && d.output.iterations_csv);
  CHECK(d.petsc_options.empty());

  // Empty sections mean "all defaults"; integers are decimal even with a leading zero.
  Deck e = load_ok("empty_sections", kHead + "fixed:\ntime:\n  frames: 010\nsolver:\noutput:\npetsc:\n");
  CHECK(e.fixed.empty());
  CHECK(e.time.frames == 10);
  CHECK(e.petsc_options.empty());
}

void test_elastic_constants() {
  Deck d = load_ok("enu", kMesh + "material: {youngs_modulus: 2.0e6, poisson_ratio: 0.45, density: 1}\n");
  const double E = 2.0e6, nu = 0.45;
  CHECK_NEAR(d.material.mu, E / (2 * (1 + nu)), 1e-6);
  CHECK_NEAR(d.material.lambda, E * nu / ((1 + nu) * (1 - 2 * nu)), 1e-6);
  // A negative Poisson ratio is physical (auxetic) and accepted above -1.
  Deck a = load_ok("auxetic", kMesh + "material: {youngs_modulus: 1, poisson_ratio: -0.5, density: 1}\n");
  CHECK_NEAR(a.material.mu, 1.0, 1e-12);
  CHECK_NEAR(a.material.lambda, -0.5 / (0.5 * 2.0), 1e-12);
}

void test_mesh_paths() {
  const std::string material = "material: {mu: 1, lambda: 1, density: 1}\n";
  // Relative to the deck's directory, normalised.
  Deck up = load_ok("decks/up", "mesh: {file: ../meshes/bar.mesh}\n" + material);
  CHECK(up.mesh.file == (g_dir / "meshes/bar.mesh").string());
  CHECK(up.name == "up");
  // Absolute paths are kept as they are.
  std::string abs = (g_dir / "meshes/bar.msh").string();
  Deck a = load_ok("decks/abs", "mesh: {file: '" + abs + "'}\n" + material);
  CHECK(a.mesh.file == abs);

  // Not relative to the working directory: meshes/bar.mesh exists from g_dir but not from decks/.
  fs::path cwd = fs::current_path();
  fs::current_path(g_dir);
  write_file("decks/cwd.yaml", "mesh: {file: meshes/bar.mesh}\n" + material);
  try {
    load_deck("decks/cwd.yaml");
    CHECK_MSG(false, "mesh path resolved against the working directory");
  } catch (const InputError& e) {
    CHECK_MSG(contains(e.what(), "decks/meshes/bar.mesh"), e.what());
  }
  // A deck given by a relative path gives a mesh path relative to the same working directory.
  try {
    CHECK(load_deck("decks/up.yaml").mesh.file == "meshes/bar.mesh");
  } catch (const std::exception& e) {
    CHECK_MSG(false, e.what());
  }
  fs::current_path(cwd);
}

void test_invalid_decks() {
  // Structure and types.
  expect_error("unknown_section", kHead + "gravty: [0, -9.81, 0]\n", "gravty", 3, "allowed:");
  expect_error("unknown_key", kMesh + "material:\n  youngs_modulus: 1.0e5\n  poisson_ration: 0.3\n  density: 1\n",
               "material.poisson_ration", 4, "allowed: model, youngs_modulus, poisson_ratio");
  expect_error("duplicate_key", kHead + "time:\n  dt: 0.1\n  dt: 0.2\n", "time.dt", 5, "duplicate");
  expect_error("dt_string", kHead + "time:\n  dt: fast\n", "time.dt", 4, "expected a number");
  expect_error("dt_empty", kHead + "time:\n  dt:\n", "time.dt", 4, "empty value");
  expect_error("quoted_number", kMesh + "material: {youngs_modulus: 1, poisson_ratio: \"0.3\", density: 1}\n",
               "material.poisson_ratio", 2, "quoted");
  expect_error("gravity_short", kHead + "gravity: [0, -9.81]\n", "gravity", 3, "list of 3 numbers");
  expect_error("gravity_element", kHead + "gravity:\n  - 0\n  - down\n  - 0\n", "gravity[1]", 5);
  expect_error("frames_fraction", kHead + "time: {frames: 10.5}\n", "time.frames", 3, "integer");
  expect_error("vtk_not_bool", kHead + "output:\n  vtk: sometimes\n", "output.vtk", 4, "true or false");
  expect_error("section_not_map", kHead + "time: 0.1\n", "time", 3, "expected a map");
  expect_error("root_not_map", "just text\n", "", 1, "expected a map");
  expect_error("missing_mesh", kMaterial, "mesh", 1, "missing");
  expect_error("missing_material", kMesh, "material", 1, "missing");
  expect_error("empty_deck", "", "mesh", 0, "missing");
  expect_error("two_documents", kHead + "---\n" + kHead, "", 4, "one YAML document");
  expect_error("name_slash", kHead + "name: a/b\n", "name", 3);

  // Mesh.
  write_file("meshes/bar.mesh", "MeshVersionFormatted 2\nDimension 3\nEnd\n");
  write_file("meshes/bar.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
  write_file("meshes/bar.stl", "solid bar\nendsolid bar\n");
  expect_error("file_and_box", kMaterial + "mesh:\n  file: meshes/bar.mesh\n  box: {size: [1, 1, 1], cells: [1, 1, 1]}\n",
               "mesh", 2, "one of file, box and sheet");
  expect_error("no_file_no_box", kMaterial + "mesh:\n  transform: {scale: 2}\n", "mesh", 2);
  expect_error("mesh_not_found", kMaterial + "mesh: {file: meshes/nothere.mesh}\n", "mesh.file", 2,
               (g_dir / "meshes/nothere.mesh").string());
  expect_error("mesh_extension", kMaterial + "mesh: {file: meshes/bar.stl}\n", "mesh.file", 2, ".msh");
  expect_error("box_cells_zero", kMaterial + "mesh:\n  box:\n    size: [4, 1, 1]\n    cells: [20, 0, 5]\n",
               "mesh.box.cells[1]", 5, ">= 1");
  expect_error("box_cells_fraction", kMaterial + "mesh: {box: {size: [4, 1, 1], cells: [2.5, 1, 1]}}\n",
               "mesh.box.cells[0]", 2, "integer");
  expect_error("box_size_zero", kMaterial + "mesh:\n  box:\n    size: [0, 1, 1]\n    cells: [1, 1, 1]\n",
               "mesh.box.size[0]", 4, "> 0");
  expect_error("box_missing_cells", kMaterial + "mesh:\n  box:\n    size: [4, 1, 1]\n", "mesh.box.cells", 3);
  expect_error("scale_zero", kMaterial + "mesh:\n  box: {size: [1, 1, 1], cells: [1, 1, 1]}\n  transform: {scale: 0}\n",
               "mesh.transform.scale", 4, "> 0");
  expect_error("rotate_short", kMaterial + "mesh:\n  box: {size: [1, 1, 1], cells: [1, 1, 1]}\n  transform:\n    rotate: [0, 90]\n",
               "mesh.transform.rotate", 5);

  // Material.
  const std::string m = kMesh + "material:\n";  // material keys start at line 3
  expect_error("both_pairs", m + "  youngs_modulus: 1\n  poisson_ratio: 0.3\n  mu: 1\n  lambda: 1\n  density: 1\n",
               "material.mu", 5, "not both");
  expect_error("E_without_nu", m + "  youngs_modulus: 1\n  density: 1\n", "material.poisson_ratio", 3);
  expect_error("lambda_without_mu", m + "  density: 1\n  lambda: 1\n", "material.mu", 4);
  expect_error("no_elastic_constants", m + "  density: 1\n", "material", 2, "youngs_modulus");
  expect_error("nu_half", m + "  youngs_modulus: 1\n  poisson_ratio: 0.5\n  density: 1\n", "material.poisson_ratio", 4);
  expect_error("nu_minus_one", m + "  youngs_modulus: 1\n  poisson_ratio: -1\n  density: 1\n", "material.poisson_ratio", 4);
  expect_error("E_zero", m + "  youngs_modulus: 0\n  poisson_ratio: 0.3\n  density: 1\n", "material.youngs_modulus", 3);
  expect_error("mu_zero", m + "  mu: 0\n  lambda: 1\n  density: 1\n", "material.mu", 3, "> 0");
  expect_error("lambda_negative", m + "  mu: 1\n  lambda: -1\n  density: 1\n", "material.lambda", 4, ">= 0");
  expect_error("density_and_mass", m + "  mu: 1\n  lambda: 1\n  density: 1\n  total_mass: 1\n",
               "material.total_mass", 6, "not both");
  expect_error("no_mass", m + "  mu: 1\n  lambda: 1\n", "material", 2, "density or total_mass");
  expect_error("density_zero", m + "  mu: 1\n  lambda: 1\n  density: 0\n", "material.density", 5);
  expect_error("total_mass_negative", m + "  mu: 1\n  lambda: 1\n  total_mass: -2\n", "material.total_mass", 5);
  expect_error("unknown_model", m + "  model: mooney-rivlin\n  mu: 1\n  lambda: 1\n  density: 1\n", "material.model", 3,
               "allowed: corotated, neohookean, stvk, principal-stretch");
  expect_error("kappa_not_stvk", m + "  mu: 1\n  lambda: 1\n  density: 1\n  kappa: 5\n", "material.kappa", 6, "stvk only");
  expect_error("principal_with_mu", m + "  model: principal-stretch\n  mu: 1\n  density: 1\n", "material.mu", 4);
  expect_error("principal_without_functions", m + "  model: principal-stretch\n  density: 1\n", "material", 2,
               "needs f, g or h");
  expect_error("spline_x_not_increasing",
               m + "  model: principal-stretch\n  density: 1\n  f: {spline: {x: [1, 0.5], y: [0, 1]}}\n",
               "material.f.spline.x", 5, "increasing");
  expect_error("fiber_zero_direction", m + "  mu: 1\n  lambda: 1\n  density: 1\n  fiber: {direction: [0, 0, 0], stiffness: 1}\n",
               "material.fiber.direction", 6);
  expect_error("J0_one", m + "  model: neohookean\n  mu: 1\n  lambda: 1\n  density: 1\n  J0: 1\n", "material.J0", 7);
  expect_error("J0_corotated", m + "  mu: 1\n  lambda: 1\n  density: 1\n  J0: 0.2\n", "material.J0", 6, "neohookean");
  expect_error("laplacian_weight_zero", m + "  mu: 1\n  lambda: 1\n  density: 1\n  laplacian_weight: 0\n",
               "material.laplacian_weight", 6, "must be > 0 (omit the key for the material's own weight), got 0");
  // The material keys come from the registry: a key of another model names the models that take
  // it and the model given; an unknown key lists the keys of the model given; a range is the
  // registry's (materials/material_factory.cpp).
  expect_error("J0_stvk", m + "  model: stvk\n  mu: 1\n  lambda: 1\n  density: 1\n  J0: 0.2\n", "material.J0", 7,
               "applies to model neohookean only (model is stvk)");
  expect_error("E_springs_unknown", m + "  model: mass-spring\n  spring_stiffness: 1\n  density: 1\n  stiffnes: 1\n",
               "material.stiffnes", 6,
               "unknown key 'stiffnes' in material; allowed: model, spring_stiffness, density, total_mass, laplacian_weight");
  expect_error("fiber_springs", m + "  model: mass-spring\n  spring_stiffness: 1\n  density: 1\n  fiber: {direction: [1, 0, 0], stiffness: 1}\n",
               "material.fiber", 6, "applies to model corotated, neohookean, stvk, principal-stretch only");
  expect_error("fiber_no_stiffness", m + "  mu: 1\n  lambda: 1\n  density: 1\n  fiber: {direction: [1, 0, 0]}\n",
               "material.fiber.stiffness", 6, "missing required key 'stiffness' in material.fiber");
  expect_error("fiber_negative_stiffness", m + "  mu: 1\n  lambda: 1\n  density: 1\n  fiber: {direction: [1, 0, 0], stiffness: -1}\n",
               "material.fiber.stiffness", 6, "must be >= 0, got -1");
  expect_error("kappa_negative", m + "  model: stvk\n  mu: 1\n  lambda: 1\n  density: 1\n  kappa: -1\n", "material.kappa", 7,
               "must be >= 0, got -1");
  expect_error("springs_zero", m + "  model: mass-spring\n  spring_stiffness: 0\n  density: 1\n",
               "material.spring_stiffness", 4, "must be > 0, got 0");
  expect_error("nu_range_text", m + "  youngs_modulus: 1\n  poisson_ratio: 0.5\n  density: 1\n", "material.poisson_ratio", 4,
               "must be in (-1, 0.5), got 0.5");
  expect_error("principal_with_E", m + "  model: principal-stretch\n  youngs_modulus: 1\n  density: 1\n",
               "material.youngs_modulus", 4, "principal-stretch takes f, g, h instead of elastic constants");
  expect_error("total_mass_zero_text", m + "  mu: 1\n  lambda: 1\n  total_mass: 0\n", "material.total_mass", 5,
               "must be > 0, got 0");

  // Fixed regions.
  expect_error("fixed_min_gt_max",
               kHead + "fixed:\n  - box: {min: [0, 0, 0], max: [1, 1, 1]}\n  - box: {min: [0, 2, 0], max: [1, 1, 1]}\n",
               "fixed[1].box", 5, "along y");
  expect_error("fixed_not_list", kHead + "fixed:\n  box: {min: [0, 0, 0], max: [1, 1, 1]}\n", "fixed", 3, "list");
  expect_error("fixed_missing_max", kHead + "fixed:\n  - box: {min: [0, 0, 0]}\n", "fixed[0].box.max", 4);
  expect_error("fixed_unknown_shape", kHead + "fixed:\n  - sphere: {center: [0, 0, 0]}\n", "fixed[0].sphere", 4);

  // Time, solver, output.
  expect_error("dt_zero", kHead + "time: {dt: 0}\n", "time.dt", 3, "> 0");
  expect_error("frames_zero", kHead + "time:\n  dt: 0.1\n  frames: 0\n", "time.frames", 5, "in [1, 100000000]");
  expect_error("damping_one", kHead + "time: {damping: 1}\n", "time.damping", 3, "[0, 1)");
  expect_error("damping_negative", kHead + "time: {damping: -0.1}\n", "time.damping", 3);
  expect_error("unknown_solver", kHead + "solver:\n  type: gauss-seidel\n", "solver.type", 4, "allowed: lbfgs, lbfgs-identity, newton, pd");
  expect_error("unknown_linear_solver", kHead + "solver: {linear_solver: lu}\n", "solver.linear_solver", 3, "allowed: auto, mumps, cg-amg");
  expect_error("study_frame_beyond_scene", kHead + "time: {frames: 5}\nstudy: {frames: [6]}\n", "study.frames[0]", 4, "[1, time.frames = 5]");
  expect_error("study_unknown_solver", kHead + "study:\n  solvers: [lbfgs, cg]\n", "study.solvers[1]", 4);
  expect_error("iterations_zero", kHead + "solver: {iterations: 0}\n", "solver.iterations", 3);
  expect_error("history_negative", kHead + "solver:\n  history: -1\n", "solver.history", 4);
  expect_error("grad_atol_negative", kHead + "solver: {grad_atol: -1.0e-9}\n", "solver.grad_atol", 3);
  expect_error("grad_rtol_negative", kHead + "solver:\n\n  grad_rtol: -1.0e-6\n", "solver.grad_rtol", 5);
  expect_error("unknown_line_search", kHead + "solver: {line_search: wolfe}\n", "solver.line_search", 3,
               "allowed: more-thuente, armijo, unit");
  expect_error("unknown_warm_start", kHead + "solver: {warm_start: zero}\n", "solver.warm_start", 3,
               "allowed: inertial, previous");
  expect_error("every_zero", kHead + "output: {every: 0}\n", "output.every", 3);

  // PETSc options.
  expect_error("petsc_list", kHead + "petsc:\n  tao:\n    ls_type: [a, b]\n", "petsc.tao.ls_type", 5);
  expect_error("petsc_dash", kHead + "petsc:\n  -tao_view:\n", "petsc.-tao_view", 4, "leading '-'");

  // PETSc options are words: a value with whitespace would be split into more options; a name is
  // letters, digits and '_' (starting with a letter); one option given twice is ambiguous.
  expect_error("petsc_value_space", kHead + "petsc: {tao_ls_type: \"unit -tao_type garbage\"}\n",
               "petsc.tao_ls_type", 3, "one word");
  expect_error("petsc_value_tab", kHead + "petsc:\n  tao:\n    ls_type: \"unit\\tx\"\n", "petsc.tao.ls_type", 5, "one word");
  expect_error("petsc_value_newline", kHead + "petsc:\n  log_view: \"a\\nb\"\n", "petsc.log_view", 4, "one word");
  expect_error("petsc_value_trailing_space", kHead + "petsc: {tao_ls_type: 'armijo '}\n", "petsc.tao_ls_type", 3, "one word");
  expect_error("petsc_name_space", kHead + "petsc:\n  tao ls_type: armijo\n", "petsc.tao ls_type", 4, "letters, digits");
  expect_error("petsc_name_equals", kHead + "petsc:\n  tao_ls_type=armijo:\n", "petsc.tao_ls_type=armijo", 4, "letters, digits");
  expect_error("petsc_name_digit", kHead + "petsc:\n  7_view: 1\n", "petsc.7_view", 4, "starting with a letter");
  expect_error("petsc_too_deep", kHead + "petsc: {a: {b: {c: {d: {e: {f: {g: {h: {i: {j: 1}}}}}}}}}}\n",
               "petsc.a.b.c.d.e.f.g.h.i", 3, "nested more than 8 levels deep");
  expect_error("gravity_text", kHead + "gravity: down\n", "gravity", 3, "expected a list of 3 numbers, got 'down'");
  expect_error("petsc_nested_name_dash", kHead + "petsc:\n  tao:\n    ls-type: armijo\n", "petsc.tao.ls-type", 5);
  expect_error("petsc_twice", kHead + "petsc:\n  tao_ls_type: unit\n  tao:\n    ls_type: armijo\n", "petsc.tao.ls_type", 6,
               "also given at line 4");
  {  // digits are fine after the first part; the deck's line and key of each option are kept
    Deck d = load_ok("petsc_places", kHead + "petsc:\n  mat_mumps_icntl: {7: 5}\n  tao:\n    ls_type: armijo\n");
    using Opts = std::vector<std::pair<std::string, std::string>>;
    CHECK((d.petsc_options == Opts{{"-mat_mumps_icntl_7", "5"}, {"-tao_ls_type", "armijo"}}));
    CHECK(d.petsc_option_places["-mat_mumps_icntl_7"].line == 4);
    CHECK(d.petsc_option_places["-tao_ls_type"].line == 6);
    CHECK(d.petsc_option_places["-tao_ls_type"].key == "petsc.tao.ls_type");
    CHECK(hyperqn::deck_option_place(d, "-tao_ls_type", "armijo") == &d.petsc_option_places["-tao_ls_type"]);
    CHECK(hyperqn::deck_option_place(d, "-tao_ls_type", "unit") == nullptr);  // the command line's value
    CHECK(hyperqn::deck_option_place(d, "-tao_type", "lmvm") == nullptr);
  }

  // Explicit YAML tags are refused wherever they are (values, list items, sections, keys, the
  // document): yaml-cpp and the Python tools would read such values differently.
  expect_error("tag_str", kHead + "time:\n  dt: !!str 0.05\n", "time.dt", 4, "YAML tags are not accepted, found !!str");
  expect_error("tag_float", kHead + "time: {dt: !!float '0.05'}\n", "time.dt", 3, "!!float");
  expect_error("tag_int", kHead + "solver:\n  iterations: !!int 3\n", "solver.iterations", 4, "!!int");
  expect_error("tag_local", kHead + "solver: {type: !foo lbfgs}\n", "solver.type", 3, "!foo");
  expect_error("tag_verbatim", kHead + "name: !<tag:yaml.org,2002:str> bar\n", "name", 3, "!!str");
  expect_error("tag_binary", kHead + "name: !!binary YmFy\n", "name", 3, "!!binary");
  expect_error("tag_null", kHead + "output:\n  directory: !!null\n", "output.directory", 4, "!!null");
  expect_error("tag_list_item", kHead + "gravity:\n  - 0\n  - !!float -9.81\n  - 0\n", "gravity[1]", 5, "!!float");
  expect_error("tag_section", kHead + "time: !!map\n  dt: 0.05\n", "time", 3, "!!map");
  expect_error("tag_list", kHead + "gravity: !!seq [0, -9.81, 0]\n", "gravity", 3, "!!seq");
  expect_error("tag_key", kHead + "time:\n  !!str dt: 0.05\n", "time.dt", 4, "!!str");
  expect_error("tag_petsc", kHead + "petsc:\n  tao_ls_type: !!str armijo\n", "petsc.tao_ls_type", 4, "!!str");
  expect_error("tag_document", "--- !!map\n" + kHead, "", 1, "!!map");
  expect_error("tag_in_mesh", kMaterial + "mesh:\n  box: {size: [1, 1, !!float 1], cells: [1, 1, 1]}\n", "mesh.box.size[2]", 3,
               "!!float");
  {  // untagged: plain, quoted, empty, anchored and aliased values
    Deck d = load_ok("untagged", kHead + "name: 'bar'\ntime: &t {dt: 0.05}\nstudy: {trajectory: true}\npetsc: {log_view: }\n");
    CHECK(d.name == "bar" && d.time.dt == 0.05);
  }

  // YAML syntax: yaml-cpp's line (the badly indented key).
  expect_error("syntax_error", kHead + "time:\n  dt: 0.1\n   frames: 3\n", "", 5, "YAML syntax error");

  // The deck file itself.
  std::string missing = (g_dir / "no_such_deck.yaml").string();
  try {
    load_deck(missing);
    CHECK_MSG(false, "missing deck accepted");
  } catch (const InputError& e) {
    CHECK_MSG(contains(e.what(), missing) && contains(e.what(), "not found"), e.what());
  }
}

#ifdef HYPERQN_SOURCE_DIR
// The shipped default deck must stay valid.
void test_new_materials() {
  Deck d = load_ok("materials", kMesh + R"(material:
  model: principal-stretch
  density: 1
  f: {polynomial: [0, 0, 2.0]}
  h: {spline: {x: [0.5, 1.0, 1.5], y: [-2.0, 0.0, 2.0]}}
  fiber: {direction: [0, 1, 0], stiffness: 3}
)");
  CHECK(d.material.model == "principal-stretch" && d.material.f.kind == "polynomial" && d.material.g.kind.empty());
  CHECK(d.material.h.kind == "spline" && d.material.h.x.size() == 3 && d.material.h.y[2] == 2.0);
  CHECK(d.material.has_fiber && d.material.fiber_direction[1] == 1 && d.material.fiber_stiffness == 3);
  Deck ms = load_ok("springs", kMesh + "material: {model: mass-spring, spring_stiffness: 40, density: 2}\n");
  CHECK(ms.material.model == "mass-spring" && ms.material.spring_stiffness == 40);
  ms = load_ok("springs_weight", kMesh + "material: {model: mass-spring, spring_stiffness: 40, density: 2, laplacian_weight: 80}\n");
  CHECK(ms.material.laplacian_weight == 80);
  expect_error("springs_without_k", kMesh + "material:\n  model: mass-spring\n  density: 1\n", "material.spring_stiffness", 2);
  expect_error("springs_with_E", kMesh + "material:\n  model: mass-spring\n  spring_stiffness: 1\n  youngs_modulus: 1\n  density: 1\n",
               "material.youngs_modulus", 5, "mass-spring takes spring_stiffness");
  expect_error("k_not_springs", kMesh + "material:\n  mu: 1\n  lambda: 1\n  density: 1\n  spring_stiffness: 5\n",
               "material.spring_stiffness", 6, "mass-spring only");
  Deck s = load_ok("stvk", kMesh + "material: {model: stvk, mu: 1, lambda: 2, kappa: 100, density: 1}\n");
  CHECK(s.material.model == "stvk" && s.material.kappa == 100);
}

void test_initial_state() {
  CHECK(load_ok("init_squash", kHead + "initial: {squash: {axis: 2, factor: 0.5}}\n").initial.kind == hyperqn::InitialKind::squash);
  Deck r = load_ok("init_random", kHead + "initial: {random: {seed: 7}}\n");
  CHECK(r.initial.kind == hyperqn::InitialKind::random && r.initial.seed == 7);
  CHECK(load_ok("init_no_collapse", kHead + "initial: {collapse: false}\n").initial.kind == hyperqn::InitialKind::rest);
  CHECK(load_ok("init_invert", kHead + "initial: {invert: {axis: 0}}\n").initial.axis == 0);
  expect_error("init_two_forms", kHead + "initial: {collapse: true, invert: {axis: 0}}\n", "initial", 3, "exactly one");
  expect_error("init_bad_axis", kHead + "initial: {invert: {axis: 3}}\n", "initial.invert.axis", 3, "in [0, 2] (x, y or z)");
  expect_error("init_negative_factor", kHead + "initial: {squash: {axis: 1, factor: -1}}\n", "initial.squash.factor", 3);
  expect_error("init_unknown", kHead + "initial: {explode: true}\n", "initial.explode", 3);
}

void test_regions_and_motion() {
  Deck d = load_ok("regions", kHead + R"(regions:
  - box: {min: [0, 0, 0], max: [0.5, 1, 1]}
    material: {model: neohookean, mu: 2, lambda: 3, density: 7}
  - tags: [2, 5]
    material: {mu: 1, lambda: 1, density: 1}
fixed:
  - box: {min: [0, 0, 0], max: [0, 1, 1]}
    motion:
      rotate: {axis: [0, 0, 2], center: [1, 2, 3], rate: 90}
      translate: {velocity: [0.5, 0, 0]}
      start: 0.5
      end: 2
)");
  CHECK(d.regions.size() == 2);
  CHECK(d.regions[0].by_box && d.regions[0].material.model == "neohookean");
  CHECK_NEAR(d.regions[0].material.density, 7, 0);
  CHECK(!d.regions[1].by_box && d.regions[1].tags == std::vector<int>({2, 5}));
  CHECK(d.regions[1].line == 6);
  const hyperqn::Motion& m = d.fixed[0].motion;
  CHECK(m.active && m.axis[2] == 2 && m.center[1] == 2 && m.rate_deg == 90 && m.velocity[0] == 0.5);
  CHECK(m.start == 0.5 && m.end == 2);
  const std::string region = "regions:\n  - box: {min: [0, 0, 0], max: [1, 1, 1]}\n    material: {mu: 1, lambda: 1, ";
  expect_error("region_total_mass", kHead + region + "total_mass: 1}\n", "regions[0].material", 5, "density");
  expect_error("region_box_and_tags", kHead + "regions:\n  - {box: {min: [0, 0, 0], max: [1, 1, 1]}, tags: [1], material: {mu: 1, lambda: 1, density: 1}}\n",
               "regions[0]", 4, "either box or tags");
  expect_error("region_no_material", kHead + "regions:\n  - tags: [1]\n", "regions[0].material", 4, "missing");
  const std::string fixed = "fixed:\n  - box: {min: [0, 0, 0], max: [0, 1, 1]}\n    motion:\n";
  expect_error("motion_zero_axis", kHead + fixed + "      rotate: {axis: [0, 0, 0], rate: 1}\n", "fixed[0].motion.rotate.axis", 6);
  expect_error("motion_end_before_start", kHead + fixed + "      start: 2\n      end: 1\n", "fixed[0].motion.end", 7);
  Deck rel = load_ok("release", kHead + "fixed:\n  - box: {min: [0, 0, 0], max: [0, 1, 1]}\n    release: 2.5\n");
  CHECK(rel.fixed[0].release == 2.5);
  expect_error("release_zero", kHead + "fixed:\n  - box: {min: [0, 0, 0], max: [0, 1, 1]}\n    release: 0\n", "fixed[0].release", 5);
  expect_error("motion_unknown_key", kHead + fixed + "      spin: 1\n", "fixed[0].motion.spin", 6);
}

// Curves (params/curve.hpp) in the motions of a fixed region, an attachment and a collider, inline
// and from a CSV file beside the deck; each bad curve names its deck line and key.
void test_curves() {
  write_file("curves/pull.csv", "time,value\n0,0\n1,0.5\n2,0.5\n");
  Deck d = load_ok("curves/good", kHead + R"(fixed:
  - box: {min: [0, 0, 0], max: [0, 1, 1]}
    motion:
      translate: {velocity: [0, 0, 1]}
      curve: {type: table, file: pull.csv}
attachments:
  - box: {min: [1, 0, 0], max: [1, 1, 1]}
    stiffness: 10
    motion: {rotate: {axis: [1, 0, 0], rate: 90}, curve: {type: ramp, start: 0.5, end: 1.5}}
colliders:
  - type: sphere
    center: [0, -1, 0]
    radius: 0.5
    motion:
      translate: {velocity: [0.1, 0, 0]}
      curve: {type: sine, amplitude: 1, frequency: 2, phase: 180}
)");
  const hyperqn::Curve& table = d.fixed[0].motion.curve;
  CHECK(table.given && table.type == hyperqn::CurveType::table && table.points.size() == 3 && table.points[1][1] == 0.5);
  CHECK(fs::path(table.file) == (g_dir / "curves/pull.csv").lexically_normal());
  const hyperqn::Curve& ramp = d.attachments[0].region.motion.curve;
  CHECK(ramp.given && ramp.type == hyperqn::CurveType::ramp && ramp.start == 0.5 && ramp.end == 1.5);
  const hyperqn::Curve& sine = d.colliders[0].motion.curve;
  CHECK(sine.given && sine.type == hyperqn::CurveType::sine && sine.frequency == 2 && sine.phase_deg == 180);

  const std::string fixed = "fixed:\n  - box: {min: [0, 0, 0], max: [0, 1, 1]}\n    motion:\n      translate: {velocity: [0, 0, 1]}\n";
  const auto bad = [&](const std::string& name, const std::string& curve, const std::string& key, int line,
                       const std::string& also) {
    expect_error("curves/" + name, kHead + fixed + curve, "fixed[0].motion." + key, line, also);
  };
  bad("one_point", "      curve: {type: table, points: [[0, 0]]}\n", "curve.points", 7, "a table of 1 point");
  bad("not_increasing", "      curve:\n        type: table\n        points:\n          - [0, 0]\n          - [1, 1]\n          - [1, 2]\n",
      "curve.points[2]", 12, "has the time 1, not after the previous point's 1");
  bad("nan_point", "      curve: {type: table, points: [[0, 0], [1, .nan]]}\n", "curve.points[1][1]", 7, "expected a number");
  bad("both", "      curve: {type: table, points: [[0, 0], [1, 1]], file: pull.csv}\n", "curve", 7, "one of the two");
  bad("neither", "      curve: {type: table}\n", "curve", 7, "one of the two");
  bad("missing_file", "      curve: {type: table, file: none.csv}\n", "curve.file", 7, "none.csv");
  write_file("curves/decreasing.csv", "0,0\n1,1\n0.5,2\n");
  bad("bad_file", "      curve: {type: table, file: decreasing.csv}\n", "curve.file", 7,
      "decreasing.csv' line 3: the row has the time 0.5, not after the previous point's 1");
  write_file("curves/nan.csv", "t,v\n0,0\n1,NaN\n");
  bad("nan_file", "      curve: {type: table, file: nan.csv}\n", "curve.file", 7, "nan.csv' line 3: the value must be finite");
  bad("not_csv", "      curve: {type: table, file: pull.txt}\n", "curve.file", 7, ".csv");
  bad("ramp_backwards", "      curve: {type: ramp, start: 2, end: 1}\n", "curve.end", 7, "> start (2)");
  bad("ramp_no_end", "      curve: {type: ramp}\n", "curve.end", 7, "missing");
  bad("sine_key_of_ramp", "      curve: {type: ramp, end: 1, amplitude: 1}\n", "curve.amplitude", 7, "sine only");
  bad("sine_not_zero", "      curve: {type: sine, amplitude: 1, frequency: 1, phase: 90}\n", "curve", 7, "at t = 0");
  bad("table_not_zero", "      curve: {type: table, points: [[0.5, 1], [1, 2]]}\n", "curve", 7, "is 1 at t = 0");
  bad("curve_and_end", "      end: 2\n      curve: {type: ramp, end: 1}\n", "end", 7, "either start and end or curve");
  bad("unknown_type", "      curve: {type: square}\n", "curve.type", 7, "allowed: ramp, sine, table");
}

void test_attachments() {
  Deck d = load_ok("attachments", kHead + R"(attachments:
  - {box: {min: [0, 0, 0], max: [0, 1, 1]}, stiffness: 1.0e4}
  - box: {min: [1, 0, 0], max: [1, 1, 1]}
    stiffness: 2.5e3
    motion: {translate: {velocity: [0, 1, 0]}, end: 0.5}
    release: 1.5
)");
  CHECK(d.attachments.size() == 2);
  if (d.attachments.size() == 2) {
    const hyperqn::AttachmentSpec &a = d.attachments[0], &b = d.attachments[1];
    CHECK(a.stiffness == 1.0e4 && a.region.line == 4 && !a.region.motion.active && a.region.release < 0);
    CHECK((a.region.max == std::array<double, 3>{0, 1, 1}));
    CHECK(b.stiffness == 2.5e3 && b.region.line == 5 && b.region.release == 1.5);
    CHECK(b.region.motion.active && b.region.motion.velocity[1] == 1 && b.region.motion.end == 0.5);
  }
  const std::string box = "attachments:\n  - box: {min: [0, 0, 0], max: [0, 1, 1]}\n";
  expect_error("attach_no_stiffness", kHead + box, "attachments[0].stiffness", 4, "missing");
  expect_error("attach_stiffness_zero", kHead + box + "    stiffness: 0\n", "attachments[0].stiffness", 5, "> 0");
  expect_error("attach_stiffness_negative", kHead + box + "    stiffness: -1\n", "attachments[0].stiffness", 5, "> 0");
  expect_error("attach_stiffness_nan", kHead + box + "    stiffness: .nan\n", "attachments[0].stiffness", 5, "number");
  expect_error("attach_stiffness_huge", kHead + box + "    stiffness: 1e300\n", "attachments[0].stiffness", 5, "1e100");
  // Every number 0 or at least 1e-100 in magnitude: a subnormal is named at its key (a key that refuses 0,
  // as the stiffness, is not told it may be 0).
  expect_error("attach_stiffness_subnormal", kHead + box + "    stiffness: 1e-320\n", "attachments[0].stiffness", 5,
               "must be at least 1e-100");
  expect_error("youngs_modulus_subnormal", kMesh + "material: {youngs_modulus: 1e-320, poisson_ratio: 0.3, density: 1000}\n",
               "material.youngs_modulus", 2, "subnormal");
  // A generated box or sheet of flat cells (M + h^2 L would not be positive definite).
  expect_error("box_flat_cells", "mesh:\n  box: {size: [1, 1, 1e-7], cells: [1, 1, 1]}\n" + kMaterial, "mesh.box.size", 2,
               "1 x 1 x 1e-07");
  expect_error("sheet_flat_cells", "mesh:\n  sheet: {size: [1, 1], cells: [1, 10000000]}\n", "mesh.sheet.size", 2,
               "less than 1e-06 of the longest");
  load_ok("box_thin_cells", "mesh:\n  box: {size: [1, 1, 2e-6], cells: [1, 1, 1]}\n" + kMaterial);
  expect_error("attach_release_zero", kHead + box + "    stiffness: 1\n    release: 0\n", "attachments[0].release", 6, "> 0");
  expect_error("attach_release_text", kHead + box + "    stiffness: 1\n    release: later\n", "attachments[0].release", 6);
  expect_error("attach_unknown_key", kHead + box + "    stiffness: 1\n    damping: 1\n", "attachments[0].damping", 6, "allowed");
  expect_error("attach_no_box", kHead + "attachments:\n  - {stiffness: 1}\n", "attachments[0].box", 4, "missing");
  expect_error("attach_box_min_gt_max", kHead + "attachments:\n  - {box: {min: [0, 2, 0], max: [1, 1, 1]}, stiffness: 1}\n",
               "attachments[0].box", 4, "along y");
  expect_error("attach_motion_unknown", kHead + box + "    stiffness: 1\n    motion: {spin: 1}\n", "attachments[0].motion.spin", 6);
  expect_error("attach_not_list", kHead + "attachments: {stiffness: 1}\n", "attachments", 3, "list");
}

// colliders: and contact:, and the solver defaults that colliders change.
void test_colliders() {
  write_file("ramp.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n");
  Deck d = load_ok("colliders", kHead + R"(colliders:
  - {type: plane, point: [0, -1, 0], normal: [0, 2, 0], friction: 0.4}
  - type: sphere
    center: [0, 1, 0]
    radius: 0.3
    motion: {translate: {velocity: [0, -0.5, 0]}}
  - {type: box, min: [-1, -2, -1], max: [1, -1.5, 1]}
  - {type: capsule, a: [0, 0, 0], b: [1, 0, 0], radius: 0.1}
  - {type: mesh, file: ramp.obj}
contact: {model: barrier, distance: 0.01, stiffness: 100, friction_velocity: 0.001}
)");
  CHECK(d.colliders.size() == 5);
  if (d.colliders.size() == 5) {
    CHECK(d.colliders[0].type == hyperqn::ColliderType::plane && d.colliders[0].normal[1] == 2 && d.colliders[0].friction == 0.4);
    CHECK(d.colliders[1].radius == 0.3 && d.colliders[1].motion.active && d.colliders[1].line == 5);
    CHECK(d.colliders[2].min[1] == -2 && d.colliders[3].b[0] == 1);
    CHECK(fs::path(d.colliders[4].file).filename() == "ramp.obj" && fs::exists(d.colliders[4].file));  // resolved beside the deck
  }
  CHECK(d.contact.model == hyperqn::ContactModel::barrier && d.contact.distance == 0.01 && d.contact.stiffness == 100 &&
        d.contact.friction_velocity == 0.001);
  CHECK(d.contact.line == 12 && d.contact.distance_line == 12);  // where a distance beyond the body is named
  CHECK(d.solver.history == 20 && d.solver.warm_start == hyperqn::WarmStart::lower);  // contact's defaults
  CHECK(d.solver.history_reset == hyperqn::HistoryReset::never);
  CHECK(d.solver.upright_guess);  // the default: y pulled back where it would invert elements
  CHECK(!load_ok("upright_guess", kHead + "solver: {upright_guess: false}\n").solver.upright_guess);
  expect_error("upright_guess_bad", kHead + "solver: {upright_guess: sometimes}\n", "solver.upright_guess", 3, "true or false");
  CHECK(load_ok("history_reset", kHead + "solver: {history_reset: contact-change}\n").solver.history_reset == hyperqn::HistoryReset::contact_change);
  expect_error("history_reset_bad", kHead + "solver: {history_reset: always}\n", "solver.history_reset", 3, "never, contact-change");
  // Choices are enums once read: solver.h0 (auto stays auto until the mesh resolves it), output.format.
  CHECK(d.solver.h0 == hyperqn::H0::automatic);
  CHECK(load_ok("h0_rest", kHead + "solver: {h0: rest-stiffness}\n").solver.h0 == hyperqn::H0::rest_stiffness);
  CHECK(load_ok("h0_volumetric", kHead + "solver: {h0: volumetric}\n").solver.h0 == hyperqn::H0::volumetric);
  CHECK(load_ok("format_xdmf", kHead + "output: {format: xdmf}\n").output.format == hyperqn::OutputFormat::xdmf);
  // study lists: declared list keys, each item checked
  const Deck st = load_ok("study_lists", kHead + "time: {frames: 4}\nstudy: {frames: [1, 4], solvers: [pd, newton]}\n");
  CHECK(st.study.frames == std::vector<int>({1, 4}) && st.study.solvers == std::vector<std::string>({"pd", "newton"}));
  expect_error("study_frames_empty", kHead + "study: {frames: []}\n", "study.frames", 3, "non-empty");
  expect_error("study_frame_zero", kHead + "study: {frames: [0]}\n", "study.frames[0]", 3, "[1, time.frames = ");
  d = load_ok("colliders_history", kHead + "colliders: [{type: plane, point: [0, 0, 0], normal: [0, 1, 0]}]\nsolver: {history: 7}\n");
  CHECK(d.solver.history == 7);  // given: kept
  CHECK(load_ok("no_colliders", kHead).solver.history == hyperqn::SolverSpec().history);
  const std::string plane = "colliders:\n  - {type: plane, point: [0, 0, 0], normal: [0, 1, 0]}\n";
  expect_error("contact_unknown_model", kHead + plane + "contact: {model: springs}\n", "contact.model", 5, "penalty, barrier");
  expect_error("contact_stiffness_low", kHead + plane + "contact: {stiffness: 0.5}\n", "contact.stiffness", 5, "[1, 1e12]");
  expect_error("collider_no_type", kHead + "colliders:\n  - {radius: 1}\n", "colliders[0].type", 4, "missing");
  expect_error("collider_sphere_no_radius", kHead + "colliders:\n  - {type: sphere, center: [0, 0, 0]}\n",
               "colliders[0].radius", 4, "missing");
  expect_error("collider_obj_extension", kHead + "colliders:\n  - {type: mesh, file: ramp.stl}\n", "colliders[0].file", 4, ".obj");
  expect_error("collider_motion", kHead + "colliders:\n  - {type: sphere, center: [0, 0, 0], radius: 1, motion: {spin: 1}}\n",
               "colliders[0].motion.spin", 4);
  // A key of another type names the types it belongs to; an unknown key, the keys of the type given.
  expect_error("collider_key_of_other_type", kHead + "colliders:\n  - {type: plane, point: [0, 0, 0], normal: [0, 1, 0], "
               "radius: 1}\n", "colliders[0].radius", 4, "applies to type sphere, capsule only (type is plane)");
  expect_error("collider_unknown_key", kHead + "colliders:\n  - {type: plane, point: [0, 0, 0], normal: [0, 1, 0], "
               "size: 1}\n", "colliders[0].size", 4, "allowed: type, point, normal, friction, motion");
  expect_error("collider_zero_normal", kHead + "colliders:\n  - {type: plane, point: [0, 0, 0], normal: [0, 0, 0]}\n",
               "colliders[0].normal", 4, "nonzero");
  expect_error("collider_type_enum", kHead + "colliders:\n  - {type: cone}\n", "colliders[0].type", 4,
               "allowed: plane, sphere, box, capsule, mesh");
}

void test_default_deck() {
  Deck d = load_deck(std::string(HYPERQN_SOURCE_DIR) + "/input/bar.yaml");
  CHECK(d.name == "bar");
  CHECK(d.mesh.is_box);
  CHECK((d.mesh.box_cells == std::array<int, 3>{24, 6, 6}));
  CHECK(d.material.model == "neohookean");
  CHECK(d.fixed.size() == 1);
  // The strands example: a cube on a rope.
  d = load_deck(std::string(HYPERQN_SOURCE_DIR) + "/input/strands.yaml");
  CHECK(d.mesh.is_box && d.mesh.strands.size() == 1 && d.mesh.strands[0].segments == 40);
  CHECK(d.has_material && d.strand_material.axial_stiffness == 2.0e4);
}
#endif

// Strands: generated or from a Medit file's Edges, with their own material section.
void test_strand_decks() {
  const std::string strand = "mesh:\n  strands:\n    - {from: [0, 0, 0], to: [0, -1, 0], segments: 10}\n";  // lines 1-3
  const std::string strand_material = "strand_material: {axial_stiffness: 50, linear_density: 0.1}\n";
  Deck d = load_ok("strand_only", strand + strand_material);
  CHECK(d.mesh.strands.size() == 1 && d.mesh.strands[0].segments == 10 && d.mesh.strands[0].to[1] == -1.0);
  CHECK(d.mesh.has_strands() && !d.mesh.has_solid() && d.strand_material.axial_stiffness == 50);
  CHECK(d.mesh.strands[0].line == 3);
  d = load_ok("box_and_strand", "mesh:\n  box: {size: [1, 1, 1], cells: [1, 1, 1]}\n  strands:\n"
                                "    - {from: [1, 1, 1], to: [1, 2, 1], segments: 3}\n" + kMaterial + strand_material);
  CHECK(d.mesh.is_box && d.mesh.strands.size() == 1 && d.strand_material.linear_density == 0.1);
  d = load_ok("medit_edges", "mesh: {file: meshes/bar.mesh, edges: strands}\n" + kMaterial + strand_material);
  CHECK(d.mesh.edges_as_strands && d.mesh.has_strands() && d.has_material);
  // A Medit file read for its edges may hold strands only: material is then optional here (the
  // scene checks it once the file is read).
  d = load_ok("medit_edges_no_material", "mesh: {file: meshes/bar.mesh, edges: strands}\n" + strand_material);
  CHECK(d.mesh.edges_as_strands && !d.has_material);
  CHECK(!load_ok("medit_ignore", "mesh: {file: meshes/bar.mesh, edges: ignore}\n" + kMaterial).mesh.has_strands());

  expect_error("strand_no_material", strand, "strand_material", 1, "the mesh has strands");
  expect_error("strand_material_without_strands", kHead + strand_material, "strand_material", 3, "no strands");
  expect_error("strand_with_material", strand + strand_material + kMaterial, "material", 5, "strands only");
  expect_error("strand_stiffness", strand + "strand_material: {axial_stiffness: 0, linear_density: 0.1}\n",
               "strand_material.axial_stiffness", 4, "> 0");
  CHECK(load_ok("strand_weight", strand + "strand_material: {axial_stiffness: 5, linear_density: 1, laplacian_weight: 9}\n")
            .strand_material.laplacian_weight == 9);
  expect_error("strand_weight_zero", strand + "strand_material: {axial_stiffness: 5, linear_density: 1, laplacian_weight: 0}\n",
               "strand_material.laplacian_weight", 4, "> 0");
  expect_error("strand_density_missing", strand + "strand_material: {axial_stiffness: 5}\n",
               "strand_material.linear_density", 4, "missing");
  expect_error("strand_segments", "mesh:\n  strands:\n    - {from: [0, 0, 0], to: [0, -1, 0], segments: 0}\n" + strand_material,
               "mesh.strands[0].segments", 3, ">= 1");
  expect_error("strand_same_points", "mesh:\n  strands:\n    - {from: [0, 0, 0], to: [0, 0, 0], segments: 2}\n" + strand_material,
               "mesh.strands[0].to", 3, "distinct");
  expect_error("strand_empty_list", "mesh:\n  strands: []\n" + strand_material, "mesh.strands", 2, "non-empty");
  expect_error("edges_with_box", "mesh: {box: {size: [1, 1, 1], cells: [1, 1, 1]}, edges: strands}\n" + kMaterial,
               "mesh.edges", 1, "Medit");
  expect_error("edges_value", "mesh: {file: meshes/bar.mesh, edges: lines}\n" + kMaterial, "mesh.edges", 1, "allowed: ignore, strands");
  expect_error("no_mesh_at_all", "mesh: {}\n" + kMaterial, "mesh", 1, "box, sheet or strands");
}

// Cloth decks: mesh.sheet, .obj files and surface: cloth, and the cloth section.
void test_cloth_decks() {
  const std::string sheet = "mesh: {sheet: {size: [1, 2], cells: [4, 8]}}\n";
  const std::string springs = "cloth: {model: mass-spring, stretch_stiffness: 100, areal_density: 0.2}\n";
  Deck d = load_ok("cloth_springs", sheet + springs);
  CHECK(d.mesh.is_sheet && d.mesh.has_cloth() && !d.mesh.has_solid());
  CHECK(d.mesh.sheet_size[1] == 2 && d.mesh.sheet_cells[1] == 8);
  CHECK(d.cloth.model == hyperqn::ClothModel::mass_spring && d.cloth.stretch_stiffness == 100 &&
        d.cloth.bending == hyperqn::BendingModel::none);
  d = load_ok("cloth_membrane", sheet + "cloth:\n  model: membrane\n  material: corotated\n  youngs_modulus: 1000\n"
                                        "  poisson_ratio: 0.25\n  bending: {model: dihedral, stiffness: 0.01}\n  areal_density: 0.1\n");
  CHECK(d.cloth.material == hyperqn::membrane::Model::corotated && d.cloth.bending == hyperqn::BendingModel::dihedral &&
        d.cloth.bending_stiffness == 0.01);
  CHECK_NEAR(d.cloth.mu, 1000 / 2.5, 1e-12);              // plane stress: E / (2 (1 + nu))
  CHECK_NEAR(d.cloth.lambda, 1000 * 0.25 / (1 - 0.0625), 1e-9);  // E nu / (1 - nu^2)
  write_file("meshes/shirt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  d = load_ok("cloth_obj", "mesh: {file: meshes/shirt.obj}\n" + springs);
  CHECK(d.mesh.surface_as_cloth && d.mesh.has_cloth());
  d = load_ok("cloth_medit", "mesh: {file: meshes/bar.mesh, surface: cloth}\n" + springs);
  CHECK(d.mesh.surface_as_cloth && !d.mesh.has_solid());

  expect_error("cloth_missing", sheet, "cloth", 1, "cloth surface");
  expect_error("cloth_without_cloth_mesh", kHead + springs, "cloth", 3, "not a cloth");
  expect_error("cloth_with_material", sheet + springs + kMaterial, "material", 3, "cloth");
  expect_error("cloth_with_strands", "mesh:\n  sheet: {size: [1, 1], cells: [2, 2]}\n  strands:\n"
               "    - {from: [0, 0, 0], to: [0, 1, 0], segments: 2}\n" + springs, "mesh.strands", 3, "strands");
  expect_error("sheet_and_box", "mesh:\n  sheet: {size: [1, 1], cells: [2, 2]}\n  box: {size: [1, 1, 1], cells: [1, 1, 1]}\n" + springs,
               "mesh", 1, "one of file, box and sheet");
  expect_error("sheet_cells_zero", "mesh: {sheet: {size: [1, 1], cells: [0, 2]}}\n" + springs, "mesh.sheet.cells[0]", 1, ">= 1");
  expect_error("sheet_size_three", "mesh: {sheet: {size: [1, 1, 1], cells: [2, 2]}}\n" + springs, "mesh.sheet.size", 1, "list of 2");
  expect_error("sheet_too_big", "mesh: {sheet: {size: [1, 1], cells: [100000, 100000]}}\n" + springs, "mesh.sheet.cells", 1,
               "triangles");
  expect_error("surface_without_file", "mesh: {sheet: {size: [1, 1], cells: [2, 2]}, surface: cloth}\n" + springs,
               "mesh.surface", 1, "mesh.file");
  expect_error("surface_value", "mesh: {file: meshes/bar.mesh, surface: skin}\n" + springs, "mesh.surface", 1, "allowed: cloth");
  expect_error("cloth_model", sheet + "cloth: {model: rubber, areal_density: 0.2}\n", "cloth.model", 2,
               "allowed: mass-spring, membrane");
  expect_error("cloth_key_of_other_model", sheet + "cloth: {model: membrane, stretch_stiffness: 1, youngs_modulus: 1, "
               "poisson_ratio: 0.3, areal_density: 0.2}\n", "cloth.stretch_stiffness", 2, "mass-spring");
  expect_error("cloth_no_stiffness", sheet + "cloth: {model: mass-spring, areal_density: 0.2}\n", "cloth.stretch_stiffness", 2,
               "missing");
  expect_error("cloth_density", sheet + "cloth: {model: mass-spring, stretch_stiffness: 1, areal_density: 0}\n",
               "cloth.areal_density", 2, "> 0");
  expect_error("cloth_poisson", sheet + "cloth: {model: membrane, youngs_modulus: 1, poisson_ratio: 0.5, areal_density: 1}\n",
               "cloth.poisson_ratio", 2, "(-1, 0.5)");
  expect_error("bending_none_stiffness", sheet + "cloth: {model: mass-spring, stretch_stiffness: 1, areal_density: 1, "
               "bending: {model: none, stiffness: 1}}\n", "cloth.bending.stiffness", 2, "none");
  expect_error("bending_model", sheet + "cloth: {model: mass-spring, stretch_stiffness: 1, areal_density: 1, "
               "bending: {model: plate, stiffness: 1}}\n", "cloth.bending.model", 2, "allowed: quadratic");
  expect_error("bending_negative", sheet + "cloth: {model: mass-spring, stretch_stiffness: 1, areal_density: 1, "
               "bending: {model: quadratic, stiffness: -1}}\n", "cloth.bending.stiffness", 2, "> 0");
}

}  // namespace

// solver.budget: fixed is the three fallback-chain keys turned off in one; adaptive (the default)
// leaves them as given; a stage key beside fixed is an error naming it.
void test_budget() {
  const Deck adaptive = load_ok("budget_default", kHead + "solver: {max_halvings: 2}\n");
  CHECK(adaptive.solver.max_iterations == 100 && adaptive.solver.max_halvings == 2 && adaptive.solver.newton_fallback);
  const Deck fixed = load_ok("budget_fixed", kHead + "solver: {iterations: 7, budget: fixed}\n");
  CHECK(fixed.solver.iterations == 7 && fixed.solver.max_iterations == 0 && fixed.solver.max_halvings == 0 &&
        !fixed.solver.newton_fallback);
  const Deck explicit_adaptive = load_ok("budget_adaptive", kHead + "solver: {budget: adaptive, newton_fallback: false}\n");
  CHECK(explicit_adaptive.solver.max_halvings == 3 && !explicit_adaptive.solver.newton_fallback);
  CHECK(adaptive.solver.keep_substeps == 8);
  CHECK(load_ok("keep_substeps_off", kHead + "solver: {keep_substeps: 0}\n").solver.keep_substeps == 0);
  expect_error("keep_substeps_negative", kHead + "solver: {keep_substeps: -1}\n", "solver.keep_substeps", 3, "");
  for (const char* key : {"max_iterations: 50", "max_halvings: 2", "newton_fallback: true", "keep_substeps: 2"}) {
    const std::string name = std::string(key).substr(0, std::string(key).find(':'));
    expect_error("budget_fixed_" + name, kHead + "solver:\n  budget: fixed\n  " + key + "\n", "solver." + name, 5,
                 "budget: fixed turns off the fallback chain");
  }
  expect_error("budget_unknown", kHead + "solver: {budget: exact}\n", "solver.budget", 3, "adaptive");
}

// time.integrator: implicit-euler by default, bdf2 or implicit-midpoint on request; with colliders
// the midpoint is refused at its line (its end-of-step map can pass through an obstacle), bdf2 not.
void test_integrator() {
  CHECK(load_ok("integrator_default", kHead).time.integrator == TimeIntegrator::implicit_euler);
  CHECK(load_ok("integrator_midpoint", kHead + "time: {integrator: implicit-midpoint}\n").time.integrator ==
        TimeIntegrator::implicit_midpoint);
  CHECK(load_ok("integrator_bdf2", kHead + "time: {integrator: bdf2}\n").time.integrator == TimeIntegrator::bdf2);
  CHECK(load_ok("integrator_bdf2_colliders", kHead + "colliders:\n  - {type: plane, point: [0, -1, 0], normal: [0, 1, 0]}\n"
                                                     "time: {integrator: bdf2}\n")
            .time.integrator == TimeIntegrator::bdf2);
  expect_error("integrator_unknown", kHead + "time: {integrator: bdf9}\n", "time.integrator", 3,
               "implicit-euler, implicit-midpoint, bdf2");
  const std::string study = kHead + "study:\n  integrators: [implicit-euler, bdf2]\n";
  const Deck axis = load_ok("study_integrators", study);
  CHECK(axis.study.integrators.size() == 2 && axis.study.integrators[1] == TimeIntegrator::bdf2);
  expect_error("study_integrators_unknown", kHead + "study:\n  integrators: [euler]\n", "study.integrators[0]", 4,
               "implicit-euler");
  expect_error("study_integrators_twice", kHead + "study:\n  integrators: [bdf2, bdf2]\n", "study.integrators[1]", 4,
               "each integrator once");
  expect_error("study_integrators_empty", kHead + "study:\n  integrators: []\n", "study.integrators", 4, "non-empty");
  expect_error("study_integrators_colliders",
               kHead + "colliders:\n  - {type: plane, point: [0, -1, 0], normal: [0, 1, 0]}\nstudy:\n  integrators: "
                       "[bdf2, implicit-midpoint]\n",
               "study.integrators", 6, "colliders");
  expect_error("integrator_colliders",
               kHead + "colliders:\n  - {type: plane, point: [0, -1, 0], normal: [0, 1, 0]}\ntime:\n  integrator: "
                       "implicit-midpoint\n",
               "time.integrator", 6, "colliders");
  // static: needs a support (fixed, attachment or collider), takes no damping; pseudo_step is its own.
  const std::string fixed = "fixed:\n  - box: {min: [-0.1, -0.1, -0.1], max: [0.01, 1.1, 1.1]}\n";
  const Deck quasi = load_ok("integrator_static", kHead + fixed + "time: {integrator: static, pseudo_step: 2.5}\n");
  CHECK(quasi.time.integrator == TimeIntegrator::quasi_static && quasi.time.pseudo_step == 2.5);
  CHECK(load_ok("integrator_static_collider", kHead + "colliders:\n  - {type: plane, point: [0, -1, 0], normal: [0, 1, 0]}\n"
                                                      "time: {integrator: static}\n")
            .time.integrator == TimeIntegrator::quasi_static);
  expect_error("integrator_static_no_support", kHead + "time:\n  integrator: static\n", "time.integrator", 4,
               "nothing holds the body");
  expect_error("integrator_static_damping", kHead + fixed + "time: {integrator: static, damping: 0.1}\n", "time.damping", 5,
               "no velocities to damp");
  expect_error("pseudo_step_dynamic", kHead + "time: {pseudo_step: 1}\n", "time.pseudo_step", 3, "integrator: static");
  expect_error("study_integrators_static_no_support", kHead + "study:\n  integrators: [implicit-euler, static]\n",
               "study.integrators", 4, "nothing holds the body");
}

int main() {
  std::random_device rd;
  g_dir = fs::temp_directory_path() /
          ("hyperqn_test_deck_" + std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()) +
           "_" + std::to_string(rd()));
  fs::create_directories(g_dir);
  write_file("meshes/bar.mesh", "MeshVersionFormatted 2\nDimension 3\nEnd\n");
  write_file("meshes/bar.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");

  test_full_deck();
  test_defaults();
  test_elastic_constants();
  test_mesh_paths();
  test_invalid_decks();
  test_budget();
  test_integrator();
  test_strand_decks();
  test_cloth_decks();
#ifdef HYPERQN_SOURCE_DIR
  test_new_materials();
  test_initial_state();
  test_regions_and_motion();
  test_attachments();
  test_colliders();
  test_curves();
  test_default_deck();
#endif

  fs::remove_all(g_dir);
  return check::summary("test_deck");
}
