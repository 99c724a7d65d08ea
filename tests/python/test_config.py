"""`hyperqn config DECK` (docs/deck-run.md#the-effective-configuration): every setting with its value
and source. On every deck of input/: it exits 0, and every key the deck gives appears with its deck
line and the value the deck wrote; contact's solver defaults come from their rule; the command line's
options and -o are marked as such; a run writes the same text to OUTDIR/config.yaml; bad input is
exit 1 with the key named."""
import glob
import os
import re

import pytest
import yaml

from conftest import REPO, run_hyperqn, write_deck

LINE = re.compile(r"^(\S+): (.*?)  # (.*)$")
SHARED_MESHES = os.path.join(REPO, "..", "shared", "meshes")


def config(args):
    """{key: (value as YAML, source)} of `hyperqn config args...` (1 process)."""
    proc = run_hyperqn(["config"] + list(args), ranks=None, timeout=120)
    out = {}
    for text in proc.stdout.splitlines():
        if text.startswith("#") or not text.strip():
            continue
        m = LINE.match(text)
        assert m, f"not a 'key: value  # source' line: {text!r}"
        assert m.group(1) not in out, f"{m.group(1)} listed twice"
        out[m.group(1)] = (m.group(2), m.group(3))
    return out


def deck_leaves(path):
    """(dotted key, line, value) of every leaf the deck gives (a scalar, or a list of non-maps), keyed as
    the deck reader keys them ("bodies[0].material.mu"), from PyYAML's node tree."""
    root = yaml.compose(open(path).read())
    leaves = []

    def walk(node, key, line):
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                walk(v, f"{key}.{k.value}" if key else k.value, k.start_mark.line + 1)
        elif isinstance(node, yaml.SequenceNode) and any(isinstance(i, yaml.MappingNode) for i in node.value):
            for i, item in enumerate(node.value):
                walk(item, f"{key}[{i}]", line)
        else:
            leaves.append((key, line, yaml.safe_load(yaml.serialize(node))))

    walk(root, "", 0)
    return leaves


def same(a, b):
    """Values equal as the run reads them: numbers as numbers (PyYAML reads 1e5 as text)."""
    if isinstance(a, list) or isinstance(b, list):
        return isinstance(a, list) and isinstance(b, list) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, bool) or isinstance(b, bool):
        return a == b
    try:
        return float(a) == float(b)
    except (TypeError, ValueError):
        return a == b or (a is None and b == "") or (b is None and a == "")


def decks():
    paths = sorted(glob.glob(os.path.join(REPO, "input", "**", "*.yaml"), recursive=True))
    return [p for p in paths if "sweep" not in yaml.safe_load(open(p))]  # a sweep names a deck, it is none


@pytest.mark.parametrize("deck", decks(), ids=lambda p: os.path.relpath(p, os.path.join(REPO, "input")))
def test_every_key_of_every_deck(deck):
    if "shared/meshes" in open(deck).read() and not os.path.isdir(SHARED_MESHES):
        pytest.skip("needs ../shared/meshes")
    settings = config([deck])
    for key, line, value in deck_leaves(deck):
        assert key in settings, f"{key} (deck line {line}) is not listed"
        shown, source = settings[key]
        assert source == f"deck line {line}", (key, source)
        if key.endswith(".file") or key == "partition":  # resolved against the deck's directory
            assert os.path.normpath(os.path.join(os.path.dirname(deck), value)) == os.path.normpath(yaml.safe_load(shown))
        else:
            assert same(yaml.safe_load(shown), value), (key, shown, value)
    # What the deck leaves out is there too, with its default.
    given = {key for key, _, _ in deck_leaves(deck)}
    for key in ("solver.iterations", "time.dt", "output.every", "guardrails.element_limit"):
        assert key in settings and (key in given or settings[key][1].startswith("default")), (key, settings.get(key))


def test_contact_defaults_come_from_their_rule():
    settings = config([os.path.join(REPO, "input", "contact", "incline_slide.yaml")])
    assert settings["solver.history"] == ("20", "rule: contact (colliders or self-contact)")
    assert settings["solver.warm_start"] == ("lower", "rule: contact (colliders or self-contact)")
    bar = config([os.path.join(REPO, "input", "bar.yaml")])  # no contact: the keys' own defaults
    assert bar["solver.history"][1].startswith("default") and bar["solver.warm_start"][1].startswith("default")


