"""hyperqn partition DECK -n N -o FILE.h5 and decks naming a partition file (docs/performance.md#partition-files).

- The command writes the file (one line: parts, vertices, tets, bytes), at 1 rank and, rank 0
  alone doing the work, at 2; its tables are those io/partition_file.hpp describes.
- Bad arguments (no -n, no -o, N < 1, more parts than elements, an output not ending in .h5, a
  deck whose mesh is itself a partition file): exit 1, a message naming the option or key,
  nothing written.
- A deck naming a partition file with a key that shapes the mesh (transform, strands, edges,
  surface), or a partition file that is missing, truncated, of another format version or not one
  at all: exit 1 at 1 rank (and two of them at 2), a message naming the key or file, no output directory.
- A deck of bodies names its file as partition: (the command writes it without -o): the file
  holds the joined bodies, each element tagged with its body, and their stamp; a moved deck and
  mesh run from it. A file stale for its deck (a body's transform or mesh file changed, a body
  fewer), missing, or of one mesh is refused naming the deck's partition key; a file of bodies as
  mesh.file, a partition: without bodies or not ending in .h5, and a partition file as a body's
  mesh are refused too.
The pieces read back at 1, 2 and 3 ranks are tests/test_partition_file.cpp's."""
import copy
import re

import h5py
import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.output import read_summary

BAR = load_deck("tests/decks/hanging_bar.yaml")


def partition(args, ranks=None):
    return run_hyperqn(["partition", *map(str, args)], ranks=ranks, check=False)


