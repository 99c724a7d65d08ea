"""A run from a partition file is the run from its mesh file (docs/performance.md#partition-files).

A hanging bar from a shared Medit mesh (moved by mesh.transform, which the file holds applied) is
written by `hyperqn partition` for 2 parts and run from the file at 1, 2, 3 and 4 ranks: at 2 ranks
(the file's parts, each rank reading its own piece) the final positions are bitwise those of the
run from the mesh file at 2 ranks; at 1 rank (the parts merged) and at 3 and 4 (a part cut again
by METIS for the ranks that share it) within 1e-8 of the rest bounding-box diagonal, and a second
run at 3 ranks repeats the first bit for bit. A run started from the mesh file continues from the
partition file (at another rank count); a partition file of another mesh is refused.

A scene of bodies (a cloth, a rope and two blocks, each with its own fixed region, attachment or
velocity) is written by `hyperqn partition` for 1 and 2 parts into the file its deck names
(partition:): run from it, it is bitwise the run that joins the bodies on rank 0 at the file's
rank count (1 part at 1 rank, 2 at 2), and within 1e-10 of the diagonal with 2 parts at 1 and 4
ranks; a run of the bodies joined on rank 0 continues from their partition file."""
import copy
import os

import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from test_bodies import CLOTH, ROPE, SOFT, STIFF
from hyperqn_tools.output import final_frame, read_summary, rest_diagonal
from hyperqn_tools.paths import REPO

TOLERANCE = 1e-8  # of the rest bounding-box diagonal
BAR990 = os.path.join(REPO, "..", "shared", "meshes", "bar990.mesh")  # x in [-1.515, 1.515]

DECK = {
    "mesh": {"file": os.path.abspath(BAR990), "transform": {"translate": [1.515, 0, 0]}},
    "material": {"model": "corotated", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 1000},
    "fixed": [{"box": {"min": [-1, -1, -1], "max": [0.02, 1, 1]}}],
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.05, "frames": 3},
    "solver": {"type": "lbfgs", "iterations": 500, "grad_rtol": 1.0e-10},
    "output": {"every": 3},
}


