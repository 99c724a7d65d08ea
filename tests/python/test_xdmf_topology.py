"""output.format xdmf with topology changes (io/xdmf_writer.hpp, docs/outputs.md#changing-topology-in-xdmf):
a bar sliced by a blade (test_cuts.py's), a rope that snaps (test_tearing.py's), a cloth that
tears (test_cloth_tear.py's), small and short; and against VTK also a notched plate that cracks,
several batches per step (test_fracture_resolve.py's), and a spinning body released and then cut
(test_cuts.py's: a new mesh without a new topology, then new topologies); and a bar sawn by a blade
that removes the tets it crosses (test_tet_removal.py's SAWN, cuts[].remove: the element rows
change), also as two bodies with the deck's element fields.

- The .h5 holds one mesh block per topology: /mesh, then /mesh/K after the Kth batch that added
  vertices or removed tets; each frame's grid names the block current at that frame, and frames without a change
  name the same block. The blocks and the index agree (read with h5py and the XML alone).
- Every frame equals the same deck's VTK frame: the same vertex ids, positions to round-off
  (1e-12 of the rest diagonal), the same cells as tuples of vertex ids; for the sawn bodies also
  each cell's J, body and element fields (1e-12 relative), the fields sized to the frame's block.
- 1 against 2 ranks (and 4 ranks, oversubscribed, for the cut): the same blocks exactly, the same
  cells, positions per vertex id to 1e-8 of the rest diagonal in every frame.
- A run killed (SIGKILL) after changes and restarted from its latest checkpoint writes the same
  index and the same .h5 datasets bit for bit (later blocks and frames go and are written again),
  also when the checkpoint falls between output frames after a change (output.every 2).
- ParaView (pvbatch, bench/xdmf_paraview.py; skipped where it is not installed): its three XDMF
  readers read every frame with its own block's points and cells, the positions exactly, and the
  pieces apart (its Connectivity filter's regions).
"""
import copy
import json
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from conftest import run_deck, run_hyperqn, write_deck
from hyperqn_tools.output import frame_list, read_checkpoint, read_frames, rest_diagonal
from test_checkpoint_faults import killed
import test_cloth_tear
import test_cuts
import test_element_fields
import test_fracture_resolve
import test_tearing
import test_tet_removal


def scene(name, tmp_path=None):
    if name == "fracture":
        d = test_fracture_resolve.plate(tmp_path, 10, frames=24)
    elif name == "spinning":
        d = copy.deepcopy(test_cuts.SPINNING)
        d["time"]["frames"] = 14  # released at frame 5, cut from frame 6 on
    elif name == "sawn":  # tets removed at frames 4, 5, 6 and 7 (a vertex added at 6, orphans dropped at 7)
        d = copy.deepcopy(test_tet_removal.SAWN)
        d["time"]["frames"] = 10
    elif name == "cut":
        d = copy.deepcopy(test_cuts.BAR)
        d["time"]["frames"] = 10  # batches at frames 4, 5, 6 and 7
    elif name == "rope":
        d = copy.deepcopy(test_tearing.ROPE)
        d["time"]["frames"] = 34  # snaps at frames 29 and 31
    else:
        d = copy.deepcopy(test_cloth_tear.CLOTH)
        d["time"]["frames"] = 36  # tears from frame 21 on
    d["name"] = "run"
    return d


def run(tmp_path, name, fmt="xdmf", ranks=None, tag="", every=1):
    d = scene(name, tmp_path)
    d["output"] = {"format": fmt, "every": every}
    out, summary = run_deck(tmp_path, f"{name}_{fmt}_{ranks}{tag}", d, ranks=ranks)
    return out


def topology_rows(out):
    """Frame numbers at which vertices were added or tets removed (topology.csv)."""
    rows = np.atleast_1d(np.genfromtxt(out / "topology.csv", delimiter=",", names=True))
    return [int(r["frame"]) for r in rows if r["vertices_added"] > 0 or r["tets_removed"] > 0]


