"""The default bar deck, 20 frames, at 1 and 2 ranks: same answer, one factorization,
monotone energy within each frame, and output files an independent reader accepts."""
import os

import numpy as np
import pytest

from conftest import event_count, run_at_1_and_2_ranks, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import Frame, final_frame, read_iterations, read_pvd, read_summary

FRAMES = 20


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{ranks: (outdir, PETSc log text)} for 1 and 2 ranks."""
    tmp = tmp_path_factory.mktemp("bar")
    deck = load_deck("input/bar.yaml")
    deck["time"]["frames"] = FRAMES
    deck_path = write_deck(tmp / "bar.yaml", deck)
    return run_at_1_and_2_ranks(deck_path, tmp)


def test_parallel_matches_serial(runs):
    # Stated tolerance: positions agree to 1e-8 of the largest displacement (measured: ~1e-15).
    rel, diff, scale = relative_difference(runs[1][0], runs[2][0])
    assert scale > 0.1, "the bar should sag visibly"
    assert rel <= 1e-8, f"1 vs 2 ranks differ by {rel:.3e} of the largest displacement"



@pytest.mark.parametrize("ranks", [1, 2])
def test_exactly_one_factorization(runs, ranks):
    outdir, log_text = runs[ranks]
    s = read_summary(outdir)
    assert s["frames"] == FRAMES and s["status"] == "ok"
    assert s["factorizations"] == 1
    # Independent of the summary's counter: PETSc's event log over the whole run. Every package
    # factors under hyperqn's event hqnH0Factor; PETSc's own MatCholFctr* events count the
    # packages PETSc calls (mumps, cholmod), not supernodal or split, which call CHOLMOD themselves.
    assert event_count(log_text, "hqnH0Factor") == 1
    through_petsc = 0 if s["h0_package"] in ("supernodal", "split") else 1
    assert event_count(log_text, "MatCholFctrNum") == through_petsc
    assert event_count(log_text, "MatCholFctrSym") == through_petsc
    # A^{-1} was applied once per L-BFGS iteration.
    assert s["h0_solves"] == s["iterations"] > 0


@pytest.mark.parametrize("ranks", [1, 2])
def test_energy_never_increases_within_a_frame(runs, ranks):
    rows = read_iterations(runs[ranks][0])
    assert {r["frame"] for r in rows} == set(range(1, FRAMES + 1))
    for prev, cur in zip(rows, rows[1:]):
        if cur["frame"] == prev["frame"]:
            assert cur["iteration"] == prev["iteration"] + 1
            assert cur["energy"] <= prev["energy"], f"g increased in frame {cur['frame']}: {prev} -> {cur}"
            assert cur["time_s"] >= prev["time_s"]
            assert cur["evaluations"] > prev["evaluations"]


@pytest.mark.parametrize("ranks", [1, 2])
def test_vtk_read_back_by_meshio(runs, ranks):
    outdir = runs[ranks][0]
    s = read_summary(outdir)
    frames = read_pvd(os.path.join(outdir, "bar.pvd"))
    assert len(frames) == FRAMES + 1  # frame 0 plus every frame
    assert frames[-1][0] == pytest.approx(FRAMES * s["dt"])
    first, last = Frame(frames[0][1]), Frame(frames[-1][1])
    assert last.num_pieces == ranks
    assert len(last.vertex_id) == s["vertices"]
    assert np.array_equal(last.vertex_id, np.arange(s["vertices"]))
    assert last.num_cells == s["tets"]
    assert set(np.unique(last.ranks)) == set(range(ranks))
    assert np.allclose(first.displacement, 0) and np.allclose(first.J, 1)
    assert np.all(np.isfinite(last.points)) and np.all(last.J > 0)
    assert np.allclose(last.points - last.displacement, first.points)
    # The clamped end (x = 0) does not move.
    clamped = first.points[:, 0] < 1e-9
    assert clamped.any() and np.all(last.displacement[clamped] == 0)


def test_summary_has_the_contract_keys(runs):
    s = read_summary(runs[2][0])
    for key in ("ranks", "vertices", "tets", "dofs", "frames", "solver", "factorizations", "factor_s",
                "wall_s", "ms_per_frame", "mean_iterations", "peak_rss_mb", "status"):
        assert key in s, key
    assert s["ranks"] == 2 and s["solver"] == "lbfgs"
    assert s["dofs"] == 3 * (s["vertices"] - s["fixed_vertices"])


def test_tiny_box_read_back(tmp_path):
    # A regression test: every array of a small mesh (e.g. the cell types, all 10 = '\n') must
    # survive an independent reader.
    deck = {"mesh": {"box": {"size": [1, 0.25, 0.25], "cells": [4, 1, 1]}},
            "material": {"model": "corotated", "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000},
            "time": {"frames": 1}}
    out = tmp_path / "out"
    run_hyperqn([write_deck(tmp_path / "tiny.yaml", deck), "-o", out], ranks=None)
    f = final_frame(out)
    assert len(f.vertex_id) == 20 and f.num_cells == 24 and np.all(f.J > 0)