def run(tmp_path, name, deck, ranks):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks, timeout=120)
    assert read_summary(out)["status"] == "ok"
    return final_frame(out)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The partition file (2 parts), the deck naming it, and the run from the mesh file at 2 ranks."""
    tmp = tmp_path_factory.mktemp("partition_runs")
    partition_file = tmp / "bar.h5"
    proc = run_hyperqn(["partition", write_deck(tmp / "mesh.yaml", DECK), "-n", 2, "-o", partition_file], ranks=None)
    assert "2 parts" in proc.stdout
    from_file = copy.deepcopy(DECK)
    from_file["mesh"] = {"file": str(partition_file)}
    return tmp, from_file, run(tmp, "mesh_np2", DECK, 2)


@pytest.mark.skipif(not os.path.exists(BAR990), reason="needs ../shared/meshes/bar990.mesh")
@pytest.mark.parametrize("ranks", [1, 2, 3, 4])
def test_runs_from_the_partition_file(runs, ranks):
    tmp, from_file, reference = runs
    f = run(tmp, f"file_np{ranks}", from_file, ranks)
    assert np.array_equal(f.vertex_id, reference.vertex_id)
    gap = np.abs(f.points - reference.points).max() / rest_diagonal(reference)
    print(f"from the partition file at {ranks} ranks: {gap:.1e} of the diagonal from the mesh file at 2")
    if ranks == 2:
        assert np.array_equal(f.points, reference.points), f"{gap:.2e} of the diagonal: not bitwise"
    else:
        assert gap <= TOLERANCE, f"at {ranks} ranks: {gap:.2e} of the diagonal"
    if ranks == 3:  # a part cut again is cut the same way every time
        again = run(tmp, "file_np3_again", from_file, ranks)
        assert np.array_equal(again.points, f.points)


@pytest.mark.skipif(not os.path.exists(BAR990), reason="needs ../shared/meshes/bar990.mesh")
def test_a_run_from_the_mesh_file_continues_from_the_partition_file(runs, tmp_path):
    """The checkpoint knows the mesh by its hash, not by the deck's mesh section: the first part
    runs from the mesh file at 2 ranks, the second from the partition file at 3 ranks, and ends
    where the run from the mesh file ends; a partition file of another mesh is refused."""
    _, from_file, reference = runs
    out = tmp_path / "continued"
    first = copy.deepcopy(DECK)
    first["time"] = dict(DECK["time"], frames=2)
    first["checkpoint"] = {"every": 1}
    run_hyperqn([write_deck(tmp_path / "first.yaml", first), "-o", out], ranks=2, timeout=120)
    second = copy.deepcopy(from_file)
    second["checkpoint"] = {"every": 1}
    proc = run_hyperqn([write_deck(tmp_path / "second.yaml", second), "-o", out, "--restart", "latest"], ranks=3,
                       timeout=120)
    assert "restart from" in proc.stdout and read_summary(out)["status"] == "ok"
    f = final_frame(out)
    gap = np.abs(f.points - reference.points).max() / rest_diagonal(reference)
    assert gap <= TOLERANCE, f"{gap:.2e} of the diagonal"
    # Another mesh (moved by 1 mm) in a partition file: the restart is refused, naming the mesh.
    moved = copy.deepcopy(DECK)
    moved["mesh"]["transform"] = {"translate": [1.516, 0, 0]}
    other = tmp_path / "moved.h5"
    run_hyperqn(["partition", write_deck(tmp_path / "moved.yaml", moved), "-n", 2, "-o", other], ranks=None)
    refused = copy.deepcopy(second)
    refused["mesh"] = {"file": str(other)}
    refused["time"] = dict(DECK["time"], frames=4)
    proc = run_hyperqn([write_deck(tmp_path / "refused.yaml", refused), "-o", out, "--restart", "latest"], ranks=2,
                       timeout=120, check=False)
    assert proc.returncode == 1 and "the mesh differs" in proc.stdout, proc.stdout[-2000:]


# A scene of bodies (docs/deck-scene.md#bodies-instead-of-mesh-and-material): a cloth and a rope
# hanging from their own fixed boxes, a block flying off with its own velocity and a block held by its own attachment, all solved to
# round-off, so that only the order of sums differs between partitions.
BODIES = {
    "bodies": [CLOTH, ROPE, dict(SOFT, velocity=[0, 0, 0.5]),
               dict(STIFF, attachments=[{"box": {"min": [-1, -1, -1], "max": [2, 2, 2]}, "stiffness": 50.0}])],
    "time": {"dt": 1.0 / 60, "frames": 6},
    "solver": {"type": "newton", "iterations": 50, "budget": "fixed", "grad_rtol": 1e-12, "grad_atol": 0},
    "output": {"every": 6},
}
BODIES_TOLERANCE = 1e-10  # of the rest bounding-box diagonal


@pytest.fixture(scope="module")
def bodies_runs(tmp_path_factory):
    """The runs of the bodies without a partition file at 1 and 2 ranks, and the directory."""
    tmp = tmp_path_factory.mktemp("bodies_partition")
    return tmp, {ranks: run(tmp, f"joined_np{ranks}", BODIES, ranks) for ranks in (1, 2)}


@pytest.mark.parametrize("parts, ranks", [(1, 1), (2, 2), (2, 1), (2, 4)])
def test_bodies_run_from_their_partition_file(bodies_runs, parts, ranks):
    """`hyperqn partition DECK -n N` writes the file the deck names (partition:); a run from it is
    bitwise the run that joins the bodies on rank 0 at the file's rank count, and within 1e-10 of
    the diagonal at another (parts merged at 1 rank, cut again at 4)."""
    tmp, joined = bodies_runs
    deck = write_deck(tmp / f"parts{parts}.yaml", dict(BODIES, partition=f"bodies{parts}.h5"))
    if not (tmp / f"bodies{parts}.h5").exists():
        proc = run_hyperqn(["partition", deck, "-n", parts], ranks=None)
        assert f"{parts} parts" in proc.stdout and "4 bodies" in proc.stdout, proc.stdout
    out = tmp / f"file{parts}_np{ranks}"
    run_hyperqn([deck, "-o", out], ranks=ranks, timeout=120)
    assert read_summary(out)["status"] == "ok"
    f = final_frame(out)
    reference = joined[ranks if ranks == parts else 1]
    assert np.array_equal(f.vertex_id, reference.vertex_id)
    assert np.array_equal(np.bincount(f.body), np.bincount(reference.body))
    gap = np.abs(f.points - reference.points).max() / rest_diagonal(reference)
    print(f"{parts} parts at {ranks} ranks: {gap:.1e} of the diagonal from the bodies joined on rank 0")
    if ranks == parts:
        assert np.array_equal(f.points, reference.points), f"{gap:.2e} of the diagonal: not bitwise"
    else:
        assert gap <= BODIES_TOLERANCE, f"{gap:.2e} of the diagonal"


def test_bodies_joined_on_rank_0_continue_from_their_partition_file(bodies_runs):
    """The checkpoint knows the bodies' mesh by its hash: 3 frames with the bodies joined at 1 rank,
    the other 3 from their 2-part file at 2 ranks, end where the joined run ends."""
    tmp, joined = bodies_runs
    out = tmp / "continued"
    first = dict(BODIES, time=dict(BODIES["time"], frames=3), checkpoint={"every": 1})
    run_hyperqn([write_deck(tmp / "continued_first.yaml", first), "-o", out], ranks=1)
    second = dict(BODIES, checkpoint={"every": 1}, partition="bodies_continued.h5")
    second = write_deck(tmp / "continued_second.yaml", second)
    run_hyperqn(["partition", second, "-n", 2], ranks=None)
    proc = run_hyperqn([second, "-o", out, "--restart", "latest"], ranks=2, timeout=120)
    assert "restart from" in proc.stdout and read_summary(out)["status"] == "ok"
    f, reference = final_frame(out), joined[1]
    gap = np.abs(f.points - reference.points).max() / rest_diagonal(reference)
    print(f"continued from the partition file: {gap:.1e} of the diagonal")
    assert gap <= BODIES_TOLERANCE, f"{gap:.2e} of the diagonal"
