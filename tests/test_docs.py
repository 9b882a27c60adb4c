"""The documentation is the repository's own and holds to the tree.

- No file cites a design document outside the repository: the design is docs/design.md.
- Every markdown link, and every `docs/….md#anchor` named in code, templates, Alloy modules,
  examples or docs, resolves inside the repository: the file exists and, for a markdown file,
  the heading its anchor names (GitHub's anchors); every file and module the docs name exists.
- Every paper cited ("paper 001 §4.3", "paper 000 Table I") is listed in docs/references.md, and
  so is every distribution `pyproject.toml` installs.
- docs/architecture.md is the map of the tree: it names every module, package, Alloy module and
  template, and every test file, each by its path from the root; every path it names exists;
  and its layers table lists the layers of the first import contract in their order.
- Every public function and class of the Component API has a docstring with its contract.
"""
from __future__ import annotations

import ast
import re
import tomllib
from functools import cache
from pathlib import Path
from typing import Iterator

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
REFERENCES = DOCS / "references.md"
ARCHITECTURE = DOCS / "architecture.md"

# What the checks read: the project's own text, not generated golden files or data.
TEXT_SUFFIXES = {".py", ".md", ".als", ".j2", ".arch", ".toml", ".yaml", ".yml", ".lark", ".xml", ".txt", ""}
SCANNED = ["README.md", "Makefile", "pyproject.toml", ".pre-commit-hooks.yaml", ".ci", "docs", "alloy_model",
           "bench", "checker", "codegen", "examples", "reconf_dsl", "reconf_ros", "tests"]
NOT_SCANNED = {"tests/golden", "tests/data", "__pycache__"}

# The packages and folders docs/architecture.md maps, and the kinds of file it names.
MAPPED = ["reconf_dsl", "checker", "codegen", "alloy_model", "reconf_ros", "bench", "tests"]
MODULE_SUFFIXES = {".py", ".als", ".lark", ".j2", ".xml"}
NOT_MAPPED = {"tests/golden", "tests/data", "tests/bad_inputs", "tests/good_inputs", "__pycache__"}


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _skipped(path: Path, skip: set[str]) -> bool:
    rel = _rel(path)
    return any(rel == s or rel.startswith(s + "/") or f"/{s}/" in f"/{rel}/" for s in skip)


@cache
def text_files() -> tuple[Path, ...]:
    out: list[Path] = []
    for name in SCANNED:
        top = ROOT / name
        paths = [top] if top.is_file() else sorted(p for p in top.rglob("*") if p.is_file())
        out += [p for p in paths if p.suffix in TEXT_SUFFIXES and not _skipped(p, NOT_SCANNED)]
    return tuple(out)


@cache
def read(path: Path) -> str:
    return path.read_bytes().decode("utf-8", errors="replace")


def line_of(text: str, index: int) -> int:
    return text.count("\n", 0, index) + 1


# --- markdown: headings and their anchors ----------------------------------------------------------

FENCE = re.compile(r"^(```|~~~).*?^\1[ \t]*$", re.M | re.S)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"!?\[([^\]\n]*)\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^#{1,6}[ \t]+(.+?)[ \t]*#*[ \t]*$", re.M)


def without_code_blocks(text: str) -> str:
    """`text` with every fenced block blanked (line numbers kept): a `#` there is no heading."""
    return FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)


def slug(heading: str) -> str:
    """The anchor GitHub gives a heading: links reduced to their text, lower case, every character
    that is not a letter, digit, `_`, `-` or space dropped, spaces made `-`."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).strip().lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


@cache
def anchors(path: Path) -> frozenset[str]:
    """Every heading anchor of a markdown file; a repeated heading's anchor gets `-1`, `-2`…"""
    seen: dict[str, int] = {}
    out = set()
    for m in HEADING.finditer(without_code_blocks(read(path))):
        base = slug(m.group(1))
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return frozenset(out)