def test_derived_values_and_the_command_line(tmp_path):
    deck = write_deck(tmp_path / "d.yaml", {
        "mesh": {"box": {"size": [1, 0.2, 0.2], "cells": [4, 1, 1]}},
        "material": {"model": "corotated", "youngs_modulus": 1e5, "poisson_ratio": 0.25, "density": 1000},
        "time": {"dt": 0.01, "frames": 1},
        "solver": {"budget": "fixed"},
        "guardrails": {"element_limit": 40},
        "petsc": {"tao": {"ls_type": "armijo"}},
    })
    settings = config([deck, "-o", tmp_path / "out", "-hyperqn_element_limit", "50", "-tao_ls_type", "unit",
                       "-log_view_memory"])
    assert settings["material.mu"] == ("40000", "rule: from youngs_modulus and poisson_ratio")  # E / (2 (1 + nu))
    assert "material.total_mass" not in settings  # the deck gives density
    assert settings["solver.max_halvings"] == ("0", "rule: budget: fixed")
    assert settings["output.directory"] == (str(tmp_path / "out"), "command line")
    assert settings["guardrails.element_limit"] == ("50", "command line")  # over the deck's 40
    assert settings["guardrails.divergence_limit"] == ("10", "default")
    assert settings["petsc.tao.ls_type"] == ("unit", "command line")  # the command line wins over the deck
    assert settings["options.log_view_memory"] == ('""', "command line")
    # Without the override the deck's value and line.
    settings = config([deck])
    assert settings["petsc.tao.ls_type"][1].startswith("deck line ")
    assert settings["guardrails.element_limit"][0] == "40" and settings["guardrails.element_limit"][1].startswith("deck line ")
    assert settings["output.directory"] == ("output/d", "default (output/<name>)")


def test_a_run_writes_the_same_config(tmp_path):
    deck = write_deck(tmp_path / "d.yaml", {
        "mesh": {"box": {"size": [1, 0.2, 0.2], "cells": [4, 1, 1]}},
        "material": {"model": "corotated", "mu": 1e5, "lambda": 1e5, "density": 1000},
        "time": {"dt": 0.01, "frames": 1},
    })
    out = tmp_path / "out"
    args = [deck, "-o", out, "-hyperqn_divergence_limit", "20"]
    run_hyperqn(args, ranks=None, timeout=120)
    printed = run_hyperqn(["config"] + args, ranks=None, timeout=120).stdout
    assert (out / "config.yaml").read_text() == printed
    assert yaml.safe_load(printed)["guardrails.divergence_limit"] == 20  # the file is YAML


@pytest.mark.parametrize("section,key,value,words", [
    ("solver", "history", -1, "solver.history"),
    ("solver", "histroy", 5, "unknown key 'histroy'"),
    ("time", "dt", "fast", "time.dt"),
])
def test_bad_input_names_the_key(tmp_path, section, key, value, words):
    deck = {"mesh": {"box": {"size": [1, 0.2, 0.2], "cells": [4, 1, 1]}},
            "material": {"model": "corotated", "mu": 1e5, "lambda": 1e5, "density": 1000},
            "time": {"dt": 0.01, "frames": 1}}
    deck.setdefault(section, {})[key] = value
    proc = run_hyperqn(["config", write_deck(tmp_path / "bad.yaml", deck)], ranks=None, check=False, timeout=120)
    assert proc.returncode == 1, proc.stdout
    assert "error" in proc.stdout and words in proc.stdout, proc.stdout


def test_bad_option_names_it(tmp_path):
    deck = write_deck(tmp_path / "d.yaml", {
        "mesh": {"box": {"size": [1, 0.2, 0.2], "cells": [4, 1, 1]}},
        "material": {"model": "corotated", "mu": 1e5, "lambda": 1e5, "density": 1000},
    })
    proc = run_hyperqn(["config", deck, "-hyperqn_h0_package", "nope"], ranks=None, check=False, timeout=120)
    assert proc.returncode == 1 and "-hyperqn_h0_package" in proc.stdout, proc.stdout


