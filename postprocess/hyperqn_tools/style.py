"""How the plots draw each solver (colour, line style), the same in every figure. A solver not
listed here (a new one in the registry) gets the next colour of matplotlib's cycle."""
SOLVER_STYLE = {"lbfgs": ("C0", "-"), "newton": ("C3", "-"), "pd": ("C2", "--"), "lbfgs-identity": ("C1", ":"),
                "reference": ("0.55", "-")}


def solver_style(name):
    """(colour, line style) of a solver's curves."""
    return SOLVER_STYLE.get(name, (None, "-"))


# Plots are optional (tables, CSV and Markdown are the tools' results): without matplotlib a tool
# writes those, says this, and skips its figures; a figure asked for by name (--png) is refused.
NO_MATPLOTLIB = "matplotlib is not installed (Debian: apt-get install python3-matplotlib)"


def pyplot():
    """matplotlib.pyplot drawing into files (the Agg backend), or None without matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt
