"""A blade through strands (docs/snapping.md#a-blade-through-strands), end to end: a cube hung on
two ropes, a blade sweeping down through both ropes at a fixed x of their rest shape. The segment
of each rope that the blade crosses snaps as an overstretched one does (it lets go at both ends),
both in the same step; the cube falls free, its piece's momentum changing by its weight's impulse
alone; the mass is unchanged exactly; 1, 2 and 4 ranks cut the same segment in the same frame;
a run killed (kill -9) after the cut and restarted equals the uninterrupted run bit for bit;
L-BFGS's corrected H0 is a fresh factor's; a blade that removes is refused on strands
(test_cuts.py). The ranks and the restart are tested on a rope between two fixed ends, cut where
the 2-rank partition divides it."""
import copy

import meshio
import numpy as np
import pytest

from conftest import run_deck
from hyperqn_tools.output import is_empty_piece, piece_files, read_summary, rest_diagonal
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise
from test_cloth_cut import pieces
from test_cloth_tear import corrected_vs_fresh
from test_tearing import ROPE, TIGHT, frames, masses

CUT_X = 0.35  # the blade's plane: inside the fourth segment of each rope (rest x 0.3 to 0.4 and 0.315 to 0.42)
# The rope deck of test_tearing.py without snapping, and a blade in the plane x = 0.35 of the rest
# shape (frame: rest), 1 m wide along z, coming down through y = 0 at 6 m/s: it crosses both
# ropes' rest positions in the step ending at t = 4/60 s.
CUT_ROPE = {**ROPE,
            "strand_material": {k: v for k, v in ROPE["strand_material"].items() if k != "snap"},
            "cuts": [{"center": [CUT_X, 0.5, 0.15], "normal": [1, 0, 0], "axis": [0, 1, 0], "size": [0.2, 1.0],
                      "frame": "rest", "motion": {"translate": {"velocity": [0, -6, 0]}, "start": 0.0, "end": 0.2}}],
            "time": {"dt": 1 / 60, "frames": 30},
            "solver": TIGHT}
CUT_FRAME = 4  # the last frame written before the cut (it is made at the start of the next step)


def pieces_with_strands(frame):
    """test_cloth_cut's pieces() over the frame's tets and strand segments (each as a triangle)."""
    joined = copy.copy(frame)
    tets, lines = frame.cells["tetra"], frame.cells["line"]
    joined.cells = {"triangle": np.concatenate([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], lines[:, [0, 1, 1]]])}
    return pieces(joined)


@pytest.fixture(scope="module")
def rope(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("rope"), "rope", CUT_ROPE)


def test_the_blade_cuts_each_rope_once_and_the_cube_falls(rope):
    out, s = rope
    fs = frames(out)
    counts = [len(f.points) for f in fs]
    assert all(c == counts[0] for c in counts[: CUT_FRAME + 1]) and all(c == counts[0] + 4 for c in counts[CUT_FRAME + 1:])
    assert s["breaks"]["segments_snapped"] == 2 and s["breaks"]["vertices_added"] == 4 and s["breaks"]["edges_torn"] == 0
    last = fs[-1]
    rest = last.points - last.displacement
    # the copies are the ends of the segments the blade crossed: each rope's segment across x = 0.35
    copies = rest[last.vertex_id >= counts[0]]
    assert np.all(np.abs(copies[:, 0] - CUT_X) < 0.06)
    assert np.sum(copies[:, 0] < CUT_X) == 2 and np.sum(copies[:, 0] > CUT_X) == 2
    # four pieces: the two stubs on the fixed ends, the cube with the rest of the ropes, the two cut
    # segments (each a piece of its own: a snapped segment lets go at both ends)
    label = pieces_with_strands(last)
    fixed_stubs = {label[k] for k in np.flatnonzero(np.linalg.norm(rest[:, [0, 1]], axis=1) < 1e-9)}
    cube = label[np.argmax(rest[:, 0])]
    assert len(np.unique(label)) == 5 and cube not in fixed_stubs and len(fixed_stubs) == 2
    # the cube's piece falls free: its momentum changes by its weight's impulse m g h each step
    # (internal forces sum to zero; Newton converged to round-off)
    m = masses(last)
    mine = label == cube
    h, g = CUT_ROPE["time"]["dt"], 9.81
    momentum = [np.sum(m[mine, None] * f.velocity[mine], axis=0) for f in fs[CUT_FRAME + 2:]]
    change = np.diff(momentum, axis=0) / (m[mine].sum() * g * h)
    print("momentum change per step over m g h:", change[:, 1].min(), change[:, 1].max(), "x, z:", np.abs(change[:, [0, 2]]).max())
    assert np.allclose(change[:, 1], -1, atol=1e-6) and np.abs(change[:, [0, 2]]).max() < 1e-6
    assert last.points[mine, 1].max() < fs[CUT_FRAME].points[:, 1].min() - 0.5  # fallen past where it hung


def test_total_mass_is_unchanged_exactly(rope):
    fs = frames(rope[0])
    before, after = masses(fs[0]).sum(), masses(fs[-1]).sum()
    assert abs(after - before) <= 1e-14 * before


