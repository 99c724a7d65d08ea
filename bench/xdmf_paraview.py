"""Opens an XDMF series of hyperqn (output.format xdmf) in ParaView with each of its XDMF readers
(XDMFReader, the "XDMF Reader" of File -> Open; Xdmf3ReaderS; Xdmf3ReaderT) and reports, per time
step, the points, cells, largest vertex_id and connected regions (ParaView's Connectivity filter)
it reads, and the largest difference of its points from the .h5's positions of that frame (matched
by vertex_id). A series whose topology changes (docs/outputs.md#changing-topology-in-xdmf) must
show each frame's own mesh block. Run with ParaView's Python (Debian: apt-get install paraview):

    pvbatch bench/xdmf_paraview.py OUTDIR/NAME.xdmf [--json FILE]

Prints a line per reader (the steps where the counts change); --json writes
{reader: {"steps": [[points, cells, max vertex_id, regions], ...], "max_difference": d}} or
{reader: {"error": "..."}} for a reader that cannot open the file.
"""
import argparse, json, os, xml.etree.ElementTree as ET

import h5py
import numpy as np
from paraview import servermanager as sm
from paraview.simple import Connectivity, Delete, XDMFReader, Xdmf3ReaderS, Xdmf3ReaderT
from vtk.numpy_interface import dataset_adapter as dsa

READERS = {"XDMFReader": lambda p: XDMFReader(FileNames=[p]), "Xdmf3ReaderS": lambda p: Xdmf3ReaderS(FileName=[p]),
           "Xdmf3ReaderT": lambda p: Xdmf3ReaderT(FileName=[p])}


def first_block(d):
    if d.IsA("vtkCompositeDataSet"):
        it = d.NewIterator()
        it.InitTraversal()
        return it.GetCurrentDataObject()
    return d


def read(path, make, grids, h5):
    reader = make(path)
    regions = Connectivity(Input=reader)
    steps, worst = [], 0.0
    for k, t in enumerate(reader.TimestepValues):
        regions.UpdatePipeline(t)
        d = first_block(sm.Fetch(regions))
        w = dsa.WrapDataObject(d)
        ids = np.asarray(w.PointData["vertex_id"]).ravel()
        grid = grids[k]
        positions = h5[grid.find("Geometry").find("DataItem").text.split(":")[1]][()]
        item = [a for a in grid.findall("Attribute") if a.get("Name") == "vertex_id"][0].find("DataItem")
        h5_ids = h5[item.text.split(":")[1]][()]
        rows = np.searchsorted(h5_ids, ids)  # the Connectivity filter reorders the points
        assert np.array_equal(h5_ids[rows], ids)
        worst = max(worst, float(np.abs(np.asarray(w.Points) - positions[rows]).max()))
        steps.append([d.GetNumberOfPoints(), d.GetNumberOfCells(), int(ids.max()),
                      len(np.unique(np.asarray(w.PointData["RegionId"])))])
    Delete(regions)
    Delete(reader)
    return {"steps": steps, "max_difference": worst}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("xdmf")
    p.add_argument("--json")
    args = p.parse_args()
    grids = ET.parse(args.xdmf).getroot().find("Domain").find("Grid").findall("Grid")
    h5_name = grids[0].find("Geometry").find("DataItem").text.strip().split(":")[0]
    out = {}
    with h5py.File(os.path.join(os.path.dirname(os.path.abspath(args.xdmf)), h5_name), "r") as h5:
        for name, make in READERS.items():
            try:
                out[name] = read(args.xdmf, make, grids, h5)
            except Exception as e:  # a reader that cannot open it: said, the others still tried
                out[name] = {"error": str(e)}
                print(f"{name}: error: {e}")
                continue
            s = out[name]["steps"]
            changes = [x for i, x in enumerate(s) if i == 0 or x != s[i - 1]]
            print(f"{name}: {len(s)} steps; (points, cells, max vertex_id, regions) where they change: {changes}; "
                  f"max |points - h5 positions| {out[name]['max_difference']:.3g}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f)


main()
