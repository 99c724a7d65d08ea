"""Reading hyperqn's output directories: the frames (.pvd/.vtu/.pvtu, or .xdmf/.h5 with
output.format xdmf), iterations.csv, summary.json.

Frames are read with meshio (an independent reader); a .pvtu is read piece by piece and the
pieces are merged by vertex_id, so runs at different rank counts can be compared vertex by vertex.
meshio reads the pieces' arrays inline (base64, the default) or raw appended (output.vtu_encoding
raw), and element fields of either precision (output.field_precision: Float32 arrays in a piece,
32-bit datasets in the .h5) as they are stored: float32 arrays for single precision.
An XDMF frame is one grid of the run's .xdmf index, named by a path "DIR/NAME.xdmf#K" (K: the
grid's place in the index); its points are already in vertex_id order.
"""
import csv
import glob
import json
import os
import re
import xml.etree.ElementTree as ET

import meshio
import numpy as np


def read_summary(outdir):
    with open(os.path.join(outdir, "summary.json")) as f:
        return json.load(f)


def read_iterations(outdir):
    """Rows of iterations.csv as dicts with numeric values."""
    rows = []
    with open(os.path.join(outdir, "iterations.csv")) as f:
        for row in csv.DictReader(f):
            rows.append({k: (int(v) if k in ("frame", "iteration", "evaluations") else float(v))
                         for k, v in row.items()})
    return rows


def read_contact(outdir):
    """contact.csv as {column: numpy array} (one row per frame and collider)."""
    with open(os.path.join(outdir, "contact.csv")) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in (rows[0] if rows else [])}


def read_reactions(outdir):
    """reactions.csv as {support name: {column: numpy array over its frames}} (docs/outputs.md)."""
    supports = {}
    path = os.path.join(outdir, "reactions.csv")
    with open(path) as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            try:
                columns = supports.setdefault(row["region"], {})
                for k, v in row.items():
                    if k != "region":
                        columns.setdefault(k, []).append(float(v))
            except (KeyError, TypeError, ValueError) as e:  # a row cut short (a crash): None, or not a number
                raise ValueError(f"{path}:{line}: not a row of reactions ({type(e).__name__}: {e})") from None
    return {name: {k: np.array(v) for k, v in columns.items()} for name, columns in supports.items()}


def frames_of_iterations(rows):
    """{frame: [its rows of iterations.csv]} in order."""
    frames = {}
    for r in rows:
        frames.setdefault(r["frame"], []).append(r)
    return frames


def xml_root(path):
    """The root element of an XML file (.pvd, .pvtu, .xdmf); ValueError naming the file when it is
    not XML (a file cut short by a crash), as for every damaged file read here."""
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as e:
        raise ValueError(f"{path}: not a readable XML file ({e})") from None


def read_pvd(path):
    """[(time, absolute file path)] in the order written."""
    root = xml_root(path)
    base = os.path.dirname(path)
    try:
        return [(float(d.get("timestep")), os.path.join(base, d.get("file"))) for d in root.iter("DataSet")]
    except (TypeError, ValueError):  # an attribute missing or not a number
        raise ValueError(f"{path}: not a .pvd index (a DataSet without a timestep or file)") from None


def read_xdmf(path):
    """[(time, frame number, path of the frame "PATH#K")] of an XDMF index, in the order written."""
    root, out = xml_root(path), []
    try:
        collection = root.find("Domain").find("Grid")
        for k, grid in enumerate(collection.findall("Grid")):
            number = re.search(r"(\d+)$", grid.get("Name"))
            out.append((float(grid.find("Time").get("Value")), int(number.group(1)) if number else k, f"{path}#{k}"))
    except (AttributeError, TypeError, ValueError):  # an element or attribute missing (find gave None), a time not a number
        raise ValueError(f"{path}: not an XDMF index of frames (Domain/Grid/Grid with Time and Name)") from None
    return out


def is_xdmf_frame(path):
    return re.search(r"\.xdmf#\d+$", str(path)) is not None


