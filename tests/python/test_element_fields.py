"""output.fields (docs/outputs.md#element-fields): per-element fields of the frames.

- The cube on a rope (tets and strand segments), stretched at frame 0 (initial.squash, the same
  positions at any rank count), asking for every field its elements have: the .vtu pieces and the
  XDMF file hold each field with its components (6 for a symmetric tensor, in VTK's order in the
  .vtu and XDMF's Tensor6 order in the .h5, read back as the 3 x 3 matrix), NaN at the elements of the other
  kind; at frame 0 the Green strain, the principal stretches, the von Mises stress (from the Cauchy
  stress written) and the axial force equal their definitions computed here from the written
  positions; by element (its vertex ids) the values at 1 and 2 ranks agree to 1e-12 at frame 0
  (the same positions) and to 1e-6 later (the positions agree to the solves' round-off only), and
  the VTK and XDMF frames of one run hold the same values.
- A membrane cloth writes membrane_stress, symmetric and in the deformed plane (sigma n = 0).
- A deck without output.fields writes none of them.
- output.field_precision single: every field's values in the .vtu pieces (Float32) and in the .h5
  (32-bit floats, Precision="4" in the index) are the double run's rounded to float, exactly, at 1
  and 2 ranks; the positions and the other arrays stay double and equal the double run's.
- output.vtu_encoding raw: the pieces hold the same arrays (of either precision) as raw appended
  data, fewer bytes, and hyperqn_tools.output reads them as it reads the inline base64 pieces.
- A restart of an XDMF series keeps each frame's fields (and their precision) in the index and
  writes the same arrays.
- Bad input (an unknown name, a field of elements the scene has none of, a name twice, the membrane
  stress of a mass-spring cloth): exit 1, the deck line and key named, no output directory.
"""
import copy
import os

import numpy as np
import pytest

from conftest import load_deck, run_hyperqn, write_deck
from hyperqn_tools.output import Frame, frame_list, frame_meshes, is_xdmf_frame, piece_files, tensors

TET_FIELDS = ["cauchy_stress", "von_mises", "principal_stretches", "green_strain", "energy_density"]
COMPONENTS = {"cauchy_stress": 6, "von_mises": 1, "principal_stretches": 3, "green_strain": 6,
              "energy_density": 1, "axial_force": 1, "membrane_stress": 6}
EA = 1.0e4  # box_on_rope.yaml's strand_material.axial_stiffness


def rope(fields, frames=3):
    deck = load_deck("tests/decks/box_on_rope.yaml")
    deck["time"]["frames"] = frames
    deck["initial"] = {"squash": {"axis": 1, "factor": 1.05}}
    deck["output"] = {"every": 1, "fields": fields}
    return deck


def run(tmp_path, deck, tag, ranks, fmt="vtu", **output):
    d = copy.deepcopy(deck)
    d["name"] = "run"
    d["output"] = dict(d.get("output") or {}, format=fmt, **output)
    out = tmp_path / f"{tag}_{fmt}_np{ranks}"
    run_hyperqn([write_deck(tmp_path / f"{tag}_{fmt}.yaml", d), "-o", out], ranks=ranks)
    return out


def frames(outdir):
    """[{"points": {vertex id: position}, "rest": {...}, "cells": {(type, sorted vertex ids): (row ids)},
    field: {(type, sorted vertex ids): values}, "components": {field: values per element in the file}}]
    per frame, over every piece; a symmetric tensor's 6 values as the 9 of its matrix, row by row."""
    out = []
    for _, _, path in frame_list(outdir):
        frame = {"points": {}, "rest": {}, "cells": {}, "components": {}}
        for m in frame_meshes(path):
            ids = np.asarray(m.point_data["vertex_id"]).reshape(-1)
            rest = m.points - m.point_data["displacement"]
            for i, v in enumerate(ids):
                frame["points"][int(v)] = m.points[i]
                frame["rest"][int(v)] = rest[i]
            for b, block in enumerate(m.cells):
                for k, row in enumerate(block.data):
                    key = (block.type, tuple(sorted(int(v) for v in ids[row])))
                    frame["cells"][key] = tuple(int(v) for v in ids[row])
                    for name in m.cell_data:
                        if name in COMPONENTS:
                            values = np.asarray(m.cell_data[name][b][k], dtype=float).reshape(-1)
                            frame["components"].setdefault(name, set()).add(len(values))
                            if len(values) == 6:
                                values = tensors(values, is_xdmf_frame(path)).reshape(-1)
                            frame.setdefault(name, {})[key] = values
        out.append(frame)
    return out


