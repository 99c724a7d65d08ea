"""`hyperqn study`: the relative errors come from the logged energies and the reference, the
HDF5 file holds the same data, the trajectories are compared with converged Newton, and the
report script turns it all into PNGs and a Markdown table."""
import csv
import math
import os
import re
import subprocess

import h5py
import numpy as np
import pytest

from conftest import NO_FALLBACK, REPO, run_hyperqn

SOLVERS = {"lbfgs", "lbfgs-identity", "pd", "newton"}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "small"
    proc = run_hyperqn(["study", os.path.join(REPO, "tests/decks/study_small.yaml"), "-o", out], ranks=2)
    assert "study written" in proc.stdout
    assert len(re.findall(r"^pd: ", proc.stdout, re.M)) == 1  # what pd runs, said once (not again for its trajectory)
    with open(out / "study.csv") as f:
        rows = list(csv.DictReader(f))
    with open(out / "trajectory.csv") as f:
        traj = list(csv.DictReader(f))
    return out, rows, traj


def test_every_solver_at_every_frame(study):
    _, rows, _ = study
    seen = {(r["solver"], int(r["frame"])) for r in rows}
    assert seen == {(s, f) for s in SOLVERS | {"reference"} for f in (5, 15)}


def test_relative_error_recomputed_from_the_csv(study):
    _, rows, _ = study
    for frame in (5, 15):
        at = [r for r in rows if int(r["frame"]) == frame]
        ref = [r for r in at if r["solver"] == "reference"]
        g0 = float(ref[0]["energy"])
        g_star = min(float(r["energy"]) for r in at)  # the lowest g anyone reached
        assert g_star <= float(ref[-1]["energy"])
        # The reference converged: its last gradient is tiny compared with its first, and no solver
        # went below it but by round-off (the study would warn).
        assert float(ref[-1]["grad_norm"]) <= 1e-8 * float(ref[0]["grad_norm"])
        assert float(ref[-1]["rel_error"]) <= 1e-6
        for r in at:
            expected = (float(r["energy"]) - g_star) / (g0 - g_star)
            assert float(r["rel_error"]) == pytest.approx(expected, rel=1e-12, abs=1e-15)
        # Every solver starts from the same state.
        starts = {float(r["energy"]) for r in at if r["iteration"] == "0"}
        assert max(starts) - min(starts) <= 1e-12 * abs(g0)
        # lbfgs gets to e <= 1e-6 within the budget.
        lbfgs = [float(r["rel_error"]) for r in at if r["solver"] == "lbfgs"]
        assert min(lbfgs) <= 1e-6


def test_hdf5_matches_csv(study):
    out, rows, _ = study
    with h5py.File(out / "study.h5") as h5:
        g = h5["frames/frame_00015/lbfgs"]
        csv_energy = [float(r["energy"]) for r in rows if r["solver"] == "lbfgs" and r["frame"] == "15"]
        assert np.array_equal(g["energy"][:], np.array(csv_energy))
        assert g.attrs["g_star"] <= g["energy"][-1]
        assert set(h5["trajectory"]) == SOLVERS


def test_trajectories(study):
    _, _, traj = study
    last = {r["solver"]: r for r in traj if r["frame"] == "20"}
    assert set(last) == SOLVERS
    for r in last.values():
        assert np.isfinite(float(r["rel_rms_error"])) and float(r["time_s"]) > 0
    # At the same 10 iterations per frame, lbfgs tracks converged Newton more closely than PD.
    assert float(last["lbfgs"]["rel_rms_error"]) < float(last["pd"]["rel_rms_error"])


def test_report(study):
    out, _, _ = study
    report = out.parent / "report.md"
    subprocess.run(["/usr/bin/python3", "-m", "hyperqn_tools.study_report", str(out), "--out", str(report)],
                   check=True)
    text = report.read_text()
    assert "| lbfgs |" in text and "speed-up@0.001" in text
    for png in (out / "error_vs_time.png", out / "trajectory.png", out.parent / "report_overview.png"):
        assert png.stat().st_size > 10000
    assert "Incomplete" not in text