def piece_files(path):
    """The .vtu files that make up a frame: the file itself, or a .pvtu's pieces."""
    if is_xdmf_frame(path):
        raise ValueError(f"{path}: an XDMF frame has no pieces; read it with frame_meshes")
    if path.endswith(".pvtu"):
        base = os.path.dirname(path)
        pieces = [p.get("Source") for p in xml_root(path).iter("Piece")]
        if not pieces or None in pieces:
            raise ValueError(f"{path}: not a .pvtu (no Piece with a Source)")
        return [os.path.join(base, p) for p in pieces]
    return [path]


def read_piece(path):
    """A .vtu piece read with meshio's VTU reader; ValueError naming the piece for one it cannot
    read (meshio.read would print its own message and exit)."""
    try:
        return meshio.vtu.read(path)
    except Exception as e:  # noqa: BLE001 - meshio's ReadError (often without a message), XML, zlib, base64
        why = str(e).strip()
        raise ValueError(f"{path}: not a readable VTK file" + (f" ({why})" if why else "")) from None


def is_empty_piece(path):
    with open(path, "rb") as f:
        head = f.read(400)
    return b'NumberOfPoints="0"' in head


def xdmf_grid(path):
    """An XDMF frame "PATH#K" read with meshio: (mesh with the frame's positions as points, its
    topology and its point and cell data, time)."""
    index, k = str(path).rsplit("#", 1)
    k = int(k)
    with meshio.xdmf.TimeSeriesReader(index) as reader:
        # meshio reads the first grid's geometry and topology only; each frame's are its own (its
        # positions, and the mesh block of its topology after cuts, snaps or tears).
        reader.mesh_grid = reader.collection[k]
        points, cells = reader.read_points_cells()
        time, point_data, cell_data = reader.read_data(k)
    return meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data), time


# Where each of a symmetric tensor field's 6 values per element sits in the 3 x 3 matrix: in a .vtu
# piece VTK's order (xx, yy, zz, xy, yz, xz: the order ParaView reads a 6-component array as a
# symmetric tensor), in the .h5 of an XDMF series XDMF's Tensor6 (xx, xy, xz, yy, yz, zz).
VTK_SYMMETRIC = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2)]
XDMF_TENSOR6 = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]


def tensors(values, xdmf=False):
    """(n, 3, 3) from a tensor field's rows as a file holds them: 6 values of a symmetric tensor per
    row (in VTK_SYMMETRIC's order, XDMF_TENSOR6's with xdmf) or 9, the matrix row by row (a run
    before symmetric tensors were written as 6)."""
    values = np.asarray(values, dtype=float)
    values = values.reshape(-1, values.shape[-1]) if values.ndim > 1 else values.reshape(1, -1)
    if values.shape[1] == 9:
        return values.reshape(-1, 3, 3)
    out = np.empty((len(values), 3, 3))
    for k, (i, j) in enumerate(XDMF_TENSOR6 if xdmf else VTK_SYMMETRIC):
        out[:, i, j] = out[:, j, i] = values[:, k]
    return out


def frame_meshes(path):
    """A frame as meshio meshes with point_data displacement: one per .vtu piece, one for an
    XDMF frame."""
    if is_xdmf_frame(path):
        return [xdmf_grid(path)[0]]
    return [read_piece(piece) for piece in piece_files(path) if not is_empty_piece(piece)]


