"""Parameters declared once (src/params/deck_keys.hpp): the tables of every section on the deck's pages
(the pages scripts/deck_tables.py lists in DOCS) are what the binary declares, and `hyperqn
--help-deck` lists every declared key with its default."""
import subprocess

from conftest import HYPERQN, REPO
from hyperqn_tools import launch


def test_docs_tables_match_the_declarations():
    """--check without pages checks the pages the script lists, each section on the one with its heading."""
    proc = subprocess.run(["/usr/bin/python3", f"{REPO}/scripts/deck_tables.py", "--check", "--bin", HYPERQN],
                          capture_output=True, text=True)  # PYTHONPATH: as ctest sets it
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_help_deck_lists_every_declared_key():
    keys = launch.registry(HYPERQN)["deck_keys"]
    assert {k["section"] for k in keys} == {"mesh", "bodies", "strand_material", "cloth", "material", "fixed", "motion", "curve",
                                            "attachments", "loads", "colliders", "cuts", "fracture", "contact", "regions", "initial", "gravity", "time",
                                            "solver", "guardrails", "output", "checkpoint", "study", "petsc"}
    text = launch.run(["--help-deck"], ranks=None, binary=HYPERQN, check=True, timeout=60).stdout
    for k in keys:
        given = f"({k['default']}" if k["default"].startswith("required") else f"(default {k['default']}"
        assert f"  {k['name']}: " in text and given in text, k


def test_material_keys_come_from_the_registry():
    """Each model's own keys are declared once, in the material registry, and named in the material
    table with the models that take them."""
    keys = {k["name"]: k for k in launch.registry(HYPERQN)["deck_keys"] if k["section"] == "material"}
    models = [m["name"] for m in launch.registry(HYPERQN)["materials"]]
    assert keys["model"]["choices"] == models
    assert keys["J0"]["doc"].startswith("with `neohookean` only:") and keys["J0"]["type"] == "number in (0, 1)"
    assert keys["kappa"]["doc"].startswith("with `stvk` only:") and keys["kappa"]["type"] == "number ≥ 0"
    assert keys["spring_stiffness"]["default"] == "required with `mass-spring`"
    for name in ("f", "g", "h"):
        assert keys[name]["doc"].startswith("with `principal-stretch` only:"), keys[name]
    for name in ("youngs_modulus", "poisson_ratio", "mu", "lambda"):
        assert keys[name]["doc"].startswith("with `corotated`, `neohookean`, `stvk`, `hencky` only:"), keys[name]
    assert keys["fiber.direction"]["default"] == "required with `fiber`"
    assert "only" not in keys["density"]["doc"] and "only" not in keys["laplacian_weight"]["doc"]
