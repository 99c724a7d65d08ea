"""solver.h0: rest-stiffness end to end on tests/decks/h0_box.yaml (nu = 0.499): lbfgs with
A = M + h^2 K(x_rest) reaches the converged answer of Newton (exact Hessian) at 1 and 2 ranks,
the same at both, in fewer iterations than with M + h^2 L; after a fixed region is released the
scene is rebuilt and the rest stiffness factored again; pd ignores h0. solver.h0: volumetric the
same way: Newton's answer at 1 and 2 ranks, the same at both, in fewer iterations than laplacian,
and a run killed and restarted equals the uninterrupted one bit for bit. solver.h0: amg on
tests/decks/amg_bar.yaml: the converged answer of the exact solve at 1 and 2 ranks, 2-rank runs
that repeat, and a study that reaches e <= 1e-3. solver.h0: auto takes volumetric from nu = 0.499
on (the largest of the scene's materials; not with h0_contact: woodbury), laplacian below, bit for
bit as if given; the same at 1 and 2 ranks, through the fallback chain's sub-steps, and restarts
bitwise after a kill. solver.h0: auto takes rest-stiffness for a stiff scene held still
(tests/decks/steel_bar.yaml: the steel bar's tip at Newton's with the default deck), bit for bit as
given, before volumetric, at 1 and 2 ranks; laplacian for a softer bar, a fixed region that moves or
lets go, or a load. h0_contact: woodbury beside rest-stiffness or volumetric is refused."""
import copy
import csv
import re

import pytest

from conftest import NO_FALLBACK, load_deck, run_hyperqn, write_deck
from hyperqn_tools.compare import relative_difference
from hyperqn_tools.output import final_frame, read_iterations, read_summary
from test_checkpoint import assert_same_run
from test_bad_input import assert_deck_refused
from test_checkpoint_faults import assert_restart_after_kill_is_bitwise

DECK = "tests/decks/h0_box.yaml"
# amg against the exact solve, and 1 against 2 ranks, relative to the largest displacement: both
# runs converge to grad_rtol 1e-10 along different paths. Measured 1.05e-10 (amg vs laplacian, 1
# rank), 3.9e-11 (2 ranks), 6.9e-11 (amg at 1 vs 2 ranks).
AMG_TOLERANCE = 1e-9


def run(tmp_path, name, deck, ranks=1, status="ok"):
    out = tmp_path / name
    run_hyperqn([write_deck(tmp_path / f"{name}.yaml", deck), "-o", out], ranks=ranks)
    s = read_summary(out)
    assert s["status"].startswith(status), s
    return out, s


def iterations(out):
    return sum(1 for r in read_iterations(out) if r["iteration"] > 0)


def test_rest_stiffness_reaches_newtons_answer(tmp_path):
    deck = load_deck(DECK)
    newton = copy.deepcopy(deck)
    newton["solver"] = {"type": "newton", "newton_hessian": "exact", "iterations": 100, "grad_rtol": 1e-12}
    ref, _ = run(tmp_path, "newton", newton)
    rest1, s1 = run(tmp_path, "rest_np1", deck, ranks=1)
    rest2, s2 = run(tmp_path, "rest_np2", deck, ranks=2)
    assert s1["converged_frames"] == s1["frames"] == 3 and s2["converged_frames"] == 3
    assert s1["factorizations"] == 1
    to_newton, _, _ = relative_difference(ref, rest1)
    ranks, _, _ = relative_difference(rest1, rest2)
    print(f"rest-stiffness vs newton: {to_newton:.2e}, 1 vs 2 ranks: {ranks:.2e} of the largest displacement")
    assert to_newton <= 1e-6
    assert ranks <= 1e-8
    # The Laplacian does not see the volumetric modes: more iterations to the same tolerance.
    laplacian = copy.deepcopy(deck)
    laplacian["solver"]["h0"] = "laplacian"
    lap, _ = run(tmp_path, "laplacian", laplacian)
    print(f"iterations: rest-stiffness {iterations(rest1)}, laplacian {iterations(lap)}")
    assert iterations(rest1) < iterations(lap)
    assert relative_difference(ref, lap)[0] <= 1e-6


