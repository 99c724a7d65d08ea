"""Physics check: a bar hanging from its top face (nu = 0) settles to the static stretch
u_bottom = rho g L^2 / (2 E) of 1-D elasticity, within 2%."""
import os

import numpy as np
import pytest

from conftest import REPO, run_hyperqn
from hyperqn_tools.output import final_frame, read_summary

RHO, G, L, E = 1000.0, 9.81, 1.0, 1.0e6


@pytest.mark.parametrize("ranks", [1, 2])
def test_static_stretch(tmp_path, ranks):
    outdir = tmp_path / "out"
    run_hyperqn([os.path.join(REPO, "tests/decks/hanging_bar.yaml"), "-o", outdir], ranks=ranks)
    assert read_summary(outdir)["status"] == "ok"
    frame = final_frame(outdir)
    rest = frame.points - frame.displacement
    bottom = rest[:, 1] < -L + 1e-9
    sag = -frame.displacement[bottom, 1].mean()
    expected = RHO * G * L**2 / (2 * E)
    assert sag == pytest.approx(expected, rel=0.02), f"sag {sag:.6e} m, expected {expected:.6e} m"
    # Settled: the bottom no longer moves.
    assert np.abs(frame.velocity[bottom]).max() < 1e-3 * expected
