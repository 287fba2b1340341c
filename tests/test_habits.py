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
    big = [p.name for p in sorted((ROOT / "docs").glob("*.md")) if p.stat().st_size > 30 * 1024]
    assert big == []