def test_volumetric_reaches_newtons_answer(tmp_path):
    deck = load_deck(DECK)
    deck["solver"]["h0"] = "volumetric"
    newton = copy.deepcopy(deck)
    newton["solver"] = {"type": "newton", "newton_hessian": "exact", "iterations": 100, "grad_rtol": 1e-12}
    ref, _ = run(tmp_path, "newton", newton)
    vol1, s1 = run(tmp_path, "vol_np1", deck, ranks=1)
    vol2, s2 = run(tmp_path, "vol_np2", deck, ranks=2)
    assert s1["converged_frames"] == s1["frames"] == 3 and s2["converged_frames"] == 3
    assert s1["factorizations"] == 1
    to_newton, _, _ = relative_difference(ref, vol1)
    ranks, _, _ = relative_difference(vol1, vol2)
    laplacian = copy.deepcopy(deck)
    laplacian["solver"]["h0"] = "laplacian"
    lap, _ = run(tmp_path, "laplacian", laplacian)
    print(f"volumetric vs newton: {to_newton:.2e}, 1 vs 2 ranks: {ranks:.2e}; "
          f"iterations: volumetric {iterations(vol1)}, laplacian {iterations(lap)}")
    assert to_newton <= 1e-6
    assert ranks <= 1e-8
    assert iterations(vol1) < iterations(lap)


@pytest.mark.parametrize("ranks", [1, 2])
def test_volumetric_restart_after_a_kill_is_bitwise(tmp_path, ranks):
    # The operator is factored from the rest shape alone, so a restart rebuilds it bit for bit:
    # a run killed (SIGKILL, every rank) after frame 4's checkpoint and restarted equals the
    # uninterrupted one in positions, velocities, iterations and the .pvd.
    deck = load_deck(DECK)
    deck["solver"]["h0"] = "volumetric"
    assert_restart_after_kill_is_bitwise(tmp_path, deck, ranks)


def auto_deck(poisson_ratio=0.499, **solver):
    """h0_box with solver.h0 left to auto."""
    deck = load_deck(DECK)
    deck["material"]["poisson_ratio"] = poisson_ratio
    deck["solver"] = {k: v for k, v in deck["solver"].items() if k != "h0"}
    deck["solver"].update(solver)
    return deck


def given(deck, h0):
    return {**deck, "solver": {**deck["solver"], "h0": h0}}


@pytest.mark.parametrize("poisson_ratio, region, solver, chosen", [
    (0.499, None, {}, "volumetric"),           # at the crossover (kVolumetricFromPoisson)
    (0.4999, None, {}, "volumetric"),
    (0.4988, None, {}, "laplacian"),           # just below it
    (0.45, None, {}, "laplacian"),
    (0.3, 0.4999, {}, "volumetric"),           # the largest of the scene's materials
    (0.4999, None, {"h0_contact": "woodbury"}, "laplacian"),  # woodbury needs M + h^2 L
])
def test_auto_h0_is_chosen_by_the_material(tmp_path, poisson_ratio, region, solver, chosen):
    # Positions, velocities, iterations and the summary's counts equal those of the run with the
    # chosen H0 given in the deck, bit for bit.
    deck = auto_deck(poisson_ratio, **solver)
    if region is not None:
        material = {**deck["material"], "poisson_ratio": region}
        deck["regions"] = [{"box": {"min": [1.0, -1, -1], "max": [3, 1, 1]}, "material": material}]
    auto, s = run(tmp_path, "auto", deck)
    explicit, e = run(tmp_path, chosen, given(deck, chosen))
    assert_same_run(auto, explicit)
    assert s["h0_factor_nonzeros"] == e["h0_factor_nonzeros"]
    other = "laplacian" if chosen == "volumetric" else "volumetric"
    other_deck = given(deck, other)
    other_deck["solver"].pop("h0_contact", None)  # woodbury beside volumetric is refused; no contact here
    _, o = run(tmp_path, other, other_deck)
    assert s["h0_factor_nonzeros"] != o["h0_factor_nonzeros"]  # the factor tells which was taken


