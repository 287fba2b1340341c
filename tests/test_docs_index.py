"""docs/README.md names every page of docs/ once, with the question it
answers, and links only pages that exist."""
import re

from conftest import ROOT

DOCS = ROOT / "docs"
INDEX = (DOCS / "README.md").read_text(encoding="utf-8")


def test_every_page_is_in_the_index_once():
    rows = re.findall(r"^\| \[([^\]]+)\]\(([^)]+)\) \| (.+) \|$", INDEX, flags=re.M)
    linked = [target for _, target, _ in rows]
    pages = sorted(p.name for p in DOCS.iterdir()
                   if p.is_file() and p.suffix in {".md", ".1", ".html"} and p.name != "README.md")
    assert sorted(linked) == pages
    assert len(set(linked)) == len(linked)
    for name, target, question in rows:
        assert name == target and (DOCS / target).is_file()
        assert len(question) > 20


def test_every_other_file_is_named():
    others = [p.name for p in DOCS.iterdir()
              if (p.is_dir() or p.suffix not in {".md", ".1", ".html"})]
    assert others
    for name in others:
        assert f"`{name}" in INDEX, f"docs/README.md does not say what docs/{name} holds"


def test_the_readme_points_to_the_index():
    assert "(docs/README.md)" in (ROOT / "README.md").read_text(encoding="utf-8")