def test_report_of_a_killed_study_says_it_did_not_end(study, tmp_path):
    """A study killed (SIGKILL) leaves its CSVs and study.json but not study.h5, written at its end:
    the report showed its partial trajectory as a finished study. Now it says it did not end."""
    import shutil
    out, _, _ = study
    killed = tmp_path / "killed"
    shutil.copytree(out, killed)
    (killed / "study.h5").unlink()
    proc = subprocess.run(["/usr/bin/python3", "-m", "hyperqn_tools.study_report", str(killed), "--out",
                           str(tmp_path / "report.md")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "**Incomplete: the study did not end**" in (tmp_path / "report.md").read_text()
    assert "the study did not end (no study.h5" in proc.stderr


def plain_runs(tmp_path, deck, ranks=1):
    """The study deck run plainly, once with its lbfgs and once with the reference's converged
    Newton: {"lbfgs": OUTDIR, "reference": OUTDIR}. The study's trajectories run without the
    fallback chain (fixed budgets), so these runs too."""
    import yaml
    runs = {}
    for name, solver in {"lbfgs": {**deck["solver"], **NO_FALLBACK},
                         "reference": {"type": "newton", "newton_hessian": "exact", "iterations": 100,
                                       "grad_rtol": 1e-10, **NO_FALLBACK}}.items():
        d = dict(deck, solver=solver)
        del d["study"]
        (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(d))
        runs[name] = tmp_path / name
        run_hyperqn([tmp_path / f"{name}.yaml", "-o", runs[name]], ranks=ranks)
    return runs


def test_study_releases_fixed_regions_like_the_simulation(tmp_path):
    """A twisted bar whose end is released at t = 0.3: the study rebuilds its scene as the
    simulation does. Its lbfgs trajectory's RMS distance to the converged reference must equal the
    distance between two plain runs of the same deck (lbfgs, and the reference's Newton)."""
    import yaml
    from hyperqn_tools.output import final_frame, read_summary
    deck = {
        "mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
        "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
        "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}},
                  {"box": {"min": [1.99, -1, -1], "max": [2.01, 1, 1]},
                   "motion": {"rotate": {"axis": [1, 0, 0], "center": [2.0, 0.25, 0.25], "rate": 360.0}, "end": 0.25},
                   "release": 0.3}],
        "gravity": [0, 0, 0],
        "time": {"dt": 0.05, "frames": 10},
        "solver": {"type": "lbfgs", "iterations": 10},
        "study": {"frames": [8], "solvers": ["lbfgs", "newton"], "iterations": 100},
    }
    path = tmp_path / "release.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"], ranks=2)
    assert "fixed region(s) released" in proc.stdout
    with open(tmp_path / "study" / "trajectory.csv") as f:
        last = {r["solver"]: r for r in csv.DictReader(f) if r["frame"] == "10"}

    runs = plain_runs(tmp_path, deck, ranks=2)
    assert read_summary(runs["lbfgs"])["factorizations"] == 2
    a, b = final_frame(runs["lbfgs"]), final_frame(runs["reference"])
    free = read_summary(runs["lbfgs"])["dofs"] // 3
    rms = np.linalg.norm(a.points - b.points) / np.sqrt(free)
    assert rms > 1e-6, "the comparison needs a visible difference"
    assert float(last["lbfgs"]["rms_error"]) == pytest.approx(rms, rel=1e-6)


