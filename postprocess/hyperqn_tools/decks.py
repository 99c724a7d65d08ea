"""Reading and writing decks (YAML) and making copies of a deck that run from another directory."""
import copy
import os

import yaml


def load_deck(path):
    """The deck as a dict ({} for an empty file)."""
    with open(path) as f:
        return yaml.safe_load(f) or {}


def write_deck(path, deck, header=None):
    """Writes `deck` (keys in their order) to path, after `header` as a comment; returns str(path)."""
    with open(path, "w") as f:
        if header:
            f.write("".join(f"# {line}\n" for line in header.splitlines()))
        yaml.safe_dump(deck, f, sort_keys=False, default_flow_style=None)  # short lists on one line
    return str(path)


def portable_copy(deck, deck_path):
    """A deep copy of `deck`, read from deck_path, that runs from any directory: a relative
    `mesh.file` (relative to the deck's directory) made absolute, and no `output.directory` (the
    caller's -o says where results go)."""
    d = copy.deepcopy(deck)
    mesh = d.get("mesh") or {}
    if isinstance(mesh.get("file"), str) and not os.path.isabs(mesh["file"]):
        mesh["file"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(deck_path)), mesh["file"]))
    if isinstance(d.get("output"), dict):
        d["output"].pop("directory", None)
    return d
