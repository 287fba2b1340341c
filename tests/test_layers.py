"""No circle in the include/call graph of src/ (scripts/layers.py).

A circle is a set of files that call functions defined in each other; the
layers then have no order. The command line (src/cli) uses the poolreps/
headers only (public, private, the tool's), no library file includes one of
its headers, and the library neither includes nor calls the tool (src/tool),
which is linked into the poolreps executable alone."""
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


def test_the_library_neither_includes_nor_calls_the_tool(tmp_path, monkeypatch):
    """The check sees a library file that includes a header of src/tool or
    calls a function defined there (the tool sits above the library)."""
    src = tmp_path / "src"
    (src / "tool" / "poolreps").mkdir(parents=True)
    (src / "tool" / "poolreps" / "staging.h").write_text("int pr_stage(void);\n")
    (src / "tool" / "staging.c").write_text("int pr_stage(void)\n{\n\treturn 0;\n}\n")
    (src / "model.c").write_text('#include "poolreps/staging.h"\nint pr_model(void)\n{\n'
                                 '\treturn pr_stage();\n}\n')
    monkeypatch.setattr(layers, "SRC", src)
    monkeypatch.setattr(layers, "ROOT", tmp_path)
    files, _, calls = layers.scan()
    assert [b.split(":")[0] for b in layers.include_problems(files)] == ["model.c"]
    assert [b.split(":")[0] for b in layers.upward_calls(files, calls)] == ["model.c"]
    (src / "model.c").write_text("int pr_model(void)\n{\n\treturn 1;\n}\n")
    files, _, calls = layers.scan()
    assert layers.include_problems(files) == [] and layers.upward_calls(files, calls) == []


def test_the_tool_is_not_in_the_library_archive():
    """Run folders, sweeps, staging and the row filters (src/tool) are linked
    into the poolreps executable alone: libpoolreps.a holds none of them."""
    import os
    import shutil
    lib = ROOT / os.environ.get("POOLREPS_BUILD", "build/rel") / "libpoolreps.a"
    if not lib.exists() or not shutil.which("ar"):
        import pytest
        pytest.skip("no build/rel/libpoolreps.a")
    members = subprocess.run(["ar", "t", str(lib)], capture_output=True, text=True,
                             check=True).stdout.split()
    tool = sorted(p.stem + ".o" for p in (ROOT / "src" / "tool").glob("*.c"))
    assert tool and not set(tool) & set(members)
