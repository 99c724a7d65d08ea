"""No page of docs/ over 450 lines, and every relative Markdown link [text](path#anchor) in
README.md, docs/*.md and docs/records/*.md leads somewhere: the file exists and, for a page with
an anchor, one of its headings has that GitHub-style anchor (lower case, punctuation dropped,
spaces as '-', '-1', '-2' for repeats). Pages move (docs/decks.md's sections went to
deck-scene.md and deck-run.md); their links must follow."""
import glob
import os
import re
from collections import Counter

from hyperqn_tools.paths import REPO

LINK = re.compile(r"\[(?:[^\[\]]|\[[^\]]*\])*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def pages():
    return ([os.path.join(REPO, "README.md")] + sorted(glob.glob(os.path.join(REPO, "docs", "*.md")))
            + sorted(glob.glob(os.path.join(REPO, "docs", "records", "*.md"))))


def lines_outside_code(path):
    """(line number, text) of the lines not in a ``` block."""
    fence = False
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if line.lstrip().startswith("```"):
                fence = not fence
            elif not fence:
                yield n, line


def slug(heading):
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).strip().lower()  # a link in a heading: its text
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen, out = Counter(), set()
        for _, line in lines_outside_code(path):
            m = HEADING.match(line)
            if m:
                s = slug(m.group(2))
                out.add(f"{s}-{seen[s]}" if seen[s] else s)
                seen[s] += 1
        cache[path] = out
    return cache[path]


def test_slug_is_githubs():
    assert slug("Crossings with the penalty") == "crossings-with-the-penalty"
    assert slug("`bodies` (instead of `mesh` and `material`)") == "bodies-instead-of-mesh-and-material"


def test_every_relative_link_resolves():
    broken, checked = [], 0
    for page in pages():
        for n, line in lines_outside_code(page):
            for target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
                    continue
                path, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(page), path)) if path else page
                checked += 1
                where = f"{os.path.relpath(page, REPO)}:{n}: {target}"
                if not os.path.exists(dest):
                    broken.append(f"{where}: no file {os.path.relpath(dest, REPO)}")
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    broken.append(f"{where}: no heading with that anchor")
    assert checked > 500  # the pages were found
    assert not broken, "\n".join(broken)


def test_no_design_page_over_450_lines():
    """A page of docs/ describes one topic's design and use; its history goes to docs/records/."""
    long = {os.path.relpath(p, REPO): n for p in glob.glob(os.path.join(REPO, "docs", "*.md"))
            if (n := sum(1 for _ in open(p, encoding="utf-8"))) > 450}
    assert not long, long
