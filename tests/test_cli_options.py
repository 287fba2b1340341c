"""`poolreps COMMAND --help` lists exactly the options the parser accepts for
that command, each with a help line and a value name exactly when it takes a
value, and the man page holds every help line.

What the parser accepts is found by asking it, not by reading the help: an
option a command does not take is refused with the documented line
"COMMAND: option X does not apply (see poolreps COMMAND --help)", one no
command takes with "unknown option X (see poolreps --help)", and one that
takes a value, given last, with "option X needs a value". A trailing
`--set nosuch.key=1` (refused by the command's key list or the configuration)
stops every probe before it runs anything. Without POOLREPS_WRAPPER: about
three hundred runs.
"""
import os
import re

import pytest

from conftest import ROOT, poolreps_path, run_cmd

# options of every command: they act at once or apply to all
GLOBAL = {"-q", "-h", "--help", "--help-keys", "--version"}
STOP = ["--set", "nosuch.key=1"]
# the help column (opts.c): "  " + option and value name in 20 + " " + help
COL = 23


def binary():
    b = poolreps_path()
    if b is None:
        pytest.skip("no poolreps binary (set POOLREPS)")
    return b


def call(args, cwd=None):
    return run_cmd([binary()] + [str(a) for a in args], capture_output=True, input=b"",
                   cwd=cwd, env=dict(os.environ, LC_ALL="C"), timeout=60)


def help_of(*args):
    r = call(list(args) + ["--help"])
    assert r.returncode == 0, r.stderr
    return r.stdout.decode()


def option_lines(lines):
    """{option: (value name or None, help lines)} of the help's option lines:
    "  -o OUT.csv           help", help continued on lines indented by COL;
    an option and value name longer than the column put the help below."""
    opts, last = {}, None
    for line in lines:
        if line.startswith(" " * COL) and last:
            opts[last][1].append(line[COL:])
        elif line.startswith("  -"):
            rest = line[2:]
            if len(rest) > COL - 2 and rest[COL - 3] == " " and rest[COL - 2] != " ":
                left, text = rest[:COL - 3].rstrip(), rest[COL - 2:]
            else:
                left, text = rest.rstrip(), ""
            name, _, metavar = left.partition(" ")
            last = name.split(",")[0]
            opts[last] = (metavar or None, [text] if text else [])
        else:
            last = None
    return opts


def sections(text):
    """(the command's part up to its Accepts line, the Common options part)
    of a help."""
    own, common = text.split("\nCommon options", 1)
    return own.split("\n  Accepts: ")[0], common.split("\nExit codes")[0]


@pytest.fixture(scope="module")
def overview():
    return help_of()


@pytest.fixture(scope="module")
def commands(overview):
    names = re.findall(r"^  poolreps (\[run\]|[a-z]+) ", overview, re.M)
    return [n.strip("[]") for n in names]


@pytest.fixture(scope="module")
def takes_value(overview):
    """Every option the help names anywhere: does the parser want a value?"""
    named = set(re.findall(r"(?<![\w-])(--?[a-z][a-z-]*)", overview)) - GLOBAL
    assert {"-c", "-i", "-o", "--set", "--seed", "--progress", "--keep", "--grid"} <= named
    out = {}
    for opt in sorted(named):
        r = call([opt])
        err = r.stderr.decode()
        assert r.returncode == 1 and err.count("\n") == 1, (opt, err)
        out[opt] = f"option {opt} needs a value" in err
        # a flag gets past the parser: the usage error for want of a command
        assert out[opt] or err.startswith("poolreps: Usage: "), (opt, err)
    return out


def accepted(cmd, takes_value, tmp_path):
    """The options the parser takes for cmd (besides GLOBAL)."""
    out = set()
    tmp_path.mkdir()
    for opt, value in takes_value.items():
        args = [cmd, opt] + (["1"] if value else [])
        # run needs its parameter file, unless it is the value of -c
        if cmd == "run" and opt != "-c":
            args.append(ROOT / "data" / "figures.ini")
        r = call(args + STOP, cwd=tmp_path)
        err = r.stderr.decode()
        assert r.returncode in (1, 2) and err.count("\n") == 1, (cmd, opt, err)
        if f"{cmd}: option {opt} does not apply (see poolreps {cmd} --help)" not in err:
            out.add(opt)
    assert list(tmp_path.iterdir()) == [], cmd
    return out


def test_unknown_option_refused(commands):
    for cmd in commands:
        r = call([cmd, "--nosuch-option"])
        assert r.returncode == 1
        assert r.stderr == b"poolreps: unknown option --nosuch-option (see poolreps --help)\n"


def test_help_lists_exactly_the_accepted_options(commands, takes_value, tmp_path):
    for cmd in commands:
        text = help_of(cmd)
        own, common = sections(text)
        accepts = re.search(r"^  Accepts: (.*)\.$", text, re.M).group(1).split(", ")
        listed = option_lines(own.splitlines())
        commons = option_lines(common.splitlines())
        got = accepted(cmd, takes_value, tmp_path / cmd)
        assert set(accepts) == got | {"-q", "-h"}, (cmd, accepts, got)
        assert len(accepts) == len(set(accepts)), cmd
        # its own options in its part, the common ones in Common options
        assert set(listed) == got - set(commons), (cmd, listed, got)
        assert GLOBAL <= set(commons) | {"--help"}, cmd
        for opt, (metavar, lines) in {**listed, **commons}.items():
            assert lines and all(line.strip() for line in lines), (cmd, opt)
            if opt not in GLOBAL:
                assert (metavar is not None) == takes_value[opt], (cmd, opt, metavar)


def roff(text):
    """A help line as gen-man.sh writes it."""
    return text.replace("\\", "\\e").replace("-", "\\-")


def test_man_page_has_every_help_line(commands, overview):
    page = (ROOT / "docs" / "poolreps.1").read_text()
    for cmd in commands + [None]:
        own, common = sections(help_of(cmd)) if cmd else overview.split("\nCommon options")
        for part in (own, common):
            for opt, (metavar, lines) in option_lines(part.splitlines()).items():
                for line in lines:
                    assert roff(line) in page, (cmd, opt, line)
                    # and the overview, which the man page is made from
                    assert line in overview, (cmd, opt, line)
