"""Triangle-mesh blades (deck cuts[k].surface, docs/topology.md): a rectangle given as 2 triangles
separates exactly the faces the rectangle blade does (same counts, same VTK bytes); a V-shaped
blade cuts the bar into 3 pieces and a U-shaped one cuts a block out of it, with the mass kept
exactly; 1 vs 2 ranks; a restart after a kill is bitwise; bad surfaces are refused at the deck
line with nothing written."""
import copy
import os

import numpy as np
import pytest

from conftest import run_deck
from hyperqn_tools.energy import frame_lumped_masses as lumped_masses
from hyperqn_tools.output import Frame, final_frame, frame_list, rest_diagonal
from test_bad_input import assert_deck_refused
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise
from test_cuts import BAR, components, piece_labels


def write_obj(path, vertices, triangles):
    with open(path, "w") as f:
        f.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in triangles)


# BAR's rectangle (centre [1.02, 1, 0.25], normal x, axis y, size [0.6, 1]) as 2 triangles wound
# so that their normal is +x: corners at y = 0.7, 1.3 and z = -0.25, 0.75.
RECTANGLE = ([(1.02, 0.7, -0.25), (1.02, 1.3, -0.25), (1.02, 1.3, 0.75), (1.02, 0.7, 0.75)], [(0, 1, 2), (0, 2, 3)])

# A strip bent twice (a U upside down in the x-y plane: down x = 1.02 from y = 0.8 to 0.27, along
# y = 0.27 to x = 1.52, up x = 1.52 to y = 0.8), extruded along z over [0.6, 1.6] (above the bar),
# moving down z through it. Its sides sit between the planes of the mesh's cells (0.25 apart), so
# no dual edge passes near it: it cuts the block inside the U (1.02 < x < 1.52, y > 0.27) out of the
# bar (2 pieces; each of its 3 sides is needed: the block stays joined if one misses). It cuts in the
# rest shape (frame rest): in the world the pieces falling under gravity would meet its arm along
# y = 0.27 again.

def write_medit(path, vertices, triangles):
    with open(path, "w") as f:
        f.write(f"MeshVersionFormatted 1\nDimension 3\nVertices\n{len(vertices)}\n")
        f.writelines(f"{x!r} {y!r} {z!r} 0\n" for x, y, z in vertices)
        f.write(f"Triangles\n{len(triangles)}\n")
        f.writelines(f"{a + 1} {b + 1} {c + 1} 0\n" for a, b, c in triangles)
        f.write("End\n")


def subdivided_rectangle(nu, nw):
    """RECTANGLE cut into nu x nw cells of 2 triangles each (wound as RECTANGLE's), so that the
    blade's triangles are found through its box tree rather than all tested."""
    ys, zs = np.linspace(0.7, 1.3, nu + 1), np.linspace(-0.25, 0.75, nw + 1)
    vertices = [(1.02, float(y), float(z)) for z in zs for y in ys]
    at = lambda i, j: j * (nu + 1) + i
    triangles = []
    for j in range(nw):
        for i in range(nu):
            triangles += [(at(i, j), at(i + 1, j), at(i + 1, j + 1)), (at(i, j), at(i + 1, j + 1), at(i, j + 1))]
    return vertices, triangles


U_XY = [(1.02, 0.8), (1.02, 0.27), (1.52, 0.27), (1.52, 0.8)]
U_BLADE = ([(x, y, z) for x, y in U_XY for z in (0.6, 1.6)],
           [(2 * i, 2 * i + 2, 2 * i + 3) for i in range(3)] + [(2 * i, 2 * i + 3, 2 * i + 1) for i in range(3)])


# A V in the x-y plane (arms from (0.6, 0.8) and (1.4, 0.8) down to (1.0, -0.3), below the bar),
# extruded along z as the U: both arms cross the whole bar, which falls into 3 pieces (the clamped
# end, the wedge between the arms, the free end).
V_XY = [(0.6, 0.8), (1.0, -0.3), (1.4, 0.8)]
V_BLADE = ([(x, y, z) for x, y in V_XY for z in (0.6, 1.6)], [(0, 2, 3), (0, 3, 1), (2, 4, 5), (2, 5, 3)])


def mesh_deck(tmp_path, blade, name="blade.obj", **cut):
    (write_medit if name.endswith(".mesh") else write_obj)(tmp_path / name, *blade)
    deck = copy.deepcopy(BAR)
    deck["cuts"] = [{"surface": name, "motion": copy.deepcopy(BAR["cuts"][0]["motion"]), **cut}]
    return deck


def u_deck(tmp_path, blade=U_BLADE):
    deck = mesh_deck(tmp_path, blade, frame="rest")
    deck["cuts"][0]["motion"]["translate"]["velocity"] = [0, 0, -8]
    return deck


def frame_bytes(out):
    """The bytes of the run's VTK files (.vtu, .pvd), by their path in the output."""
    found = {}
    for root, _, files in os.walk(out):
        for f in files:
            if f.endswith((".vtu", ".pvd", ".vtk", ".pvtu")):
                p = os.path.join(root, f)
                found[os.path.relpath(p, out)] = open(p, "rb").read()
    return found


@pytest.mark.parametrize("remove,cells,name", [(False, (1, 1), "blade.obj"), (True, (1, 1), "blade.obj"),
                                               (False, (13, 11), "blade.obj"), (False, (13, 11), "blade.mesh")])
