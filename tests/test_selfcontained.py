"""The repository is self-contained: no README, doc, source, script, header,
test, example or Python file points outside it (to a specification file or a
folder next to the checkout) or to tracker numbers; the thesis is cited by
title, chapter and equation instead."""
import re

from conftest import ROOT

DIRS = ["docs", "src", "scripts", "include", "tests", "examples", "python", "data"]
SUFFIXES = {".md", ".c", ".h", ".py", ".sh", ".ini", ".in", ".1", ""}
# built from pieces so that this file does not match itself
FORBIDDEN = [
    re.compile(re.escape(".." + "/shared")),
    re.compile(re.escape("/work" + "/shared")),
    re.compile(re.escape("SPEC" + ".md")),
    re.compile(r"\bissues?\s+#?\d", re.IGNORECASE),
    re.compile(r"\b(work|development|previous|earlier|this)\s+sess" + r"ions?\b", re.IGNORECASE),
]


def files():
    yield ROOT / "README.md"
    yield ROOT / "Makefile"
    for d in DIRS:
        for p in sorted((ROOT / d).rglob("*")):
            if (p.is_file() and p.suffix in SUFFIXES and "corpus" not in p.parts
                    and "regress" not in p.parts and "__pycache__" not in p.parts):
                yield p


def test_no_outside_references():
    hits = []
    for p in files():
        try:
            text = p.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            for pat in FORBIDDEN:
                if pat.search(line):
                    hits.append(f"{p.relative_to(ROOT)}:{n}: {line.strip()[:100]}")
    assert not hits, "references outside the repository:\n" + "\n".join(hits)


def test_the_check_can_fail():
    """Each pattern matches the kind of line it is meant to catch."""
    samples = ["see " + ".." + "/shared/x", "/work" + "/shared/thesis", "SPEC" + ".md §2",
               "(iss" + "ue 3 items 1-3)", "as in the previous sess" + "ion"]
    for pat, s in zip(FORBIDDEN, samples):
        assert pat.search(s), (pat.pattern, s)