def unresolved(target: Path, anchor: str) -> str:
    """Why `target#anchor` does not resolve inside the repository ("" when it does)."""
    try:
        target.resolve().relative_to(ROOT)
    except ValueError:
        return "points outside the repository"
    if not target.exists():
        return "no such file"
    if anchor and target.suffix == ".md" and anchor not in anchors(target):
        return f"no heading with anchor #{anchor} in {_rel(target)}"
    return ""


# --- 1. no outside design document ---------------------------------------------------------------

OUTSIDE_DESIGN = "DESIGN" + ".md"


def test_nothing_cites_a_design_document_outside_the_repository() -> None:
    cites = [f"{_rel(p)}:{line_of(read(p), m.start())}" for p in text_files()
             for m in re.finditer(re.escape(OUTSIDE_DESIGN), read(p))]
    assert not cites, f"{OUTSIDE_DESIGN} is not in the repository; cite docs/design.md (or the doc that says it): {cites}"


# --- 2. links and references resolve ------------------------------------------------------------

def markdown_links(path: Path) -> Iterator[tuple[int, str]]:
    text = INLINE_CODE.sub(lambda m: " " * len(m.group(0)), without_code_blocks(read(path)))
    for m in LINK.finditer(text):
        yield line_of(text, m.start()), m.group(2)


def test_every_markdown_link_resolves_inside_the_repository() -> None:
    bad = []
    for path in (p for p in text_files() if p.suffix == ".md"):
        for line, target in markdown_links(path):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):      # https:, mailto:: outside by design
                continue
            file, _, anchor = target.partition("#")
            why = unresolved(path.parent / file if file else path, anchor)
            if why:
                bad.append(f"{_rel(path)}:{line}: ({target}): {why}")
    assert not bad, "links that do not resolve:\n" + "\n".join(bad)


# A markdown file named by its path from the root, in prose, a docstring or a comment:
# docs/executor.md#names, bench/README.md#measured-figures, README.md. (A bare `gate.md` is a
# file name in an example, such as `--report markdown=gate.md`, not a reference.)
MENTION = re.compile(r"(?<![\w./-])((?:[\w-]+/)+[\w.-]+\.md|README\.md)(?:#([\w-]+))?")


def test_every_docs_reference_resolves_inside_the_repository() -> None:
    bad = []
    for path in text_files():
        text = read(path)
        if path.suffix == ".md":     # a link's target is relative to its file: checked above
            text = LINK.sub(lambda m: " " * len(m.group(0)), text)
        for m in MENTION.finditer(text):
            why = unresolved(ROOT / m.group(1), m.group(2) or "")
            if why:
                bad.append(f"{_rel(path)}:{line_of(text, m.start())}: {m.group(0)}: {why}")
    assert not bad, "references that do not resolve (paths are from the repository root):\n" + "\n".join(bad)


def test_the_anchors_are_github_s() -> None:
    assert slug("Selection: `reconf ftm select COMPONENT [-f FILE]`") == "selection-reconf-ftm-select-component--f-file"
    assert slug("The Component API (paper 001 §5.2)") == "the-component-api-paper-001-52"
    assert slug("The paper's Algorithm 1") == "the-papers-algorithm-1"
    assert slug("Running an FTM on ROS 2 (`reconf_ros.nodes.ftm`)") == "running-an-ftm-on-ros-2-reconf_rosnodesftm"
    assert "tests" in anchors(ARCHITECTURE) and "the-layers" in anchors(ARCHITECTURE)


# A file or module of the tree named in the docs' prose: `checker/alloy/bridge.py`, `tests/ros/`,
# `reconf_ros.executor.status.find_node`. A pattern (`tests/ros/test_live_*`, `checker/cli/<name>.py`)
# names no one file; fenced blocks hold commands and their output, not references.
TREE_PATH = re.compile(r"(?<![\w./-])((?:reconf_dsl|checker|codegen|reconf_ros|alloy_model|bench|tests|docs|examples)"
                       r"/[\w./-]*[\w/])(?![\w*<])")
