"""No circle in the include/call graph of src/ (scripts/layers.py).

A circle is a set of files that call functions defined in each other; the
layers then have no order. The command line (src/cli) uses the public
headers only, and no library file includes one of its headers."""
import subprocess
import sys

from conftest import ROOT

sys.path.insert(0, str(ROOT / "scripts"))
import layers  # noqa: E402


def test_no_circle_and_the_command_line_outside_the_library():
    p = subprocess.run([sys.executable, str(ROOT / "scripts/layers.py"), "--check"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_the_analysis_finds_a_circle_and_ignores_statics(tmp_path):
    a = "static int helper(void) { return 1; }\nint pr_a(void)\n{\n\treturn pr_b() + helper();\n}\n"
    b = "static int helper(void) { return 2; }\nint pr_b(void)\n{\n\treturn 0;\n}\n"
    c = "int pr_c(void)\n{\n\treturn pr_a();\n}\n"
    texts = {"a.c": a, "b.c": b, "c.c": c}
    defs = {f: layers.definitions(layers.strip(t)) for f, t in texts.items()}
    assert defs["a.c"] == {"helper": True, "pr_a": False}
    calls = {"a.c": {"b.c": {"pr_b"}}, "b.c": {}, "c.c": {"a.c": {"pr_a"}}}
    assert all(len(x) == 1 for x in layers.components(list(texts), calls))
    calls["b.c"] = {"c.c": {"pr_c"}}
    assert [sorted(x) for x in layers.components(list(texts), calls) if len(x) > 1] == \
        [["a.c", "b.c", "c.c"]]


def test_no_function_in_src_is_over_120_lines():
    files = sorted((ROOT / "src").rglob("*.c"))
    assert layers.MAX_LINES == 120 and not layers.long_functions(files)
    assert sum(len(layers.function_lengths(p.read_text())) for p in files) > 500


def test_the_length_count_sees_a_long_function():
    body = "".join("\tx += %d;\n" % k for k in range(layers.MAX_LINES - 3))
    text = ("static int f(int a,\n             int b)\n{\n" + body + "}\n"
            "int g(void)\n{\n\treturn 0;\n}\n")
    assert layers.function_lengths(text) == [(layers.MAX_LINES + 1, "static int f(int a,"),
                                             (4, "int g(void)")]