class Frame:
    """One output frame, merged over pieces and sorted by vertex_id. ranks (the VTK cell field
    rank) is None for an XDMF frame, which does not depend on the rank count; body (the cell field
    of a scene of bodies: each element's body) is None without bodies. cells: {meshio cell type
    ("tetra", "line", "triangle"): (n, k) rows into points}, every piece's."""

    def __init__(self, path):
        self.path = path
        if is_xdmf_frame(path):
            self._read_xdmf(path)
            return
        ids, points, disp, vel, force, piece_cells = [], [], [], [], [], []
        self.num_cells = 0
        self.J = []
        self.ranks = []
        bodies = []
        for piece in piece_files(path):
            if is_empty_piece(piece):  # a rank without cells (tiny meshes); meshio cannot read it
                continue
            m = read_piece(piece)
            ids.append(np.asarray(m.point_data["vertex_id"]).reshape(-1))
            points.append(m.points)
            disp.append(m.point_data["displacement"])
            vel.append(m.point_data["velocity"])
            if "contact_force" in m.point_data:  # scenes with colliders
                force.append(m.point_data["contact_force"])
            self.num_cells += sum(len(c.data) for c in m.cells)
            piece_cells += [(c.type, ids[-1][c.data]) for c in m.cells]  # as vertex ids
            self.J.append(np.concatenate([np.ravel(a) for a in m.cell_data["J"]]))
            self.ranks.append(np.concatenate([np.ravel(a) for a in m.cell_data["rank"]]))
            if "body" in m.cell_data:
                bodies.append(np.concatenate([np.ravel(a) for a in m.cell_data["body"]]))
        self.body = np.concatenate(bodies) if bodies else None
        ids = np.concatenate(ids)
        self.vertex_id, first = np.unique(ids, return_index=True)  # ghosts appear in several pieces
        self.points = np.concatenate(points)[first]
        self.displacement = np.concatenate(disp)[first]
        self.velocity = np.concatenate(vel)[first]
        self.contact_force = np.concatenate(force)[first] if force else None
        self.cells = cells_by_type((kind, np.searchsorted(self.vertex_id, rows)) for kind, rows in piece_cells)
        self.J = np.concatenate(self.J)
        self.ranks = np.concatenate(self.ranks)
        self.num_pieces = len(piece_files(path))

    def _read_xdmf(self, path):
        m, _ = xdmf_grid(path)
        self.vertex_id = np.asarray(m.point_data["vertex_id"]).reshape(-1)
        self.points = m.points
        self.displacement = m.point_data["displacement"]
        self.velocity = m.point_data["velocity"]
        self.contact_force = m.point_data.get("contact_force")
        self.num_cells = sum(len(c.data) for c in m.cells)
        self.cells = cells_by_type((c.type, c.data) for c in m.cells)  # points are in vertex_id order
        self.J = np.concatenate([np.ravel(a) for a in m.cell_data["J"]])
        self.ranks = None
        self.body = np.concatenate([np.ravel(a) for a in m.cell_data["body"]]) if "body" in m.cell_data else None
        self.num_pieces = 1


def cells_by_type(blocks):
    """{cell type: rows of all (type, rows) blocks of that type, concatenated in order}."""
    out = {}
    for kind, rows in blocks:
        out.setdefault(kind, []).append(np.asarray(rows, dtype=np.int64))
    return {kind: np.concatenate(rows) for kind, rows in out.items()}


def file_head(path, size=4096):
    with open(path, "rb") as f:
        return f.read(size).decode("utf-8", "replace")


def written_by_a_run(path):
    """Whether an index is one hyperqn writes, by its own rule (is_run_output,
    src/io/output_directory.cpp; docs/outputs.md#a-directory-that-holds-an-earlier-run): a
    NAME.pvd that lists files named NAME_..., a NAME.xdmf whose data are in NAME.h5."""
    name, kind = os.path.splitext(os.path.basename(path))
    return (f'file="{name}_' if kind == ".pvd" else f">{name}.h5:/") in file_head(path)


def series_indexes(outdir):
    """The .pvd and .xdmf indexes of a run's frame series (both if output.format changed at a
    restart): the only .pvd and the only .xdmf; of two or more in a run's directory (it holds
    summary.json) those the run wrote, by written_by_a_run (a user's other .pvd beside them is not
    the run's). ValueError naming them for two of a kind left."""
    run = os.path.exists(os.path.join(outdir, "summary.json"))
    indexes = []
    for kind in ("pvd", "xdmf"):
        found = sorted(glob.glob(os.path.join(outdir, f"*.{kind}")))
        if run and len(found) > 1:  # one alone is read as it is (a damaged index is said, not passed over)
            found = [path for path in found if written_by_a_run(path)]
        if len(found) > 1:
            names = ", ".join(os.path.basename(path) for path in found)
            raise ValueError(f"{outdir}: more than one .{kind} series ({names}): "
                             + ("each lists frames of its own name, as a run's does" if run else
                                "which is the run's? (no summary.json to tell)"))
        indexes += found
    return indexes