def test_a_key_whose_default_is_none_shows_none():
    """Left out, a key declared with the default none shows none, not its member's zero or [] (a
    load's normal showed [0, 0, 0], a value the deck refuses; output.fields showed [])."""
    settings = config([os.path.join(REPO, "input", "engineering", "bar_tip_load.yaml")])
    assert settings["loads[0].normal"] == ("none", "default")
    assert settings["output.fields"] == ("none", "default")
    assert settings["loads[1].normal"] == ("[0, 1, 0]", "deck line 15")


def test_tao_s_options_show_as_the_keys_they_set(tmp_path):
    """-tao_lmvm_mat_lmvm_hist_size is read over solver.history (solvers/lbfgs_solver.cpp): config
    showed the deck's history with its deck line, and the option only among the options."""
    deck = write_deck(tmp_path / "d.yaml", {
        "mesh": {"box": {"size": [1, 0.2, 0.2], "cells": [4, 1, 1]}},
        "material": {"model": "corotated", "youngs_modulus": 1e5, "poisson_ratio": 0.25, "density": 1000},
        "time": {"dt": 0.01, "frames": 1},
        "solver": {"history": 7},
    })
    assert config([deck])["solver.history"][0] == "7"
    # the budget and tolerances likewise (config said iterations: 2000 while -tao_max_it 7 ran)
    settings = config([deck, "-tao_max_it", "7", "-tao_gatol", "1e-9", "-tao_grtol", "0"])
    assert settings["solver.iterations"] == ("7", "option -tao_max_it, command line")
    assert settings["solver.grad_atol"] == ("1e-9", "option -tao_gatol, command line")
    assert settings["solver.grad_rtol"] == ("0", "option -tao_grtol, command line")
    # and refuses what a run refuses (config printed 'solver.history: abc' and exited 0)
    for bad in (["-tao_max_it", "-1"], ["-tao_gatol", "-1"], ["-tao_lmvm_mat_lmvm_hist_size", "abc"],
                ["-tao_lmvm_mat_lmvm_hist_size", "1001"]):
        proc = run_hyperqn(["config", deck] + bad, ranks=None, check=False, timeout=60)
        assert proc.returncode == 1 and f"option {bad[0]} {bad[1]}: " in proc.stdout, proc.stdout
    settings = config([deck, "-tao_lmvm_mat_lmvm_hist_size", "12"])
    assert settings["solver.history"] == ("12", "option -tao_lmvm_mat_lmvm_hist_size, command line")
    with_option = write_deck(tmp_path / "e.yaml", {**yaml.safe_load(open(deck)), "petsc": {"tao_lmvm_mat_lmvm_hist_size": 9}})
    value, source = config([with_option])["solver.history"]
    assert value == "9" and source.startswith("option -tao_lmvm_mat_lmvm_hist_size, deck line "), source
    # the same for the line search (TAO's -tao_ls_type over solver.line_search)
    assert config([deck, "-tao_ls_type", "armijo"])["solver.line_search"] == ("armijo", "option -tao_ls_type, command line")


def test_config_is_yaml_whatever_the_deck_s_list_style(tmp_path):
    """A list the deck writes as a block (a curve's points, a strand's end) was echoed as written
    among the keys a section's own reader reads: config.yaml was not YAML (and force_displacement,
    which reads it, failed)."""
    deck = tmp_path / "d.yaml"
    deck.write_text("""mesh: {box: {size: [1, 0.2, 0.2], cells: [4, 1, 1]}}
material: {model: corotated, youngs_modulus: 1.0e5, poisson_ratio: 0.3, density: 1000}
fixed:
  - box: {min: [-0.01, -1, -1], max: [0.01, 1, 1]}
  - box: {min: [0.99, -1, -1], max: [1.01, 1, 1]}
    motion:
      translate:
        velocity:
          - 0.1
          - 0
          - 0
      curve:
        type: table
        points:
          - [0, 0]
          - [1, 1]
time: {dt: 0.01, frames: 1}
""")
    proc = run_hyperqn(["config", deck], ranks=None, timeout=120)
    settings = yaml.safe_load(proc.stdout)
    assert settings["fixed[1].motion.curve.points"] == [[0, 0], [1, 1]]
    assert settings["fixed[1].motion.translate.velocity"] == [0.1, 0, 0]


