"""The docs speak of the code as it is: no development history told by numbered rounds of work in any
tracked text file (git holds the history), nothing cites files outside the repository, and the README
stays short and gives the commands that CI runs."""

import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: A numbered round of work: the word for a working session (or "round of work") followed by its number.
NARRATIVE = re.compile(r"\b(?:sessions?|rounds? of work) \d+", re.IGNORECASE)
#: A string literal split over source lines ("... before session "\n    "16 ..."), joined before searching.
SPLIT_LITERAL = re.compile(r"[\"']\s*\n\s*[\"']")
TEXT = (".py", ".md", ".toml", ".json", ".xml", ".txt", ".cfg", "")


def _tracked_text_files():
    files = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    for f in files:
        p = REPO / f
        if p.suffix in TEXT and p.is_file():
            try:
                yield f, p.read_text()
            except UnicodeDecodeError:
                continue


def test_no_tracked_text_tells_numbered_history():
    hits = [f"{f}: {m.group(0)}" for f, text in _tracked_text_files() if f != "tests/test_docs.py"
            for m in NARRATIVE.finditer(SPLIT_LITERAL.sub("", text))]
    assert not hits, hits


def test_nothing_cites_files_outside_the_repository():
    outside = re.compile(r"\.\./shared|\bDESIGN\.md\b|\bPAPER\.md\b|\bSTYLE\.md\b")
    hits = [f for f, text in _tracked_text_files() if f != "tests/test_docs.py" and outside.search(text)]
    assert not hits, hits


def test_the_readme_is_short_and_gives_the_ci_command():
    readme = (REPO / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    ci = (REPO / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci in readme
    for link in re.findall(r"\]\(([^)#]+)\)", readme):
        if not link.startswith("http"):
            assert (REPO / link).exists(), link
