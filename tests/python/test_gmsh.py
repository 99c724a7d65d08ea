"""Gmsh meshes: MSH 2.2 and 4.1 ASCII (Gmsh's own, with $Entities, and meshio's, without) give the
same scene; every malformed file ends with exit 1, a message naming the file, line and section,
and nothing written."""
import numpy as np
import pytest

from conftest import run_hyperqn, write_deck
from hyperqn_tools.output import final_frame, read_summary
from test_bad_input import assert_clean_failure

MATERIAL = {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000}
DECK = {
    "material": MATERIAL,
    "fixed": [{"box": {"min": [-0.1, -0.1, -0.1], "max": [0.1, 1.1, 1.1]}}],
    "regions": [{"tags": [2], "material": dict(MATERIAL, youngs_modulus=1.0e7)}],
    "time": {"frames": 3},
}

# Two tets tagged 1 and 2 (physical groups), with a point and a triangle that are skipped.
MSH22 = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
3 1 "soft"
3 2 "hard"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
5 1 1 1
$EndNodes
$Elements
4
1 15 2 0 1 1
2 2 2 0 1 1 2 3
3 4 2 1 1 1 2 3 4
4 4 2 2 2 2 3 4 5
$EndElements
"""

# The same as Gmsh writes 4.1: tags come from the volumes' physical groups, via $Entities.
MSH41 = """$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
3 1 "soft"
3 2 "hard"
$EndPhysicalNames
$Entities
0 0 1 2
1 0 0 0 1 1 1 0 0
1 0 0 0 1 1 1 1 1 1 1
2 0 0 0 1 1 1 1 2 1 1
$EndEntities
$Nodes
2 5 1 5
3 1 0 4
1
2
3
4
0 0 0
1 0 0
0 1 0
0 0 1
3 2 0 1
5
1 1 1
$EndNodes
$Elements
3 3 1 3
2 1 2 1
1 1 2 3
3 1 4 1
2 1 2 3 4
3 2 4 1
3 2 3 4 5
$EndElements
"""


def run(tmp_path, name, text, deck=DECK, ranks=None, check=True):
    (tmp_path / f"{name}.msh").write_text(text)
    out = tmp_path / f"out_{name}"
    proc = run_hyperqn([write_deck(tmp_path / f"{name}.yaml", dict(deck, mesh={"file": f"{name}.msh"})), "-o", out],
                       ranks=ranks, check=check, timeout=60)
    return proc, out


@pytest.mark.parametrize("ranks", [None, 2])
def test_gmsh_41_with_entities_is_the_22_scene(tmp_path, ranks):
    frames = []
    for name, text in [("v22", MSH22), ("v41", MSH41)]:
        _, out = run(tmp_path, name, text, ranks=ranks)
        assert read_summary(out)["status"] == "ok"
        frames.append(final_frame(out))
    a, b = frames
    assert a.num_cells == b.num_cells == 2
    assert np.array_equal(a.vertex_id, b.vertex_id) and np.array_equal(a.points, b.points)


def test_meshio_41_without_entities_is_the_22_scene(tmp_path):
    import meshio
    n = 3  # a cube of 5-tet cells is enough: the test is about reading, not solving
    grid = np.stack(np.meshgrid(*[np.linspace(0, 1, n + 1)] * 3, indexing="ij"), -1).reshape(-1, 3)
    i, j, k = [a.ravel() for a in np.meshgrid(*[np.arange(n)] * 3, indexing="ij")]
    v = lambda a, b, c: ((i + a) * (n + 1) + j + b) * (n + 1) + k + c
    tets = np.stack([v(0, 0, 0), v(1, 0, 0), v(0, 1, 0), v(0, 0, 1)], 1)
    mesh = meshio.Mesh(grid, [("tetra", tets)])
    meshio.write(tmp_path / "m41.msh", mesh, file_format="gmsh", binary=False)
    meshio.write(tmp_path / "m22.msh", mesh, file_format="gmsh22", binary=False)
    assert "$Entities" not in (tmp_path / "m41.msh").read_text()
    deck = dict(DECK, regions=[])
    frames = []
    for name in ["m41", "m22"]:
        out = tmp_path / f"out_{name}"
        run_hyperqn([write_deck(tmp_path / f"{name}.yaml", dict(deck, mesh={"file": f"{name}.msh"})), "-o", out],
                    ranks=None, timeout=60)
        frames.append(final_frame(out))
    a, b = frames
    assert a.num_cells == b.num_cells == len(tets)
    assert np.array_equal(a.vertex_id, b.vertex_id) and np.array_equal(a.points, b.points)


def changed(text, old, new):
    assert old in text
    return text.replace(old, new, 1)


BAD = {
    # name: (file text, section, line, a fragment of the message)
    "empty": ("", "$MeshFormat", 1, "empty"),
    "version1": ("$NOD\n1\n1 0 0 0\n$ENDNOD\n", "$MeshFormat", 1, "version 1"),
    "version3": (changed(MSH22, "2.2 0 8", "3 0 8"), "$MeshFormat", 2, "version 3"),
    "version40": (changed(MSH22, "2.2 0 8", "4 0 8"), "$MeshFormat", 2, "version 4"),
    "version99": (changed(MSH22, "2.2 0 8", "99 0 8"), "$MeshFormat", 2, "version 99"),
    "version_text": (changed(MSH22, "2.2 0 8", "two 0 8"), "$MeshFormat", 2, "'two'"),
    "binary": (changed(MSH22, "2.2 0 8", "2.2 1 8"), "$MeshFormat", 2, "binary Gmsh files are not supported"),
    "truncated": (MSH22[: MSH22.index("3 0 1 0")], "$Nodes", 12, "file ends inside the section"),
    "nodes_count_large": (changed(MSH22, "$Nodes\n5\n", "$Nodes\n6\n"), "$Nodes", 16, "'$EndNodes'"),
    "nodes_count_small": (changed(MSH22, "$Nodes\n5\n", "$Nodes\n4\n"), "$Nodes", 15, "expected $EndNodes"),
    "nodes_count_text": (changed(MSH22, "$Nodes\n5\n", "$Nodes\nfive\n"), "$Nodes", 10, "'five'"),
    "coordinate_text": (changed(MSH22, "3 0 1 0", "3 0 one 0"), "$Nodes", 13, "'one'"),
    "coordinate_nan": (changed(MSH22, "3 0 1 0", "3 0 nan 0"), "$Nodes", 13, "not finite"),
    "coordinate_hex": (changed(MSH22, "3 0 1 0", "3 0 0x1 0"), "$Nodes", 13, "'0x1' (hexadecimal"),
    "coordinate_inf": (changed(MSH22, "3 0 1 0", "3 0 1 -Infinity"), "$Nodes", 13, "'-Infinity' (not finite"),
    "coordinate_subnormal": (changed(MSH22, "3 0 1 0", "3 0 1 1e-320"), "$Nodes", 13, "'1e-320' must be 0 or at least 1e-100"),
    "coordinate_huge": (changed(MSH22, "3 0 1 0", "3 0 1e200 0"), "$Nodes", 13, "'1e200' must be at most 1e100"),
    "duplicate_node": (changed(MSH22, "5 1 1 1", "4 1 1 1"), "$Nodes", 15, "appears twice"),
    "missing_end_nodes": (changed(MSH22, "$EndNodes\n", ""), "$Nodes", 16, "expected $EndNodes"),
    "missing_end_elements": (changed(MSH22, "$EndElements\n", ""), "$Elements", 22, "no $EndElements"),
    "missing_end_names": (changed(MSH22, "$EndPhysicalNames\n", ""), "$PhysicalNames", 8,
                          "expected $EndPhysicalNames after the 2 physical names it declares, found '$Nodes'"),
    # $PhysicalNames is read as declared (before: skipped to its end)
    "names_count_large": (changed(MSH22, "$PhysicalNames\n2\n", "$PhysicalNames\n5\n"), "$PhysicalNames", 8,
                          "ends at '$EndPhysicalNames' where physical name 3 of 5"),
    "name_unterminated": (changed(MSH22, '3 2 "hard"', '3 2 "hard'), "$PhysicalNames", 7, "double quote is not closed"),
    # a flat tet is the file's $Elements' (before: 'Tetrahedra', Medit's section)
    "flat_tet": (changed(MSH22, "4 0 0 1\n", "4 1 1 0\n"), "$Elements", 21, "tet 1 (1-based, as in the input) is degenerate"),
    "elements_count_large": (changed(MSH22, "$Elements\n4\n", "$Elements\n5\n"), "$Elements", 23, "'$EndElements'"),
    "unknown_type": (changed(MSH22, "2 2 2 0 1 1 2 3", "2 99 2 0 1 1 2 3"), "$Elements", 20, "unknown element type 99"),
    "hexahedron": (changed(MSH22, "3 4 2 1 1 1 2 3 4", "3 5 2 1 1 1 2 3 4 5 1 2 3"), "$Elements", 21, "hexahedron"),
    "second_order_tet": (changed(MSH22, "3 4 2 1 1 1 2 3 4", "3 11 2 1 1 1 2 3 4 5 1 2 3 4 5"), "$Elements", 21,
                         "first-order"),
    "bad_node_reference": (changed(MSH22, "2 2 3 4 5", "2 2 3 4 9"), "$Elements", 22, "node 9 is not in $Nodes"),
    "negative_tag_count": (changed(MSH22, "1 15 2 0 1 1", "1 15 -2 0 1 1"), "$Elements", 19, "number of tags"),
    "no_tets": (changed(MSH22, "4\n1 15", "2\n1 15").replace("3 4 2 1 1 1 2 3 4\n4 4 2 2 2 2 3 4 5\n", ""),
                "$Elements", 17, "no tetrahedra"),
    "stray_text": (changed(MSH22, "$Nodes\n", "junk\n$Nodes\n"), "", 9, "'junk'"),
    "v41_truncated": (MSH41[: MSH41.index("0 1 0")], "$Nodes", 23, "file ends inside the section"),
    "v41_node_blocks_short": (changed(MSH41, "2 5 1 5", "2 6 1 6"), "$Nodes", 15, "blocks hold 5"),
    "v41_node_block_too_big": (changed(MSH41, "3 1 0 4", "3 1 0 9"), "$Nodes", 17, "holds 9 nodes"),
    "v41_parametric_flag": (changed(MSH41, "3 1 0 4", "3 1 7 4"), "$Nodes", 17, "parametric"),
    "v41_volume_not_in_entities": (changed(MSH41, "3 2 4 1", "3 7 4 1"), "$Elements", 36, "volume 7"),
    "v41_type_on_wrong_dimension": (changed(MSH41, "3 1 4 1", "2 1 4 1"), "$Elements", 34, "3-D"),
    "v41_element_block_too_big": (changed(MSH41, "3 2 4 1", "3 2 4 5"), "$Elements", 36, "holds 5 elements"),
    "v41_missing_end_entities": (changed(MSH41, "$EndEntities\n", ""), "$Entities", 14, "expected $EndEntities"),
    "v41_entity_count_text": (changed(MSH41, "0 0 1 2", "0 0 x 2"), "$Entities", 10, "'x'"),
    "v41_partitioned": (changed(MSH41, "$Entities", "$PartitionedEntities\n$EndPartitionedEntities\n$Entities"),
                        "$PartitionedEntities", 9, "partitioned"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_malformed_gmsh_file(tmp_path, case):
    text, section, line, fragment = BAD[case]
    proc, out = run(tmp_path, case, text, check=False)
    assert proc.returncode == 1, proc.stdout
    key = f"'{section}': " if section else ""
    assert_clean_failure(proc, out, [f"{case}.msh:{line}: {key}", fragment])


def test_malformed_gmsh_file_at_2_ranks(tmp_path):
    proc, out = run(tmp_path, "bad", changed(MSH22, "2 2 3 4 5", "2 2 3 4 9"), ranks=2, check=False)
    assert proc.returncode == 1, proc.stdout
    assert_clean_failure(proc, out, ["bad.msh:22: '$Elements': ", "node 9"])