def test_a_left_out_key_shows_its_default_not_a_stand_in():
    """Found from outside: config showed the members' stand-ins, which the run does not use as such
    and the keys refuse: components [] (all three held), release -1 (never), pseudo_step 0 (auto),
    motion.end 1e300 (never)."""
    settings = config([os.path.join(REPO, "input", "engineering", "static_cantilever.yaml")])
    assert settings["fixed[0].components"] == ("[x, y, z]", "default")
    assert settings["fixed[0].release"] == ("never", "default")
    assert settings["time.pseudo_step"][0] == "auto"
    settings = config([os.path.join(REPO, "input", "contact", "twist.yaml")])
    assert settings["fixed[0].motion.end"] == ("never", "default")
    # worked out as the scene is built: auto, not the 0 the keys refuse
    settings = config([os.path.join(REPO, "input", "contact", "bunny_drop.yaml")])
    for key in ("contact.friction_velocity", "material.laplacian_weight"):
        assert settings[key][0] == "auto", (key, settings[key])


def test_a_cut_lists_its_defaults(tmp_path):
    """Found from outside: a blade's keys were listed only as the deck wrote them, among the keys a
    section's own reader reads: frame, remove, motion.start and motion.end left out at their defaults
    were missing, and a surface blade's surface_scale and surface_offset."""
    settings = config([os.path.join(REPO, "input", "topology", "bar_sliced.yaml")])
    assert settings["cuts[0].frame"] == ("world", "default")
    assert settings["cuts[0].remove"] == ("false", "default")
    assert settings["cuts[0].center"][1].startswith("deck line ")
    assert "cuts[0].surface" not in settings and "cuts[0].surface_scale" not in settings  # the rectangle's
    (tmp_path / "blade.obj").write_text("v 1 -1 -1\nv 1 2 -1\nv 1 -1 2\nf 1 2 3\n")
    deck = write_deck(tmp_path / "d.yaml", {
        "mesh": {"box": {"size": [2, 0.5, 0.5], "cells": [4, 1, 1]}},
        "material": {"model": "neohookean", "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000},
        "cuts": [{"surface": "blade.obj", "motion": {"translate": {"velocity": [0, -1, 0]}}}],
        "time": {"dt": 0.01, "frames": 1},
    })
    settings = config([deck])
    assert settings["cuts[0].surface_scale"] == ("1", "default")
    assert settings["cuts[0].surface_offset"] == ("[0, 0, 0]", "default")
    assert settings["cuts[0].motion.start"] == ("0", "default")
    assert settings["cuts[0].motion.end"] == ("never", "default")
    assert "cuts[0].center" not in settings and "cuts[0].size" not in settings  # the surface's


def test_plastic_hardening_and_loads_list_what_applies(tmp_path):
    """Found from outside: a plastic map without its hardening moduli listed neither (they default
    to 0); a force or body_force load listed `normal: none` and `angle: 30`, which it refuses."""
    deck = write_deck(tmp_path / "d.yaml", {
        "mesh": {"box": {"size": [1, 0.2, 0.2], "cells": [4, 1, 1]}},
        "material": {"model": "hencky", "youngs_modulus": 1e5, "poisson_ratio": 0.3, "density": 1000,
                     "plastic": {"yield_stress": 5}},
        "fixed": [{"box": {"min": [-0.01, -1, -1], "max": [0.01, 1, 1]}}],
        "loads": [{"type": "force", "box": {"min": [0.99, -1, -1], "max": [1.01, 1, 1]}, "force": [0, -1, 0]},
                  {"type": "traction", "box": {"min": [0.99, -1, -1], "max": [1.01, 1, 1]}, "traction": [0, -1, 0]}],
        "time": {"dt": 0.01, "frames": 1},
    })
    settings = config([deck])
    assert settings["material.plastic.isotropic_hardening"] == ("0", "default")
    assert settings["material.plastic.kinematic_hardening"] == ("0", "default")
    assert "loads[0].normal" not in settings and "loads[0].angle" not in settings
    assert settings["loads[1].normal"] == ("none", "default") and "loads[1].angle" in settings