def test_a_rectangle_as_triangles_separates_the_same_faces(tmp_path, remove, cells, name):
    # (with remove: removes the same tets, docs/removal.md; 13 x 11 cells: 286 triangles, found
    # through the blade's box tree; .mesh: the same surface in Medit's format)
    (tmp_path / "rect").mkdir()
    (tmp_path / "mesh").mkdir()
    deck = copy.deepcopy(BAR)
    deck["cuts"][0]["remove"] = remove
    rect, sr = run_deck(tmp_path / "rect", "bar", deck)  # the same name: the same file names inside
    blade = RECTANGLE if cells == (1, 1) else subdivided_rectangle(*cells)
    mesh, sm = run_deck(tmp_path / "mesh", "bar", mesh_deck(tmp_path / "mesh", blade, name, remove=remove))
    assert sr["cuts"]["tets_removed" if remove else "faces_separated"] >= 8
    assert {k: v for k, v in sr["cuts"].items() if k != "topology_s"} == \
        {k: v for k, v in sm["cuts"].items() if k != "topology_s"}
    a, b = frame_bytes(rect), frame_bytes(mesh)
    assert len(a) >= 16 and a == b


def test_a_bent_blade_cuts_the_bar_into_two_pieces_with_its_mass(tmp_path):
    out, s = run_deck(tmp_path, "u", u_deck(tmp_path))
    first, last = Frame(frame_list(out)[0][2]), final_frame(out)
    assert components(first) == 1 and components(last) == 2
    assert len(last.points) == len(first.points) + s["cuts"]["vertices_added"]
    m0, m1 = lumped_masses(first, 1000).sum(), lumped_masses(last, 1000).sum()
    assert m0 == pytest.approx(1000 * 2.0 * 0.5 * 0.5, rel=1e-12) and m1 == pytest.approx(m0, rel=1e-14)
    # the pieces are the tets on each side of the U, by their rest centroids
    tets = last.cells["tetra"]
    rest = (last.points - last.displacement)[tets].mean(axis=1)
    x, y = rest[:, 0], rest[:, 1]
    block = (x > 1.02) & (x < 1.52) & (y > 0.27)
    label = piece_labels(last)
    assert block.sum() == 2 * 1 * 2 * (len(tets) // (8 * 2 * 2)) > 0  # 2 x 1 x 2 of the 8 x 2 x 2 cells
    assert len(set(label[block])) == 1 and len(set(label[~block])) == 1 and set(label[block]) != set(label[~block])


def test_a_v_blade_cuts_the_bar_into_three_pieces_with_its_mass(tmp_path):
    out, s = run_deck(tmp_path, "v", u_deck(tmp_path, V_BLADE))
    first, last = Frame(frame_list(out)[0][2]), final_frame(out)
    m0, m1 = lumped_masses(first, 1000).sum(), lumped_masses(last, 1000).sum()
    assert m1 == pytest.approx(m0, rel=1e-14)
    tets = last.cells["tetra"]
    x, y = (last.points - last.displacement)[tets].mean(axis=1)[:, :2].T
    arm = 0.4 * (0.8 - y) / 1.1  # each arm's distance from x = 0.6 and 1.4 at height y
    side = np.where(x < 0.6 + arm, 0, np.where(x > 1.4 - arm, 2, 1))
    label = piece_labels(last)
    assert len(set(label)) == 3 and all(len(set(label[side == k])) == 1 for k in range(3))
    assert len({label[side == k][0] for k in range(3)}) == 3


@pytest.mark.parametrize("ranks", [2, 4])
def test_ranks_agree_on_a_u_blade(tmp_path, ranks):
    # (4 ranks oversubscribed on a 2-core machine)
    deck = u_deck(tmp_path)
    one, s1 = run_deck(tmp_path, "one", deck)
    many, s2 = run_deck(tmp_path, "many", deck, ranks=ranks)
    assert s2["ranks"] == ranks
    same = ["faces_separated", "vertices_added"]
    assert {k: s1["cuts"][k] for k in same} == {k: s2["cuts"][k] for k in same}
    a, b = final_frame(one), final_frame(many)
    assert np.array_equal(a.vertex_id, b.vertex_id)
    assert np.abs(a.points - b.points).max() <= 1e-8 * rest_diagonal(a)


@pytest.mark.parametrize("ranks", [None, 2])
def test_restart_after_a_kill_with_a_u_blade_is_bitwise(tmp_path, ranks):
    assert_restart_after_kill_is_bitwise(tmp_path, u_deck(tmp_path), ranks, frames=BAR["time"]["frames"], every=3,
                                         kill_after=10)


def bad_case(tmp_path, case):
    deck = mesh_deck(tmp_path, RECTANGLE)
    deck["time"]["frames"] = 2
    cut = deck["cuts"][0]
    if case == "missing_file":
        cut["surface"] = "nowhere.obj"
        return deck, ["cuts[0].surface", "nowhere.obj"]
    if case == "no_triangles":
        (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
        cut["surface"] = "flat.obj"
        return deck, ["cuts[0].surface", "no triangle"]
    if case == "turning":
        cut["motion"] = {"rotate": {"axis": [0, 0, 1], "rate": 10}}
        return deck, ["cuts[0].motion", "does not turn"]
    if case == "leaving_a_triangle":
        cut["motion"] = {"translate": {"velocity": [1, -1, 0]}}
        return deck, ["cuts[0].motion", "leaves the plane of the surface's triangle 1"]
    if case == "with_a_rectangle_key":
        cut["size"] = [0.6, 1.0]
        return deck, ["cuts[0].size", "not with surface"]
    if case == "neither":
        del cut["surface"]
        return deck, ["cuts", "missing center"]
    raise KeyError(case)


@pytest.mark.parametrize("case", ["missing_file", "no_triangles", "turning", "leaving_a_triangle",
                                  "with_a_rectangle_key", "neither"])
def test_bad_mesh_blade_is_refused(tmp_path, case):
    deck, fragments = bad_case(tmp_path, case)
    assert_deck_refused(tmp_path, case, deck, fragments)