def test_study_cuts_the_trajectories_like_the_simulation(tmp_path):
    """test_cuts.py's bar sliced by a blade, with the blade in the rest frame (faces decided by the
    rest shape, so every solver's run cuts the same faces in the same frames), at one rank, where
    each cut's H0 follows by a TopologyH0 correction: the study cuts its reference and every
    trajectory together and says so; the per-frame comparison after cuts starts every solver from
    the same state; the lbfgs trajectory's RMS distance to the reference equals that of two plain
    runs (lbfgs, and the reference's Newton), as for a release above."""
    import copy
    import yaml
    from hyperqn_tools.output import final_frame, read_summary
    from test_cuts import BAR
    deck = copy.deepcopy(BAR)
    deck["cuts"][0]["frame"] = "rest"
    deck["solver"] = {"type": "lbfgs", "iterations": 10}
    deck["study"] = {"frames": [8], "solvers": ["lbfgs", "newton"], "iterations": 100}
    path = tmp_path / "cut.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"])
    cut_lines = [line for line in proc.stdout.splitlines() if line.startswith("study: t = ")]
    assert cut_lines and all(": cut: " in line and line.endswith("constant matrix corrected (TopologyH0)")
                             for line in cut_lines), proc.stdout[-3000:]
    assert float(cut_lines[0].split("t = ")[1].split(":")[0]) < 8 * deck["time"]["dt"]  # cut before frame 8
    with open(tmp_path / "study" / "study.csv") as f:
        rows = list(csv.DictReader(f))
    starts = {float(r["energy"]) for r in rows if r["iteration"] == "0"}
    assert len(starts) == 1
    assert min(float(r["rel_error"]) for r in rows if r["solver"] == "lbfgs") <= 1e-6
    with open(tmp_path / "study" / "trajectory.csv") as f:
        traj = list(csv.DictReader(f))
    frames = deck["time"]["frames"]
    assert [int(r["frame"]) for r in traj if r["solver"] == "lbfgs"] == list(range(1, frames + 1))
    last = {r["solver"]: r for r in traj if r["frame"] == str(frames)}

    runs = plain_runs(tmp_path, deck)
    s = read_summary(runs["lbfgs"])
    assert s["cuts"]["h0_corrections"] == len(cut_lines) and s["cuts"]["refactorizations"] == 0
    a, b = final_frame(runs["lbfgs"]), final_frame(runs["reference"])
    assert np.array_equal(a.vertex_id, b.vertex_id)
    rms = np.linalg.norm(a.points - b.points) / np.sqrt(s["dofs"] // 3)
    assert rms > 1e-6, "the comparison needs a visible difference"
    print(f"lbfgs against the reference after {len(cut_lines)} cuts: study {float(last['lbfgs']['rms_error']):.9e}, "
          f"plain runs {rms:.9e}")
    assert float(last["lbfgs"]["rms_error"]) == pytest.approx(rms, rel=1e-6)


def test_study_through_snaps_and_a_reference_that_is_not_the_lowest(tmp_path):
    """test_tearing.py's cube on two ropes, studied at frame 30, after the first snap: the study
    snaps the reference and every trajectory together (the reference's positions decide) and each
    trajectory runs to the end. Frame 30's step is not convex (a recoiling rope): the reference's
    exact Newton converges (|grad g| to 1e-13 of its start) to a stationary point above the lowest
    g that projected Newton finds (measured 3.5e-2 of g(x0) - g*), and the study says so."""
    import copy
    import yaml
    from test_tearing import ROPE
    deck = copy.deepcopy(ROPE)
    deck["solver"] = {"type": "lbfgs", "iterations": 20}
    deck["study"] = {"frames": [30], "solvers": ["lbfgs", "newton"], "iterations": 100}
    path = tmp_path / "rope.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"])
    assert "study: t = " in proc.stdout and ": snap: " in proc.stdout
    with open(tmp_path / "study" / "trajectory.csv") as f:
        traj = list(csv.DictReader(f))
    for solver in ("lbfgs", "newton"):
        assert [int(r["frame"]) for r in traj if r["solver"] == solver] == list(range(1, 41))
    with open(tmp_path / "study" / "study.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["frame"] == "30"]
    reference = [r for r in rows if r["solver"] == "reference"]
    assert float(reference[-1]["grad_norm"]) <= 1e-10 * float(reference[0]["grad_norm"])
    above = float(reference[-1]["rel_error"])
    assert above > 1e-6
    assert f"study frame   30  warning: a solver went below the converged reference by {above:.3e}" in proc.stdout


def test_integrator_axis(tmp_path):
    """study.integrators: the study once per integrator, each into OUTDIR/<integrator>/ with every
    solver at every study frame, and the report takes the parent directory for all of them."""
    deck = os.path.join(REPO, "tests/decks/study_small.yaml")
    text = open(deck).read().replace("  iterations: 100", "  iterations: 100\n  trajectory: false\n"
                                     "  integrators: [implicit-euler, bdf2, implicit-midpoint]")
    text = text.replace("solvers: [lbfgs, lbfgs-identity, pd, newton]", "solvers: [lbfgs, newton]")
    path = tmp_path / "axis.yaml"
    path.write_text(text)
    out = tmp_path / "axis"
    # A plain study in the same directory first: its files were left beside the integrators'
    # studies, and the report showed it alone (found from outside)
    plain = tmp_path / "plain.yaml"
    plain.write_text(text.replace("\n  integrators: [implicit-euler, bdf2, implicit-midpoint]", ""))
    run_hyperqn(["study", plain, "-o", out], ranks=1)
    assert (out / "study.csv").exists()
    proc = run_hyperqn(["study", path, "-o", out], ranks=1)
    assert f"{out} held an earlier study: 4 file(s) removed" in proc.stdout
    assert not any((out / f).exists() for f in ("study.csv", "trajectory.csv", "study.h5", "study.json"))
    integrators = ["implicit-euler", "bdf2", "implicit-midpoint"]
    for name in integrators:
        assert f"study written to {out / name}" in proc.stdout
        with open(out / name / "study.csv") as f:
            rows = list(csv.DictReader(f))
        assert {(r["solver"], r["frame"]) for r in rows} == {(s, f) for s in ("lbfgs", "newton", "reference")
                                                              for f in ("5", "15")}
        assert min(float(r["rel_error"]) for r in rows if r["solver"] == "newton") < 1e-6
    report = tmp_path / "report.md"
    subprocess.run(["/usr/bin/python3", "-m", "hyperqn_tools.study_report", str(out), "--out", str(report)],
                   check=True)
    text = report.read_text()
    for name in integrators:
        assert f"## axis, {name} (1 rank)" in text


def test_a_trajectory_that_diverges_is_stopped_and_said(tmp_path):
    """The study steps through the run's guardrails (src/app/frame_step.hpp): at h = 1 s with 10
    iterations, each step from y itself and no fallback chain, lbfgs's trajectory runs away
    (test_stability.py's h = 1 run-away); the study says so, writes the stopping frame with its
    reason in trajectory.csv's status, and goes on with the other solvers. Which guardrail stops it,
    and whether Newton's 10-iteration trajectory runs away too, depends on the CPU's round-off
    (an edge too long on one machine, |det F| too large at frame 9 on another), so either reason is
    taken."""
    reasons = ("diverged: ", "elements exploded: ")
    deck = os.path.join(REPO, "tests/decks/stability_dt_1.yaml")
    text = open(deck).read().replace("solver: {type: lbfgs}", "solver: {type: lbfgs, upright_guess: false}")
    text += "study: {frames: [1], solvers: [lbfgs, newton], trajectory_iterations: {lbfgs: 10, newton: 10}}\n"
    path = tmp_path / "h1.yaml"
    path.write_text(text)
    out = tmp_path / "h1"
    proc = run_hyperqn(["study", path, "-o", out], ranks=1)
    assert any(f"lbfgs           trajectory stopped by a guardrail: {r}" in proc.stdout for r in reasons)
    with open(out / "trajectory.csv") as f:
        rows = list(csv.DictReader(f))
    lbfgs = [r for r in rows if r["solver"] == "lbfgs"]
    assert [r["status"] for r in lbfgs[:-1]] == ["ok"] * (len(lbfgs) - 1)
    assert lbfgs[-1]["status"].startswith(reasons) and np.isnan(float(lbfgs[-1]["rms_error"]))
    assert int(lbfgs[-1]["frame"]) < 20
    # Newton goes on past lbfgs's stop: to the last frame, or to its own guardrail's stop.
    newton = [r for r in rows if r["solver"] == "newton"]
    assert [int(r["frame"]) for r in newton] == list(range(1, len(newton) + 1))
    assert len(newton) > int(lbfgs[-1]["frame"])
    assert len(newton) == 20 or newton[-1]["status"].startswith(reasons)
    assert [r["status"] for r in newton[:-1]] == ["ok"] * (len(newton) - 1)
    report = tmp_path / "report.md"
    subprocess.run(["/usr/bin/python3", "-m", "hyperqn_tools.study_report", str(out), "--out", str(report)],
                   check=True)
    assert f"lbfgs: trajectory stopped at frame {lbfgs[-1]['frame']}" in report.read_text()


@pytest.mark.parametrize("scene", ["tear", "fracture"])
def test_study_through_tears_and_fracture(tmp_path, scene):
    """The study tears test_cloth_tear.py's sheet (from frame 20, one edge a step) and breaks
    test_fracture.py's pulled bar (frame 20: 24 faces) as it snaps ropes: the reference and every
    trajectory together, each trajectory to the end, every solver at the study frame after them."""
    import copy
    import yaml
    if scene == "tear":
        from test_cloth_tear import CLOTH
        deck, frames, at, said = copy.deepcopy(CLOTH), 40, 30, ": tear: "
    else:
        from test_fracture import plate_mesh, pulled_plate
        deck, frames, at, said = pulled_plate(plate_mesh(tmp_path / "bar.mesh", (3, 10, 1)), 1.0, frames=30), 30, 25, ": fracture: "
    deck["time"]["frames"] = frames
    deck["solver"] = {"type": "lbfgs"}
    deck["study"] = {"frames": [at], "solvers": ["lbfgs", "newton"], "iterations": 100}
    path = tmp_path / f"{scene}.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"])
    changes = [line for line in proc.stdout.splitlines() if line.startswith("study: t = ") and said in line]
    assert changes and float(changes[0].split("t = ")[1].split(":")[0]) < at * deck["time"]["dt"]
    with open(tmp_path / "study" / "trajectory.csv") as f:
        traj = list(csv.DictReader(f))
    for solver in ("lbfgs", "newton"):
        assert [int(r["frame"]) for r in traj if r["solver"] == solver] == list(range(1, frames + 1))
    with open(tmp_path / "study" / "study.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["frame"] == str(at)]
    assert {r["solver"] for r in rows} == {"lbfgs", "newton", "reference"}
    assert all(math.isfinite(float(r["rel_error"])) for r in rows)


def test_a_study_of_bodies_names_each_body_s_material(tmp_path):
    import json
    import yaml
    block = lambda x, model: {"mesh": {"box": {"size": [0.2, 0.2, 0.2], "cells": [1, 1, 1]}, "transform": {"translate": [x, 0, 0]}},
                              "material": {"model": model, "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
                              "fixed": [{"box": {"min": [x - 0.01, -0.01, -0.01], "max": [x + 0.01, 0.21, 0.21]}}]}
    deck = {"bodies": [{"name": "soft", **block(0.0, "neohookean")}, {"name": "hard", **block(1.0, "stvk")},
                       {"name": "yielding", **block(2.0, "hencky")}],
            "gravity": [0, -9.81, 0], "time": {"dt": 0.02, "frames": 2},
            "study": {"frames": [1], "solvers": ["lbfgs"], "iterations": 20}}
    # an inelastic block is named with its model (before: "hencky", like the elastic one)
    deck["bodies"][2]["material"]["plastic"] = {"yield_stress": 1.0e3}
    path = tmp_path / "bodies.yaml"
    path.write_text(yaml.safe_dump(deck))
    run_hyperqn(["study", path, "-o", tmp_path / "study"], ranks=None)
    assert json.loads((tmp_path / "study" / "study.json").read_text())["material"] == \
        "soft: neohookean, hard: stvk, yielding: hencky + plastic"


BAR_AT_REST = {"mesh": {"box": {"size": [1.0, 0.2, 0.2], "cells": [4, 1, 1]}},
               "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
               "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
               "time": {"dt": 0.01, "frames": 2}}


def test_a_frame_that_starts_at_its_answer_has_error_0(tmp_path):
    """A bar at rest without gravity: g(x0) = g*, and e = (g - g*)/(g(x0) - g*) would be 0/0 (the
    CSV held -nan before). Every error is 0, and the study says why."""
    import yaml
    deck = dict(BAR_AT_REST, gravity=[0, 0, 0], study={"frames": [1], "solvers": ["lbfgs", "newton"], "trajectory": False})
    path = tmp_path / "rest.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"], ranks=None)
    assert "study frame    1  note: the frame starts at its answer" in proc.stdout
    with open(tmp_path / "study" / "study.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["solver"] for r in rows} == {"lbfgs", "newton", "reference"}
    assert all(float(r["rel_error"]) == 0.0 for r in rows)


def test_a_reference_that_stops_short_of_reference_rtol_is_said(tmp_path):
    """reference_rtol 1e-15 is below what Newton's round-off reaches on the bar (about 7e-13): the
    reference stops at its cap, and the study warns that smaller errors are not resolved."""
    import yaml
    deck = dict(BAR_AT_REST, study={"frames": [1], "solvers": ["lbfgs"], "trajectory": False, "reference_rtol": 1.0e-15})
    path = tmp_path / "tight.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"], ranks=None)
    assert re.search(r"study frame    1  warning: the reference stopped at its iteration cap \(\d+ iterations", proc.stdout)
    assert "not at study.reference_rtol = 1e-15" in proc.stdout
    # a time limit that stops the reference before its first iteration: said (not the note of a
    # frame that starts at its answer, which a bar at rest without gravity gets)
    rest = dict(BAR_AT_REST, gravity=[0, 0, 0], study={"frames": [1], "solvers": ["lbfgs"], "trajectory": False,
                                                       "time_limit": 1e-90})
    path.write_text(yaml.safe_dump(rest))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study_rest"], ranks=None)
    assert "warning: the reference stopped at study.time_limit (0 iterations" in proc.stdout
    assert "note: the frame starts at its answer" not in proc.stdout
    # the default reference_rtol is reached: no warning
    deck["study"].pop("reference_rtol")
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study2"], ranks=None)
    assert "warning: the reference stopped" not in proc.stdout


