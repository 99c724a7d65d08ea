#!/usr/bin/env python3
"""The tables of the declared deck sections in the deck's pages (DOCS below), from the binary's
declarations (src/params/deck_keys.hpp, exported by `hyperqn registry`): one place for each key's
type, range, default and documentation.

    export PYTHONPATH=$PWD/postprocess
    /usr/bin/python3 scripts/deck_tables.py            # print the tables
    /usr/bin/python3 scripts/deck_tables.py --check    # exit 1 where the docs differ
    /usr/bin/python3 scripts/deck_tables.py --write    # rewrite those tables

--check and --write take the pages DOCS lists, or the pages given after them
(`--check docs/deck-scene.md docs/deck-run.md`). A section's table is the first block of lines
starting with '|' after its heading "### `<section>`", on whichever of the pages has that
heading: every declared section's heading must be on exactly one of them. A link in a key's
documentation is relative to the page its table is on. tests/python/test_deck_tables.py runs
--check.
"""
import argparse
import os
import subprocess
import sys

from hyperqn_tools import launch
from hyperqn_tools.cli import ArgumentParser

# The pages of the deck's reference, from the repository root: the one place that lists them.
DOCS = ("docs/decks.md", "docs/deck-scene.md", "docs/deck-run.md", "docs/loads.md", "docs/topology.md")
REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tables(keys):
    """{section: [table lines]} in the declared order."""
    out = {}
    for k in keys:
        lines = out.setdefault(k["section"], ["| key | type | default | meaning |", "|---|---|---|---|"])
        if k["choices"]:
            kind = " \\| ".join(f"`{c}`" for c in k["choices"])
            if k["type"] == "list":
                kind = "list of " + kind
        else:
            kind = k["type"]
        if k["unit"]:
            kind += f", in {k['unit']}"
        default = k["default"]
        if k["choices"] and "`" not in default and not default.startswith("required"):
            default = f"`{default}`"
        lines.append(f"| `{k['name']}` | {kind} | {default} | {k['doc']} |")
    return out


def headings(lines, section):
    return [i for i, line in enumerate(lines) if line.startswith(f"### `{section}`")]


def table_span(lines, section):
    """(first, end) of the table under '### `section`' in lines (end exclusive)."""
    heading = headings(lines, section)
    if len(heading) != 1:
        raise SystemExit(f"docs: {len(heading)} headings '### `{section}`' (expected one)")
    first = next((i for i in range(heading[0] + 1, len(lines)) if lines[i].startswith("|")), None)
    if first is None:
        raise SystemExit(f"docs: no table after '### `{section}`'")
    end = first
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return first, end


def page_of(pages, section):
    """The one page (a path of `pages`, {path: lines}) with the heading '### `section`'."""
    holding = [path for path, lines in pages.items() if headings(lines, section)]
    if len(holding) != 1:
        raise SystemExit(f"docs: the heading '### `{section}`' is on {len(holding)} of the pages "
                         f"{', '.join(pages)} (expected one)")
    return holding[0]


def main():
    ap = ArgumentParser(prog="scripts/deck_tables.py", description=__doc__,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", metavar="DOC", nargs="*", help="the pages to check (default: DOCS)")
    ap.add_argument("--write", metavar="DOC", nargs="*", help="the pages to rewrite (default: DOCS)")
    ap.add_argument("--bin", default=launch.default_binary())
    args = ap.parse_args()
    if args.check is not None and args.write is not None:
        ap.error("give --check or --write, not both")
    paths = args.check if args.check is not None else args.write
    if paths is not None:
        paths = paths or [os.path.join(REPO, doc) for doc in DOCS]
    pages = {}
    for path in paths or []:  # read before the binary runs: a mistyped page is said first
        try:
            with open(path) as f:
                pages[path] = f.read().split("\n")
        except (OSError, UnicodeDecodeError) as e:
            ap.error(f"{path}: cannot be read ({getattr(e, 'strerror', None) or e})")
    if not (os.path.isfile(args.bin) and os.access(args.bin, os.X_OK)):
        ap.error(f"--bin {args.bin}: not an executable file")
    try:
        generated = tables(launch.registry(args.bin)["deck_keys"])
    except (OSError, subprocess.SubprocessError, ValueError, KeyError) as e:  # it ran but said no registry
        ap.error(f"--bin {args.bin}: `hyperqn registry` failed ({e})")
    if paths is None:
        for section, lines in generated.items():
            print(f"### `{section}`\n\n" + "\n".join(lines) + "\n")
        return 0
    differ = {}
    for section, table in generated.items():
        path = page_of(pages, section)
        lines = pages[path]
        first, end = table_span(lines, section)
        if lines[first:end] != table:
            differ.setdefault(path, []).append(section)
            if args.write is not None:
                lines[first:end] = table
            else:
                for want, have in zip(table + [""] * len(lines[first:end]), lines[first:end] + [""] * len(table)):
                    if want != have:
                        print(f"{path}, section {section}:\n  docs: {have}\n  code: {want}")
                        break
    if args.write is not None:
        for path, lines in pages.items():
            if path in differ:
                with open(path, "w") as f:
                    f.write("\n".join(lines))
            print(f"{path}: rewrote the tables of {', '.join(differ.get(path, [])) or 'no section'}")
        return 0
    if differ:
        for path, sections in differ.items():
            print(f"{path} differs from the declared keys in: {', '.join(sections)}")
        print(f"(fix the declaration or run scripts/deck_tables.py --write {' '.join(paths)})")
        return 1
    print(f"{', '.join(paths)}: the tables of {', '.join(generated)} match the declared keys")
    return 0


if __name__ == "__main__":
    sys.exit(main())
