#!/usr/bin/env python3
"""docs/decks.md's tables of the declared deck sections, from the binary's declarations
(src/io/deck_keys.hpp, exported by `hyperqn registry`): one place for each key's type, range,
default and documentation.

    export PYTHONPATH=$PWD/postprocess
    /usr/bin/python3 scripts/deck_tables.py                      # print the tables
    /usr/bin/python3 scripts/deck_tables.py --check docs/decks.md  # exit 1 where the docs differ
    /usr/bin/python3 scripts/deck_tables.py --write docs/decks.md  # rewrite those tables

A section's table in docs/decks.md is the first block of lines starting with '|' after its
heading "### `<section>`". tests/python/test_deck_tables.py runs --check.
"""
import argparse
import sys

from hyperqn_tools import launch


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


def table_span(lines, section):
    """(first, end) of the table under '### `section`' in lines (end exclusive)."""
    heading = [i for i, line in enumerate(lines) if line.startswith(f"### `{section}`")]
    if len(heading) != 1:
        raise SystemExit(f"docs: {len(heading)} headings '### `{section}`' (expected one)")
    first = next((i for i in range(heading[0] + 1, len(lines)) if lines[i].startswith("|")), None)
    if first is None:
        raise SystemExit(f"docs: no table after '### `{section}`'")
    end = first
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    return first, end


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", metavar="DOC")
    ap.add_argument("--write", metavar="DOC")
    ap.add_argument("--bin", default=launch.default_binary())
    args = ap.parse_args()
    generated = tables(launch.registry(args.bin)["deck_keys"])
    path = args.check or args.write
    if not path:
        for section, lines in generated.items():
            print(f"### `{section}`\n\n" + "\n".join(lines) + "\n")
        return 0
    with open(path) as f:
        lines = f.read().split("\n")
    differ = []
    for section, table in generated.items():
        first, end = table_span(lines, section)
        if lines[first:end] != table:
            differ.append(section)
            if args.write:
                lines[first:end] = table
            else:
                for want, have in zip(table + [""] * len(lines[first:end]), lines[first:end] + [""] * len(table)):
                    if want != have:
                        print(f"{path}, section {section}:\n  docs: {have}\n  code: {want}")
                        break
    if args.write:
        with open(path, "w") as f:
            f.write("\n".join(lines))
        print(f"{path}: rewrote the tables of {', '.join(differ) or 'no section'}")
        return 0
    if differ:
        print(f"{path} differs from the declared keys in: {', '.join(differ)} "
              f"(fix the declaration or run scripts/deck_tables.py --write {path})")
        return 1
    print(f"{path}: the tables of {', '.join(generated)} match the declared keys")
    return 0


if __name__ == "__main__":
    sys.exit(main())
