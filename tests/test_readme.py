"""The README stays true: it opens with the two set-up commands, its parameter
list is poolreps --help's, every key is documented, and every picture it shows
exists."""
import re

from conftest import ROOT

README = (ROOT / "README.md").read_text(encoding="utf-8")


def test_opens_with_the_two_commands():
    block = re.search(r"```sh\n(.*?)```", README, re.S)
    assert block and README.index(block.group(0)) < README.index("\n## ")
    commands = [line.split("#")[0].strip() for line in block.group(1).splitlines()]
    assert commands == ["make reproduce", "make check"]


def test_parameter_list_is_the_help_text(poolreps):
    out = poolreps(["--help"]).stdout.decode()
    help_keys = out[out.index("Parameter keys"):].rstrip("\n")
    block = re.search(r"<!-- keys:begin -->\n```\n(.*?)\n```\n<!-- keys:end -->", README, re.S)
    assert block, "README lacks the keys block"
    assert block.group(1) == help_keys, "README parameter list differs from --help: regenerate it"


def test_every_key_documented(poolreps):
    ini = poolreps(["config"]).stdout.decode()
    section = None
    missing = []
    for line in ini.splitlines():
        if line.startswith("["):
            section = line.strip("[]")
        elif "=" in line:
            key = f"{section}.{line.split('=')[0].strip()}"
            if not re.search(r"^  " + re.escape(key) + r" +=", README, re.M):
                missing.append(key)
    assert not missing, f"keys missing from README: {missing}"


def test_pictures_exist_and_no_placeholders():
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README)
    assert len(pictures) >= 14
    for p in pictures:
        assert (ROOT / p).is_file(), p
    assert "BENCH_" not in README
