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


def anchors(text):
    """GitHub's anchors of a page's headings: lower case, punctuation
    dropped, spaces to hyphens, a repeated heading numbered."""
    seen, out = {}, set()
    for h in re.findall(r"^#+ (.+?)\s*$", re.sub(r"```.*?```", "", text, flags=re.S), flags=re.M):
        slug = re.sub(r"[^\w\- ]", "", h.strip().lower().replace("`", "")).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def test_every_link_between_pages_lands():
    """Every relative link of README.md and docs/**/*.md names a file that
    exists and, after #, a heading of that page."""
    pages = [ROOT / "README.md"] + sorted(DOCS.rglob("*.md"))
    bad = []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for target in re.findall(r"\]\(([^)\s]+)\)", re.sub(r"```.*?```", "", text, flags=re.S)):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if not dest.exists():
                bad.append(f"{page.relative_to(ROOT)}: {target}: no such file")
            elif anchor and dest.suffix == ".md" and \
                    anchor not in anchors(dest.read_text(encoding="utf-8")):
                bad.append(f"{page.relative_to(ROOT)}: {target}: no such heading")
    assert bad == []
