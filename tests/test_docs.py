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


def test_the_schemas_readme_lists_every_schema_with_the_version_the_code_writes():
    """Each schema file's `$id` is the version its `schema` field holds and the README's table names it."""
    import json

    folder = REPO / "itup_jax" / "schemas"
    readme = (folder / "README.md").read_text()
    files = sorted(folder.glob("*.schema.json"))
    assert files
    for f in files:
        doc = json.loads(f.read_text())
        assert doc["$id"] == doc["properties"]["schema"]["const"], f.name
        assert f"`{f.name}` (`{doc['$id']}`)" in readme, f.name
    listed = set(re.findall(r"`([a-z_0-9]+\.schema\.json)`", readme))
    assert listed == {f.name for f in files}


def test_the_design_doc_matches_the_code():
    """design.md's tool spec names the fields, units and categories `tools.mesh` and `tools.priors` take,
    and every module path it names exists."""
    from itup_jax.tools import mesh, priors

    design = (REPO / "docs" / "design.md").read_text()
    spec = design.split("## Your own tool", 1)[1].split("\n## ", 1)[0]
    for field in sorted(mesh._SPEC_REQUIRED | mesh._SPEC_OPTIONAL):
        assert f"`{field}`" in spec, field
    for unit in mesh.SPEC_UNITS:
        assert f'"{unit}"' in spec, unit
    for category in priors.CATEGORY_PRIORS:
        assert f"`{category}`" in spec, category
    for path in set(re.findall(r"`(itup_jax/[\w/]+\.py|experiments/\w+\.py|mjcf/[\w/]+\.xml)`", design)):
        assert (REPO / path).exists(), path


def test_the_docs_state_the_present():
    """README, the docs and the model card speak of the code as it is: no machine-local paths, no history
    of earlier checkpoints (git and CHANGELOG.md hold it)."""
    docs = [REPO / "README.md", REPO / "itup_jax" / "models" / "MODEL_CARD.md", *sorted((REPO / "docs").glob("*.md"))]
    stale = re.compile(r"/tmp/|\bprevious (?:checkpoint|network|shipped)|\bsessions?\b", re.IGNORECASE)
    hits = [f"{p.relative_to(REPO)}: {m.group(0)}" for p in docs for m in stale.finditer(p.read_text())]
    assert not hits, hits


def test_every_experiment_documents_a_command_on_data_the_docs_make():
    """Each experiment's docstring gives its command; the datasets it reads (`data/...`) are ones
    docs/results.md's "Data" makes with `itup generate`."""
    import ast

    results = (REPO / "docs" / "results.md").read_text()
    made = set(re.findall(r"itup generate --out (data/[\w/]+)", results.split("## Data", 1)[1].split("\n## ", 1)[0]))
    made |= {"data/families/" + f for f in ("screwdriver", "spanner", "pry_bar", "hatchet", "squeegee")}
    for script in sorted((REPO / "experiments").glob("*.py")):
        doc = ast.get_docstring(ast.parse(script.read_text())) or ""
        assert f"python experiments/{script.name}" in doc, script.name
        for folder in re.findall(r"\b(data/[\w/]+)", doc):
            # `data/train_*` (the four training sets) reads as its prefix
            assert folder.rstrip("/") in made or (folder == "data/train_" and {f"data/train_{x}" for x in "abcd"} <= made), \
                (script.name, folder)
