"""Reading and writing decks (YAML) and making copies of a deck that run from another directory."""
import os
import re

import yaml

from hyperqn_tools.cli import writing


class Loader(yaml.SafeLoader):
    """yaml.SafeLoader reading a deck as hyperqn does (YAML 1.2's scalars), so that a sweep's copy of
    a deck means what the deck means:
    - `1e5` is a number (PyYAML, YAML 1.1, takes it for a string, which write_deck would quote);
    - `010` is 10 (YAML 1.1: octal 8), and `0x1f`, `1_000` or `1:20` stay words, as hyperqn refuses them;
    - only true/false (True, TRUE, ...) are booleans: YAML 1.1's yes, no, on, off stay words, which
      hyperqn refuses where it wants a boolean;
    - a key given twice in a map is refused, as hyperqn refuses it (PyYAML keeps the last);
    - explicit tags (`!!str 0.05`, `!foo`) are refused, as hyperqn refuses them: `!!float "0.05"`
      would otherwise become a plain number in a copy of a deck that hyperqn itself rejects."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(None, None, f"key '{key}' given twice in a map",
                                                        key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)

    def compose_node(self, parent, index):
        event = self.peek_event()
        tag = getattr(event, "tag", None)  # None for an untagged node or an alias; "!" when quoted
        if tag not in (None, "!"):
            shown = "!!" + tag[len("tag:yaml.org,2002:"):] if tag.startswith("tag:yaml.org,2002:") else tag
            raise yaml.composer.ComposerError(None, None, f"YAML tags are not accepted, found {shown}",
                                              event.start_mark)
        return super().compose_node(parent, index)


# YAML 1.1's int and bool resolvers out (octal, sexagesimal, underscores; yes/no/on/off), 1.2's in.
Loader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:bool")]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
Loader.add_implicit_resolver("tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"),
                             list("tTfF"))
Loader.add_implicit_resolver("tag:yaml.org,2002:int", re.compile(r"^[-+]?[0-9]+$"), list("-+0123456789"))
Loader.add_constructor("tag:yaml.org,2002:int", lambda loader, node: int(loader.construct_scalar(node), 10))
Loader.add_implicit_resolver("tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$"),
                             list("-+0123456789."))


def load_yaml(path):
    """A YAML file's content, with Loader."""
    with open(path) as f:
        return yaml.load(f, Loader=Loader)


def load_deck(path):
    """The deck as a dict ({} for an empty file)."""
    return load_yaml(path) or {}


class Dumper(yaml.SafeDumper):
    """yaml.SafeDumper writing every entry in full: no `&id001` anchors and `*id001` aliases where
    two entries are one object (a deck's copy has none, see plain_copy; any other is written out)."""

    def ignore_aliases(self, data):
        return True


def write_deck(path, deck, header=None):
    """Writes `deck` (keys in their order, no YAML aliases) to path, after `header` as a comment;
    returns str(path). On an OSError (a full disk) the file is removed, not left cut short, and a
    cli.WriteFailed naming path is raised."""
    with writing(path), open(path, "w") as f:
        if header:
            f.write("".join(f"# {line}\n" for line in header.splitlines()))
        yaml.dump(deck, f, Dumper=Dumper, sort_keys=False, default_flow_style=None)  # short lists on one line
    return str(path)


PLAIN_COPY_MAX_NODES = 1_000_000  # a YAML alias bomb expands past any memory (docs/decks.md, input limits)


def plain_copy(deck):
    """A deep copy of a loaded deck in which no two entries are one object: a YAML alias
    (`material: *mat`) loads as the anchored entry itself, so that setting a key in one would set it
    in every entry that shares the anchor (copy.deepcopy keeps such sharing). ValueError for an
    alias inside the node it names, or a deck whose aliases expand past PLAIN_COPY_MAX_NODES."""
    count = 0
    inside = set()  # ids of the maps and lists being copied: an alias to one of them is a cycle

    def copy_of(node):
        nonlocal count
        count += 1
        if count > PLAIN_COPY_MAX_NODES:
            raise ValueError(f"its YAML aliases expand to more than {PLAIN_COPY_MAX_NODES} entries")
        if not isinstance(node, (dict, list)):
            return node
        if id(node) in inside:
            raise ValueError("a YAML alias refers to the node it is in")
        inside.add(id(node))
        done = ({k: copy_of(v) for k, v in node.items()} if isinstance(node, dict) else
                [copy_of(v) for v in node])
        inside.discard(id(node))
        return done

    return copy_of(deck)


def portable_copy(deck, deck_path):
    """A deep copy of `deck`, read from deck_path, that runs from any directory: every file it names
    relative to the deck's directory made absolute (a `file` anywhere: a mesh's, a body's mesh's, a
    collider's, a curve table's; a blade's `surface`; the top-level `partition`), and no
    `output.directory` (the caller's -o says where results go). Entries that share a YAML anchor are
    separate in the copy (plain_copy)."""
    d = plain_copy(deck)
    base = os.path.dirname(os.path.abspath(deck_path))

    def walk(node, inside_cuts=False):
        if isinstance(node, list):
            for item in node:
                walk(item, inside_cuts)
        elif isinstance(node, dict):
            for key, value in node.items():
                if isinstance(value, str) and (key == "file" or (inside_cuts and key == "surface")):
                    node[key] = absolute_path(value, base)
                else:
                    walk(value, inside_cuts or key == "cuts")

    walk({k: v for k, v in d.items() if k not in ("output", "petsc", "partition")})
    if isinstance(d.get("partition"), str):
        d["partition"] = absolute_path(d["partition"], base)
    if isinstance(d.get("output"), dict):
        d["output"].pop("directory", None)
    return d


def absolute_path(path, base):
    """path made absolute against the directory base (an absolute path is kept)."""
    return path if os.path.isabs(path) else os.path.normpath(os.path.join(base, path))
