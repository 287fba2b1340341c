#!/usr/bin/env python3
"""The include/call layers of src/: which file calls which, and any circle.

    scripts/layers.py [--check]

For every .c file under src/ (src/cli included) the functions it defines
(at file level, static or not) and the functions of other files it calls
(an identifier followed by '(' that another file defines and this one does
not). A circle is a set of files that reach each other through calls
(a strongly connected component of more than one file); --check exits 1 if
there is one, if a file outside src/cli includes a header of src/cli or
src/cli includes a module's private header (src/*.h), if the library (src/
outside src/cli and src/tool) includes a header of the tool or calls into
the tool or the command line, or if a function is longer than
MAX_LINES (from its first unindented line to its closing brace). Without
--check the layers are printed bottom up: each file above every file it
calls."""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
SRC = ROOT / "src"
MAX_LINES = 120
KEYWORDS = {"if", "for", "while", "switch", "return", "sizeof", "do", "else", "case",
            "defined", "_Static_assert", "offsetof"}


def strip(text):
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)
    return re.sub(r"'(?:\\.|[^'\\\n])*'", "''", text)


def definitions(text):
    """{name: static?} of the functions defined at file level: NAME(...) followed by '{'."""
    names = {}
    depth = 0
    i = 0
    n = len(text)
    while i < n:
        c = text[i]
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
        elif depth == 0 and c == "(":
            m = re.search(r"(\w+)\s*$", text[:i])
            # the matching ')' and what follows it
            j, d = i, 0
            while j < n:
                if text[j] == "(":
                    d += 1
                elif text[j] == ")":
                    d -= 1
                    if d == 0:
                        break
                j += 1
            rest = text[j + 1:j + 200].lstrip()
            if m and m.group(1) not in KEYWORDS and rest.startswith("{"):
                head = re.split(r"[;}]", text[:m.start()])[-1]
                names[m.group(1)] = bool(re.search(r"\bstatic\b", head))
            i = j
        i += 1
    return names


def scan():
    files = sorted(p for p in SRC.rglob("*.c"))
    texts = {f: strip(f.read_text()) for f in files}
    defs = {f: definitions(t) for f, t in texts.items()}
    owner = {}  # a static function is called from its own file only
    for f, names in defs.items():
        for nm, static in names.items():
            if not static:
                owner.setdefault(nm, set()).add(f)
    calls = {}
    for f, t in texts.items():
        out = {}
        for nm in set(re.findall(r"\b([A-Za-z_]\w*)\s*\(", t)):
            if nm in defs[f] or nm not in owner:
                continue
            for g in owner[nm]:
                out.setdefault(g, set()).add(nm)
        calls[f] = out
    return files, defs, calls


def components(files, calls):
    """Tarjan's strongly connected components of the call graph."""
    index, low, stack, on, comps = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in calls[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            comps.append(comp)

    sys.setrecursionlimit(10000)
    for v in files:
        if v not in index:
            visit(v)
    return comps


def layers(files, calls):
    """Each file's floor: 1 + the highest floor of the files it calls (no circles)."""
    floor = {}

    def f(v, seen=()):
        if v not in floor:
            floor[v] = 1 + max((f(w, seen + (v,)) for w in calls[v] if w not in seen), default=0)
        return floor[v]

    for v in files:
        f(v)
    return floor


def function_lengths(text):
    """(lines, first line) of every function of a C file in the project's
    style: the body opens with '{' and closes with '}' alone at column 0;
    the function starts at the last unindented line before the '{' (its
    return type or name; continued parameters are indented)."""
    lines, out, start = text.split("\n"), [], None
    for i, line in enumerate(lines):
        if line == "{" and i > 0:
            j = i - 1
            while j > 0 and lines[j][:1] in (" ", "\t"):
                j -= 1
            start = j
        elif line == "}" and start is not None:
            out.append((i - start + 1, lines[start]))
            start = None
    return out


def long_functions(files):
    return [f"{name(f)}: {head.strip()} is {n} lines (more than {MAX_LINES})"
            for f in files for n, head in function_lengths(f.read_text()) if n > MAX_LINES]


TOP = ("cli", "tool")  # the executable's layers, above the library


def is_tool_header(inc):
    return (SRC / "tool" / inc).exists() and not (SRC / inc).exists() and \
        not (SRC / "private" / inc).exists() and not (ROOT / "include" / inc).exists()


def include_problems(files):
    bad = []
    for f in files:
        rel = f.relative_to(SRC)
        for inc in re.findall(r'^\s*#\s*include\s+"([^"]+)"', f.read_text(), flags=re.M):
            if rel.parts[0] == "cli" and not (inc.startswith("poolreps/") or (SRC / "cli" / inc).exists()):
                bad.append(f"{rel}: includes the module header {inc} (the CLI uses poolreps/ headers only)")
            if rel.parts[0] != "cli" and (SRC / "cli" / inc).exists() and not (SRC / inc).exists():
                bad.append(f"{rel}: includes the command line's {inc}")
            if rel.parts[0] not in TOP and is_tool_header(inc):
                bad.append(f"{rel}: includes the tool's {inc} (the library is below the tool)")
    return bad


def upward_calls(files, calls):
    """A library file (outside src/cli and src/tool) calling into them."""
    return [f"{name(f)}: calls {name(g)} ({', '.join(sorted(calls[f][g])[:3])}): the library "
            f"is below the tool and the command line"
            for f in files if f.relative_to(SRC).parts[0] not in TOP
            for g in calls[f] if g.relative_to(SRC).parts[0] in TOP]


def name(f):
    return str(f.relative_to(SRC))


def main(argv):
    files, defs, calls = scan()
    circles = [c for c in components(files, calls) if len(c) > 1]
    bad = include_problems(files) + upward_calls(files, calls) + long_functions(files)
    if "--check" in argv:
        for c in circles:
            pairs = [f"{name(a)} -> {name(b)} ({', '.join(sorted(calls[a][b])[:3])})"
                     for a in c for b in c if b in calls[a]]
            print("layers: circle: " + "; ".join(sorted(pairs)), file=sys.stderr)
        for b in bad:
            print("layers: " + b, file=sys.stderr)
        return 1 if circles or bad else 0
    if circles:
        for c in circles:
            print("circle:", " ".join(sorted(name(f) for f in c)))
        return 1
    floor = layers(files, calls)
    top = max(floor.values())
    arrows = sum(len(calls[f]) for f in files)
    print(f"{len(files)} files, {top} floors, {arrows} call arrows, no circle")
    for k in range(top, 0, -1):
        print(f"{k:2d}: " + " ".join(sorted(name(f) for f in files if floor[f] == k)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
