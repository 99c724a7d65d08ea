"""The engineering scenes of input/engineering/ (docs/loads.md#scenes), end to end.

- tensile_bar.yaml (static load steps, a clamp moved by a ramp, reactions.csv): the two clamps'
  forces balance (no gravity, no inertia), the moving clamp's force grows with its travel, which
  hyperqn_tools.force_displacement reads as 5 mm per step; 1 and 2 ranks agree; the tool writes the
  curve's CSV and PNG.
- block_compression.yaml (a rough plate compresses a block on a rough floor): the top plate's
  force in contact.csv grows while it moves and holds after.
"""
import csv
import os
import subprocess
import sys

import numpy as np

from conftest import run_hyperqn
from hyperqn_tools.force_displacement import curve
from hyperqn_tools.output import read_contact, read_reactions
from hyperqn_tools.paths import REPO


def deck(name):
    return os.path.join(REPO, "input", "engineering", name)


def test_tensile_bar(tmp_path):
    outs = {}
    for ranks in (1, 2):
        outs[ranks] = tmp_path / f"np{ranks}"
        run_hyperqn([deck("tensile_bar.yaml"), "-o", outs[ranks]], ranks=ranks)
    r = read_reactions(outs[1])
    fixed, pulled = r["fixed[0]"]["fx"], r["fixed[1]"]["fx"]
    print("clamp forces along x:", pulled)
    assert np.all(pulled > 0) and np.all(np.diff(pulled) > 0), "the pulled clamp's force grows"
    assert np.abs(fixed + pulled).max() <= 1e-6 * pulled.max(), "the clamps balance"
    r2 = read_reactions(outs[2])
    assert np.abs(r2["fixed[1]"]["fx"] - pulled).max() <= 1e-8 * pulled.max(), "1 and 2 ranks"
    travel, force = curve(outs[1], "fixed[1]", "x")
    assert np.allclose(travel, 0.005 * np.arange(1, 11), rtol=0, atol=1e-12) and np.array_equal(force, pulled)
    png, table = tmp_path / "curve.png", tmp_path / "curve.csv"
    subprocess.run([sys.executable, "-m", "hyperqn_tools.force_displacement", str(outs[1]), "--support", "fixed[1]",
                    "--axis", "x", "--png", str(png), "--csv", str(table)], check=True, stdout=subprocess.DEVNULL)
    with open(table) as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["travel_x", "force_x"] and len(rows) == 11 and png.stat().st_size > 1000


def test_block_compression(tmp_path):
    out = tmp_path / "out"
    run_hyperqn([deck("block_compression.yaml"), "-o", out], ranks=2)
    c = read_contact(out)
    plate = c["collider"] == 1
    t, force = c["time"][plate], c["normal_force"][plate]
    moving = (t > 0.2) & (t <= 1.0)
    print("plate force at t = 0.2, 0.6, 1.0, 1.2:", [force[np.argmin(abs(t - s))] for s in (0.2, 0.6, 1.0, 1.2)])
    assert np.all(np.diff(force[moving]) > 0), "the force grows while the plate moves down"
    # 10% of the height: some 4 kN for a 0.04 m^2 face of E = 1 MPa, more with the friction's barrel
    assert 3.0e3 < force[-1] < 8.0e3