DOTTED = re.compile(r"(?<![\w./-])((?:reconf_dsl|checker|codegen|reconf_ros|bench|tests)(?:\.[A-Za-z_]\w*)+)")


@cache
def top_level_names(module: Path) -> frozenset[str]:
    out = set()
    for node in ast.walk(ast.parse(read(module))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            out |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            out |= {t.id for t in targets if isinstance(t, ast.Name)}
    return frozenset(out)


def dotted_exists(name: str) -> bool:
    """`a.b.c.f`: the longest prefix that is a module of the tree, then a name it defines."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        base = ROOT.joinpath(*parts[:i])
        module = base.with_suffix(".py") if base.with_suffix(".py").is_file() else base / "__init__.py"
        if module.is_file():
            return i == len(parts) or parts[i] in top_level_names(module)
    return False


def test_every_file_and_module_the_docs_name_exists() -> None:
    bad = []
    for path in (p for p in text_files() if p.suffix == ".md"):
        text = without_code_blocks(read(path))
        for m in TREE_PATH.finditer(text):
            if not (ROOT / m.group(1)).exists():
                bad.append(f"{_rel(path)}:{line_of(text, m.start())}: {m.group(1)}")
        for m in DOTTED.finditer(text):
            if not dotted_exists(m.group(1)):
                bad.append(f"{_rel(path)}:{line_of(text, m.start())}: {m.group(1)}")
    assert not bad, "the docs name what the tree does not have:\n" + "\n".join(bad)

# --- 3. papers and projects are in docs/references.md -------------------------------------------

SECTION = r"§\s*\d+(?:\.\d+)*"
# "paper 001 §4.3", "paper 001's §5.2", "paper 001 (§4.4)", "paper 000 §5.2, §5.3", "paper 000 Table I"
CITATION = re.compile(r"\b[Pp]aper\s+(\d{3})\b(?:'s)?(?:\s*\(?\s*(?:(%s(?:\s*(?:,|and|–|-|to)\s*%s)*)|Tables?\s+([IVX]+)))?"
                      % (SECTION, SECTION))


def listed_parts() -> dict[str, set[str]]:
    """Paper key → the parts docs/references.md lists for it ("§4.3", "Table I", "Fig. 2–3")."""
    text = without_code_blocks(read(REFERENCES))
    out: dict[str, set[str]] = {}
    sections = re.split(r"^###? ", text, flags=re.M)
    for section in sections:
        key = re.match(r"paper (\d{3})\s*$", section.split("\n", 1)[0])
        if key:
            cells = re.findall(r"^\| *([^|]+?) *\|", section, re.M)
            out[key.group(1)] = {part.strip() for cell in cells for part in cell.split(",")}
    return out


def test_every_paper_cited_is_in_the_references() -> None:
    parts = listed_parts()
    assert set(parts) == {"000", "001"} and "§4.3" in parts["001"] and "Table I" in parts["000"], parts
    bad = []
    for path in text_files():
        text = read(path)
        cited = list(CITATION.finditer(text))
        for m in cited:
            key, sections, table = m.groups()
            wanted = {"§" + n for n in re.findall(r"§\s*(\d+(?:\.\d+)*)", sections or "")}
            wanted |= {f"Table {table}"} if table else set()
            if key not in parts:
                bad.append(f"{_rel(path)}:{line_of(text, m.start())}: {m.group(0)}: no paper {key} in references.md")
            elif wanted - parts[key]:
                bad.append(f"{_rel(path)}:{line_of(text, m.start())}: {m.group(0)}: that part of paper {key} "
                           "is not listed in references.md")
        spans = [range(m.start(), m.end()) for m in cited]
        for s in re.finditer(r"§\s*\d", text):
            if path not in (REFERENCES, Path(__file__)) and not any(s.start() in r for r in spans):
                bad.append(f"{_rel(path)}:{line_of(text, s.start())}: a section cited without its paper: "
                           f"write 'paper 00x §N' ({text[max(0, s.start() - 30):s.end() + 5]!r})")
    assert not bad, "\n".join(bad)


def distributions() -> set[str]:
    project = tomllib.loads(read(ROOT / "pyproject.toml"))
    specs = list(project["project"]["dependencies"]) + list(project["build-system"]["requires"])
    specs += [s for extra in project["project"]["optional-dependencies"].values() for s in extra]
    return {re.match(r"[A-Za-z0-9_.-]+", s).group(0) for s in specs}  # type: ignore[union-attr]


def test_every_distribution_installed_is_in_the_references() -> None:
    listed = set(re.findall(r"`([A-Za-z0-9_.-]+)`", read(REFERENCES)))
    missing = sorted(d for d in distributions() if d not in listed)
    assert "ros-rclpy" in distributions() and "lark" in distributions()
    assert not missing, f"say in docs/references.md what reconf takes from: {missing}"


# --- 4. docs/architecture.md is the map of the tree -------------------------------------------------

PATH_IN_BACKTICKS = re.compile(r"`((?:[\w.-]+/)+(?:[\w.-]+\.\w+)?)`")


def named_in_map() -> set[str]:
    return set(PATH_IN_BACKTICKS.findall(read(ARCHITECTURE)))


def tree() -> tuple[set[str], set[str]]:
    """Every module, Alloy module, grammar, template and profile under the mapped folders (a
    package's `__init__.py` is its folder), and every package folder."""
    files, packages = set(), set()
    for top in MAPPED:
        for p in sorted((ROOT / top).rglob("*")):
            if _skipped(p, NOT_MAPPED) or not p.is_file() or p.suffix not in MODULE_SUFFIXES:
                continue
            if p.name == "__init__.py":
                packages.add(_rel(p.parent) + "/")
            else:
                files.add(_rel(p))
    return files, packages


def test_the_map_names_every_module_and_test() -> None:
    files, packages = tree()
    assert "checker/alloy/worker.py" in files and "reconf_ros/executor/" in packages and "tests/test_docs.py" in files
    missing = sorted((files | packages) - named_in_map())
    assert not missing, ("docs/architecture.md is the map of the tree; name each of these there, by its path "
                         f"from the root (a test file in the table of tests): {missing}")


def test_every_path_the_map_names_exists() -> None:
    gone = sorted(p for p in named_in_map() if not (ROOT / p).exists())
    assert not gone, f"docs/architecture.md names what the tree does not have: {gone}"


def test_the_map_draws_the_layers_in_the_contract_s_order() -> None:
    contract = tomllib.loads(read(ROOT / "pyproject.toml"))["tool"]["importlinter"]["contracts"][0]
    layers = [m.replace(".", "/") + "/" for m in contract["layers"]]
    section = read(ARCHITECTURE).split("\n## The layers", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| *`([\w/]+/)`", section, re.M)
    assert rows == layers, f"the layers table of docs/architecture.md: {rows}; the contract: {layers}"


# --- 5. the Component API states its contracts ----------------------------------------------------

COMPONENT_API = ["reconf_ros/nodes/api.py", "reconf_ros/nodes/component.py"]


def test_every_public_function_of_the_component_api_has_its_contract() -> None:
    """What a node's author calls or overrides says what it does, when it may be called, what it
    guarantees and what it raises; a class's docstring holds its constructor's."""
    bare = []
    for rel in COMPONENT_API:
        tree = ast.parse(read(ROOT / rel))
        for node in tree.body:
            members = node.body if isinstance(node, ast.ClassDef) else []
            for f in [node, *members]:
                public = isinstance(f, ast.ClassDef) or isinstance(f, ast.FunctionDef) and not f.name.startswith("_")
                if public and not ast.get_docstring(f):  # type: ignore[arg-type]
                    bare.append(f"{rel}:{f.lineno}: {getattr(f, 'name', '?')}")
    assert not bare, f"public functions of the Component API without a docstring: {bare}"
