"""The layers of docs/architecture.md that the code must keep: includes go down the picture's order;
io/ writes what the terms report through EnergyTerm's reporting interface (log, report,
point_fields) and includes no term's header; the app and the scene hold no typed pointer to a term (contact is a term like any other)."""
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


def picture_layers():
    """The folders of docs/architecture.md's layer picture, top first ("src/app/", ..., "solvers/")."""
    with open(os.path.join(REPO, "docs", "architecture.md"), encoding="utf-8") as f:
        text = f.read()
    picture = text.split("## The layers", 1)[1].split("```", 2)[1]
    return [m.group(1).rstrip("/") for m in re.finditer(r"^((?:src/)?\w+/)\s", picture, re.M)]


def test_includes_go_down_the_picture():
    """Every include of src/ and solvers/ names a folder at or below its own in the picture (and the
    picture lists every folder of src/): no edge up the layers, so no cycle between them."""
    layers = [folder for folder in picture_layers() if folder != "postprocess"]
    depth = {folder.split("/")[-1]: i for i, folder in enumerate(layers)}  # 0: the top
    on_disk = {d for d in os.listdir(os.path.join(REPO, "src")) if os.path.isdir(os.path.join(REPO, "src", d))}
    assert on_disk | {"solvers"} == set(depth), (sorted(on_disk), layers)
    up = []
    for folder in depth:
        root = os.path.join(REPO, "solvers" if folder == "solvers" else os.path.join("src", folder))
        for name in sorted(os.listdir(root)):
            if not name.endswith((".hpp", ".cpp")):
                continue
            with open(os.path.join(root, name), encoding="utf-8") as f:
                for inc in INCLUDE.findall(f.read()):
                    target = inc.split("/")[0]
                    if target in depth and depth[target] < depth[folder]:
                        up.append(f"{folder}/{name} includes {inc}")
    assert not up, "\n".join(up)
