#!/usr/bin/env python3
"""Fuzzes hyperqn's inputs: decks, meshes and command-line options, mutated from a small valid
scene. Every run must end cleanly:

  - no crash: the exit code is 0, 1, or 2 with status "inverted" (a signal, an abort or an MPI abort is a crash);
  - no hang: each run finishes within --timeout seconds;
  - rejected input writes nothing: a run that exits 1 before its first frame leaves no output
    directory (a run that started and then stopped, e.g. diverged, has its summary.json);
  - every failure says "hyperqn: error" and no raw PETSc trace;
  - the input classes that must be refused (tagged YAML values, hexadecimal, inf and nan numbers in
    mesh files, an unknown MeshVersionFormatted, vertex indices out of range in any Medit section,
    PETSc option values with whitespace or names that are not names, nan/inf values of -hyperqn_
    options in the deck, a contact distance larger than the body, attachments inside fixed boxes)
    are: rejected, with a message naming the file and line.

    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/fuzz.py --cases 1000     # make fuzz
    PYTHONPATH=$PWD/postprocess /usr/bin/python3 scripts/fuzz.py --cases 60 --budget 50

Cases are drawn from --seed, so a run is reproducible; a failing case's deck, mesh and command
are kept in --out/cases/ and listed. Prints counts per outcome and writes fuzz.json; exits 1
if any case failed. A rerun removes what an earlier one wrote in --out (cases/, fuzz.json) and
nothing else there.
"""
import argparse
import copy
import json
import os
import random
import re
import shutil
import subprocess
import sys
import time

import yaml

from hyperqn_tools import cli, launch
from hyperqn_tools.paths import REPO