def test_auto_volumetric_at_1_and_2_ranks_and_through_substeps(tmp_path):
    # 1 vs 2 ranks at nu = 0.499: both converge to grad_rtol 1e-10 (tolerance 1e-8 of the largest
    # displacement, as for volumetric given; at nu = 0.4999 the 2-rank run's last frame stops at
    # g's round-off, 5.8e-7 of the force scale). Then h = 0.2 s and a budget of 1 iteration without
    # extensions: the chain tries 2 sub-steps, whose constant matrix (the second factorization) is
    # the scene's kind (volumetric), bit for bit as given.
    deck = auto_deck(0.499)
    one, s1 = run(tmp_path, "np1", deck, ranks=1)
    two, s2 = run(tmp_path, "np2", deck, ranks=2)
    assert s1["converged_frames"] == s2["converged_frames"] == 3
    ranks, _, _ = relative_difference(one, two)
    print(f"auto (volumetric) 1 vs 2 ranks: {ranks:.2e} of the largest displacement")
    assert ranks <= 1e-8
    sub = auto_deck(0.4999, iterations=1, max_iterations=0, max_halvings=1, newton_fallback=False, grad_rtol=1e-6)
    sub["time"] = {**sub["time"], "dt": 0.2}
    far = "flagged: 3 of 3 frames could not decrease g or stayed far from converged"  # (1 iteration: by design)
    auto, s = run(tmp_path, "sub_auto", sub, status=far)
    explicit, _ = run(tmp_path, "sub_volumetric", given(sub, "volumetric"), status=far)
    assert s["factorizations"] == 2
    assert_same_run(auto, explicit, status=far)


@pytest.mark.parametrize("ranks", [1, 2])
def test_auto_volumetric_restart_after_a_kill_is_bitwise(tmp_path, ranks):
    assert_restart_after_kill_is_bitwise(tmp_path, auto_deck(0.4999), ranks)


@pytest.mark.parametrize("ranks", [1, 2])
def test_rest_stiffness_after_release(tmp_path, ranks):
    # The far end is held at rest for 2 frames, then released: the scene is rebuilt and
    # M + h^2 K(x_rest) factored again with its vertices free.
    deck = load_deck(DECK)
    deck["time"]["frames"] = 4
    deck["fixed"].append({"box": {"min": [1.999, -1, -1], "max": [2.001, 1, 1]}, "release": 0.06})
    rest, s = run(tmp_path, f"release_np{ranks}", deck, ranks=ranks)
    assert s["factorizations"] == 2 and s["converged_frames"] == 4
    laplacian = copy.deepcopy(deck)
    laplacian["solver"]["h0"] = "laplacian"
    lap, _ = run(tmp_path, f"release_laplacian_np{ranks}", laplacian, ranks=ranks)
    assert relative_difference(lap, rest)[0] <= 1e-6


def test_other_solvers_ignore_h0(tmp_path):
    # pd is defined by M + h^2 L: with h0: rest-stiffness it takes the same steps as without.
    deck = load_deck(DECK)
    deck["solver"] = {"type": "pd", "iterations": 20, **NO_FALLBACK}  # the scene's factorizations only
    plain, _ = run(tmp_path, "pd", deck)
    deck["solver"]["h0"] = "rest-stiffness"
    with_h0, s = run(tmp_path, "pd_h0", deck)
    assert s["factorizations"] == 1
    def steps(out):
        return [{k: v for k, v in r.items() if k != "time_s"} for r in read_iterations(out)]
    assert steps(plain) == steps(with_h0)


@pytest.mark.parametrize("h0", ["volumetric", "rest-stiffness"])
def test_woodbury_beside_a_full_matrix_is_refused(tmp_path, h0):
    # h0_contact: woodbury corrects the factor of A1 (x) I3; beside these 3n x 3n matrices it did
    # nothing (before: a self-contact run's frames byte for byte those of off, config.yaml saying woodbury).
    deck = load_deck(DECK)
    deck["solver"] = {"h0": h0, "h0_contact": "woodbury"}
    assert_deck_refused(tmp_path, "woodbury", deck, ["solver.h0_contact", "woodbury corrects the factor of M + h^2 L",
                                                     f"h0: {h0} is a full 3n x 3n matrix"])


