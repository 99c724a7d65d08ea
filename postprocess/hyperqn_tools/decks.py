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
    """A deep copy of `deck`, read from deck_path, that runs from any directory: relative
    `mesh.file` and `colliders[].file` (relative to the deck's directory) made absolute, and no
    `output.directory` (the caller's -o says where results go)."""
    d = copy.deepcopy(deck)
    base = os.path.dirname(os.path.abspath(deck_path))
    holders = [d.get("mesh")] + (d["colliders"] if isinstance(d.get("colliders"), list) else [])
    for h in holders:
        if isinstance(h, dict) and isinstance(h.get("file"), str):
            h["file"] = absolute_path(h["file"], base)
    if isinstance(d.get("output"), dict):
        d["output"].pop("directory", None)
    return d


def absolute_path(path, base):
    """path made absolute against the directory base (an absolute path is kept)."""
    return path if os.path.isabs(path) else os.path.normpath(os.path.join(base, path))
