"""Parameters declared once (src/io/deck_keys.hpp): docs/decks.md's tables of the declared
sections (mesh, strand_material, cloth, fixed, motion, attachments, colliders, contact, regions, initial, time, solver, output,
checkpoint, study) are what the binary declares, and `hyperqn
--help-deck` lists every declared key with its default."""
import subprocess

from conftest import HYPERQN, REPO
from hyperqn_tools import launch


def test_docs_tables_match_the_declarations():
    proc = subprocess.run(["/usr/bin/python3", f"{REPO}/scripts/deck_tables.py", "--check", f"{REPO}/docs/decks.md",
                           "--bin", HYPERQN], capture_output=True, text=True)  # PYTHONPATH: as ctest sets it
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_help_deck_lists_every_declared_key():
    keys = launch.registry(HYPERQN)["deck_keys"]
    assert {k["section"] for k in keys} == {"mesh", "strand_material", "cloth", "fixed", "motion", "attachments", "colliders",
                                            "contact", "regions", "initial", "time", "solver", "output", "checkpoint", "study"}
    text = launch.run(["--help-deck"], ranks=None, binary=HYPERQN, check=True, timeout=60).stdout
    for k in keys:
        given = f"({k['default']}" if k["default"].startswith("required") else f"(default {k['default']}"
        assert f"  {k['name']}: " in text and given in text, k
