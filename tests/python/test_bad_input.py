"""Bad decks, meshes and options: a non-zero exit, a message naming the file and key or line,
and no output directory left behind."""
import copy
import os
import subprocess

import pytest
from pathlib import Path

from conftest import HYPERQN, MPIEXEC, REPO, run_hyperqn, write_deck
from hyperqn_tools import launch

GOOD = {
    "mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 1, 1]}},
    "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "time": {"dt": 0.01, "frames": 2},
}

TET_HEADER = "MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
# 12 vertices (lines 5-16) and a tet (lines 17-19)
TWELVE = ("MeshVersionFormatted 1\nDimension 3\nVertices\n12\n" + "".join(f"{i % 2} {i // 2 % 2} {i // 4} 0\n" for i in range(12))
          + "Tetrahedra\n1\n1 2 3 5 0\n")
BAD_MESHES = {
    # name: (file text, expected fragments of the message)
    "truncated": ("MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n", ["truncated.mesh", "Vertices"]),
    "out_of_range": (TET_HEADER + "Tetrahedra\n1\n1 2 3 9 0\nEnd\n", ["out_of_range.mesh", "tet 1"]),
    # errors found once the file is read still name the element's line
    "degenerate": (TET_HEADER + "Tetrahedra\n1\n1 2 3 3 0\nEnd\n", ["degenerate.mesh:11: 'Tetrahedra'", "tet 1 ", "degenerate"]),
    "duplicated_tet": (TET_HEADER + "Tetrahedra\n3\n1 2 3 4 0\n\n1 2 4 3 7\n4 3 2 1 0\nEnd\n",
                       ["duplicated_tet.mesh:13: 'Tetrahedra'", "tets 1 and 2 have the same 4 vertices"]),
    "not_a_number": (TET_HEADER.replace("1 0 0 0", "1 zero 0 0") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                     ["not_a_number.mesh", ":6"]),
    # strtod reads these, but numbers in mesh files are plain decimals
    "hex_coordinate": (TET_HEADER.replace("1 0 0 0", "0x10 0 0 0") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                       ["hex_coordinate.mesh:6: 'Vertices'", "'0x10'", "hexadecimal"]),
    "inf_coordinate": (TET_HEADER.replace("0 1 0 0", "0 inf 0 0") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                       ["inf_coordinate.mesh:7: 'Vertices'", "'inf'", "not finite"]),
    "nan_coordinate": (TET_HEADER.replace("0 0 1 0", "0 0 NaN 0") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                       ["nan_coordinate.mesh:8: 'Vertices'", "'NaN'", "not finite"]),
    # numbers a run cannot compute with: subnormal (they underflow) or past 1e100 (they overflow)
    "subnormal_coordinate": (TET_HEADER.replace("0 1 0 0", "1e-320 1 0 0") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                             ["subnormal_coordinate.mesh:7: 'Vertices'", "vertex 3: its coordinate '1e-320' must be 0 or at least 1e-100",
                              "subnormal"]),
    "huge_coordinate": (TET_HEADER.replace("0 0 1 0", "0 0 1e101 0") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                        ["huge_coordinate.mesh:8: 'Vertices'", "'1e101' must be at most 1e100"]),
    "version_99": (TET_HEADER.replace("MeshVersionFormatted 1", "MeshVersionFormatted 99") + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n",
                   ["version_99.mesh:1: 'MeshVersionFormatted'", "99"]),
    # the sections the reader skips (Triangles, and Edges unless edges: strands) are checked too
    "triangle_index": (TWELVE + "Triangles\n2\n1 2 3 0\n1 2 999 0\nEnd\n",
                       ["triangle_index.mesh:23: 'Triangles'", "index 999", "1..12"]),
    "edge_index": (TWELVE + "Edges\n1\n13 1 0\nEnd\n", ["edge_index.mesh:22: 'Edges'", "index 13", "1..12"]),
    # other 3-D elements are not skipped (the body lost them, their vertices dropped as unused), as in Gmsh files
    "hexahedra": (TWELVE + "Hexahedra\n1\n5 6 7 8 9 10 11 12 0\nEnd\n",
                  ["hexahedra.mesh:20: 'Hexahedra': Hexahedra (8-vertex elements, 1 in this section) are not "
                   "supported: the body must be made of 4-vertex tetrahedra"]),
    "prisms": (TWELVE + "Prisms\n1\n5 6 7 8 9 10 0\nEnd\n", ["prisms.mesh:20: 'Prisms'", "6-vertex elements"]),
    # a file's bytes are quoted without control characters (a terminal's escapes) and cut at 64
    "escape_keyword": ("MeshVersionFormatted 1\nDimension 3\n\x1b[31mRED\x1b[0m\n",
                       ["escape_keyword.mesh:3", "unknown keyword '?[31mRED?[0m'"]),
    "long_keyword": ("MeshVersionFormatted 1\nDimension 3\n" + "A" * 200000 + "\n",
                     ["long_keyword.mesh:3", "unknown keyword '" + "A" * 64 + "...'"]),
}


def deck_with(**changes):
    """GOOD with section.key=value changes ('section.key': value)."""
    deck = copy.deepcopy(GOOD)
    for dotted, value in changes.items():
        node = deck
        *path, last = dotted.split(".")
        for p in path:
            node = node.setdefault(p, {})
        if value is None:
            node.pop(last, None)
        else:
            node[last] = value
    return deck