# solver.h0: amg (tests/decks/amg_bar.yaml): M + h^2 L applied by one GAMG V-cycle, distributed.
AMG_DECK = "tests/decks/amg_bar.yaml"


def gamg_levels(stdout):
    """Levels of the h0_ multigrid from -h0_ksp_view's 'levels=N'."""
    m = re.search(r"levels=(\d+)", stdout)
    assert m, stdout[-3000:]
    return int(m.group(1))


@pytest.mark.parametrize("ranks", [1, 2])
def test_amg_reaches_the_laplacian_answer(tmp_path, ranks):
    # An approximate H0 changes the path, not the answer: every frame converges (grad_rtol 1e-10)
    # to the positions the exact M + h^2 L solve gives. The V-cycle has a coarse level (it is not
    # a direct solve in disguise) and takes more iterations than the exact solve.
    deck = load_deck(AMG_DECK)
    out = tmp_path / f"amg_np{ranks}"
    proc = run_hyperqn([write_deck(tmp_path / "amg.yaml", deck), "-o", out, "-h0_ksp_view"], ranks=ranks)
    s = read_summary(out)
    assert s["status"] == "ok" and s["converged_frames"] == 3, s
    assert s["h0_package"] == "amg" and s["h0_factor_nonzeros"] > 0 and s["factorizations"] == 1
    assert gamg_levels(proc.stdout) >= 2
    laplacian = copy.deepcopy(deck)
    laplacian["solver"]["h0"] = "laplacian"
    lap, _ = run(tmp_path, f"laplacian_np{ranks}", laplacian, ranks=ranks)
    diff, _, _ = relative_difference(lap, out)
    print(f"amg vs laplacian at {ranks} rank(s): {diff:.2e} of the largest displacement; "
          f"iterations {iterations(out)} vs {iterations(lap)}")
    assert diff <= AMG_TOLERANCE
    assert iterations(out) > iterations(lap)


def test_amg_one_and_two_ranks_agree_and_repeat(tmp_path):
    # At 2 ranks the hierarchy differs from 1 rank's (aggregation follows the partition), so the
    # iterates differ; the converged answers agree to the solver tolerance. Two runs at 2 ranks
    # take the same steps: iterations.csv equal apart from timings.
    deck = load_deck(AMG_DECK)
    one, _ = run(tmp_path, "np1", deck, ranks=1)
    two, _ = run(tmp_path, "np2", deck, ranks=2)
    again, _ = run(tmp_path, "np2_again", deck, ranks=2)
    diff, _, _ = relative_difference(one, two)
    print(f"amg 1 vs 2 ranks: {diff:.2e} of the largest displacement")
    assert diff <= AMG_TOLERANCE

    def steps(out):
        return [{k: v for k, v in r.items() if k != "time_s"} for r in read_iterations(out)]
    assert steps(two) == steps(again)


def test_amg_with_another_preconditioner_warns_of_nothing_unasked(tmp_path):
    # hyperqn's own -matptap_via (GAMG's coarse products at 2 ranks and more) was warned of as
    # "given but never used (misspelt...)" when -h0_pc_type hypre made no products
    proc = run_hyperqn([write_deck(tmp_path / "amg.yaml", load_deck(AMG_DECK)), "-o", tmp_path / "hypre", "-h0_pc_type", "hypre"],
                       ranks=2)
    assert "matptap_via" not in proc.stdout, proc.stdout[-2000:]
    assert "hyperqn: warning" not in proc.stdout


def test_amg_in_the_fallback_chain(tmp_path):
    # 2 iterations per frame leave every frame far from converged: the chain redoes it in 2 and 4
    # sub-steps, each size with its own V-cycle of M + (h/k)^2 L (3 setups in all); still far, every
    # frame is flagged.
    deck = load_deck(AMG_DECK)
    deck["solver"].update({"iterations": 2, "max_iterations": 2, "max_halvings": 2, "newton_fallback": False})
    _, s = run(tmp_path, "chain", deck, status="flagged: 3 of 3 frames could not decrease g or stayed far from converged")
    assert s["h0_package"] == "amg" and s["factorizations"] == 3


