"""Habits: commit messages every git tool can show: a subject of at most 72
characters, then a blank line before the body. The rule holds for every
commit after 619731f (the older history is left as it was); skipped outside
a git checkout or in a clone without that commit."""
import subprocess

import pytest

from conftest import ROOT

SINCE = "619731f"
MAX_SUBJECT = 72


def git(*args):
    return subprocess.run(["git", "-C", str(ROOT)] + list(args), capture_output=True, text=True)


def messages():
    if git("cat-file", "-e", SINCE + "^{commit}").returncode != 0:
        pytest.skip(f"not a git checkout holding {SINCE}")
    out = git("log", "--format=%H%x00%B%x01", f"{SINCE}..HEAD")
    assert out.returncode == 0, out.stderr
    return [m.strip("\n").split("\0", 1) for m in out.stdout.split("\1") if m.strip()]


def bad_messages(msgs):
    bad = []
    for sha, body in msgs:
        lines = body.split("\n")
        if len(lines[0]) > MAX_SUBJECT:
            bad.append(f"{sha[:9]}: subject of {len(lines[0])} characters")
        elif len(lines) > 1 and lines[1].strip():
            bad.append(f"{sha[:9]}: no blank line after the subject")
    return bad


def test_new_commit_subjects_are_short_and_stand_alone():
    assert bad_messages(messages()) == []


def test_the_check_sees_a_long_subject_and_a_missing_blank_line():
    assert bad_messages([("a" * 40, "x" * 73 + "\n\nbody"), ("b" * 40, "short\nbody"),
                         ("c" * 40, "fine\n\nbody"), ("d" * 40, "x" * 72)]) == \
        ["aaaaaaaaa: subject of 73 characters", "bbbbbbbbb: no blank line after the subject"]


def test_docs_a_reader_can_hold():
    """The README at most 220 lines, no page of docs/ over 30 KB (generated
    tables of numbers belong in CSV files or the report page)."""
    assert len((ROOT / "README.md").read_text().splitlines()) <= 220
    big = [p.name for p in sorted((ROOT / "docs").rglob("*.md")) if p.stat().st_size > 30 * 1024]
    assert big == []


DOCS_TOTAL_MAX = 200 * 1024   # bytes of Markdown in docs/, every folder


def docs_total_problem(sizes, limit=DOCS_TOTAL_MAX):
    """None when the pages fit in `limit` bytes; otherwise one message naming
    the total and the five largest pages."""
    total = sum(sizes.values())
    if total <= limit:
        return None
    largest = sorted(sizes.items(), key=lambda kv: (-kv[1], kv[0]))[:5]
    pages = ", ".join(f"{name} {size / 1024:.1f} KB" for name, size in largest)
    return (f"docs/**/*.md hold {total / 1024:.1f} KB, over {limit / 1024:.0f} KB; "
            f"largest: {pages}")


# DOCS TOTAL: the whole of docs/ a reader can hold (fails until every page is short).
def test_docs_total_at_most_200_kb():
    docs = ROOT / "docs"
    sizes = {str(p.relative_to(docs)): p.stat().st_size for p in sorted(docs.rglob("*.md"))}
    assert sizes
    problem = docs_total_problem(sizes)
    assert problem is None, problem


def test_the_total_check_names_the_total_and_the_largest_pages():
    assert docs_total_problem({"a.md": 100, "b.md": 200}, limit=300) is None
    msg = docs_total_problem({"a.md": 1024, "b.md": 2048, "c.md": 512}, limit=3000)
    assert msg == ("docs/**/*.md hold 3.5 KB, over 3 KB; "
                   "largest: b.md 2.0 KB, a.md 1.0 KB, c.md 0.5 KB")
