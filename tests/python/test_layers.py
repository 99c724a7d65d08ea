"""The layers of docs/architecture.md that the code must keep: io/ writes what the terms report
through EnergyTerm's reporting interface (log, report, point_fields) and includes no term's
header; the app and the scene hold no typed pointer to a term (contact is a term like any other)."""
import os
import re

from conftest import REPO

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def sources(directory):
    root = os.path.join(REPO, "src", directory)
    for name in sorted(os.listdir(root)):
        if name.endswith((".hpp", ".cpp")):
            with open(os.path.join(root, name)) as f:
                yield f"src/{directory}/{name}", f.read()


def test_io_includes_no_term():
    found = [(path, inc) for path, text in sources("io") for inc in INCLUDE.findall(text) if inc.startswith("terms/")]
    assert not found, found


BUILDERS = {
    "src/model/elastic_terms.cpp",  # the scene's terms from its description
    "src/app/run_options.cpp",      # the NaN injection test hook (SceneOptions::extra_terms)
}


def test_no_typed_term_outside_terms_and_their_builders():
    """Only the terms themselves and the functions that build them name a term's class (comments
    aside)."""
    term_classes = set()
    for path, text in sources("terms"):
        term_classes.update(re.findall(r"class (\w+) (?:final )?: public EnergyTerm", text))
    assert "ContactTerm" in term_classes
    found = []
    for directory in ("app", "io", "model"):
        for path, text in sources(directory):
            if path in BUILDERS:
                continue
            code = re.sub(r"//[^\n]*", "", text)
            found += [(path, c) for c in term_classes if re.search(rf"\b{c}\b", code)]
    assert not found, found