def assert_same(a, b, rtol, fields):
    assert len(a) == len(b)
    for fa, fb in zip(a, b):
        for name in fields:
            assert fa[name].keys() == fb[name].keys(), name
            x = np.array([fa[name][k] for k in sorted(fa[name])])
            y = np.array([fb[name][k] for k in sorted(fa[name])])
            assert np.array_equal(np.isnan(x), np.isnan(y)), name
            scale = np.nanmax(np.abs(y))
            assert np.nanmax(np.abs(x - y)) <= rtol * scale, (name, np.nanmax(np.abs(x - y)) / scale)


def check_definitions(frame):
    """Frame 0's fields against their definitions from the written positions."""
    P, X = frame["points"], frame["rest"]
    tets = [k for k in frame["cells"] if k[0] == "tetra"]
    lines = [k for k in frame["cells"] if k[0] == "line"]
    assert len(tets) == 48 and len(lines) == 10
    for key in tets:
        v = frame["cells"][key]
        Ds = np.column_stack([P[v[j]] - P[v[0]] for j in (1, 2, 3)])
        Dm = np.column_stack([X[v[j]] - X[v[0]] for j in (1, 2, 3)])
        F = Ds @ np.linalg.inv(Dm)
        E = 0.5 * (F.T @ F - np.eye(3))
        assert np.abs(frame["green_strain"][key] - E.reshape(-1)).max() <= 1e-12 * max(np.abs(E).max(), 1e-3)
        s = np.linalg.svd(F, compute_uv=False)
        assert np.abs(frame["principal_stretches"][key] - s).max() <= 1e-12
        sigma = frame["cauchy_stress"][key].reshape(3, 3)
        assert np.abs(sigma - sigma.T).max() == 0
        dev = sigma - np.trace(sigma) / 3 * np.eye(3)
        assert frame["von_mises"][key][0] == pytest.approx(np.sqrt(1.5 * np.sum(dev * dev)), rel=1e-12)
        assert frame["energy_density"][key][0] > 0
        assert np.isnan(frame["axial_force"][key]).all()
    forces = []
    for key in lines:
        a, b = frame["cells"][key]
        force = EA * (np.linalg.norm(P[b] - P[a]) / np.linalg.norm(X[b] - X[a]) - 1)
        assert frame["axial_force"][key][0] == pytest.approx(force, rel=1e-12, abs=1e-9)
        forces.append(force)
        for name in TET_FIELDS:
            assert np.isnan(frame[name][key]).all()
    assert max(forces) > 100  # stretched by about 5 %


def test_fields_in_vtu_and_xdmf_at_1_and_2_ranks(tmp_path):
    fields = TET_FIELDS + ["axial_force"]
    deck = rope(fields)
    runs = {(fmt, ranks): frames(run(tmp_path, deck, "rope", ranks, fmt)) for fmt in ("vtu", "xdmf") for ranks in (1, 2)}
    check_definitions(runs[("vtu", 1)][0])
    for (fmt, ranks), got in runs.items():
        assert len(got) == 4
        for name in fields:
            assert got[0]["components"][name] == {COMPONENTS[name]}, (fmt, ranks, name)
        assert "membrane_stress" not in got[0]
    for fmt in ("vtu", "xdmf"):
        assert_same(runs[(fmt, 2)][:1], runs[(fmt, 1)][:1], 1e-12, fields)
        assert_same(runs[(fmt, 2)], runs[(fmt, 1)], 1e-6, fields)
    for ranks in (1, 2):
        assert_same(runs[("xdmf", ranks)], runs[("vtu", ranks)], 1e-12, fields)


def stored_arrays(outdir):
    """{(frame, piece, array name): numpy array as stored} of every frame: each .vtu piece's arrays
    as meshio reads them, or each /frames/NNNNN dataset of the .h5; and the index's text."""
    import h5py

    arrays, index = {}, ""
    for n, _, path in frame_list(outdir):
        if is_xdmf_frame(path):
            index = (outdir / "run.xdmf").read_text()
            with h5py.File(outdir / "run.h5", "r") as f:
                for name, data in f["frames"][f"{n:05d}"].items():
                    arrays[(n, 0, name)] = data[()]
            continue
        for p, m in enumerate(frame_meshes(path)):
            arrays[(n, p, "points")] = m.points
            for name, data in list(m.point_data.items()) + [(k, np.concatenate(v)) for k, v in m.cell_data.items()]:
                arrays[(n, p, name)] = np.asarray(data)
    return arrays, index


