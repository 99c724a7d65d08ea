"""How the plots draw each solver (colour, line style), the same in every figure. A solver not
listed here (a new one in the registry) gets the next colour of matplotlib's cycle."""
SOLVER_STYLE = {"lbfgs": ("C0", "-"), "newton": ("C3", "-"), "pd": ("C2", "--"), "lbfgs-identity": ("C1", ":"),
                "reference": ("0.55", "-")}


def solver_style(name):
    """(colour, line style) of a solver's curves."""
    return SOLVER_STYLE.get(name, (None, "-"))