def test_a_reference_stopped_by_the_time_limit_is_not_called_a_higher_stationary_point(tmp_path):
    # Newton stopped after an iteration or two by study.time_limit, lbfgs below it: the study said
    # both "the reference ... converged to a stationary point that is not the lowest found" and
    # "the reference stopped at study.time_limit"; only the second is true
    import yaml
    deck = {"mesh": {"box": {"size": [2.0, 0.5, 0.5], "cells": [8, 2, 2]}},
            "material": {"model": "neohookean", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 1000},
            "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
            "gravity": [0, -9.81, 0], "time": {"dt": 1 / 30, "frames": 3},
            "study": {"frames": [2], "solvers": ["lbfgs"], "iterations": 60, "time_limit": 2e-4, "trajectory": False}}
    path = tmp_path / "limited.yaml"
    path.write_text(yaml.safe_dump(deck))
    proc = run_hyperqn(["study", path, "-o", tmp_path / "study"], ranks=None)
    assert "warning: the reference stopped at study.time_limit" in proc.stdout, proc.stdout[-3000:]
    assert "not the lowest found" not in proc.stdout
    # and at the frames the study does not compare, where the scene goes on along the reference's
    # path (the trajectories' too): said there as well (before: only at the compared frames)
    for frame in (1,):
        assert re.search(rf"study frame +{frame}  warning: the reference stopped at study.time_limit .*the scene goes "
                         r"on from a point not converged", proc.stdout), proc.stdout[-3000:]