def test_amg_study_reaches_1e3(tmp_path):
    # The error-against-time study with lbfgs + amg: e <= 1e-3 at both study frames; the pd
    # contender beside it factors M + h^2 L as always.
    deck = load_deck("tests/decks/study_small.yaml")
    deck["solver"] = {"h0": "amg"}
    deck["study"].update({"solvers": ["lbfgs", "pd"], "trajectory": False})
    out = tmp_path / "study"
    run_hyperqn(["study", write_deck(tmp_path / "study.yaml", deck), "-o", out], ranks=2)
    with open(out / "study.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["solver"] == "lbfgs"]
    for frame in ("5", "15"):
        best = min(float(r["rel_error"]) for r in rows if r["frame"] == frame)
        print(f"frame {frame}: lbfgs + amg reached e = {best:.1e}")
        assert best <= 1e-3


# A cloth dropped on a sphere with friction (found from outside): with the rest stiffness the
# fallback chain's sub-step matrices M + (h/k)^2 K are factored when first needed; K included the
# contact term's Hessian (the sphere where it stood, the lagged friction), so a restart, which
# factors them at another frame, went another way (5.7e-2 of the diagonal at the end). K is the
# scene's alone now (EnergyTerm::add_rest_stiffness): no contact, histories at their start.
DRAPE = {"mesh": {"sheet": {"size": [1.0, 1.0], "cells": [12, 12]}, "transform": {"translate": [-0.2, 0.55, -0.5]}},
         "cloth": {"model": "mass-spring", "stretch_stiffness": 2.0e2, "bending": {"model": "dihedral", "stiffness": 1e-4},
                   "areal_density": 0.15},
         "colliders": [{"type": "sphere", "center": [0, 0.25, 0], "radius": 0.25, "friction": 0.05}],
         "gravity": [0, -9.81, 0],
         "time": {"dt": 1 / 30, "frames": 40},
         "solver": {"type": "lbfgs", "h0": "rest-stiffness"}}


@pytest.mark.parametrize("ranks", [1, 2])
def test_rest_stiffness_restart_with_friction_and_substeps_is_bitwise(tmp_path, ranks):
    ref, _ = assert_restart_after_kill_is_bitwise(tmp_path, DRAPE, ranks, frames=40, every=15, kill_after=20)
    assert read_summary(ref)["substepped_frames"] > 0  # what made the difference: sub-step matrices


def test_rest_stiffness_of_a_yielding_cloth_restarts_bitwise(tmp_path):
    # the same through a history: the drape without friction, its edge springs yielding
    deck = {**DRAPE, "colliders": [{**DRAPE["colliders"][0], "friction": 0.0}],
            "cloth": {**DRAPE["cloth"], "yield_strain": 0.002}}
    ref, _ = assert_restart_after_kill_is_bitwise(tmp_path, deck, 1, frames=40, every=15, kill_after=20)
    assert read_summary(ref)["substepped_frames"] > 0


STEEL_BAR = "tests/decks/steel_bar.yaml"
# The steel bar's tip against Newton's: measured 1.6e-7 of it with auto (rest-stiffness, 1.9 it.
# per frame); M + h^2 L at the same budget ended 287 times Newton's deflection, status ok.
STEEL_TIP_TOLERANCE = 1e-3


def tip_deflection(out):
    """The mean y-displacement of the vertices at x = max of the final frame."""
    f = final_frame(out)
    x = f.points[:, 0]
    return float(f.displacement[x >= x.max() - 1e-9, 1].mean())


def test_steel_bar_tip_is_newtons_with_the_default_deck(tmp_path):
    # input/bar.yaml in steel (E = 2e11), 8 x 2 x 2 cubes, 10 frames, the default solver settings:
    # auto takes the rest stiffness (the log says so) and the tip ends at Newton's.
    deck = load_deck(STEEL_BAR)
    newton = copy.deepcopy(deck)
    newton["solver"] = {"type": "newton", "newton_hessian": "exact", "iterations": 100, "grad_rtol": 1e-10,
                        "max_halvings": 0, "newton_fallback": False}
    ref = tmp_path / "newton"
    run_hyperqn([write_deck(tmp_path / "newton.yaml", newton), "-o", ref])
    assert read_summary(ref)["frames"] == 10  # (its status may flag frames that stop at g's round-off)
    out = tmp_path / "auto"
    proc = run_hyperqn([write_deck(tmp_path / "auto.yaml", deck), "-o", out])
    s = read_summary(out)
    assert s["status"] == "ok", s["status"]
    tip, expected = tip_deflection(out), tip_deflection(ref)
    print(f"steel bar tip: auto {tip:.6e}, newton {expected:.6e}; {s['mean_iterations']} it. per frame")
    assert abs(tip - expected) <= STEEL_TIP_TOLERANCE * abs(expected)
    assert "solver.h0: auto takes rest-stiffness" in proc.stdout


@pytest.mark.parametrize("change, chosen", [
    ({}, "rest-stiffness"),
    ({"material": {"youngs_modulus": 5.0e6}}, "laplacian"),  # self-weight deflection scale 0.15 > 0.1
    ({"release": 0.2}, "laplacian"),                          # a fixed region that lets go
    ({"motion": {"translate": {"velocity": [0, 0.1, 0]}}}, "laplacian"),  # or moves
    ({"loads": [{"type": "traction", "box": {"min": [3.99, -0.01, -0.01], "max": [4.01, 1.01, 1.01]},
                 "traction": [0, -1.0, 0]}]}, "laplacian"),  # anything else acting on it
    ({"material": {"poisson_ratio": 0.4999}}, "rest-stiffness"),  # before volumetric
])
def test_auto_h0_takes_rest_stiffness_for_a_stiff_scene_held_still(tmp_path, change, chosen):
    # Bit for bit as the chosen H0 given in the deck; the factor tells which was taken.
    deck = load_deck(STEEL_BAR)
    deck["time"]["frames"] = 3
    deck["material"].update(change.get("material", {}))
    for key in ("release", "motion"):
        if key in change:
            deck["fixed"][0][key] = change[key]
    if "loads" in change:
        deck["loads"] = change["loads"]
    auto, s = run(tmp_path, "auto", deck, status="")
    explicit, e = run(tmp_path, chosen, given(deck, chosen), status="")
    assert_same_run(auto, explicit, status="")
    assert s["h0_factor_nonzeros"] == e["h0_factor_nonzeros"]
    other = "laplacian" if chosen == "rest-stiffness" else "rest-stiffness"
    _, o = run(tmp_path, other, given(deck, other), status="")
    assert s["h0_factor_nonzeros"] != o["h0_factor_nonzeros"]


def test_auto_rest_stiffness_at_2_ranks(tmp_path):
    # The choice is the same at 2 ranks (the rest bounding box is reduced over them) and the
    # answer that of 1 rank.
    deck = load_deck(STEEL_BAR)
    deck["time"]["frames"] = 3
    one, s1 = run(tmp_path, "np1", deck)
    two, s2 = run(tmp_path, "np2", deck, ranks=2)
    explicit, e2 = run(tmp_path, "given_np2", given(deck, "rest-stiffness"), ranks=2)
    assert_same_run(two, explicit)
    assert relative_difference(one, two)[0] <= 1e-6


def test_factor_nonzeros_are_written_whole(tmp_path):
    # summary.json's h0_factor_nonzeros was streamed at 6 significant digits: 1.4211e+06 for this
    # box's 1,421,100 entries (the other numbers are written at full precision)
    deck = {"mesh": {"box": {"size": [1.0, 1.0, 1.0], "cells": [12, 12, 12]}},
            "material": {"model": "corotated", "youngs_modulus": 1.0e5, "poisson_ratio": 0.3, "density": 100},
            "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 2, 2]}}],
            "time": {"dt": 0.01, "frames": 1}, "output": {"vtk": False}}
    out, s = run(tmp_path, "nonzeros", deck)
    written = re.search(r'"h0_factor_nonzeros": ([^,\n]*),', (out / "summary.json").read_text()).group(1)
    assert re.fullmatch(r"\d+", written) and s["h0_factor_nonzeros"] > 1e6, written