PLANE = {"type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0]}
CLOTH = {"mesh": {"sheet": {"size": [1.0, 0.5], "cells": [4, 2]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 100.0, "areal_density": 0.2},
         "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.51]}}],
         "time": {"dt": 0.01, "frames": 2}}


def cloth_with_thickness(thickness, self_contact):
    deck = copy.deepcopy(CLOTH)
    deck["cloth"]["thickness"] = thickness
    if self_contact:
        deck["contact"] = {"self": True, "distance": 0.01}
    return deck


STRAND = {"mesh": {"strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 2}]},
          "strand_material": {"axial_stiffness": 100.0, "linear_density": 0.1},
          "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}],
          "time": {"dt": 0.01, "frames": 2}}


def with_keys(base, section, **keys):
    """base with keys set in its section (a dotted section for a nested map)."""
    deck = copy.deepcopy(base)
    node = deck
    for p in section.split("."):
        node = node.setdefault(p, {})
    node.update(keys)
    return deck


CLOTH_SPRINGS_BENDING = with_keys(CLOTH, "cloth.bending", model="springs", stiffness=1.0)

BAD_DECKS = {
    "nu_half": (deck_with(**{"material.poisson_ratio": 0.5}), ["material.poisson_ratio"]),
    "dt_zero": (deck_with(**{"time.dt": 0.0}), ["time.dt"]),
    "frames_text": (deck_with(**{"time.frames": "ten"}), ["time.frames"]),
    "unknown_key": (deck_with(**{"material.youngs": 3.0}), ["material.youngs"]),
    "no_material": (deck_with(material=None), ["material"]),
    "missing_mesh_file": (deck_with(mesh={"file": "nowhere/bar.mesh"}), ["mesh.file", "bar.mesh"]),
    "empty_fixed_region": (deck_with(fixed=[{"box": {"min": [5, 5, 5], "max": [6, 6, 6]}}]),
                           ["fixed[0].box", "selects no vertex"]),
    "everything_fixed": (deck_with(fixed=[{"box": {"min": [-1, -1, -1], "max": [2, 2, 2]}}]),
                         ["every vertex is fixed"]),
    "empty_attachment_box": (deck_with(attachments=[{"box": {"min": [5, 5, 5], "max": [6, 6, 6]}, "stiffness": 1.0e3}]),
                             ["attachments[0].box", "selects no vertex", ".yaml:12:"]),
    "attachment_stiffness_zero": (deck_with(attachments=[{"box": {"min": [-1, -1, -1], "max": [2, 2, 2]}, "stiffness": 0}]),
                                  ["attachments[0].stiffness", "> 0"]),
    "bad_line_search": (deck_with(**{"solver.line_search": "bogus"}), ["solver.line_search"]),
    "bad_output_format": (deck_with(**{"output.format": "vtk"}), ["'output.format'", "unknown value 'vtk'", "vtu, xdmf"]),
    "bad_field_precision": (deck_with(**{"output.fields": ["von_mises"], "output.field_precision": "half"}),
                            [".yaml:13: 'output.field_precision'", "unknown value 'half'", "double, single"]),
    "fields_without_frames": (deck_with(**{"output.fields": ["von_mises"], "output.vtk": False}),
                              [".yaml:", "'output.fields'", "output.vtk is false"]),
    "bad_vtu_encoding": (deck_with(**{"output.vtu_encoding": "ascii"}),
                         [".yaml:11: 'output.vtu_encoding'", "unknown value 'ascii'", "base64, raw"]),
    "vtu_encoding_of_xdmf": (deck_with(**{"output.format": "xdmf", "output.vtu_encoding": "raw"}),
                             [".yaml:11: 'output.vtu_encoding'", "applies to format vtu only (format is xdmf)"]),
    "collider_zero_normal": (deck_with(colliders=[{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 0]}]),
                             ["colliders[0].normal", "nonzero"]),
    "collider_negative_radius": (deck_with(colliders=[{"type": "sphere", "center": [0, 0, 0], "radius": -0.1}]),
                                 ["colliders[0].radius", "> 0"]),
    "collider_negative_friction": (deck_with(colliders=[{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0],
                                                         "friction": -0.2}]), ["colliders[0].friction"]),
    # a box whose cells are far flatter than wide: M + h^2 L would not be positive definite (before:
    # "setting up the scene failed: PETSc: the constant matrix A ... is not positive definite")
    "box_flat": (deck_with(**{"mesh.box.size": [1e-9, 0.2, 0.2]}),
                 [".yaml:3: 'mesh.box.size'", "its cells would be 2.5e-10 x 0.2 x 0.2", "less than 1e-06 of the longest",
                  "not be positive definite", "Check the size"]),
    "box_thin": (deck_with(**{"mesh.box.size": [1.0, 0.2, 1e-8]}), ["'mesh.box.size'", "its cells would be 0.25 x 0.2 x 1e-08"]),
    "box_size_1e-300": (deck_with(**{"mesh.box.size": [1e-300, 0.2, 0.2]}),
                        [".yaml:3: 'mesh.box.size[0]': must be at least 1e-100 in magnitude", "underflow"]),
    # a key that refuses 0 does not offer it for a tiny value (a range per number, or an inelastic block's)
    "tau_1e-200": (deck_with(**{"material.viscoelastic": {"branches": [{"g": 0.3, "tau": 1e-200}]}}),
                   ["'material.viscoelastic.branches[0].tau': must be at least 1e-100 in magnitude"]),
    "sheet_flat": (dict(copy.deepcopy(CLOTH), mesh={"sheet": {"size": [1e-9, 0.5], "cells": [4, 2]}}),
                   ["'mesh.sheet.size'", "its cells would be 2.5e-10 x 0.25", "the triangles' stiffness"]),
    "collider_missing_file": (deck_with(colliders=[{"type": "mesh", "file": "nowhere.obj"}]),
                              ["colliders[0].file", "nowhere.obj", "not found"]),
    "collider_unknown_type": (deck_with(colliders=[{"type": "torus"}]), ["colliders[0].type", "plane, sphere"]),
    "collider_key_of_other_type": (deck_with(colliders=[{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0],
                                                         "radius": 1}]), ["colliders[0].radius", "applies to type sphere, capsule only"]),
    "collider_box_inside_out": (deck_with(colliders=[{"type": "box", "min": [0, 0, 0], "max": [1, -1, 1]}]),
                                ["colliders[0].max", "along y"]),
    "contact_without_colliders": (deck_with(contact={"distance": 0.01}), ["contact", "no", "colliders"]),
    "contact_zero_distance": (deck_with(colliders=[{"type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0]}],
                                        contact={"distance": 0}), ["contact.distance", "> 0"]),
    "bad_h0": (deck_with(**{"solver.h0": "stiffness"}), ["solver.h0", "laplacian, rest-stiffness, amg"]),
    # pd's steps are exact solves with M + h^2 L; a V-cycle would silently change the method.
    "pd_amg": (deck_with(solver={"type": "pd", "h0": "amg"}), ["solver.h0", "amg is for lbfgs", "pd"]),
    # PETSc would split the value into two options and blame the command line for the second
    "petsc_value_with_space": (deck_with(petsc={"tao_ls_type": "unit -tao_type garbage"}),
                               [".yaml:11: 'petsc.tao_ls_type'", "one word"]),
    "petsc_name_with_space": (deck_with(petsc={"tao ls_type": "armijo"}), [".yaml:11: 'petsc.tao ls_type'", "letters"]),
    # the bar's rest diagonal is 1.04 (0.104 scaled by 0.1)
    "contact_distance_beyond_body": (deck_with(colliders=[PLANE], contact={"distance": 2.0}),
                                     [".yaml:15: 'contact.distance'", "larger than the body", "1.03923"]),
    "contact_distance_beyond_scaled_body": (deck_with(**{"mesh.transform": {"scale": 0.1}}, colliders=[PLANE],
                                                      contact={"distance": 0.5}),
                                            ["'contact.distance'", "larger than the body", "0.103923"]),
    # boxes whose vertices are all fixed for good: the springs would do nothing
    "attachment_inside_fixed": (deck_with(attachments=[{"box": {"min": [-0.005, -0.5, -0.5], "max": [0.005, 0.5, 0.5]},
                                                        "stiffness": 1.0e3}]),
                                [".yaml:12: 'attachments[0].box'", "only vertices that are fixed"]),
    "second_attachment_inside_fixed": (deck_with(attachments=[{"box": {"min": [0.99, -1, -1], "max": [1.01, 1, 1]}, "stiffness": 1.0},
                                                              {"box": GOOD["fixed"][0]["box"], "stiffness": 1.0e3}]),
                                       [".yaml:16: 'attachments[1].box'", "only vertices that are fixed"]),
    "cloth_attachment_inside_fixed": (dict(copy.deepcopy(CLOTH), attachments=[{"box": {"min": [-0.01, -0.01, -0.01],
                                                                                       "max": [0.01, 0.01, 0.01]},
                                                                               "stiffness": 10.0}]),
                                      [".yaml:12: 'attachments[0].box'", "only vertices that are fixed"]),
    # cloth.thickness: a length >= 0, and only with self-contact (without it the key would say nothing)
    "cloth_negative_thickness": (cloth_with_thickness(-0.01, True), ["'cloth.thickness'", ">= 0"]),
    "cloth_infinite_thickness": (cloth_with_thickness(float("inf"), True), ["'cloth.thickness'", "expected a number"]),
    "cloth_thickness_without_self_contact": (cloth_with_thickness(0.01, False),
                                             ["'cloth.thickness'", "acts in self-contact only"]),
    # springs that yield (docs/yielding-springs.md): a yield strain > 0, a hardening >= 0
    # that needs one, on the spring models only
    "strand_negative_yield_strain": (with_keys(STRAND, "strand_material", yield_strain=-0.01),
                                     [".yaml:6: 'strand_material.yield_strain'", "> 0"]),
    "strand_negative_hardening": (with_keys(STRAND, "strand_material", yield_strain=0.01, hardening=-1.0),
                                  [".yaml:7: 'strand_material.hardening'", ">= 0"]),
    "strand_hardening_without_yield": (with_keys(STRAND, "strand_material", hardening=0.5),
                                       [".yaml:6: 'strand_material.hardening'", "give yield_strain too"]),
    "cloth_zero_yield_strain": (with_keys(CLOTH, "cloth", yield_strain=0.0), [".yaml:5: 'cloth.yield_strain'", "> 0"]),
    "cloth_yield_on_membrane": (dict(CLOTH, cloth={"model": "membrane", "youngs_modulus": 100.0, "poisson_ratio": 0.3,
                                                   "areal_density": 0.2, "yield_strain": 0.01}),
                                ["'cloth.yield_strain'", "mass-spring"]),
    "cloth_bending_yield_on_dihedral": (with_keys(with_keys(CLOTH_SPRINGS_BENDING, "cloth.bending", model="dihedral"),
                                                  "cloth.bending", yield_strain=0.05),
                                        ["'cloth.bending.yield_strain'", "springs"]),
    "cloth_bending_negative_yield_strain": (with_keys(CLOTH_SPRINGS_BENDING, "cloth.bending", yield_strain=-0.05),
                                            ["'cloth.bending.yield_strain'", "> 0"]),
    # study: a frame or a solver twice would write two sets of rows under one key (study.csv,
    # study.h5's groups); a trajectory budget for a solver that is not studied would do nothing
    "study_frame_twice": (deck_with(study={"frames": [1, 2, 1], "solvers": ["lbfgs"]}),
                          ["'study.frames[2]'", "a frame not listed before"]),
    "study_solver_twice": (deck_with(study={"frames": [1], "solvers": ["lbfgs", "newton", "lbfgs"]}),
                           ["'study.solvers[2]'", "a solver not listed before"]),
    "study_budget_without_trajectories": (deck_with(study={"frames": [1], "solvers": ["lbfgs"], "trajectory": False,
                                                           "trajectory_iterations": {"lbfgs": 10}}),
                                          ["'study.trajectory_iterations'", "study.trajectory is false"]),
    "study_static_with_damping": (deck_with(**{"time.damping": 0.1},
                                            study={"frames": [1], "solvers": ["lbfgs"], "integrators": ["implicit-euler", "static"]}),
                                  ["'study.integrators'", "static has no velocities to damp"]),
    # keys that said nothing where they were given
    "field_precision_without_fields": (deck_with(**{"output.field_precision": "single"}),
                                       ["'output.field_precision'", "the deck asks for none"]),
    "study_budget_for_no_solver": (deck_with(study={"frames": [1], "solvers": ["lbfgs"],
                                                    "trajectory_iterations": {"pd": 10}}),
                                   ["'study.trajectory_iterations.pd'", "pd is not among study.solvers (lbfgs)"]),
    "cloth_bending_hardening_without_yield": (with_keys(CLOTH_SPRINGS_BENDING, "cloth.bending", hardening=0.1),
                                              ["'cloth.bending.hardening'", "give yield_strain too"]),
}


def assert_clean_failure(proc, outdir, fragments):
    assert proc.returncode != 0, proc.stdout
    for fragment in fragments:
        assert fragment in proc.stdout, f"{fragment!r} not in:\n{proc.stdout[-3000:]}"
    assert "hyperqn: error" in proc.stdout
    assert not outdir.exists(), "an output directory was left behind"


def assert_deck_refused(tmp_path, name, deck, fragments):
    """Writes deck as NAME.yaml and runs it alone: exit 1, an error naming NAME.yaml:LINE and each
    fragment, nothing written. The bad-input tables of the material and output tests use it."""
    path = write_deck(tmp_path / f"{name}.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, [f"{name}.yaml:"] + fragments)
    assert proc.returncode == 1


@pytest.mark.parametrize("case", sorted(BAD_DECKS))
def test_bad_deck(tmp_path, case):
    deck, fragments = BAD_DECKS[case]
    path = write_deck(tmp_path / f"{case}.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, [f"{case}.yaml"] + fragments)


def test_a_deck_over_1_mb_is_refused_before_it_is_parsed(tmp_path):
    """A deck's parse takes some 250 bytes per byte on every rank: 10 MB of cuts took 2.6 GB a rank."""
    path = write_deck(tmp_path / "big.yaml", GOOD)
    with open(path, "a") as f:
        f.write(("# " + "x" * 98 + "\n") * 10500)  # 1.05 MB of comments
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, ["big.yaml", "larger than 1 MB", "a file of its own"])


@pytest.mark.parametrize("option,value,said", [
    ("-tao_gatol", "nan", "option -tao_gatol nan: must be a finite number >= 0 (the solver's tolerance)"),
    ("-tao_grtol", "-1", "option -tao_grtol -1: must be a finite number >= 0"),
    ("-tao_gttol", "1e999", "option -tao_gttol 1e999: must be a finite"),  # every frame "converged" at 0 iterations
    ("-tao_max_it", "-3", "option -tao_max_it -3: must be a whole number from 0 to 2147483647"),  # TAO ran its own default
])
def test_tao_tolerances_and_budget_from_the_options_are_checked(tmp_path, option, value, said):
    path = write_deck(tmp_path / "good.yaml", GOOD)
    proc = run_hyperqn([path, "-o", tmp_path / "out", option, value], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", [said])
    assert proc.returncode == 1

def test_a_release_after_the_last_step_is_said(tmp_path):
    # before: a release at t = 1000 s in a run of 2 frames said nothing (a blade that never comes
    # near the body is said)
    deck = deck_with(fixed=[dict(GOOD["fixed"][0], release=1000.0)])
    proc = run_hyperqn([write_deck(tmp_path / "late.yaml", deck), "-o", tmp_path / "out"], ranks=None, timeout=60)
    assert "late.yaml:" in proc.stdout and ("a fixed region's release at t = 1000 s comes after the run's last step "
                                            "starts (t = 0.01 s): it is not released in this run") in proc.stdout
    proc = run_hyperqn([write_deck(tmp_path / "due.yaml", deck_with(fixed=[dict(GOOD["fixed"][0], release=0.01)])),
                        "-o", tmp_path / "out2"], ranks=None, timeout=60, check=False)
    assert "not released in this run" not in proc.stdout

@pytest.mark.parametrize("ranks", [None, 2])
def test_the_error_goes_to_standard_error(tmp_path, ranks):
    """The error alone on standard error (a run's progress and summary on standard output), at 1 and 2 ranks."""
    path = write_deck(tmp_path / "deck.yaml", deck_with(**{"time.dt": -1}))
    proc = launch.run([path, "-o", tmp_path / "out"], ranks, HYPERQN, MPIEXEC, timeout=60, stderr=subprocess.PIPE)
    assert proc.returncode == 1
    assert "hyperqn: error: " not in proc.stdout
    assert proc.stderr.count("hyperqn: error: ") == 1 and "'time.dt'" in proc.stderr


@pytest.mark.parametrize("ranks", [None, 2])
@pytest.mark.parametrize("case", sorted(BAD_MESHES))
def test_bad_mesh(tmp_path, case, ranks):
    text, fragments = BAD_MESHES[case]
    (tmp_path / f"{case}.mesh").write_text(text)
    deck = deck_with(mesh={"file": f"{case}.mesh"}, fixed=[])
    path = write_deck(tmp_path / "deck.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=ranks, check=False, timeout=60)
    assert_clean_failure(proc, outdir, fragments)


BAD_OBSTACLES = {
    # name: (file name, text, expected fragments)
    "obj_bad_index": ("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", ["bad.obj:4"]),
    "obj_bad_number": ("num.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", ["num.obj:2"]),
    # a texture or normal index that is not one (before: read as "f 1 2 3")
    "obj_bad_texture_index": ("slash.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n",
                              ["slash.obj:4: 'f'", "i, i/t, i//n or i/t/n", "'1/x'"]),
    "obj_no_triangles": ("empty.obj", "v 0 0 0\n", ["empty.obj", "colliders[0].file"]),
    "medit_truncated": ("cut.mesh", "MeshVersionFormatted 1\nDimension 3\nVertices\n3\n0 0 0 0\n", ["cut.mesh"]),
    "obj_subnormal": ("tiny.obj", "v 0 0 0\nv 1 0 0\nv 0 1e-320 0\nf 1 2 3\n", ["tiny.obj:3: 'v'", "'1e-320' must be 0 or"]),
    "medit_subnormal": ("tiny.mesh", "MeshVersionFormatted 1\nDimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n0 1 -1e-310 0\n"
                        "Triangles\n1\n1 2 3 0\nEnd\n", ["tiny.mesh:7: 'Vertices'", "'-1e-310' must be 0 or"]),
}


@pytest.mark.parametrize("ranks", [None, 2])
@pytest.mark.parametrize("case", sorted(BAD_OBSTACLES))
def test_bad_obstacle_file(tmp_path, case, ranks):
    name, text, fragments = BAD_OBSTACLES[case]
    (tmp_path / name).write_text(text)
    deck = deck_with(colliders=[{"type": "mesh", "file": name}])
    path = write_deck(tmp_path / "deck.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=ranks, check=False, timeout=60)
    assert_clean_failure(proc, outdir, fragments)


TAGGED = {
    # name: (line of GOOD's deck, the line with a tag, its key): every explicit tag is refused
    "str": ("time: {dt: 0.01, frames: 2}", "time: {dt: !!str 0.01, frames: 2}", "time.dt"),
    "float": ("time: {dt: 0.01, frames: 2}", "time: {dt: !!float '0.01', frames: 2}", "time.dt"),
    "int": ("time: {dt: 0.01, frames: 2}", "time: {dt: 0.01, frames: !!int 2}", "time.frames"),
    "local": ("    cells: [4, 1, 1]", "    cells: !cells [4, 1, 1]", "mesh.box.cells"),
    "binary": ("    max: [0.01, 1, 1]", "    max: [0.01, 1, !!binary MQ==]", "fixed[0].box.max[2]"),
    "key": ("time: {dt: 0.01, frames: 2}", "!!str time: {dt: 0.01, frames: 2}", "time"),
}


@pytest.mark.parametrize("case", sorted(TAGGED))
def test_yaml_tags_are_refused(tmp_path, case):
    plain, tagged, key = TAGGED[case]
    write_deck(tmp_path / "plain.yaml", GOOD)
    lines = (tmp_path / "plain.yaml").read_text().splitlines()
    line = lines.index(plain) + 1
    lines[line - 1] = tagged
    path = tmp_path / f"tag_{case}.yaml"
    path.write_text("\n".join(lines) + "\n")
    proc = run_hyperqn([path, "-o", tmp_path / "out"], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", [f"tag_{case}.yaml:{line}: '{key}'", "YAML tags are not accepted"])


def test_yaml_syntax_error(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("mesh:\n  box: {size: [1, 1, 1], cells: [1, 1, 1]\nmaterial: {}\n")
    proc = run_hyperqn([path, "-o", tmp_path / "out"], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", ["broken.yaml"])


def test_missing_deck(tmp_path):
    proc = run_hyperqn([tmp_path / "absent.yaml", "-o", tmp_path / "out"], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", ["absent.yaml"])


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_a_deck_that_is_not_a_regular_file(tmp_path, kind):
    # a FIFO hung the run (opening it waits for a writer); /dev/null and /dev/stdin were said to be
    # "larger than 1 MB"
    path = tmp_path / "deck.yaml"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path = Path("/dev/null")
    proc = run_hyperqn([path, "-o", tmp_path / "out"], ranks=None, check=False, timeout=30)
    assert_clean_failure(proc, tmp_path / "out", [f"{path}: not a regular file"])
    assert proc.returncode == 1


def test_no_deck_given(tmp_path):
    proc = run_hyperqn([], ranks=None, check=False, timeout=60)
    assert proc.returncode != 0 and "usage" in proc.stdout


def test_unknown_petsc_line_search_option(tmp_path):
    path = write_deck(tmp_path / "deck.yaml", GOOD)
    proc = run_hyperqn([path, "-o", tmp_path / "out", "-tao_ls_type", "bogus"], ranks=None, check=False, timeout=60)
    assert proc.returncode != 0 and "bogus" in proc.stdout
    assert not (tmp_path / "out").exists()



@pytest.mark.parametrize("where", ["command_line", "deck"])
def test_mat_type_is_refused(tmp_path, where):
    # -mat_type retypes the matrices DMCreateMatrix makes; dense and is crashed (SEGV) in PETSc's
    # preallocation, sbaij failed at setup naming nothing of the deck
    deck = GOOD if where == "command_line" else {**GOOD, "petsc": {"mat_type": "dense"}}
    path = write_deck(tmp_path / "deck.yaml", deck)
    args = [path, "-o", tmp_path / "out"] + (["-mat_type", "dense"] if where == "command_line" else [])
    proc = run_hyperqn(args, ranks=None, check=False, timeout=60)
    where_said = "option -mat_type dense:" if where == "command_line" else "deck.yaml:11: 'petsc.mat_type':"
    assert_clean_failure(proc, tmp_path / "out", [where_said, "is not an option of hyperqn", "leave it out"])
    assert proc.returncode == 1


VIEWERS = {
    # read at PetscFinalize: the run wrote everything, said "ok", then PETSc failed (exit 56, 65)
    "log_view_false": (["-log_view", "false"], None, ["option -log_view false:", "Unsupported viewer false"]),
    "log_view_missing_directory": (["-log_view", ":/nonexistent/dir/x.txt"], None,
                                   ["option -log_view :/nonexistent/dir/x.txt:", "Cannot open PetscViewer file"]),
    "deck_tao_view_0": ([], {"tao_view": 0}, ["deck.yaml:11: 'petsc.tao_view':", "not a viewer PETSc can open", "got 0"]),
    # YAML 1.1's booleans are refused here as in the rest of the deck (yes became true, a viewer true)
    "deck_tao_view_yes": ([], {"tao_view": "yes"}, ["deck.yaml:11: 'petsc.tao_view':", "expected true or false, got yes"]),
}


@pytest.mark.parametrize("case", sorted(VIEWERS))
def test_viewer_options_that_petsc_cannot_open_are_refused_before_the_run(tmp_path, case):
    args, petsc, fragments = VIEWERS[case]
    path = write_deck(tmp_path / "deck.yaml", {**GOOD, "petsc": petsc} if petsc else GOOD)
    # the plain word yes, as a user writes it (the writer quotes it)
    Path(path).write_text(Path(path).read_text().replace("'yes'", "yes"))
    proc = run_hyperqn([path, "-o", tmp_path / "out"] + args, ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", fragments)
    assert proc.returncode == 1 and "PETSC ERROR" not in proc.stdout


@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("case", ["missing_options_file", "unknown_log_view_format", "nested_log_view"])
def test_options_petsc_reads_as_it_starts_are_input_errors(tmp_path, case, ranks):
    # PETSc reads these in PetscInitialize: before, its stack trace and exit codes 83 and 56 (a
    # missing options file at 2 ranks: rank 0 alone opens it); a nested log (ascii_xml,
    # ascii_flamegraph) failed as the program ended, after "ok" (exit 77)
    path = write_deck(tmp_path / "deck.yaml", GOOD)
    log = tmp_path / "log.txt"
    args, said = {
        "missing_options_file": (["-options_file", str(tmp_path / "none.txt")],
                                 f"option -options_file {tmp_path / 'none.txt'}: cannot open the file"),
        "unknown_log_view_format": (["-log_view", f":{log}:bogus"], f"option -log_view :{log}:bogus: unknown viewer format 'bogus'"),
        "nested_log_view": (["-log_view", f":{log}:ascii_flamegraph"],
                            f"option -log_view :{log}:ascii_flamegraph: the format ascii_flamegraph is PETSc's nested log"),
    }[case]
    proc = run_hyperqn([path, "-o", tmp_path / "out"] + args, ranks=ranks, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", ["hyperqn: error: command line: " + said])
    assert proc.returncode == 1 and "PETSC ERROR" not in proc.stdout
    assert proc.stdout.count("hyperqn: error") == 1  # rank 0 says it
    assert not log.exists()


@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("where", ["options_file", "PETSC_OPTIONS"])
def test_a_missing_options_file_named_elsewhere_is_an_input_error(tmp_path, monkeypatch, where, ranks):
    # named in another options file or in PETSC_OPTIONS: PETSc's stack trace, exit 83
    path = write_deck(tmp_path / "deck.yaml", GOOD)
    missing = tmp_path / "none.txt"
    args = []
    if where == "options_file":
        (tmp_path / "opts").write_text(f"# options\n-tao_max_it 5 -options_file {missing} # nested\n")
        args, said = ["-options_file", tmp_path / "opts"], f"(named in {tmp_path / 'opts'})"
    else:
        monkeypatch.setenv("PETSC_OPTIONS", f"-options_file {missing}")
        said = "(in PETSC_OPTIONS)"
    proc = run_hyperqn([path, "-o", tmp_path / "out"] + args, ranks=ranks, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out",
                         [f"hyperqn: error: command line: option -options_file {missing} {said}: cannot open the file"])
    assert proc.returncode == 1 and "PETSC ERROR" not in proc.stdout and proc.stdout.count("hyperqn: error") == 1


def test_options_file_in_the_deck_is_refused(tmp_path):
    # PETSc reads options files only as it starts: the deck's was read by nothing (a warning)
    (tmp_path / "opts").write_text("-tao_max_it 3\n")
    path = write_deck(tmp_path / "deck.yaml", {**GOOD, "petsc": {"options_file": str(tmp_path / "opts")}})
    proc = run_hyperqn([path, "-o", tmp_path / "out"], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out",
                         ["deck.yaml:", "'petsc.options_file': PETSc reads options files only as it starts"])


@pytest.mark.parametrize("args, said", [
    (["-log_view", "DECK"], "no deck given: PETSc takes DECK as the value of -log_view; give the deck first"),
    (["-log_view", "word"], "no deck given"),
    (["DECK", "-"], "'-': not an option"),
    (["DECK", "--", "-tao_max_it", "3"], "'--': not an option"),
])
def test_a_deck_taken_as_an_option_s_value_and_bare_dashes(tmp_path, args, said):
    # -log_view DECK: "no deck given", then PETSc's stack trace on a viewer named DECK (exit 56);
    # a bare - or -- was passed to PETSc unsaid
    path = str(write_deck(tmp_path / "deck.yaml", GOOD))
    args = [path if a == "DECK" else a for a in args] + ["-o", tmp_path / "out"]
    proc = run_hyperqn(args, ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", [said.replace("DECK", path)])
    assert proc.returncode == 1 and "PETSC ERROR" not in proc.stdout


def test_a_nested_log_in_the_deck_is_refused(tmp_path):
    # it crashed (SEGV) after the run had written everything and said ok
    log = tmp_path / "log.xml"
    path = write_deck(tmp_path / "deck.yaml", {**GOOD, "petsc": {"log_view": f":{log}:ascii_xml"}})
    proc = run_hyperqn([path, "-o", tmp_path / "out"], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", ["deck.yaml:11: 'petsc.log_view': the format ascii_xml is PETSc's nested log"])
    assert proc.returncode == 1 and "PETSC ERROR" not in proc.stdout and not log.exists()


def test_a_deck_s_true_passes_a_viewer_option_alone(tmp_path):
    # log_view: true is -log_view (PETSc's summary on the screen), not "-log_view true"
    path = write_deck(tmp_path / "deck.yaml", {**GOOD, "petsc": {"log_view": True}})
    proc = run_hyperqn([path, "-o", tmp_path / "out"], ranks=None, timeout=60)
    assert "PETSc Performance Summary" in proc.stdout and "PETSC ERROR" not in proc.stdout


def test_a_closed_pipe_ends_the_program_quietly():
    # `hyperqn registry | head`: before, PETSc's handler said "Caught signal number 13 Broken Pipe"
    # and aborted MPI
    proc = subprocess.run(f"'{HYPERQN}' registry | head -c 10", shell=True, capture_output=True, text=True, timeout=60)
    assert proc.stdout == '{\n  "mater'
    assert "PETSC ERROR" not in proc.stderr and "MPI_ABORT" not in proc.stderr, proc.stderr

# A body that starts inside an obstacle (docs/contact.md#a-start-inside-an-obstacle): an input
# error naming the collider's deck line and index, how many free vertices it holds and the
# deepest one. The sheet lies in y = 0 (15 vertices, 3 fixed); the bar's vertices at y = 0 are
# 8 of its 16 free ones.
def sheet_in_plane(height, **contact):
    deck = copy.deepcopy(CLOTH)
    deck["colliders"] = [{"type": "plane", "point": [0, height, 0], "normal": [0, 1, 0]}]
    if contact:
        deck["contact"] = contact
    return deck


START_INSIDE = {
    # name: (deck, index of the collider named, fragments of the message)
    "sheet_inside_ground": (sheet_in_plane(0.9), 0,
                            ["inside this plane", "12 of its 12 free vertices", "deeper than the activation distance",
                             "(contact.distance) at frame 0", ", is 0.9 inside"]),
    "bar_inside_ground_barrier": (deck_with(colliders=[{"type": "plane", "point": [0, 0.1, 0], "normal": [0, 1, 0]}],
                                            contact={"model": "barrier"}), 0,
                                  ["inside this plane", "8 of its 16 free vertices", "the barrier's energy is infinite",
                                   ", is 0.1 inside"]),
    # the first collider is clear of the bar; the second, a solid box, holds its far end
    "bar_end_in_second_collider": (deck_with(colliders=[{"type": "sphere", "center": [0, 5, 0], "radius": 1},
                                                        {"type": "box", "min": [0.9, -1, -1], "max": [2, 1, 1]}]), 1,
                                   ["inside this box", "4 of its 16 free vertices", "at (1, ", ", is 0.1 inside"]),
}


def deck_line_of_collider(path, index):
    """The 1-based line of the deck's colliders[index] item (the line its error names)."""
    lines = open(path).read().splitlines()
    first = lines.index("colliders:")
    items = [k for k in range(first + 1, len(lines)) if lines[k].startswith("- ")]
    return items[index] + 1


@pytest.mark.parametrize("case", sorted(START_INSIDE))
def test_start_inside_an_obstacle(tmp_path, case):
    deck, index, fragments = START_INSIDE[case]
    path = write_deck(tmp_path / f"{case}.yaml", deck)
    line = deck_line_of_collider(path, index)
    messages = {}
    for ranks in (None, 2):
        outdir = tmp_path / f"out{ranks}"
        proc = run_hyperqn([path, "-o", outdir], ranks=ranks, check=False, timeout=60)
        assert proc.returncode == 1
        assert_clean_failure(proc, outdir, [f"{case}.yaml:{line}: 'colliders[{index}]': the body starts"] + fragments)
        messages[ranks] = [l for l in proc.stdout.splitlines() if "hyperqn: error" in l]
    assert messages[None] == messages[2], "the message (the deepest vertex) depends on the rank count"


def test_start_inside_an_obstacle_in_a_study(tmp_path):
    deck, index, fragments = START_INSIDE["sheet_inside_ground"]
    deck = dict(deck, study={"frames": [1], "solvers": ["lbfgs"], "trajectory": False})
    path = write_deck(tmp_path / "study.yaml", deck)
    outdir = tmp_path / "out"
    proc = run_hyperqn(["study", path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, [f"study.yaml:{deck_line_of_collider(path, index)}: 'colliders[0]'"] + fragments)


# In a deck of bodies the body that starts inside an obstacle is named, and the count is of its own
# free vertices (before: "the body starts inside this plane: 4 of its 35 free vertices", the count
# over the whole scene and no body named). The right block (8 vertices, the lower 4 at y = -0.15)
# is 0.05 into the ground; the left one (27 vertices) is clear of it.
BODIES_ONE_INSIDE = {
    "bodies": [
        {"mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [2, 2, 2]}}, "material": GOOD["material"]},
        {"name": "right", "mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [1, 1, 1]},
                                   "transform": {"translate": [1, -0.15, 0]}}, "material": GOOD["material"]},
    ],
    "colliders": [{"type": "plane", "point": [0, -0.1, 0], "normal": [0, 1, 0]}],
    "time": {"dt": 0.01, "frames": 2},
}


def test_start_inside_an_obstacle_names_the_body(tmp_path):
    path = write_deck(tmp_path / "bodies.yaml", BODIES_ONE_INSIDE)
    lines = open(path).read().splitlines()
    body_line = next(n for n, text in enumerate(lines, 1) if "name: right" in text)
    messages = {}
    for ranks in (None, 2):
        outdir = tmp_path / f"out{ranks}"
        proc = run_hyperqn([path, "-o", outdir], ranks=ranks, check=False, timeout=60)
        assert proc.returncode == 1
        assert_clean_failure(proc, outdir, [f"bodies.yaml:{deck_line_of_collider(path, 0)}: 'colliders[0]': "
                                            f"bodies[1] 'right' (deck line {body_line}) starts inside this plane: "
                                            "4 of its 8 free vertices", "vertex 27 at (1, -0.15, 0)"])
        messages[ranks] = [l for l in proc.stdout.splitlines() if "hyperqn: error" in l]
    assert messages[None] == messages[2]


# A one-body cloth that crosses itself at frame 0 (two squares of one .obj through each other): the
# crossing is the error, naming contact.self (docs/contact.md) (before: the rest gap of 0 between
# the crossing triangles was, advising a contact.distance of 1.8e-17).
CROSSED_OBJ = ("v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0.5 -0.5 0.2\nv 0.5 0.5 0.2\nv 0.5 0.5 0.8\nv 0.5 -0.5 0.8\n"
               "f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 7 8\n")


@pytest.mark.parametrize("ranks", [None, 2])
def test_cloth_crossing_itself_names_contact_self(tmp_path, ranks):
    (tmp_path / "crossed.obj").write_text(CROSSED_OBJ)
    deck = dict(copy.deepcopy(CLOTH), mesh={"file": "crossed.obj"}, contact={"self": True, "distance": 0.01})
    path = write_deck(tmp_path / "crossed.yaml", deck)
    line = next(n for n, text in enumerate(open(path).read().splitlines(), 1) if "self:" in text)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=ranks, check=False, timeout=60)
    assert proc.returncode == 1
    assert_clean_failure(proc, outdir, [f"crossed.yaml:{line}: 'contact.self': the body's surface crosses itself at frame 0",
                                        "start from a mesh that does not cross itself"])
    assert "contact.distance" not in proc.stdout


def test_missing_mesh_file_gives_the_resolved_path(tmp_path, monkeypatch):
    """Run from another directory than the deck's: the message gives the full path the deck's
    relative one resolves to, and the deck's spelling (before: 'meshes/bar.mesh', the path joined
    to the deck's directory as the command line gave it)."""
    (tmp_path / "sub").mkdir()
    write_deck(tmp_path / "sub" / "deck.yaml", deck_with(mesh={"file": "../meshes/bar.mesh"}))
    monkeypatch.chdir(tmp_path)
    proc = run_hyperqn(["sub/deck.yaml", "-o", "out"], ranks=None, check=False, timeout=60)
    full = os.path.join(os.getcwd(), "meshes", "bar.mesh")
    assert_clean_failure(proc, tmp_path / "out", [f"sub/deck.yaml:1: 'mesh.file': file not found: '{full}' "
                                                  "(the deck's '../meshes/bar.mesh', relative to the deck's directory)"])


@pytest.mark.parametrize("word", ["yes", "on", "no", "off", "y"])
def test_yaml_1_1_booleans_are_refused(tmp_path, word):
    # docs/decks.md: a bool is true or false (True, FALSE too); yaml-cpp alone would take these
    path = Path(write_deck(tmp_path / f"{word}.yaml", deck_with(**{"output.reactions": "BOOLEAN_WORD"})))
    path.write_text(path.read_text().replace("BOOLEAN_WORD", word))
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, [f"{word}.yaml:", "'output.reactions'", "expected true or false"])
    path.write_text(path.read_text().replace(f"reactions: {word}", "reactions: True"))
    run_hyperqn([path, "-o", outdir], ranks=None)


@pytest.mark.parametrize("command", ["registry", "--help-deck"])
def test_commands_without_arguments_refuse_one(tmp_path, command):
    proc = run_hyperqn([command, "extra"], ranks=None, check=False, timeout=60)
    assert proc.returncode == 1 and f"'{command}': takes no argument, got 'extra'" in proc.stdout, proc.stdout


@pytest.mark.parametrize("case", ["stray_word", "second_deck", "two_outdirs", "option_without_value", "deck_option_without_value",
                                  "type_without_value", "restart_empty", "restart_with_equals", "restart_one_dash",
                                  "outdir_empty", "unknown_long_option", "rigid_share_without_value",
                                  "outdir_an_option", "restart_an_option",
                                  "rigid_share_out_of_range"])
def test_bad_command_lines_are_refused(tmp_path, case):
    # every argument is used or refused: a word that is neither the deck nor an option's value, a
    # second -o, or a numeric option without its number (PETSc alone would keep the default, unsaid)
    path = write_deck(tmp_path / "good.yaml", GOOD)
    outdir = tmp_path / "out"
    args, fragments = {
        "stray_word": ([path, "-o", outdir, "stray"], ["unexpected argument 'stray'", "the deck is"]),
        "second_deck": ([path, path, "-o", outdir], ["unexpected argument", "one deck a run"]),
        "two_outdirs": ([path, "-o", outdir, "-o", tmp_path / "other"], ["-o", "given twice"]),
        "option_without_value": ([path, "-o", outdir, "-hyperqn_divergence_limit"],
                                 ["-hyperqn_divergence_limit", "needs a value"]),
        # PETSc would fail at setup without naming it ("Unable to find requested TaoLineSearch type")
        "type_without_value": ([path, "-o", outdir, "-tao_ls_type"], ["option -tao_ls_type: needs a value"]),
        # these started afresh and removed the run they were meant to continue (PETSc took the
        # misspelt forms as options nothing reads, said after the run)
        "restart_empty": ([path, "-o", outdir, "--restart", ""], ["'--restart': needs a checkpoint file"]),
        "restart_with_equals": ([path, "-o", outdir, "--restart=latest"], ["'--restart=latest': not an option: write --restart VALUE"]),
        "restart_one_dash": ([path, "-o", outdir, "-restart", "latest"], ["'-restart': not an option: write --restart VALUE"]),
        "outdir_empty": ([path, "-o", ""], ["'-o': needs a directory"]),
        "unknown_long_option": ([path, "-o", outdir, "--frames", "3"], ["'--frames': not an option of hyperqn"]),
        # the option after -o became the directory ('-o', '-tao_monitor'), the word after it dropped
        "outdir_an_option": ([path, "-o", "-tao_monitor", outdir], ["'-o': needs a directory, got the option '-tao_monitor'"]),
        "restart_an_option": ([path, "-o", outdir, "--restart", "-o"], ["'--restart': needs a checkpoint file"]),
        # taken without a value (the default), or refused only by a scene with stiff clusters, in its setup
        "rigid_share_without_value": ([path, "-o", outdir, "-hyperqn_rigid_h0_share"], ["option -hyperqn_rigid_h0_share: needs a value"]),
        "rigid_share_out_of_range": ([path, "-o", outdir, "-hyperqn_rigid_h0_share", "5"], ["option -hyperqn_rigid_h0_share 5: must be a number in (0, 1]"]),
        "deck_option_without_value": (None, ["good.yaml:", "hyperqn_progress_seconds", "needs a value"]),
    }[case]
    if args is None:
        path = write_deck(tmp_path / "good.yaml", {**GOOD, "petsc": {"hyperqn_progress_seconds": None}})
        args = [path, "-o", outdir]
    proc = run_hyperqn(args, ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, fragments)
    assert not (tmp_path / "other").exists()
    assert proc.returncode == 1


@pytest.mark.parametrize("restart", [["--restart", ""], ["--restart=latest"], ["-restart", "latest"], "options_file", "deck",
                                     "options_file_restart", "options_file_restart=", "PETSC_OPTIONS_restart"])
def test_a_misspelt_restart_leaves_the_run_it_names(tmp_path, monkeypatch, restart):
    # each started afresh and removed the earlier run's files and checkpoints (exit 0); -restart
    # from an options file or the deck's petsc: too, and --restart latest (or --restart=latest) from
    # an options file or PETSC_OPTIONS, which nothing read: refused before PETSc starts, naming them
    path = write_deck(tmp_path / "good.yaml", {**GOOD, "checkpoint": {"every": 1}})
    outdir = tmp_path / "out"
    run_hyperqn([path, "-o", outdir], ranks=None, timeout=60)
    before = {p: p.stat().st_mtime_ns for p in outdir.rglob("*")}
    assert any("checkpoint" in str(p) for p in before)
    if restart == "options_file":
        (tmp_path / "opts").write_text("-restart latest\n")
        restart = ["-options_file", str(tmp_path / "opts")]
    elif restart == "deck":
        path = write_deck(tmp_path / "good.yaml", {**GOOD, "checkpoint": {"every": 1}, "petsc": {"restart": "latest"}})
        restart = []
    said = None
    if restart in ("options_file_restart", "options_file_restart="):
        word = "--restart latest" if restart == "options_file_restart" else "--restart=latest"
        (tmp_path / "opts").write_text(f"-tao_max_it 5\n{word}\n")
        restart = ["-options_file", str(tmp_path / "opts")]
        said = f"hyperqn: error: command line: option {word} (named in {tmp_path / 'opts'}): --restart VALUE is read from the command line only"
    elif restart == "PETSC_OPTIONS_restart":
        monkeypatch.setenv("PETSC_OPTIONS", "--restart latest")
        restart = []
        said = "hyperqn: error: command line: option --restart latest (in PETSC_OPTIONS): --restart VALUE is read from the command line only"
    proc = run_hyperqn([path, "-o", outdir] + restart, ranks=None, check=False, timeout=60)
    assert proc.returncode == 1 and "hyperqn: error:" in proc.stdout and "restart" in proc.stdout, proc.stdout
    assert said is None or (said in proc.stdout and proc.stdout.count("hyperqn: error") == 1), proc.stdout
    assert "removed" not in proc.stdout and "never used" not in proc.stdout
    assert {p: p.stat().st_mtime_ns for p in outdir.rglob("*")} == before


@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("where", ["options_file", "PETSC_OPTIONS"])
def test_an_output_directory_outside_the_command_line_is_refused(tmp_path, monkeypatch, where, ranks):
    # -o DIR from an options file or PETSC_OPTIONS was dropped unsaid: the run wrote to
    # output/<name>, replacing an earlier run there
    path = write_deck(tmp_path / "deck.yaml", {**GOOD, "name": "elsewhere_test"})
    wanted = tmp_path / "wanted"
    if where == "options_file":
        (tmp_path / "opts").write_text(f"-o {wanted}\n")
        args, said = ["-options_file", str(tmp_path / "opts")], f"(named in {tmp_path / 'opts'})"
    else:
        monkeypatch.setenv("PETSC_OPTIONS", f"-o {wanted}")
        args, said = [], "(in PETSC_OPTIONS)"
    proc = subprocess.run(launch.command([path] + args, None if ranks == 1 else ranks, HYPERQN, MPIEXEC), cwd=tmp_path,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60,
                          env={**os.environ, **launch.MPI_ENV})
    assert proc.returncode == 1, proc.stdout
    assert f"hyperqn: error: command line: option -o {wanted} {said}: -o OUTDIR is read from the command line only" in proc.stdout, proc.stdout
    assert proc.stdout.count("hyperqn: error") == 1 and "PETSC ERROR" not in proc.stdout
    assert not wanted.exists() and not (tmp_path / "output").exists()


def test_a_deck_the_run_would_overwrite_is_refused(tmp_path):
    # a deck named config.yaml in OUTDIR was replaced by the run's config.yaml (exit 0; the next
    # run of it then failed on its first key)
    outdir = tmp_path / "out"
    outdir.mkdir()
    path = write_deck(outdir / "config.yaml", GOOD)
    text = Path(path).read_text()
    for args in ([path, "-o", outdir], ["config.yaml", "-o", "."]):
        proc = subprocess.run([HYPERQN] + [str(a) for a in args], cwd=outdir, capture_output=True, text=True, timeout=60)
        assert proc.returncode == 1, proc.stdout + proc.stderr
        assert "is a file that the run writes in its output directory" in proc.stderr, proc.stderr
        assert sorted(os.listdir(outdir)) == ["config.yaml"] and Path(path).read_text() == text


def test_a_material_beside_a_mesh_without_tets_is_refused(tmp_path):
    # a Medit file of edges read as strands, with a material: accepted and unused (as a body's it was refused)
    (tmp_path / "rope.mesh").write_text("MeshVersionFormatted 1\nDimension 3\nVertices\n3\n0 0 0 0\n0.1 0 0 0\n0.2 0 0 0\n"
                                        "Edges\n2\n1 2 0\n2 3 0\nEnd\n")
    deck = {"mesh": {"file": "rope.mesh", "edges": "strands"},
            "strand_material": {"axial_stiffness": 100, "linear_density": 0.5},
            "material": {"model": "corotated", "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1},
            "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}],
            "time": {"dt": 0.01, "frames": 1}}
    proc = run_hyperqn([write_deck(tmp_path / "rope.yaml", deck), "-o", tmp_path / "out"], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, tmp_path / "out", ["rope.yaml: 'material': the mesh ", "rope.mesh has no tetrahedra"])
    assert proc.returncode == 1


def test_a_directory_as_the_mesh_file_is_said_to_be_one(tmp_path):
    (tmp_path / "dir.mesh").mkdir()
    path = write_deck(tmp_path / "dir.yaml", deck_with(mesh={"file": "dir.mesh"}))
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=None, check=False, timeout=60)
    assert_clean_failure(proc, outdir, ["dir.yaml:", "'mesh.file'", "not a regular file", "dir.mesh"])


@pytest.mark.parametrize("file_name", ["my deck.yaml", ".yaml", "-dash.yaml"])
def test_the_deck_file_s_name_as_the_run_s_name_keeps_the_name_rule(tmp_path, file_name):
    # `name: "my deck"` is refused, the same name from the file was not (nor '.yaml', whose files
    # were hidden: .yaml.pvd, .yaml_00000.vtu)
    path = write_deck(tmp_path / file_name, GOOD)
    proc = subprocess.run([HYPERQN, "./" + file_name, "-o", str(tmp_path / "out")], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and f"'name': left out, is the deck file's name" in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists()
    with_name = write_deck(tmp_path / file_name, {**GOOD, "name": "bar"})
    run_hyperqn([with_name, "-o", tmp_path / "out"], ranks=None, timeout=60)


def test_help_deck_after_the_deck():
    # `hyperqn DECK --help-deck` was refused as "not an option of hyperqn", naming --help-deck among them
    proc = subprocess.run([HYPERQN, os.path.join(REPO, "input", "bar.yaml"), "--help-deck"], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0 and "Deck keys declared" in proc.stdout, proc.stdout + proc.stderr