BASE = {
    "name": "fuzz",
    "mesh": {"box": {"size": [1.0, 0.25, 0.25], "cells": [4, 1, 1]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.0333333333, "frames": 3},
    "solver": {"type": "lbfgs", "iterations": 10},
    "output": {"every": 1},
}
MESH = ("MeshVersionFormatted 1\nDimension 3\nVertices\n5\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 1\n"
        "Tetrahedra\n2\n1 2 3 4 1\n2 3 4 5 2\nEdges\n1\n1 2 0\nEnd\n")
GMSH = ("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 1 1\n1 0 0 0 1 1 1 0 0\n1 0 0 0 1 1 1 1 2 1 1\n"
        "$EndEntities\n$Nodes\n1 5 1 5\n3 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
        "$Elements\n2 3 1 3\n2 1 2 1\n1 1 2 3\n3 1 4 2\n2 1 2 3 4\n3 2 3 4 5\n$EndElements\n")

# Values a fuzzer tries anywhere: wrong types, edges of ranges, overflow, text, structure.
ODD_VALUES = [0, -1, 1, 2147483647, -2147483648, 1e308, -1e308, 1e-320, float("nan"), float("inf"), 0.5, 1e100,
              "", "x", "0x10", "1e5", "..", "a/b", "a\nb", None, True, [], [1], [1, 2, 3, 4], {}, {"a": 1},
              [[1, 2, 3]], "\0", "é" * 300]
KEYS = ["name", "mesh", "material", "fixed", "gravity", "time", "solver", "output", "regions", "initial",
        "strand_material", "study", "petsc", "colliders", "contact", "attachments", "cloth", "bogus"]
CLOTH = {"mesh": {"sheet": {"size": [1.0, 0.5], "cells": [4, 2]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 100.0, "bending": {"model": "quadratic", "stiffness": 1e-3},
                   "areal_density": 0.2},
         "fixed": [{"box": {"min": [-0.01, -0.01, 0.49], "max": [0.01, 0.01, 0.51]}}]}
CLOTH_OBJ = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0.5 0.2 0.5\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n"
OBJ = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 4 3\nf 1 3 2\n"
COLLIDERS = [{"type": "plane", "point": [0, -0.1, 0], "normal": [0, 1, 0], "friction": 0.3},
             {"type": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.2},
             {"type": "box", "min": [-1, -1, -1], "max": [2, -0.05, 2]},
             {"type": "capsule", "a": [0, 0.5, -1], "b": [0, 0.5, 2], "radius": 0.1},
             {"type": "mesh", "file": "fuzz.obj", "friction": 0.2}]
COLLIDER_KEYS = ["type", "point", "normal", "center", "radius", "min", "max", "a", "b", "file", "friction", "motion"]
SUBKEYS = {"mesh": ["box", "file", "transform", "edges", "strands"],
           "material": ["model", "youngs_modulus", "poisson_ratio", "mu", "lambda", "density", "total_mass", "J0",
                        "kappa", "laplacian_weight", "fiber", "spring_stiffness", "f"],
           "time": ["dt", "frames", "damping"],
           "solver": ["type", "iterations", "grad_atol", "grad_rtol", "history", "line_search", "warm_start",
                      "newton_method", "linear_solver", "newton_hessian", "h0"],
           "output": ["every", "vtk", "iterations_csv", "contact_csv", "directory"],
           "contact": ["model", "distance", "stiffness", "friction_velocity"],
           "cloth": ["model", "stretch_stiffness", "material", "youngs_modulus", "poisson_ratio", "bending",
                     "areal_density"]}
OPTIONS = ["-tao_type", "-tao_ls_type", "-tao_max_it", "-tao_gatol", "-tao_lmvm_mat_lmvm_hist_size",
           "-h0_mat_mumps_icntl_7", "-h0_mat_mumps_icntl_14", "-hyperqn_divergence_limit", "-tao_ls_stepinit",
           "-tao_bogus_option", "-hyperqn_h0_package", "-h0_mat_cholmod_factor"]
OPTION_VALUES = ["0", "-1", "1", "nan", "inf", "abc", "1e308", "lmvm", "nls", "armijo", "unit", "", "99999999999",
                 "mumps", "cholmod", "supernodal", "split"]


# Classes of input that must be refused, each with the file and line its message must name.
REFUSED = ["tagged", "mesh_number", "mesh_version", "mesh_index", "petsc_word", "petsc_nonfinite",
           "contact_distance", "attached_fixed"]
KINDS = ["deck"] * 4 + ["mesh", "gmsh", "options", "contact", "cloth"] * 2 + REFUSED
TAGS = ["!!str", "!!float", "!!int", "!!bool", "!!null", "!!binary", "!!map", "!foo", "!<tag:yaml.org,2002:str>",
        "!!python/object"]
ODD_NUMBERS = ["0x10", "0X1P3", "-0x.8p1", "inf", "-inf", "+INF", "Infinity", "nan", "NaN", "-nan", "nan(0x1)", "1e999"]
BAD_INDICES = [0, -1, 6, 999, 2147483647, 99999999999]
SURFACE = ("MeshVersionFormatted 2\nDimension 3\nVertices\n4\n-1 0 -1 0\n1 0 -1 0\n1 0 1 0\n-1 0 1 0\n"
           "Triangles\n2\n1 4 3 0\n1 3 2 0\nEnd\n")
PETSC_WORDS = ["unit -tao_type garbage", "armijo ", " armijo", "a\tb", "a\nb", "more-thuente -tao_max_it 0", "1 2"]
PETSC_NAMES = ["tao ls_type", "tao_ls_type=armijo", "tao.ls_type", "1tao", "tao/ls", "tao-ls-type", "tao_ls_type\t"]
HYPERQN_OPTIONS = ["divergence_limit", "element_limit", "test_nan_energy_beyond", "test_nan_energy_from_step", "h0_package"]
NONFINITE = ["nan", "NaN", "inf", "-inf", "Infinity", ".nan", ".inf", "1e999", "-1e999"]


def line_of(text, needle, start=0):
    """1-based number of the first line of text from line start (0-based) that holds needle."""
    lines = text.splitlines()
    return next(i + 1 for i in range(start, len(lines)) if needle in lines[i])


def tag_deck(rng, deck):
    """The deck's YAML with an explicit tag on one value, list item, section or key; its line."""
    lines = yaml.safe_dump(deck, sort_keys=False, allow_unicode=True).splitlines()
    i = rng.randrange(len(lines))
    line, tag = lines[i], rng.choice(TAGS)
    indent = line[: len(line) - len(line.lstrip())]
    body = line.lstrip()
    if body.startswith("- "):
        lines[i] = f"{indent}- {tag} {body[2:]}"
    else:
        key, _, value = body.partition(":")
        value = value.strip()
        if value and rng.random() < 0.7:
            lines[i] = f"{indent}{key}: {tag} {value}"
        elif not value and rng.random() < 0.7:
            lines[i] = f"{indent}{key}: {tag}"  # the section's map (or an empty value)
        else:
            lines[i] = f"{indent}{tag} {body}"  # the key
    return "\n".join(lines) + "\n", i + 1


def refused_case(rng, what, deck, casedir):
    """A case of a class that must be refused: writes its files; returns (deck or its YAML text,
    patterns its message must match)."""
    deck_at = r"deck\.yaml:\d+"
    def write(name, text):
        with open(os.path.join(casedir, name), "w") as f:
            f.write(text)

    def cloth(d):
        d.pop("material")
        d.update(copy.deepcopy(CLOTH))
        return d

    if what == "tagged":
        if rng.random() < 0.3:
            deck = cloth(deck)
        text, line = tag_deck(rng, deck)
        return text, [rf"deck\.yaml:{line}: ", "YAML tags are not accepted"]
    if what == "mesh_number":
        number, form = rng.choice(ODD_NUMBERS), rng.choice(["medit", "gmsh", "obj"])
        if form == "medit":
            lines, i = MESH.splitlines(), rng.randrange(4, 9)  # a vertex line
            deck["mesh"], deck["fixed"], name = {"file": "fuzz.mesh"}, [], "fuzz.mesh"
        elif form == "gmsh":
            lines = GMSH.splitlines()
            start, end = lines.index("$Nodes"), lines.index("$EndNodes")
            i = rng.choice([k for k in range(start, end) if len(lines[k].split()) == 3])  # node coordinates
            deck["mesh"], deck["fixed"], name = {"file": "fuzz.msh"}, [], "fuzz.msh"
        else:
            lines = CLOTH_OBJ.splitlines()
            i = rng.choice([k for k, l in enumerate(lines) if l.startswith("v ")])
            deck = cloth(deck)
            deck["mesh"], deck["fixed"], name = {"file": "fuzz.obj"}, [], "fuzz.obj"
        tokens = lines[i].split()
        # a Medit vertex's reference is not used: a decimal that overflows is harmless there
        last = 3 if form == "medit" and number == "1e999" else len(tokens)
        tokens[rng.randrange(1 if form == "obj" else 0, last)] = number
        lines[i] = " ".join(tokens)
        write(name, "\n".join(lines) + "\n")
        return deck, [rf"{name}:{i + 1}: "]
    if what == "mesh_version":
        version = rng.choice([0, 5, 99, -1, 2147483648])
        if rng.random() < 0.3:  # an obstacle's Medit surface
            write("obstacle.mesh", SURFACE.replace("MeshVersionFormatted 2", f"MeshVersionFormatted {version}"))
            deck["colliders"] = [{"type": "mesh", "file": "obstacle.mesh"}]
            return deck, [r"obstacle\.mesh:1: 'MeshVersionFormatted'"]
        write("fuzz.mesh", MESH.replace("MeshVersionFormatted 1", f"MeshVersionFormatted {version}"))
        deck["mesh"], deck["fixed"] = {"file": "fuzz.mesh"}, []
        return deck, [r"fuzz\.mesh:1: 'MeshVersionFormatted'"]
    if what == "mesh_index":
        index, form = rng.choice(BAD_INDICES), rng.choice(["triangles", "edges", "tets", "quads", "corners", "cloth", "obstacle"])
        if form == "obstacle":
            text = SURFACE.replace("End\n", f"Edges\n1\n1 {index} 0\nEnd\n")
            write("obstacle.mesh", text)
            deck["colliders"] = [{"type": "mesh", "file": "obstacle.mesh"}]
            return deck, [rf"obstacle\.mesh:{line_of(text, f'1 {index} 0')}: 'Edges'"]
        if form == "cloth":
            deck = cloth(deck)
        deck["mesh"], deck["fixed"] = {"file": "fuzz.mesh"}, []
        if form != "cloth" and rng.random() < 0.5:  # Edges read, not skipped
            deck["mesh"]["edges"] = "strands"
            deck["strand_material"] = {"axial_stiffness": 10, "linear_density": 0.1}
        text = MESH
        if form == "triangles":
            text = MESH.replace("End\n", f"Triangles\n2\n1 2 3 0\n2 {index} 4 0\nEnd\n")
            line, section = line_of(text, f"2 {index} 4 0"), "Triangles"
        elif form == "edges":
            text = MESH.replace("1\n1 2 0\n", f"1\n{index} 2 0\n")
            line, section = line_of(text, f"{index} 2 0", 10), "Edges"
        elif form == "tets":
            text = MESH.replace("2 3 4 5 2", f"2 3 {index} 5 2")
            line, section = line_of(text, f"2 3 {index} 5 2"), "Tetrahedra"
        elif form == "quads":
            text = MESH.replace("End\n", f"Quadrilaterals\n1\n1 2 3 {index} 0\nEnd\n")
            line, section = line_of(text, f"1 2 3 {index} 0"), "Quadrilaterals"
        elif form == "corners":  # before Vertices: checked once they are read
            text = MESH.replace("Vertices\n", f"Corners\n1\n{index}\nVertices\n")
            line, section = 5, "Corners"
        else:  # a cloth's triangles are read and its tetrahedra skipped
            deck["mesh"]["surface"] = "cloth"
            text = MESH.replace("2 3 4 5 2", f"2 3 {index} 5 2").replace("End\n", "Triangles\n1\n1 2 3 0\nEnd\n")
            line, section = line_of(text, f"2 3 {index} 5 2"), "Tetrahedra"
        write("fuzz.mesh", text)
        return deck, [rf"fuzz\.mesh:{line}: '{section}'"]
    if what == "petsc_word":
        if rng.random() < 0.5:
            name, value = rng.choice(["tao_ls_type", "log_view", "tao_max_it"]), rng.choice(PETSC_WORDS)
        else:
            name, value = rng.choice(PETSC_NAMES), "armijo"
        nested = rng.random() < 0.3 and not name[0].isdigit()  # a_1tao is a name
        deck["petsc"] = {"a": {name: value}} if nested else {name: value}
        return deck, [deck_at + r": 'petsc\."]
    if what == "petsc_nonfinite":
        option, value = rng.choice(HYPERQN_OPTIONS), rng.choice(NONFINITE)
        deck["petsc"] = {"hyperqn_" + option: value} if rng.random() < 0.7 else {"hyperqn": {option: value}}
        return deck, [deck_at]
    if what == "contact_distance":
        if rng.random() < 0.3:
            deck, diagonal = cloth(deck), (1.0 ** 2 + 0.5 ** 2) ** 0.5
        else:
            diagonal = (1.0 + 2 * 0.25 ** 2) ** 0.5
        scale = rng.choice([0.01, 0.1, 1, 10])
        deck["mesh"]["transform"] = {"scale": scale}
        deck["fixed"] = []  # its box would select other vertices of the scaled mesh
        deck["colliders"] = [copy.deepcopy(rng.choice(COLLIDERS[:4]))]
        deck["contact"] = {"distance": diagonal * scale * rng.choice([1.01, 2, 10, 1e6])}
        return deck, [deck_at + r": 'contact\.distance'", "larger than the body"]
    # attached_fixed: an attachment inside a fixed box, after an attachment that acts, or not
    if rng.random() < 0.3:
        deck = cloth(deck)
        inside, acts = {"min": [-0.01, -0.01, 0.49], "max": [0.01, 0.01, 0.51]}, {"min": [0.99, -1, -1], "max": [1.01, 1, 2]}
    else:
        inside = rng.choice([copy.deepcopy(BASE["fixed"][0]["box"]), {"min": [-0.001, -0.1, -0.1], "max": [0.001, 0.3, 0.3]}])
        acts = {"min": [0.99, -1, -1], "max": [1.01, 1, 1]}
    if rng.random() < 0.3:  # a moving clamp is still fixed
        deck["fixed"][0]["motion"] = {"translate": {"velocity": [0, 0.1, 0]}}
    attachments = [{"box": acts, "stiffness": 1.0e3}] if rng.random() < 0.5 else []
    attachments.append({"box": inside, "stiffness": rng.choice([1.0, 1.0e5])})
    deck["attachments"] = attachments
    return deck, [deck_at + rf": 'attachments\[{len(attachments) - 1}\]\.box'", "fixed"]


def mutate_deck(rng, deck):
    """One to three mutations: a value replaced, a key removed, or an unknown key added."""
    d = copy.deepcopy(deck)
    for _ in range(rng.randint(1, 3)):
        kind = rng.random()
        section = rng.choice(KEYS)
        if kind < 0.15:
            d.pop(section, None)
        elif kind < 0.35 or section not in SUBKEYS:
            d[section] = rng.choice(ODD_VALUES)
        else:
            node = d.setdefault(section, {})
            if not isinstance(node, dict):
                node = d[section] = {}
            key = rng.choice(SUBKEYS[section] + ["bogus"])
            node[key] = rng.choice(ODD_VALUES + [rng.uniform(-10, 10), rng.randint(-5, 50)])
    return d


def mutate_mesh(rng, text):
    """A mesh text with a line changed, removed, duplicated or cut, or bytes flipped."""
    lines = text.splitlines(keepends=True)
    kind = rng.random()
    i = rng.randrange(len(lines))
    if kind < 0.25:
        del lines[i]
    elif kind < 0.45:
        lines.insert(i, lines[i])
    elif kind < 0.7:
        lines[i] = " ".join(str(rng.choice([0, -1, 7, 1e308, "nan", "x", 99999999999])) for _ in range(rng.randint(1, 6))) + "\n"
    elif kind < 0.85:
        return "".join(lines)[: rng.randrange(len(text))]
    else:
        text = bytearray("".join(lines), "utf-8")
        for _ in range(rng.randint(1, 5)):
            text[rng.randrange(len(text))] = rng.randrange(256)
        return text.decode("utf-8", errors="replace")
    return "".join(lines)


def make_case(rng, k, casedir):
    """Writes case k's files into casedir; returns (command arguments, ranks, what was fuzzed,
    patterns the message must match if the input must be refused, else None)."""
    os.makedirs(casedir, exist_ok=True)
    # Every class once first, so that a short run (fuzz_quick) draws each.
    classes = sorted(set(KINDS), key=KINDS.index)
    deck, args, what, expect = copy.deepcopy(BASE), [], classes[k] if k < len(classes) else rng.choice(KINDS), None
    if what in REFUSED:
        deck, expect = refused_case(rng, what, deck, casedir)
    elif what == "cloth":
        # A sheet or an OBJ surface (maybe mutated) with the cloth section and mesh keys mutated.
        deck.pop("material")
        deck.update(copy.deepcopy(CLOTH))
        if rng.random() < 0.4:
            with open(os.path.join(casedir, "fuzz.obj"), "w") as f:
                f.write(mutate_mesh(rng, CLOTH_OBJ) if rng.random() < 0.6 else CLOTH_OBJ)
            deck["mesh"] = {"file": "fuzz.obj"}
            deck["fixed"] = [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}}]
        if rng.random() < 0.3:
            deck["cloth"] = {"model": "membrane", "material": rng.choice(["stvk", "corotated", "neohookean"]),
                             "youngs_modulus": 100.0, "poisson_ratio": 0.3, "areal_density": 0.2,
                             "bending": {"model": rng.choice(["dihedral", "springs", "none"]), "stiffness": 1e-3}}
            if deck["cloth"]["bending"]["model"] == "none":
                deck["cloth"]["bending"].pop("stiffness")
        if rng.random() < 0.8:
            deck = mutate_deck(rng, deck) if rng.random() < 0.4 else deck
            section = rng.choice(["cloth", "mesh"])
            keys = SUBKEYS["cloth"] if section == "cloth" else ["sheet", "surface", "file", "transform", "strands"]
            node = deck.setdefault(section, {})
            if isinstance(node, dict):
                node[rng.choice(keys + ["bogus"])] = rng.choice(ODD_VALUES + [rng.uniform(-10, 10), rng.randint(-5, 50)])
    elif what == "deck":
        deck = mutate_deck(rng, deck)
    elif what == "contact":
        # Colliders of every type, one item or the obstacle file mutated, maybe a contact section.
        with open(os.path.join(casedir, "fuzz.obj"), "w") as f:
            f.write(mutate_mesh(rng, OBJ) if rng.random() < 0.3 else OBJ)
        deck["colliders"] = copy.deepcopy(rng.sample(COLLIDERS, rng.randint(1, len(COLLIDERS))))
        item = rng.choice(deck["colliders"])
        for _ in range(rng.randint(0, 2)):
            item[rng.choice(COLLIDER_KEYS + ["bogus"])] = rng.choice(ODD_VALUES + [rng.uniform(-10, 10)])
        if rng.random() < 0.5:
            deck = mutate_deck(rng, deck) if rng.random() < 0.3 else deck
            deck["contact"] = {rng.choice(SUBKEYS["contact"] + ["bogus"]): rng.choice(ODD_VALUES + [rng.uniform(0, 1)])}
    elif what == "mesh":
        with open(os.path.join(casedir, "fuzz.mesh"), "w") as f:
            f.write(mutate_mesh(rng, MESH))
        deck["mesh"] = {"file": "fuzz.mesh", "edges": rng.choice(["ignore", "strands"])}
        deck["fixed"] = []
        deck["strand_material"] = {"axial_stiffness": 10, "linear_density": 0.1}
        if deck["mesh"]["edges"] == "ignore":
            deck.pop("strand_material")
    elif what == "gmsh":
        with open(os.path.join(casedir, "fuzz.msh"), "w") as f:
            f.write(mutate_mesh(rng, GMSH))
        deck["mesh"] = {"file": "fuzz.msh"}
        deck["fixed"] = []
    else:
        for _ in range(rng.randint(1, 3)):
            args += [rng.choice(OPTIONS), rng.choice(OPTION_VALUES)]
    deck_path = os.path.join(casedir, "deck.yaml")
    with open(deck_path, "w") as f:
        if isinstance(deck, str):
            f.write(deck)
        else:
            yaml.safe_dump(deck, f, sort_keys=False, allow_unicode=True)
    ranks = 2 if rng.random() < 0.2 else None
    return [deck_path, "-o", os.path.join(casedir, "out")] + args, ranks, what, expect


