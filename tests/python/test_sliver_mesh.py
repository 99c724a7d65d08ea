"""Neo-Hookean on sliver-laden meshes (scripts/sliver_mesh.py: worst shape quality 1e-5) hanging
from their top 5 % under gravity (E = 1e6, nu = 0.4, rho = 1000, h = 1/30, 20 frames), lbfgs at
the default budget: every frame unflagged, min det F > 0 (docs/guardrails.md#fallback). Measured
before the fallback chain judged det F: the 0.1 x 0.5 x 0.1 m body with 5 cm cells and 10 %
slivers was stopped at frame 2 with |det F| = 3.1e3, the one with 1 cm cells ended flagged with
min det F = -2e4.

Not covered (docs/guardrails.md): the 0.4 x 2 x 0.4 m body with 5 cm cells and 2 % slivers still
explodes at frame 2 (stopped, exit 1)."""
import os
import subprocess
import sys

import pytest

from conftest import REPO, run_hyperqn, write_deck
from hyperqn_tools.output import read_summary

GENERATOR = os.path.join(REPO, "scripts", "sliver_mesh.py")

# name: (body size, element size, sliver fraction, seed)
MESHES = {
    "5cm_10pct": ([0.1, 0.5, 0.1], 0.05, 0.1, 3),
    "5cm_1m": ([0.2, 1.0, 0.2], 0.05, 0.02, 1),
    "1cm": ([0.1, 0.5, 0.1], 0.01, 0.02, 1),
    "2mm": ([0.01, 0.5, 0.01], 0.002, 0.02, 1),
}


def make_mesh(path, size, element, fraction, seed):
    out = subprocess.run([sys.executable, GENERATOR, str(path), "--size", *map(str, size), "--element", str(element),
                          "--worst", "1e-5", "--fraction", str(fraction), "--seed", str(seed)],
                         capture_output=True, text=True, check=True).stdout
    assert "worst quality 1.000e-05" in out, out
    assert "inverted or flat: 0" in out, out
    return out


@pytest.mark.parametrize("name", sorted(MESHES))
def test_neohookean_lbfgs_on_slivers(tmp_path, name):
    size, element, fraction, seed = MESHES[name]
    mesh = tmp_path / "slivers.mesh"
    make_mesh(mesh, size, element, fraction, seed)
    top = size[1]
    deck = write_deck(tmp_path / "slivers.yaml", {
        "name": "slivers",
        "mesh": {"file": str(mesh)},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e6, "poisson_ratio": 0.4, "density": 1000},
        "fixed": [{"box": {"min": [-10, 0.95 * top, -10], "max": [10, 10, 10]}}],
        "time": {"dt": 1 / 30, "frames": 20},
        "output": {"vtk": False},
    })
    outdir = tmp_path / "out"
    proc = run_hyperqn([deck, "-o", outdir], ranks=None, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:]
    summary = read_summary(outdir)
    assert summary["status"] == "ok" and summary["frames"] == 20, summary["status"]
    assert not summary["flagged_frames"]
    assert summary["min_J"] > 0, summary["min_J"]
