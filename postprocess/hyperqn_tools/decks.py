"""Reading and writing decks (YAML) and making copies of a deck that run from another directory."""
import copy
import os
import re

import yaml


class Loader(yaml.SafeLoader):
    """yaml.SafeLoader reading numbers as hyperqn does: PyYAML (YAML 1.1) takes `1e5` for a string,
    which write_deck would then quote and hyperqn refuse; yaml-cpp reads it as a number."""


Loader.add_implicit_resolver("tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$"),
                             list("-+0123456789."))


def load_yaml(path):
    """A YAML file's content, with Loader."""
    with open(path) as f:
        return yaml.load(f, Loader=Loader)


def load_deck(path):
    """The deck as a dict ({} for an empty file)."""
    return load_yaml(path) or {}


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