def judge(proc, outdir, timed_out, expect=None):
    """The outcome of one run: 'ok', 'rejected', 'stopped' (ran, then could not continue),
    'inverted' (ran to the end with inverted elements, exit 2), or a failure class. With expect
    (patterns of the message), only 'rejected' with a message matching them is not a failure."""
    outcome = judge_run(proc, outdir, timed_out)
    if expect is None or outcome not in ("ok", "rejected", "stopped", "inverted"):
        return outcome
    if outcome != "rejected":
        return f"not refused ({outcome})"
    error = next((line for line in (proc.stdout or "").splitlines() if "hyperqn: error" in line), "")
    missing = [p for p in expect if not re.search(p, error)]
    return f"refused without {missing[0]!r}" if missing else outcome


def judge_run(proc, outdir, timed_out):
    if timed_out:
        return "hang"
    out = proc.stdout or ""
    if proc.returncode not in (0, 1, 2):
        return f"crash (exit {proc.returncode})"
    if "PETSC ERROR" in out:
        return "petsc trace"
    if proc.returncode == 2:
        summary = os.path.join(outdir, "summary.json")
        if not os.path.exists(summary):
            return "exit 2 without summary"
        with open(summary) as f:
            status = json.load(f).get("status", "")
        return "inverted" if status.startswith("inverted") else "exit 2 with status " + status[:30]
    if proc.returncode == 0:
        return "ok" if os.path.exists(os.path.join(outdir, "summary.json")) else "ok without summary"
    if "hyperqn: error" not in out:
        return "error without message"
    if not os.path.exists(outdir):
        return "rejected"
    summary = os.path.join(outdir, "summary.json")
    if os.path.exists(summary):
        with open(summary) as f:
            status = json.load(f).get("status", "")
        return "stopped" if status.startswith("error") else "exit 1 with status " + status[:30]
    return "rejected input wrote output"


