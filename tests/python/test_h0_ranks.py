"""Every way of applying the constant matrix gives the same run at 1, 2 and 4 ranks (4
oversubscribed), and the defaults choose as docs/performance.md#distributed-h0 says.

- -hyperqn_h0_package split (the default on more than one rank), supernodal and mumps (gathered to
  rank 0), and solver.h0: amg: a hanging box converged to grad_rtol 1e-10 at 1, 2 and 4 ranks,
  positions within 1e-8 of the rest diagonal of the 1-rank run. The solves differ in their last
  bits (other orderings, other sums), the converged positions by round-off.
- The same for the default on a cloth sheet (the vertex matrix of a surface).
- solver.h0 and -hyperqn_h0_package left out: supernodal on one rank, split with an interface
  block on two; amg on a mesh of kAmgFromTets (200,000) tetrahedra or more.
Bitwise repetition at a fixed rank count is tests/python/test_reproducible.py's."""
import copy

import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_summary, rest_diagonal

TOLERANCE = 1e-8  # of the rest bounding-box diagonal
RANKS = (1, 2, 4)

BOX = load_deck("tests/decks/hanging_bar.yaml")
BOX["mesh"]["box"]["cells"] = [4, 16, 4]
BOX["time"] = {"dt": 0.1, "frames": 3}  # h well below the axial period, so that amg converges as well
BOX["output"] = {"every": 3}

CLOTH = load_deck("input/cloth/sheet_corners.yaml")
CLOTH["mesh"]["sheet"]["cells"] = [24, 24]
CLOTH["time"]["frames"] = 4
CLOTH["solver"] = {"type": "lbfgs", "iterations": 500, "grad_rtol": 1e-10}
CLOTH["output"] = {"every": 4}

PATHS = {  # name: (solver keys, PETSc options)
    "default": ({}, []),
    "supernodal": ({}, ["-hyperqn_h0_package", "supernodal"]),
    "mumps": ({}, ["-hyperqn_h0_package", "mumps"]),
    "amg": ({"h0": "amg"}, []),
}


def run(tmp_path, name, deck, ranks, options=()):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out, *options], ranks=ranks)
    s = read_summary(out)
    assert s["status"] == "ok", s
    return out, s


def same_at_every_rank_count(tmp_path, name, deck, options=()):
    """Runs at 1, 2 and 4 ranks; returns the summaries after checking the positions."""
    outs, summaries = {}, {}
    for ranks in RANKS:
        outs[ranks], summaries[ranks] = run(tmp_path, f"{name}_np{ranks}", deck, ranks, options)
    base = final_frame(outs[1])
    diagonal = rest_diagonal(base)
    for ranks in RANKS[1:]:
        f = final_frame(outs[ranks])
        assert np.array_equal(f.vertex_id, base.vertex_id)
        gap = np.abs(f.points - base.points).max() / diagonal
        print(f"{name}: {ranks} ranks against 1: {gap:.1e} of the diagonal")
        assert gap <= TOLERANCE, f"{name} at {ranks} ranks: {gap:.2e} of the diagonal from 1 rank"
    return summaries


@pytest.mark.parametrize("path", sorted(PATHS))
def test_box_at_1_2_and_4_ranks(tmp_path, path):
    keys, options = PATHS[path]
    deck = copy.deepcopy(BOX)
    deck["solver"].update(keys)
    s = same_at_every_rank_count(tmp_path, path, deck, options)
    expected = {"default": ("supernodal", "split"), "amg": ("amg", "amg")}.get(path, (path, path))
    assert s[1]["h0_package"] == expected[0] and s[2]["h0_package"] == s[4]["h0_package"] == expected[1]
    if path == "default":  # the split factor: an interface between the ranks, growing with them
        assert s[1]["h0_interface"] == 0 < s[2]["h0_interface"] < s[4]["h0_interface"]


def test_cloth_at_1_2_and_4_ranks(tmp_path):
    s = same_at_every_rank_count(tmp_path, "cloth", CLOTH)
    assert s[2]["h0_package"] == "split" and s[2]["h0_interface"] > 0


@pytest.mark.parametrize("cells, ranks, expected", [
    ([40, 30, 28], 2, "amg"),        # 201,600 tets: past the threshold
    ([40, 30, 27], 2, "split"),      # 194,400 tets: below it
    ([40, 30, 27], 1, "supernodal"),
])
def test_auto_choice(tmp_path, cells, ranks, expected):
    deck = copy.deepcopy(BOX)
    deck["mesh"]["box"]["cells"] = cells
    deck["time"]["frames"] = 1
    deck["solver"] = {"type": "lbfgs", "iterations": 2, "max_iterations": 2, "max_halvings": 0,
                      "newton_fallback": False}
    deck["output"] = {"vtk": False}
    _, s = run(tmp_path, "auto", deck, ranks)
    assert s["h0_package"] == expected