# A rope of 20 segments hanging between two fixed ends, cut at x = 0.49 (its 10th segment, 0.45 to
# 0.5, frame: rest): at 2 ranks METIS gives each rank half the rope, so the cut segment's end at
# x = 0.5 is the vertex the two ranks share; the two halves swing down.
LINE_CUT_X = 0.49
LINE = {"mesh": {"strands": [{"from": [0, 0, 0], "to": [1, 0, 0], "segments": 20}]},
        "strand_material": CUT_ROPE["strand_material"],
        "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.01]}},
                  {"box": {"min": [0.99, -0.01, -0.01], "max": [1.01, 0.01, 0.01]}}],
        "gravity": [0, -9.81, 0],
        "cuts": [{**CUT_ROPE["cuts"][0], "center": [LINE_CUT_X, 0.5, 0.0], "size": [0.2, 0.4]}],
        "time": {"dt": 1 / 60, "frames": 30},
        "solver": TIGHT}


@pytest.fixture(scope="module")
def line(tmp_path_factory):
    return run_deck(tmp_path_factory.mktemp("line"), "line", LINE)


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_cut_the_same_segments_in_the_same_frame(line, tmp_path, ranks):
    ref, s1 = line
    out, s2 = run_deck(tmp_path, "line", LINE, ranks=ranks)
    assert s2["ranks"] == ranks and s1["breaks"]["segments_snapped"] == 1 and s1["breaks"]["vertices_added"] == 2
    skip = ("topology_s", "h0_corrections", "refactorizations")
    assert {k: v for k, v in s1["breaks"].items() if k not in skip} == {k: v for k, v in s2["breaks"].items() if k not in skip}
    fa, fb = frames(ref), frames(out)
    assert len(fa) == len(fb) and len(fa[-1].points) == len(fa[0].points) + 2
    for a, b in zip(fa, fb):
        assert np.array_equal(a.vertex_id, b.vertex_id)
        assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)
    if ranks == 2:  # the cut segment and the one beyond its end at x = 0.5 are on different ranks
        held = segment_ranks(fb[0])
        print("ranks of the segments at x = 0.475 and 0.525:", held[0.475], held[0.525])
        assert len(held[0.475]) == len(held[0.525]) == 1 and held[0.475] != held[0.525]


def segment_ranks(frame):
    """{a segment's rest midpoint x (rounded to 1e-3): the ranks holding it} from the frame's .vtu pieces."""
    held = {}
    for piece in piece_files(frame.path):
        if is_empty_piece(piece):
            continue
        m = meshio.read(piece)
        rest = m.points - m.point_data["displacement"]
        for block, rank in zip(m.cells, m.cell_data["rank"]):
            if block.type == "line":
                for cell, r in zip(block.data, np.ravel(rank)):
                    held.setdefault(round(float(rest[cell, 0].mean()), 3), set()).add(int(r))
    return held


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_kill_after_the_cut_is_bitwise(tmp_path, ranks):
    # the cut at the start of frame 5's step: the checkpoint at 6 holds it, frames 7-10 come after the restart
    assert_restart_after_kill_is_bitwise(tmp_path, LINE, ranks, frames=10, every=6, kill_after=8)


def test_corrected_h0_follows_the_cut(tmp_path):
    found, s = corrected_vs_fresh(tmp_path, {**CUT_ROPE, "solver": {"type": "lbfgs"}})
    assert s["segments_snapped"] == 2 and len(found) == s["h0_corrections"] == 1 and s["refactorizations"] == 0
    assert max(found) <= 1e-12  # measured 1.1e-13 (the bound: 1e-10)


# A blade in the plane z = 0.05 sweeping along x through the whole scene: it separates the cube's
# faces (cut batches) and snaps the second rope's segment across z = 0.05 (a break batch); a restart
# replays them in the run's order (docs/topology.md#h0-across-a-cut), with L-BFGS (its H0 corrected
# at 1 rank) as with Newton.
THROUGH_ALL = {**CUT_ROPE, "cuts": [{"center": [-0.2, 0.0, 0.05], "normal": [0, 0, 1], "axis": [1, 0, 0], "size": [1.0, 0.6],
                                     "frame": "rest", "motion": {"translate": {"velocity": [6, 0, 0]}, "start": 0.0, "end": 0.5}}]}


@pytest.mark.parametrize("solver", ["newton", "lbfgs"])
@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_blade_through_tets_and_a_strand_is_bitwise(tmp_path, ranks, solver):
    deck = {**THROUGH_ALL, "solver": TIGHT if solver == "newton" else {"type": "lbfgs"}}
    # the rope's segment snaps at the start of frame 7's step, the cube's faces at frames 9's and 10's
    # (1 rank, Newton): the checkpoint at 10 holds all three batches, a break before two cuts
    ref, _ = assert_restart_after_kill_is_bitwise(tmp_path, deck, ranks, frames=16, every=10, kill_after=13)
    s = read_summary(ref)
    assert s["cuts"]["faces_separated"] > 0 and s["breaks"]["segments_snapped"] == 1