OWN = ["cases", "fuzz.json"]  # what a run writes in --out: a rerun removes these, and only these


def main():
    p = cli.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", type=cli.count, default=1000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=cli.positive_float, default=30, help="seconds per run")
    p.add_argument("--budget", type=cli.seconds_or_0, default=0, help="stop after this many seconds (0: no limit)")
    p.add_argument("--out", default=os.path.join(REPO, "output", "fuzz"))
    p.add_argument("--bin", type=cli.program, default=launch.default_binary())
    args = p.parse_args()
    why = cli.unwritable_dir(args.out)
    if why:
        p.error(f"--out {why}")
    cli.remove_own(args.out, OWN)
    rng = random.Random(args.seed)
    counts, classes, failures, start = {}, {}, [], time.time()
    run_cases = 0
    for k in range(args.cases):
        if args.budget and time.time() - start > args.budget:
            break
        casedir = os.path.join(args.out, "cases", f"{k:05d}")
        cmd, ranks, what, expect = make_case(rng, k, casedir)
        timed_out = False
        try:
            proc = launch.run(cmd, ranks=ranks, binary=args.bin, timeout=args.timeout)
        except subprocess.TimeoutExpired as e:
            proc, timed_out = subprocess.CompletedProcess(cmd, -1, e.output or ""), True
        outcome = judge(proc, os.path.join(casedir, "out"), timed_out, expect)
        counts[outcome] = counts.get(outcome, 0) + 1
        classes[what] = classes.get(what, 0) + 1
        run_cases += 1
        if outcome in ("ok", "rejected", "stopped", "inverted"):
            shutil.rmtree(casedir)
        else:
            failures.append({"case": k, "fuzzed": what, "ranks": ranks or 1, "outcome": outcome,
                             "command": " ".join(proc.args), "output": (proc.stdout or "")[-1500:]})
    seconds = time.time() - start
    print(f"{run_cases} cases in {seconds:.0f} s (seed {args.seed}):")
    for outcome, n in sorted(counts.items(), key=lambda kv: -kv[1]):
        print(f"  {n:6d}  {outcome}")
    print("cases per class: " + ", ".join(f"{c} {classes[c]}" for c in sorted(classes, key=KINDS.index)))
    for f in failures:
        print(f"FAILED case {f['case']} ({f['fuzzed']}, {f['ranks']} rank(s)): {f['outcome']}\n  {f['command']}\n"
              + "\n".join("    " + line for line in f["output"].splitlines()[-6:]))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "fuzz.json"), "w") as f:
        json.dump({"cases": run_cases, "seed": args.seed, "seconds": seconds, "counts": counts, "classes": classes,
                   "failures": failures},
                  f, indent=1)
    print(f"{len(failures)} failed, {run_cases - len(failures)} passed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