@pytest.fixture(scope="module")
def bar_file(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("partition")
    deck = write_deck(tmp / "bar.yaml", BAR)
    out = tmp / "bar.h5"
    proc = partition([deck, "-n", 2, "-o", out])
    assert proc.returncode == 0, proc.stdout
    return tmp, deck, out, proc.stdout


def test_writes_the_pieces(bar_file):
    tmp, deck, out, stdout = bar_file
    # 2 x 12 x 2 cubes: 3 x 13 x 3 vertices, 6 tets each
    line = re.search(r"hyperqn partition: (\S+): (\d+) parts, (\d+) vertices, (\d+) tets, .* (\d+) bytes", stdout)
    assert line, stdout
    assert line.group(1) == str(out) and line.groups()[1:4] == ("2", "117", "288")
    assert int(line.group(5)) == out.stat().st_size
    with h5py.File(out, "r") as f:
        assert bytes(f["format"][:]).decode() == "hyperqn partition file"
        assert f["format_version"][0, 0] == 1 and f["parts"][0, 0] == 2 and f["global_vertices"][0, 0] == 117
        assert f["tets"].shape == (288, 4) and f["tets"].dtype == np.int32
        assert f["coords"].dtype == np.float64 and f["triangle_edges"].dtype == np.uint8
        offsets = f["tets_offsets"][:, 0]
        assert offsets[0] == 0 and offsets[-1] == 288 and len(offsets) == 3
        numbers = np.sort(f["element_numbers"][:, 0])
        assert np.array_equal(numbers, np.arange(288))  # every tet once
        assert str(deck) in bytes(f["source"][:]).decode()


def test_at_two_ranks_rank_0_writes_the_same_file(bar_file):
    tmp, deck, out, _ = bar_file
    again = tmp / "bar_np2.h5"
    proc = partition([deck, "-n", 2, "-o", again], ranks=2)
    assert proc.returncode == 0, proc.stdout
    assert proc.stdout.count("hyperqn partition:") == 1
    with h5py.File(again, "r") as f, h5py.File(out, "r") as g:  # (the bytes differ by HDF5's timestamps)
        assert sorted(f) == sorted(g)
        for name in f:
            assert np.array_equal(f[name][()], g[name][()]) and f[name].dtype == g[name].dtype, name


def test_bad_arguments(bar_file):
    tmp, deck, out, _ = bar_file
    h5_deck = copy.deepcopy(BAR)
    h5_deck["mesh"] = {"file": str(out)}
    h5_deck = write_deck(tmp / "from_h5.yaml", h5_deck)
    cases = {
        "no_n": ([deck, "-o", tmp / "no_n.h5"], "'-n'"),
        "no_o": ([deck, "-n", 2], "'-o'"),
        "zero": ([deck, "-n", 0, "-o", tmp / "zero.h5"], "'-n'"),
        "not_a_number": ([deck, "-n", "two", "-o", tmp / "not_a_number.h5"], "'-n'"),
        "too_many": ([deck, "-n", 289, "-o", tmp / "too_many.h5"], "288 elements"),
        "not_h5": ([deck, "-n", 2, "-o", tmp / "not_h5.mesh"], "ends in .h5"),
        "from_h5": ([h5_deck, "-n", 2, "-o", tmp / "from_h5.h5"], "'mesh.file'"),
        "no_deck": ([tmp / "none.yaml", "-n", 2, "-o", tmp / "no_deck.h5"], "none.yaml"),
        "two_o": ([deck, "-n", 2, "-o", tmp / "two_o.h5", "-o", tmp / "two_o_again.h5"], "'-o': given twice"),
        "two_n": ([deck, "-n", 2, "-n", 3, "-o", tmp / "two_n.h5"], "'-n': given twice"),
    }
    for name, (args, expected) in cases.items():
        proc = partition(args)
        assert proc.returncode == 1, (name, proc.stdout)
        assert "hyperqn: error:" in proc.stdout and expected in proc.stdout, (name, proc.stdout)
        assert not list(tmp.glob(f"{name}*.h5")) and not list(tmp.glob(f".{name}*")), name


def bad_deck(tmp, name, out, **mesh_keys):
    deck = copy.deepcopy(BAR)
    deck["mesh"] = {"file": str(out), **mesh_keys}
    return write_deck(tmp / f"{name}.yaml", deck)


@pytest.mark.parametrize("ranks", [None, 2])
def test_decks_refused(bar_file, ranks):
    tmp, _, out, _ = bar_file
    truncated = tmp / "truncated.h5"
    truncated.write_bytes(out.read_bytes()[: out.stat().st_size // 2])
    version = tmp / "version.h5"
    version.write_bytes(out.read_bytes())
    with h5py.File(version, "r+") as f:
        f["format_version"][0, 0] = 7
    other = tmp / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.zeros(3)
    cases = {
        "transform": (bad_deck(tmp, "transform", out, transform={"scale": 2.0}), ["transform.yaml", "'mesh.transform'", "hyperqn partition"]),
        "strands": (bad_deck(tmp, "strands", out, strands=[{"from": [0, 0, 0], "to": [0, 1, 0], "segments": 2}]),
                    ["strands.yaml", "'mesh.strands'"]),
        "edges": (bad_deck(tmp, "edges", out, edges="strands"), ["edges.yaml", "'mesh.edges'"]),
        "surface": (bad_deck(tmp, "surface", out, surface="cloth"), ["surface.yaml", "'mesh.surface'"]),
        "missing": (bad_deck(tmp, "missing", tmp / "missing.h5"), ["missing.yaml", "missing.h5", "not found"]),
        "truncated": (bad_deck(tmp, "truncated", truncated), [str(truncated), "cannot read"]),
        "version": (bad_deck(tmp, "version", version), [str(version), "format version 7"]),
        "other": (bad_deck(tmp, "other", other), [str(other), "not a partition file"]),
    }
    if ranks == 2:  # every rank reads the deck alike: two cases suffice
        cases = {name: cases[name] for name in ("transform", "version")}
    for name, (deck, expected) in cases.items():
        outdir = tmp / f"out_{name}_np{ranks}"
        proc = run_hyperqn([deck, "-o", outdir], ranks=ranks, check=False)
        assert proc.returncode == 1, (name, proc.stdout)
        for fragment in expected:
            assert fragment in proc.stdout, (name, fragment, proc.stdout)
        assert proc.stdout.count("hyperqn: error:") == 1, (name, proc.stdout)
        assert not outdir.exists(), name


@pytest.mark.parametrize("ranks", [None, 2])
def test_damaged_parts_name_the_deck_key(bar_file, ranks):
    """A part that HDF5 reads but whose values do not match its checksum, or an array of another type,
    is found as the ranks read their parts: named with the deck's mesh.file and line too, as the
    header's errors (before: the file alone, 'FILE: part 1: its arrays do not match their checksum'
    and 'cannot read FILE: coords does not hold float64 values')."""
    tmp, _, out, _ = bar_file
    changed, retyped = tmp / "changed.h5", tmp / "retyped.h5"
    changed.write_bytes(out.read_bytes())
    with h5py.File(changed, "r+") as f:  # a vertex of part 1 (HDF5's own checksum rewritten)
        f["coords"][-1, 0] = f["coords"][-1, 0] + 0.5
    retyped.write_bytes(out.read_bytes())
    with h5py.File(retyped, "r+") as f:
        coords = f["coords"][()]
        del f["coords"]
        f["coords"] = coords.astype(np.int64)
    cases = {"changed": (changed, "part 1: its arrays do not match their checksum"),
             "retyped": (retyped, "coords does not hold float64 values")}
    for name, (file, said) in cases.items():
        deck = bad_deck(tmp, f"{name}_np{ranks}", file)
        outdir = tmp / f"out_{name}_np{ranks}"
        proc = run_hyperqn([deck, "-o", outdir], ranks=ranks, check=False)
        assert proc.returncode == 1, (name, proc.stdout)
        assert re.search(rf"{name}_np{ranks}\.yaml:\d+: 'mesh\.file': .*{file.name}.*{said}", proc.stdout), (name, proc.stdout)
        assert proc.stdout.count("hyperqn: error:") == 1, (name, proc.stdout)
        assert not outdir.exists(), name


ONE_TET = """MeshVersionFormatted 1
Dimension 3
Vertices
4
0 0 0 0
1 0 0 0
0 1 0 0
0 0 1 0
Tetrahedra
1
1 2 3 4 0
End
"""
SOLID = {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000}
# A box and a tet read from a Medit file beside the deck, the file named relative to it.
BODIES = {
    "bodies": [{"name": "block", "mesh": {"box": {"size": [0.2] * 3, "cells": [2, 2, 2]}}, "material": SOLID},
               {"name": "tet", "mesh": {"file": "one_tet.mesh", "transform": {"scale": 0.1, "translate": [1, 0, 0]}},
                "material": SOLID}],
    "partition": "bodies.h5",
    "gravity": [0, 0, 0],
    "time": {"dt": 0.01, "frames": 1},
    "output": {"every": 1},
}


@pytest.fixture(scope="module")
def bodies_file(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bodies")
    (tmp / "one_tet.mesh").write_text(ONE_TET)
    deck = write_deck(tmp / "bodies.yaml", BODIES)
    proc = partition([deck, "-n", 2])  # no -o: the deck's partition:
    assert proc.returncode == 0, proc.stdout
    return tmp, deck, proc.stdout


def test_writes_the_bodies(bodies_file):
    tmp, deck, stdout = bodies_file
    out = tmp / "bodies.h5"
    assert f"hyperqn partition: {out}: 2 parts, 2 bodies, 31 vertices, 49 tets" in stdout, stdout
    with h5py.File(out, "r") as f:
        assert f["bodies"][0, 0] == 2 and "bodies_hash" in f
        tags = f["tet_tags"][:, 0][np.argsort(f["element_numbers"][:, 0])]  # in the joined mesh's order
        assert np.array_equal(tags, [0] * 48 + [1])
        source = bytes(f["source"][:]).decode()
        assert "bodies: block (box cells 2 2 2), tet (" in source and "one_tet.mesh" in source
    moved = tmp / "moved"  # the deck, its mesh and its partition file moved together still run
    moved.mkdir()
    for name in ("bodies.yaml", "one_tet.mesh", "bodies.h5"):
        (moved / name).write_bytes((tmp / name).read_bytes())
    run_hyperqn([moved / "bodies.yaml", "-o", moved / "out"], ranks=None)
    assert read_summary(moved / "out")["status"] == "ok"


def refused(tmp, name, deck, expected, ranks=None):
    outdir = tmp / f"out_{name}"
    proc = run_hyperqn([write_deck(tmp / f"{name}.yaml", deck), "-o", outdir], ranks=ranks, check=False)
    assert proc.returncode == 1, (name, proc.stdout)
    assert proc.stdout.count("hyperqn: error:") == 1, (name, proc.stdout)
    for fragment in expected:
        assert fragment in proc.stdout, (name, fragment, proc.stdout)
    assert not outdir.exists(), name


def test_stale_or_mismatched_bodies_files_are_refused(bodies_file, bar_file):
    tmp, _, _ = bodies_file
    _, _, bar_h5, _ = bar_file
    with_bodies = tmp / "bodies.h5"
    stale = "was written from other bodies"
    turned = copy.deepcopy(BODIES)
    turned["bodies"][1]["mesh"]["transform"]["scale"] = 0.2
    refused(tmp, "turned", turned, ["turned.yaml", "'partition'", stale, "hyperqn partition"])
    refused(tmp, "turned_np2", turned, ["'partition'", stale], ranks=2)
    edited = tmp / "edited"  # the same deck beside a changed mesh file, naming the file of the first
    edited.mkdir()
    (edited / "one_tet.mesh").write_text(ONE_TET.replace("0 0 1 0\n", "0 0 2 0\n"))
    refused(edited, "edited", dict(BODIES, partition=str(with_bodies)), ["'partition'", stale])
    fewer = dict(BODIES, bodies=BODIES["bodies"][:1])
    refused(tmp, "fewer", fewer, ["'partition'", "holds 2 bodies and the deck has 1"])
    refused(tmp, "missing", dict(BODIES, partition="none.h5"), ["'partition'", "none.h5", "not found", "hyperqn partition"])
    refused(tmp, "one_mesh", dict(BODIES, partition=str(bar_h5)), ["'partition'", "holds one mesh"])
    (tmp / "garbage.h5").write_bytes(b"not an HDF5 file\n" * 10)  # before: no deck line, no key
    refused(tmp, "garbage", dict(BODIES, partition="garbage.h5"), ["garbage.yaml:", "'partition'", "garbage.h5"])
    refused(tmp, "not_h5", dict(BODIES, partition="bodies.mesh"), ["not_h5.yaml", "'partition'", "ends in .h5"])
    damaged = tmp / "damaged.h5"  # a part's values changed behind HDF5's checksums (before: the file alone)
    damaged.write_bytes(with_bodies.read_bytes())
    with h5py.File(damaged, "r+") as f:
        f["coords"][-1, 0] = f["coords"][-1, 0] + 0.5
    refused(tmp, "damaged", dict(BODIES, partition="damaged.h5"),
            ["damaged.yaml:", "'partition': ", "damaged.h5: part 1: its arrays do not match their checksum"])
    as_mesh = copy.deepcopy(BAR)
    as_mesh["mesh"] = {"file": str(with_bodies)}
    refused(tmp, "as_mesh", as_mesh, ["'mesh.file'", "holds the 2 bodies", "partition:"])
    without_bodies = dict(BAR, partition=str(bar_h5))
    refused(tmp, "without_bodies", without_bodies, ["'partition'", "mesh.file"])
    body_h5 = copy.deepcopy(BODIES)
    body_h5["bodies"][0]["mesh"] = {"file": str(bar_h5)}
    refused(tmp, "body_h5", body_h5, ["'bodies[0].mesh'", "partition:"])


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_partition_file_the_run_would_write_is_refused(tmp_path, bar_file, bodies_file, ranks):
    # OUTDIR/NAME.h5 as the mesh of a run that writes XDMF into OUTDIR under NAME: the run wrote its
    # frames into it (exit 0) and the next run failed "not a partition file"; so did a deck of bodies
    # naming it as partition:. Refused on the first run, before anything is written.
    _, _, bar_h5, _ = bar_file
    out = tmp_path / "out"
    out.mkdir()
    (out / "px.h5").write_bytes(bar_h5.read_bytes())
    deck = copy.deepcopy(BAR)
    deck.update(name="px", mesh={"file": str(out / "px.h5")}, output={"format": "xdmf"})
    deck["time"]["frames"] = 1
    proc = run_hyperqn([write_deck(tmp_path / "px.yaml", deck), "-o", out], ranks=ranks, check=False)
    assert proc.returncode == 1, proc.stdout
    assert "px.yaml:" in proc.stdout and proc.stdout.count("hyperqn: error") == 1, proc.stdout
    assert f"'mesh.file': {out / 'px.h5'} is a file that the run writes in its output directory" in proc.stdout, proc.stdout
    assert sorted(p.name for p in out.iterdir()) == ["px.h5"] and (out / "px.h5").read_bytes() == bar_h5.read_bytes()
    # A deck of bodies whose partition: is OUTDIR/NAME.h5 (the file the command wrote there).
    tmp, _, _ = bodies_file
    bodies = dict(BODIES, name="joined", partition=str(out / "joined.h5"), output={"format": "xdmf"})
    bodies_deck = write_deck(tmp / "joined.yaml", bodies)
    assert partition([bodies_deck, "-n", 2]).returncode == 0
    written = (out / "joined.h5").read_bytes()
    proc = run_hyperqn([bodies_deck, "-o", out], ranks=ranks, check=False)
    assert proc.returncode == 1, proc.stdout
    assert "joined.yaml:" in proc.stdout and "'partition': " in proc.stdout, proc.stdout
    assert "joined.h5 is a file that the run writes in its output directory" in proc.stdout, proc.stdout
    assert sorted(p.name for p in out.iterdir()) == ["joined.h5", "px.h5"] and (out / "joined.h5").read_bytes() == written
    # Elsewhere the same files are read as before.
    run_hyperqn([bodies_deck, "-o", tmp_path / "other"], ranks=ranks)