def frame_list(outdir):
    """[(frame number, time, path)] of the frames the run's indexes list (series_indexes), by frame
    number; [] if there is none."""
    listed = {}
    for index in series_indexes(outdir):
        if index.endswith(".pvd"):
            for t, path in read_pvd(index):
                m = re.search(r"_(\d+)\.p?vtu$", path)
                listed[int(m.group(1)) if m else len(listed)] = (t, path)
        else:
            for t, number, path in read_xdmf(index):
                listed[number] = (t, path)
    return [(n, t, path) for n, (t, path) in sorted(listed.items())]


def read_frame(path, number):
    """Frame(path), frame `number` of its run; ValueError naming the file (an XDMF frame's index and
    its data file) for one that cannot be read: cut short by a crash, damaged, not a frame."""
    try:
        return Frame(path)
    except Exception as e:  # noqa: BLE001 - meshio, h5py and XML raise many kinds
        why = str(e).removeprefix(f"{path}: ")  # output's own errors name the file already
    where = str(path)
    if is_xdmf_frame(path):  # h5py's messages name no file: the run's data file (written_by_a_run)
        where += f" (data in {os.path.splitext(where.rsplit('#', 1)[0])[0]}.h5)"
    raise ValueError(f"{where}: cannot read frame {number}: {why}") from None


def last_listed(outdir):
    """(frame number, time, path) of the last frame the run's indexes list; FileNotFoundError if
    there is none."""
    listed = frame_list(outdir)
    if not listed:
        raise FileNotFoundError(f"{outdir}: no .pvd or .xdmf listing the run's frames")
    return listed[-1]


def final_frame(outdir):
    """The last frame the run's indexes list (read_frame)."""
    number, _, path = last_listed(outdir)
    return read_frame(path, number)


def rest_diagonal(frame):
    """Length of the diagonal of the rest shape's bounding box."""
    rest = frame.points - frame.displacement
    return float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0)))


def read_frames(outdir):
    """[(frame number, Frame)] of every frame written (VTK or XDMF), or [] if there is none.
    ValueError naming an unreadable file (a crash in the middle of writing: read_frame)."""
    return [(n, read_frame(path, n)) for n, _, path in frame_list(outdir)]


def read_checkpoint(path):
    """A checkpoint file (src/io/checkpoint.hpp, docs/outputs.md#checkpoints) as a dict: every
    "key value" line of its header (numbers as int or float, the rest as text), plus "positions",
    "velocities" and, with an integrator's history, "previous_positions" and "previous_velocities"
    ((slots, 3) arrays in vertex-id order), the element states ("elements_<name>": a row per global
    element id, the ids no element has 0) and its other texts ("physics",
    "flagged_frames", "inverted_frames", "writer_<key>"). h5py checks the datasets' checksums: a
    damaged file raises OSError."""
    import h5py  # only checkpoints need it

    # Values that look like numbers but are not: ids, hashes, one 0/1 flag per region.
    text_keys = {"run_id", "run_started", "deck", "mesh_hash", "positions_hash", "velocities_hash",
                 "previous_positions_hash", "previous_velocities_hash", "released", "released_attachments", "writers"}

    def number(text):
        for kind in (int, float):
            try:
                return kind(text)
            except ValueError:
                pass
        return text

    with h5py.File(path, "r") as f:
        out = {}
        for name, item in f.items():
            data = item[()]
            if name in ("positions", "velocities", "previous_positions", "previous_velocities") or name.startswith("elements_"):
                out[name] = data
            elif name == "header":
                for line in data.tobytes().decode().splitlines():
                    key, _, value = line.partition(" ")
                    out[key] = value if key in text_keys else number(value)
            else:
                out[name] = data.tobytes().decode()
        return out
