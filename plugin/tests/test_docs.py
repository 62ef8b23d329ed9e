"""The docs are self-contained: no tracked file points outside the repository, every doc a file names
exists, and docs/README.md indexes every doc. Pure Python and git; imports nothing compiled."""

import re
import subprocess
from pathlib import Path

import pytest
from ci import skip_or_fail

ROOT = Path(__file__).resolve().parents[2]

# Notes that once lived outside the repository, and paths that lead out of it. The names are
# split so that this file does not match itself.
OUTSIDE = re.compile(
    "|".join(
        [
            "cycles-hair" + "-notes",
            "peer" + "-tests",
            "blender" + "-integration",
            "lighttree" + "_notes",
            r"(?<![\w.~])/" + "work/",
            r"\.\./shared\b",
        ]
    )
)
BINARY_SUFFIXES = {".png", ".jpg", ".jpeg", ".gif", ".exr", ".hdr", ".npz", ".npy", ".blend", ".ico", ".pdf"}


def tracked_files():
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True, text=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        skip_or_fail("not a git checkout")
    return [ROOT / p for p in out.split("\0") if p]


def read_text(path):
    """The file's text, or None for binary files, images and files that are not there."""
    if path.suffix.lower() in BINARY_SUFFIXES or not path.is_file():
        return None
    data = path.read_bytes()
    if b"\0" in data[:8192]:
        return None
    return data.decode("utf-8", errors="replace")


def outside_pointers(paths):
    """'file:line: text' for every line that points outside the repository."""
    hits = []
    for path in paths:
        text = read_text(path)
        if text is None:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                name = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
                hits.append(f"{name}:{n}: {line.strip()[:120]}")
    return hits


def test_no_file_points_outside_the_repository():
    hits = outside_pointers(tracked_files())
    assert not hits, "pointers outside the repository (cite docs/cycles.md or docs/validation.md):\n" + "\n".join(hits)


@pytest.mark.parametrize(
    "planted",
    [
        "// Cycles' frame (" + "cycles-hair" + "-notes §4.1)",
        "# furnace floor (" + "peer" + "-tests §5.D)",
        "see " + "/work" + "/shared/docs/notes.md",
        "see ../" + "shared/x.md",
    ],
)
def test_planted_pointer_is_caught(tmp_path, planted):
    f = tmp_path / "planted.h"
    f.write_text("// a clean line\n" + planted + "\n")
    assert outside_pointers([f]) == [f"{f}:2: {planted.strip()}"]


DOC_MENTION = re.compile(r"(?<![\w./-])docs/([\w./-]+?\.md)\b")
MD_LINK = re.compile(r"\]\(([^)\s#]+\.md)(?:#[^)\s]*)?\)")


def test_every_named_doc_exists():
    missing = []
    for path in tracked_files():
        if path.suffix not in {".md", ".py", ".h", ".cpp"}:
            continue
        text = read_text(path)
        if text is None:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            for name in DOC_MENTION.findall(line):
                if not (ROOT / "docs" / name).is_file():
                    missing.append(f"{path.relative_to(ROOT)}:{n}: docs/{name}")
            if path.suffix == ".md":
                for target in MD_LINK.findall(line):
                    if "://" not in target and not (path.parent / target).resolve().is_file():
                        missing.append(f"{path.relative_to(ROOT)}:{n}: link {target}")
    assert not missing, "named docs that do not exist:\n" + "\n".join(missing)


def test_index_lists_every_doc():
    if not (ROOT / "docs" / "README.md").is_file():
        skip_or_fail("no docs/ beside the tests (not a source checkout)")
    index = (ROOT / "docs" / "README.md").read_text()
    linked = set(MD_LINK.findall(index))
    docs = sorted(p.name for p in (ROOT / "docs").glob("*.md") if p.name != "README.md")
    missing = [d for d in docs if d not in linked]
    assert not missing, f"docs/README.md does not link {missing}"
    for extra in ("../lab/README.md", "../CHANGELOG.md"):
        assert extra in linked, extra