@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
def test_single_precision_fields_are_the_double_ones_rounded(tmp_path, fmt):
    fields = TET_FIELDS + ["axial_force"]
    deck = rope(fields)
    for ranks in (1, 2):
        double, _ = stored_arrays(run(tmp_path, deck, "double", ranks, fmt))
        single, index = stored_arrays(run(tmp_path, deck, "single", ranks, fmt, field_precision="single"))
        assert double.keys() == single.keys() and len(double) > 4 * len(fields)
        rounded = set()
        for key, x in double.items():
            y = single[key]
            assert x.shape == y.shape, key
            if key[2] in fields:
                assert x.dtype == np.float64 and y.dtype == np.float32, key
                assert np.array_equal(x.astype(np.float32), y, equal_nan=True), key
                if np.any((y != x) & ~np.isnan(x)):
                    rounded.add(key[2])
            else:  # positions, J, ids, ...: as without the key
                assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True), key
        assert rounded == set(fields)  # the values were not floats already
        if fmt == "xdmf":
            assert index.count('Precision="4" Format="HDF">run.h5:/frames/') == 4 * len(fields)
            for name in fields:
                assert f'Precision="4" Format="HDF">run.h5:/frames/00003/{name}<' in index
            assert index.count('Precision="8" Format="HDF">run.h5:/frames/') == 4 * 4  # positions, displacement, velocity, J


@pytest.mark.parametrize("ranks", [1, 2])
def test_raw_vtu_pieces_hold_the_same_arrays(tmp_path, ranks):
    deck = rope(TET_FIELDS + ["axial_force"])
    for precision in ("double", "single"):
        inline = run(tmp_path, deck, f"base64_{precision}", ranks, field_precision=precision)
        raw = run(tmp_path, deck, f"raw_{precision}", ranks, field_precision=precision, vtu_encoding="raw")
        a, _ = stored_arrays(inline)
        b, _ = stored_arrays(raw)
        assert a.keys() == b.keys()
        for key, x in a.items():
            assert x.dtype == b[key].dtype and np.array_equal(x, b[key], equal_nan=True), key
        for (_, _, p), (_, _, q) in zip(frame_list(inline), frame_list(raw)):
            for piece, raw_piece in zip(piece_files(p), piece_files(q)):
                text, raw_bytes = open(piece, "rb").read(), open(raw_piece, "rb").read()
                assert b"AppendedData" not in text and b'format="binary"' in text
                assert b'<AppendedData encoding="raw">' in raw_bytes and b'format="binary"' not in raw_bytes
                assert len(raw_bytes) < 0.85 * len(text)
            x, y = Frame(p), Frame(q)
            assert np.array_equal(x.points, y.points) and np.array_equal(x.J, y.J) and np.array_equal(x.ranks, y.ranks)


MEMBRANE = {"mesh": {"sheet": {"size": [1.0, 0.5], "cells": [4, 2]}},
            "cloth": {"model": "membrane", "material": "neohookean", "youngs_modulus": 1.0e3, "poisson_ratio": 0.3,
                      "areal_density": 0.2},
            "fixed": [{"box": {"min": [-0.01, -0.01, -0.01], "max": [0.01, 0.01, 0.51]}}],
            "gravity": [0, -9.81, 0],
            "time": {"dt": 0.05, "frames": 2},
            "output": {"fields": ["membrane_stress"]}}


@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
def test_membrane_stress_lies_in_the_deformed_plane(tmp_path, fmt):
    last = frames(run(tmp_path, MEMBRANE, "sheet", 1, fmt))[-1]
    P = last["points"]
    assert len(last["membrane_stress"]) == 16
    largest = 0
    for key, values in last["membrane_stress"].items():
        a, b, c = last["cells"][key]
        n = np.cross(P[b] - P[a], P[c] - P[a])
        n /= np.linalg.norm(n)
        sigma = values.reshape(3, 3)
        assert np.abs(sigma - sigma.T).max() == 0
        assert np.linalg.norm(sigma @ n) <= 1e-10 * np.abs(sigma).max()
        largest = max(largest, np.abs(sigma).max())
    assert largest > 0.1  # N/m: the sheet sags under its weight


@pytest.mark.parametrize("fmt", ["vtu", "xdmf"])
def test_no_fields_without_the_key(tmp_path, fmt):
    deck = rope(None, frames=1)
    del deck["output"]["fields"]
    for frame in frames(run(tmp_path, deck, "plain", 1, fmt)):
        assert not set(COMPONENTS) & set(frame) and not frame["components"]


