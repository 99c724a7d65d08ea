"""Reading hyperqn's output directories: the .pvd/.vtu/.pvtu frames, iterations.csv, summary.json.

VTK files are read with meshio (an independent reader); a .pvtu is read piece by piece and the
pieces are merged by vertex_id, so runs at different rank counts can be compared vertex by vertex.
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


def frames_of_iterations(rows):
    """{frame: [its rows of iterations.csv]} in order."""
    frames = {}
    for r in rows:
        frames.setdefault(r["frame"], []).append(r)
    return frames


def read_pvd(path):
    """[(time, absolute file path)] in the order written."""
    root = ET.parse(path).getroot()
    base = os.path.dirname(path)
    return [(float(d.get("timestep")), os.path.join(base, d.get("file"))) for d in root.iter("DataSet")]


def piece_files(path):
    """The .vtu files that make up a frame: the file itself, or a .pvtu's pieces."""
    if path.endswith(".pvtu"):
        base = os.path.dirname(path)
        return [os.path.join(base, p.get("Source")) for p in ET.parse(path).getroot().iter("Piece")]
    return [path]


def is_empty_piece(path):
    with open(path, "rb") as f:
        head = f.read(400)
    return b'NumberOfPoints="0"' in head


class Frame:
    """One output frame, merged over pieces and sorted by vertex_id."""

    def __init__(self, path):
        self.path = path
        ids, points, disp, vel, force = [], [], [], [], []
        self.num_cells = 0
        self.J = []
        self.ranks = []
        for piece in piece_files(path):
            if is_empty_piece(piece):  # a rank without cells (tiny meshes); meshio cannot read it
                continue
            m = meshio.read(piece)
            ids.append(np.asarray(m.point_data["vertex_id"]).reshape(-1))
            points.append(m.points)
            disp.append(m.point_data["displacement"])
            vel.append(m.point_data["velocity"])
            if "contact_force" in m.point_data:  # scenes with colliders
                force.append(m.point_data["contact_force"])
            self.num_cells += sum(len(c.data) for c in m.cells)
            self.J.append(np.concatenate([np.ravel(a) for a in m.cell_data["J"]]))
            self.ranks.append(np.concatenate([np.ravel(a) for a in m.cell_data["rank"]]))
        ids = np.concatenate(ids)
        self.vertex_id, first = np.unique(ids, return_index=True)  # ghosts appear in several pieces
        self.points = np.concatenate(points)[first]
        self.displacement = np.concatenate(disp)[first]
        self.velocity = np.concatenate(vel)[first]
        self.contact_force = np.concatenate(force)[first] if force else None
        self.J = np.concatenate(self.J)
        self.ranks = np.concatenate(self.ranks)
        self.num_pieces = len(piece_files(path))


def final_frame(outdir):
    pvd = [f for f in os.listdir(outdir) if f.endswith(".pvd")]
    if len(pvd) != 1:
        raise FileNotFoundError(f"{outdir}: expected one .pvd file, found {pvd}")
    return Frame(read_pvd(os.path.join(outdir, pvd[0]))[-1][1])


def rest_diagonal(frame):
    """Length of the diagonal of the rest shape's bounding box."""
    rest = frame.points - frame.displacement
    return float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0)))


def read_frames(outdir):
    """[(frame number, Frame)] of every VTK frame written, or [] if there is none. Raises on
    unreadable files (a crash in the middle of writing)."""
    pvd = glob.glob(os.path.join(outdir, "*.pvd"))
    if len(pvd) != 1:
        return []
    frames = []
    for _, path in read_pvd(pvd[0]):
        m = re.search(r"_(\d+)\.p?vtu$", path)
        frames.append((int(m.group(1)) if m else len(frames), Frame(path)))
    return frames


def read_checkpoint(path):
    """A checkpoint file (src/io/checkpoint.hpp, docs/outputs.md#checkpoints) as a dict: every
    "key value" line of its header (numbers as int or float, the rest as text), plus "positions" and
    "velocities" ((slots, 3) arrays in vertex-id order) and its other texts ("physics",
    "flagged_frames", "inverted_frames", "writer_<key>"). h5py checks the datasets' checksums: a
    damaged file raises OSError."""
    import h5py  # only checkpoints need it

    # Values that look like numbers but are not: ids, hashes, one 0/1 flag per region.
    text_keys = {"run_id", "run_started", "deck", "mesh_hash", "positions_hash", "velocities_hash", "released",
                 "released_attachments", "writers"}

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
            if name in ("positions", "velocities"):
                out[name] = data
            elif name == "header":
                for line in data.tobytes().decode().splitlines():
                    key, _, value = line.partition(" ")
                    out[key] = value if key in text_keys else number(value)
            else:
                out[name] = data.tobytes().decode()
        return out