@pytest.mark.parametrize("ranks", [None, 2])
def test_a_study_stopped_by_a_signal_keeps_its_whole_frames(tmp_path, ranks):
    """SIGTERM after frame 2 (the test hook): the study ends with exit 3, its files hold frames 1
    and 2 and no more, study.json says so, and no temporary is left (before: killed by the signal,
    exit 143, with .study.h5.tmp-PID left behind, which the next study into the directory kept)."""
    import json
    import yaml
    deck = dict(BAR_AT_REST, time={"dt": 0.01, "frames": 4},
                study={"frames": [1, 2, 3], "solvers": ["lbfgs", "newton"], "trajectory": True})
    path = tmp_path / "stopped.yaml"
    path.write_text(yaml.safe_dump(deck))
    out = tmp_path / "study"
    out.mkdir()
    (out / ".study.h5.tmp-99999").write_text("an earlier study killed while writing")
    proc = run_hyperqn(["study", path, "-o", out, "-hyperqn_test_signal_after_frame", "2"], ranks=ranks, check=False)
    assert proc.returncode == 3, proc.stdout[-2000:]
    assert "study stopped by SIGTERM" in proc.stdout and "holds the frames up to 2" in proc.stdout
    with open(out / "study.json") as f:
        assert json.load(f)["stopped"] == "SIGTERM after frame 2"
    with open(out / "study.csv") as f:
        assert {int(r["frame"]) for r in csv.DictReader(f)} == {1, 2}
    with open(out / "trajectory.csv") as f:
        assert {int(r["frame"]) for r in csv.DictReader(f)} == {1, 2}
    assert sorted(p.name for p in out.iterdir()) == ["study.csv", "study.h5", "study.json", "trajectory.csv"]
    report = tmp_path / "report.md"
    proc = subprocess.run(["/usr/bin/python3", "-m", "hyperqn_tools.study_report", str(out), "--out", str(report)],
                          capture_output=True, text=True, env=dict(os.environ, PYTHONPATH=os.path.join(REPO, "postprocess")))
    assert proc.returncode == 0 and "cut short (SIGTERM after frame 2)" in proc.stderr, proc.stderr
    assert "**Cut short: SIGTERM after frame 2**" in report.read_text()


def test_two_reports_in_one_directory_keep_their_own_overview(study, tmp_path):
    """study_report wrote overview.png beside every report: a second report in the directory replaced
    the figure the first links to. Each report now links REPORT_overview.png, its own."""
    out, _, _ = study
    for name in ("a.md", "b.md"):
        subprocess.run(["/usr/bin/python3", "-m", "hyperqn_tools.study_report", str(out), "--out", str(tmp_path / name)],
                       check=True, capture_output=True)
    for stem in ("a", "b"):
        assert f"![overview]({stem}_overview.png)" in (tmp_path / f"{stem}.md").read_text()
        assert (tmp_path / f"{stem}_overview.png").stat().st_size > 10000