ROPE_TEXT = """mesh:
  box: {size: [0.2, 0.2, 0.2], cells: [2, 2, 2]}
material: {model: neohookean, youngs_modulus: 1.0e6, poisson_ratio: 0.3, density: 1000}
time: {dt: 0.1, frames: 2}
output:
  every: 1
  fields:
    - von_mises
    - FIELD
"""
SHEET_TEXT = """mesh: {sheet: {size: [1.0, 0.5], cells: [4, 2]}}
cloth: {model: mass-spring, stretch_stiffness: 100.0, areal_density: 0.2}
time: {dt: 0.05, frames: 2}
output: {fields: [membrane_stress]}
"""
BAD = {
    # name: (deck text, ranks, expected fragments)
    "unknown": (ROPE_TEXT.replace("FIELD", "stress"), None,
                ["unknown.yaml:9: 'output.fields[1]': unknown value 'stress'; allowed: cauchy_stress, von_mises"]),
    "no_strands": (ROPE_TEXT.replace("FIELD", "axial_force"), None,
                   ["no_strands.yaml:9: 'output.fields[1]': axial_force is a field of strand segments, and the scene has none"]),
    "no_strands_2_ranks": (ROPE_TEXT.replace("FIELD", "axial_force"), 2,
                           ["no_strands_2_ranks.yaml:9: 'output.fields[1]': axial_force is a field of strand segments"]),
    "twice": (ROPE_TEXT.replace("FIELD", "von_mises"), None, ["twice.yaml:9: 'output.fields[1]': von_mises is listed twice"]),
    "tets_of_cloth": (SHEET_TEXT.replace("membrane_stress", "cauchy_stress"), None,
                      ["tets_of_cloth.yaml:4: 'output.fields[0]': cauchy_stress is a field of tets"]),
    "springs_membrane": (SHEET_TEXT, None,
                         ["springs_membrane.yaml:4: 'output.fields[0]': membrane_stress is a field of cloth triangles of "
                          "the membrane model", "edge springs have no membrane stress"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_fields(tmp_path, case):
    text, ranks, fragments = BAD[case]
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    outdir = tmp_path / "out"
    proc = run_hyperqn([path, "-o", outdir], ranks=ranks, check=False, timeout=120)
    assert proc.returncode == 1, proc.stdout
    for fragment in fragments:
        assert fragment in proc.stdout, f"{fragment!r} not in:\n{proc.stdout[-3000:]}"
    assert not outdir.exists(), "an output directory was left behind"


@pytest.mark.parametrize("precision", ["double", "single"])
def test_xdmf_restart_keeps_the_fields_in_the_index(tmp_path, precision):
    """A restart resumes the XDMF index with each frame's fields (the restart state names them, and
    their precision) and writes the same arrays as the run without a stop."""
    import h5py

    deck = rope(["cauchy_stress", "axial_force"], frames=4)
    deck["output"]["field_precision"] = precision
    whole = run(tmp_path, deck, "whole", 1, "xdmf")
    first = copy.deepcopy(deck)
    first["checkpoint"] = {"every": 2}
    first["time"]["frames"] = 3
    out = run(tmp_path, first, "first", 1, "xdmf")
    then = copy.deepcopy(deck)
    then.update(name="run", output=dict(deck["output"], format="xdmf"))
    run_hyperqn([write_deck(tmp_path / "then.yaml", then), "-o", out, "--restart",
                 str(out / "checkpoints" / "checkpoint_2.h5")], ranks=1)
    index = (out / "run.xdmf").read_text()
    assert index == (whole / "run.xdmf").read_text()
    assert index.count('<Attribute Name="cauchy_stress" AttributeType="Tensor6" Center="Cell">') == 5
    assert index.count('<Attribute Name="axial_force" AttributeType="Scalar" Center="Cell">') == 5
    assert index.count('Precision="4"') == (10 if precision == "single" else 0)
    with h5py.File(out / "run.h5", "r") as a, h5py.File(whole / "run.h5", "r") as b:
        assert list(a["frames"]) == list(b["frames"]) == ["00000", "00001", "00002", "00003", "00004"]
        for frame in a["frames"]:
            for field in ("cauchy_stress", "axial_force"):
                x, y = a["frames"][frame][field][()], b["frames"][frame][field][()]
                assert x.shape == y.shape and np.array_equal(x, y, equal_nan=True), (frame, field)
                assert x.dtype == (np.float32 if precision == "single" else np.float64)


# A bar whose turned end is released at t = 0.1 (the step to frame 3), with a checkpoint at frame 4.
RELEASED_BAR = {
    "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
    "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
    "gravity": [0, -9.81, 0],
    "time": {"dt": 0.05, "frames": 8},
    "solver": {"iterations": 50},
    "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}},
              {"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
               "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 90.0}},
               "release": 0.1}],
    "output": {"every": 1, "fields": ["cauchy_stress"]},
}


@pytest.mark.parametrize("ranks", [1, 2])
def test_vtu_frames_after_a_release_and_a_restart(tmp_path, ranks):
    """A .vtu piece's arrays of the mesh alone (connectivity, offsets, types, rank, vertex_id) are
    built and encoded at the mesh's first frame and kept (io/vtk_writer.hpp, MeshArrays) until the
    scene changes (a release of fixed regions: set_mesh drops them) or the run ends. Every frame,
    before and after the release: J, computed from the frame's positions, equals det F from the
    written points, rest positions and connectivity, tet by tet, and the cells are frame 0's; the
    Cauchy stress is symmetric and finite (zero at rest, frame 0). A restart from frame 4 (after the release: the restarted
    run builds the released scene and its arrays afresh) writes every piece byte for byte as the
    run without a stop."""
    whole = run(tmp_path, RELEASED_BAR, "whole", ranks)
    first = copy.deepcopy(RELEASED_BAR)
    first["time"]["frames"] = 4
    first["checkpoint"] = {"every": 4}
    out = run(tmp_path, first, "first", ranks)
    then = copy.deepcopy(RELEASED_BAR)
    then["name"] = "run"
    then["output"]["format"] = "vtu"
    proc = run_hyperqn([write_deck(tmp_path / "then.yaml", then), "-o", out, "--restart",
                        str(out / "checkpoints" / "checkpoint_4.h5")], ranks=ranks)
    assert "restart from" in proc.stdout
    listed = frame_list(whole)
    assert len(listed) == 9 and len(frame_list(out)) == 9
    cells0 = None
    for number, _, path in listed:
        pieces = piece_files(path)
        assert len(pieces) == ranks
        for piece in pieces:  # the restarted run's pieces: the same bytes
            with open(piece, "rb") as a, open(out / os.path.relpath(piece, whole), "rb") as b:
                assert a.read() == b.read(), piece
        cells = set()
        for m in frame_meshes(path):
            (tets,) = [b.data for b in m.cells if b.type == "tetra"]
            ids = np.asarray(m.point_data["vertex_id"]).reshape(-1)
            rest = m.points - m.point_data["displacement"]
            edges = lambda x: np.stack([x[tets[:, j]] - x[tets[:, 0]] for j in (1, 2, 3)], axis=2)
            F = edges(m.points) @ np.linalg.inv(edges(rest))
            J = np.asarray(m.cell_data["J"][0]).reshape(-1)
            assert np.abs(J - np.linalg.det(F)).max() <= 1e-12, path
            sigma = tensors(np.asarray(m.cell_data["cauchy_stress"][0]))
            assert np.isfinite(sigma).all() and np.array_equal(sigma, np.swapaxes(sigma, 1, 2))
            assert (np.abs(sigma).max() > 0) == (number > 0)  # at rest at frame 0
            cells |= {tuple(sorted(ids[row])) for row in tets}
        assert len(cells) == 8 * 2 * 2 * 6
        cells0 = cells0 or cells
        assert cells == cells0, path


@pytest.mark.parametrize("start", [{"collapse": True}, {"invert": {"axis": 0}}])
def test_a_flat_or_inverted_tet_has_no_cauchy_stress(tmp_path, start):
    """Frame 0 of a collapsed or inverted start: a tet with J <= 0 holds NaN in cauchy_stress and
    von_mises, as an element without the field (before: inf, and 3e21 or sign-flipped values from
    P F^T / J); a tet with J > 0 a finite value."""
    deck = {"mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 1, 1]}},
            "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
            "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
            "time": {"dt": 0.01, "frames": 1}, "initial": start,
            "output": {"every": 1, "fields": ["cauchy_stress", "von_mises"]}}
    first = frames(run(tmp_path, deck, "start", 1))[0]
    flat = 0
    for key, ids in first["cells"].items():
        x = np.array([first["points"][v] for v in ids])
        X = np.array([first["rest"][v] for v in ids])
        J = np.linalg.det((x[1:] - x[0]).T) / np.linalg.det((X[1:] - X[0]).T)
        sigma, vm = first["cauchy_stress"][key], first["von_mises"][key]
        assert not np.isinf(sigma).any() and not np.isinf(vm).any()
        if J < -1e-9 or (J <= 1e-9 and np.isnan(vm).all()):
            assert np.isnan(sigma).all() and np.isnan(vm).all(), (J, sigma)
            flat += 1
        else:
            assert np.isfinite(sigma).all() and np.isfinite(vm).all(), (J, sigma)
    assert flat >= len(first["cells"]) // 2