def grids(out):
    """Per grid of run.xdmf: (frame number, mesh block path, number of points), with every
    DataItem's Dimensions checked against its dataset in run.h5 (h5py and the XML alone)."""
    listed = []
    root = ET.parse(out / "run.xdmf").getroot()
    with h5py.File(out / "run.h5", "r") as f:
        for grid in root.find("Domain").find("Grid").findall("Grid"):
            for item in grid.iter("DataItem"):
                name, path = item.text.strip().split(":")
                assert name == "run.h5"
                dims = tuple(int(d) for d in item.get("Dimensions").split())
                assert f[path].shape == dims, (grid.get("Name"), path)
            topology = grid.find("Topology").find("DataItem").text.strip().split(":")[1]
            block = topology[: -len("/topology")]
            points = int(grid.find("Geometry").find("DataItem").get("Dimensions").split()[0])
            ids = [a for a in grid.findall("Attribute") if a.get("Name") == "vertex_id"][0]
            assert ids.find("DataItem").text.strip().endswith(block + "/vertex_id")
            listed.append((int(grid.get("Name").split("_")[1]), block, points))
    return listed


def blocks(out):
    """{block path: (topology, vertex_id, rest)} of run.h5."""
    with h5py.File(out / "run.h5", "r") as f:
        found = {"/mesh": f["mesh"]}
        found.update({f"/mesh/{k}": f["mesh"][k] for k in f["mesh"] if k.isdigit()})
        return {b: tuple(g[n][()] for n in ("topology", "vertex_id", "rest")) for b, g in found.items()}


def cell_tuples(frame):
    """The frame's cells as tuples of vertex ids, sorted (independent of the file's order)."""
    return {kind: sorted(map(tuple, frame.vertex_id[rows].tolist())) for kind, rows in frame.cells.items()}


@pytest.mark.parametrize("name", ["cut", "rope", "cloth", "fracture", "spinning", "sawn"])
def test_xdmf_follows_the_topology_and_holds_the_vtk_frames(tmp_path, name):
    out = run(tmp_path, name)
    changes = topology_rows(out)
    assert changes, "the scene changed its topology"
    # one block per topology: the first mesh, then one per frame with new vertices or removed tets
    found = blocks(out)
    assert set(found) == {"/mesh"} | {f"/mesh/{k}" for k in range(1, len(changes) + 1)}
    listed = grids(out)
    assert [n for n, _, _ in listed] == list(range(scene(name, tmp_path)["time"]["frames"] + 1))
    for frame, block, points in listed:
        k = sum(1 for c in changes if c <= frame)  # the batches the frame shows
        assert block == ("/mesh" if k == 0 else f"/mesh/{k}")
        assert points == len(found[block][1])
    for k in range(1, len(changes) + 1):  # each block keeps the ids of the one before, and adds;
        # a removal drops tets (and the points no tet uses any more)
        before, after = found["/mesh" if k == 1 else f"/mesh/{k - 1}"], found[f"/mesh/{k}"]
        if name == "sawn":
            added = set(after[1].tolist()) - set(before[1].tolist())  # copies: ids after the input's
            assert len(after[0]) < len(before[0]) and all(v > found["/mesh"][1].max() for v in added)
        else:
            assert len(after[1]) > len(before[1]) and set(before[1]) <= set(after[1])
        after = after[1]
        assert np.all(np.diff(after) > 0)  # points in vertex id order
    # the same deck's VTK frames
    vtu = read_frames(run(tmp_path, name, "vtu"))
    xdmf = read_frames(out)
    assert [n for n, _ in xdmf] == [n for n, _ in vtu]
    diagonal = rest_diagonal(vtu[0][1])
    for (n, a), (_, b) in zip(xdmf, vtu):
        assert np.array_equal(a.vertex_id, b.vertex_id), n
        assert np.abs(a.points - b.points).max() <= 1e-12 * diagonal, n
        assert np.abs(a.velocity - b.velocity).max() <= 1e-12 * max(1.0, np.abs(b.velocity).max()), n
        assert cell_tuples(a) == cell_tuples(b), n
    if name == "sawn":
        assert len(xdmf[-1][1].cells["tetra"]) < len(xdmf[0][1].cells["tetra"])
    else:
        assert len(xdmf[-1][1].vertex_id) > len(xdmf[0][1].vertex_id)


