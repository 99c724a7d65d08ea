"""The stability suite (`python3 -m hyperqn_tools.stability`, see suite.py): run.py runs a case
with a solver, judge.py measures a run and gives its verdict, report.py writes the CSV, Markdown
and figures, suite.py does all of it for a set of decks. The names below are what the tests and
other scripts use."""
from hyperqn_tools.decks import load_deck
from hyperqn_tools.stability.judge import (BLOWUP_TOL, REF_TOL, REST_TOL, analyse_run, completed,
                                           reference_distance, reference_ok, rest_distance, verdict)
from hyperqn_tools.stability.run import REFERENCE_SOLVER, expectation, rejection, run_deck
from hyperqn_tools.stability.suite import main

__all__ = ["BLOWUP_TOL", "REF_TOL", "REST_TOL", "REFERENCE_SOLVER", "analyse_run", "completed",
           "expectation", "load_deck", "main", "reference_distance", "reference_ok", "rejection", "rest_distance",
           "run_deck", "verdict"]
