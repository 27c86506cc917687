"""The documentation site is written to be read: at most 4,000 words a page
and 20,000 in all, counted as `wc -w` counts the source (runs of characters
between whitespace).  Generated pages (the API reference, the build) are not
counted; the benchmark tables are directives in the source, made at build
time, so only the page's own text counts."""

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
PAGE_LIMIT = 4_000
TOTAL_LIMIT = 20_000
# written by the build, not by hand
GENERATED = ("_build", "reference/generated", ".ipynb_checkpoints")


def _pages():
    for path in sorted(DOCS.rglob("*")):
        rel = path.relative_to(DOCS).as_posix()
        if (
            path.suffix in {".md", ".rst", ".ipynb"}
            and path.is_file()
            and not any(rel == g or rel.startswith(g + "/") or f"/{g}/" in f"/{rel}" for g in GENERATED)
        ):
            yield rel, path


def words(path: Path) -> int:
    """The words of a page's source; a notebook's are those of its cells."""
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".ipynb":
        text = "\n".join("".join(cell.get("source", "")) for cell in json.loads(text)["cells"])
    return len(text.split())


def over_budget(counts: dict[str, int]) -> list[str]:
    """What breaks the budget, in words a reader can act on."""
    problems = [
        f"docs/{rel}: {n} words (at most {PAGE_LIMIT})"
        for rel, n in sorted(counts.items(), key=lambda kv: -kv[1])
        if n > PAGE_LIMIT
    ]
    total = sum(counts.values())
    if total > TOTAL_LIMIT:
        largest = ", ".join(f"docs/{rel} {n}" for rel, n in sorted(counts.items(), key=lambda kv: -kv[1])[:5])
        problems.append(f"all pages: {total} words (at most {TOTAL_LIMIT}); largest: {largest}")
    return problems


def test_the_pages_keep_to_the_word_budget():
    counts = {rel: words(path) for rel, path in _pages()}
    assert "MODEL.md" in counts and "DYNAMICS.md" in counts
    problems = over_budget(counts)
    assert not problems, "\n".join(problems)


def test_the_budget_check_names_the_pages_over_it(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("word " * 10 + "\n`two words`\n")
    assert words(page) == 12
    notebook = tmp_path / "page.ipynb"
    notebook.write_text(json.dumps({"cells": [{"source": ["one two\n", "three"]}, {"source": "four"}]}))
    assert words(notebook) == 4
    assert over_budget({"a.md": PAGE_LIMIT, "b.md": 1}) == []
    problems = over_budget({"big.md": PAGE_LIMIT + 1, "small.md": 10})
    assert problems == [f"docs/big.md: {PAGE_LIMIT + 1} words (at most {PAGE_LIMIT})"]
    problems = over_budget({f"p{i}.md": 3_000 for i in range(7)})
    assert len(problems) == 1 and "21000 words" in problems[0] and "docs/p0.md" in problems[0]