def sawn_bodies():
    """The sawn bar as two bodies side by side (the second 0.75 m along z), both clamped and sawn,
    with two of the deck's element fields."""
    d = scene("sawn")
    mesh, material = d.pop("mesh"), d.pop("material")
    d["bodies"] = [{"name": "near", "mesh": mesh, "material": material},
                   {"name": "far", "mesh": dict(mesh, transform={"translate": [0, 0, 0.75]}), "material": material}]
    d["fixed"][0]["box"]["max"][2] = 1.3
    d["cuts"][0]["size"] = [0.6, 3.0]
    return d


def test_sawn_bodies_carry_each_blocks_body_and_fields(tmp_path):
    d = sawn_bodies()
    outs = {}
    for fmt in ("xdmf", "vtu"):
        d["output"] = {"format": fmt, "every": 1, "fields": ["cauchy_stress", "von_mises"]}
        outs[fmt], _ = run_deck(tmp_path, f"bodies_{fmt}", d)
    out = outs["xdmf"]
    changes = topology_rows(out)
    found = blocks(out)
    assert len(changes) >= 2 and set(found) == {"/mesh"} | {f"/mesh/{k}" for k in range(1, len(changes) + 1)}
    root = ET.parse(out / "run.xdmf").getroot()
    with h5py.File(out / "run.h5", "r") as f:
        for grid in root.find("Domain").find("Grid").findall("Grid"):
            frame = int(grid.get("Name").split("_")[1])
            topology = grid.find("Topology").find("DataItem").text.strip().split(":")[1]
            block = topology[: -len("/topology")]
            tets = len(f[topology])
            assert int(grid.find("Topology").get("NumberOfElements")) == tets
            body = [a for a in grid.findall("Attribute") if a.get("Name") == "body"][0]
            path = body.find("DataItem").text.strip().split(":")[1]
            assert path == block + "/body"  # every block after a removal has its own
            assert f[path].shape == (tets,)
            for field, c in (("J", 1), ("cauchy_stress", 6), ("von_mises", 1)):
                assert f[f"/frames/{frame:05d}/{field}"].shape == ((tets, c) if c > 1 else (tets,)), (frame, field)
    grids(out)  # every DataItem's Dimensions are its dataset's
    x, v = read_frames(out), read_frames(outs["vtu"])
    for (n, a), (_, b) in zip(x, v):
        key = lambda f: {tuple(sorted(f.vertex_id[t].tolist())): i for i, t in enumerate(f.cells["tetra"])}
        ka, kb = key(a), key(b)
        assert ka.keys() == kb.keys(), n
        order_a, order_b = [ka[k] for k in sorted(ka)], [kb[k] for k in sorted(ka)]
        assert np.array_equal(a.body[order_a], b.body[order_b]), n
        assert set(a.body.tolist()) == {0, 1}, n
        assert np.abs(a.J[order_a] - b.J[order_b]).max() <= 1e-12, n
    test_element_fields.assert_same(test_element_fields.frames(out), test_element_fields.frames(outs["vtu"]), 1e-12,
                                    ["cauchy_stress", "von_mises"])


@pytest.mark.parametrize("name,ranks", [("cut", 2), ("cut", 4), ("rope", 2), ("cloth", 2), ("fracture", 2), ("sawn", 2),
                                        ("sawn", 4)])
def test_ranks_write_the_same_blocks_and_frames(tmp_path, name, ranks):
    one, many = run(tmp_path, name), run(tmp_path, name, ranks=ranks)
    a, b = blocks(one), blocks(many)
    assert sorted(a) == sorted(b) and len(a) > 1
    for block in a:
        for x, y in zip(a[block], b[block]):  # a global order that does not depend on the rank count
            assert np.array_equal(x, y), block
    assert grids(one) == grids(many)
    fa, fb = read_frames(one), read_frames(many)
    diagonal = rest_diagonal(fa[0][1])
    assert [n for n, _ in fa] == [n for n, _ in fb]
    for (n, x), (_, y) in zip(fa, fb):
        assert np.array_equal(x.vertex_id, y.vertex_id), n
        assert np.abs(x.points - y.points).max() <= 1e-8 * diagonal, n
        assert cell_tuples(x) == cell_tuples(y), n


def h5_contents(path):
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


# (scene, ranks, output.every, checkpoint.every, kill after): the kill comes after changes that
# follow the checkpoint, so the restart removes mesh blocks and writes them again. With output
# every 2 the cut's checkpoint at 5 falls after a change (frame 5) that no frame has shown yet; the
# sawn bar's then lists its blocks' counts of tets (its mesh has fewer than the last block).
RESTARTS = [("cut", None, 1, 5, 9), ("cut", 2, 2, 5, 9), ("rope", None, 1, 30, 33), ("cloth", None, 1, 30, 33),
            ("fracture", None, 1, 15, 19), ("sawn", None, 1, 5, 9), ("sawn", 2, 2, 5, 9)]


@pytest.mark.parametrize("name,ranks,every,checkpoint,kill_after", RESTARTS)
def test_restart_after_a_kill_after_changes_writes_the_same_series(tmp_path, name, ranks, every, checkpoint, kill_after):
    d = scene(name, tmp_path)
    d["output"] = {"format": "xdmf", "every": every}
    d["checkpoint"] = {"every": checkpoint}
    path = write_deck(tmp_path / "deck.yaml", d)
    ref, out = tmp_path / "ref", tmp_path / "out"
    run_hyperqn([path, "-o", ref], ranks=ranks)
    killed(path, out, kill_after, ranks)
    blocks_killed = sorted(blocks(out))
    run_hyperqn([path, "-o", out, "--restart", "latest"], ranks=ranks)
    assert (ref / "run.xdmf").read_bytes() == (out / "run.xdmf").read_bytes()
    a, b = h5_contents(ref / "run.h5"), h5_contents(out / "run.h5")
    assert sorted(a) == sorted(b)
    for name_ in a:
        assert np.array_equal(a[name_], b[name_]), name_
    # the checkpoint lists fewer blocks than the killed run had written: the restart removed some
    saved = read_checkpoint(out / "checkpoints" / f"checkpoint_{checkpoint}.h5")["writer_xdmf"]
    listed = [line for line in str(saved).splitlines() if line.startswith("mesh ")]
    assert 1 < len(listed) < len(blocks_killed) <= len(blocks(ref))
    if name == "sawn":  # the blocks' tets, not the checkpoint mesh's, follow their points
        assert all(len(line.split()) == 6 for line in listed) == (every == 2), listed
    assert [n for n, _, _ in frame_list(out)] == list(range(0, d["time"]["frames"] + 1, every))


@pytest.mark.skipif(shutil.which("pvbatch") is None, reason="ParaView (pvbatch) is not installed")
@pytest.mark.parametrize("name,pieces", [("cut", 2), ("rope", 3), ("sawn", 2)])
def test_paraview_reads_each_frame_with_its_own_mesh(tmp_path, name, pieces):
    out = run(tmp_path, name)
    script = os.path.join(os.path.dirname(__file__), "..", "..", "bench", "xdmf_paraview.py")
    subprocess.run(["pvbatch", script, str(out / "run.xdmf"), "--json", str(tmp_path / "pv.json")], check=True,
                   capture_output=True, timeout=300)
    with open(tmp_path / "pv.json") as f:
        found = json.load(f)
    listed = grids(out)
    if name == "rope":  # the rope's 48 tets and 20 segments
        cells = [68] * len(listed)
    else:  # each frame's block's tets (fewer after removals)
        cells = [len(blocks(out)[block][0]) for _, block, _ in listed]
    assert set(found) == {"XDMFReader", "Xdmf3ReaderS", "Xdmf3ReaderT"}
    for reader, r in found.items():
        assert "error" not in r, (reader, r)
        assert [s[0] for s in r["steps"]] == [points for _, _, points in listed], reader
        assert [s[1] for s in r["steps"]] == cells, reader
        assert r["max_difference"] == 0.0, reader
        assert r["steps"][0][3] == 1 and r["steps"][-1][3] == pieces, reader
