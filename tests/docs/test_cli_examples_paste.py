"""The command reference's examples paste: each rendered block parses, ``--`` intact.

The texts are those the docs' ``command-reference`` directive renders
(``docs/_ext/cli_examples.py``); one small Sphinx build of a page with the directive
checks that they appear as literal blocks and that no option name is smart-quoted.
"""

import shlex
import sys
import xml.etree.ElementTree as ET

import pytest

from dpdfit.cli.main import build_parser
from tests.helpers.paths import ROOT

DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

from cli_examples import example_texts  # noqa: E402

SMART = "\u2013\u2014\u2018\u2019\u201c\u201d"   # en/em dash, curly single and double quotes


def _commands(text: str) -> list[list[str]]:
    """The command lines of an example, as a shell splits them (continuations joined)."""
    lines = text.replace("\\\n", " ").splitlines()
    return [argv for argv in (shlex.split(line, comments=True) for line in lines) if argv]


def _parse(argv: list[str], capsys) -> int:
    """0 when the parser accepts ``argv`` (``--help`` included), else its exit status."""
    try:
        build_parser().parse_args(argv)
    except SystemExit as exc:
        capsys.readouterr()
        return exc.code
    return 0


def test_every_command_and_the_overview_have_an_example():
    texts = example_texts()
    assert set(build_parser()._subparsers._group_actions[0].choices) | {"dpdfit"} == set(texts)


@pytest.mark.parametrize("name", sorted(example_texts()))
def test_each_rendered_example_parses_when_pasted(name, capsys):
    text = example_texts()[name]
    assert not set(text) & set(SMART), text
    commands = _commands(text)
    dpdfit = [argv for argv in commands if argv[0] == "dpdfit"]
    assert dpdfit, f"{name}: no dpdfit command in {text!r}"
    # the one other command an example runs is the install of an optional extra
    assert all(argv[:2] == ["pip", "install"] for argv in commands if argv[0] != "dpdfit")
    failed = [argv for argv in dpdfit if _parse(argv[1:], capsys) != 0]
    assert not failed, failed
    if name != "dpdfit":
        assert all(argv[1] == name for argv in dpdfit if argv[1] != "simulate-campaign"
                   and argv[1] != "write-artiq-results")


def test_a_mistyped_example_would_fail_the_parser(capsys):
    """The check above can fail: an en dash in place of ``--`` is refused."""
    assert _parse(["propagate", "\u2013calibration-runs", "x.csv", "--A", "0.5"], capsys) == 2


@pytest.fixture(scope="module")
def rendered_reference(tmp_path_factory):
    """The doctree (XML) of a page holding only the command reference, built by Sphinx."""
    sphinx = pytest.importorskip("sphinx.application")
    pytest.importorskip("sphinxarg")
    src = tmp_path_factory.mktemp("cli_docs")
    (src / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(DOCS / '_ext')!r})\n"
        "extensions = ['cli_examples']\n")
    (src / "index.rst").write_text(
        "Commands\n========\n\n.. command-reference::\n   :module: dpdfit.cli.main\n"
        "   :func: build_parser\n   :prog: dpdfit\n")
    out = src / "_build"
    from sphinx.util.docutils import docutils_namespace, patch_docutils
    # as sphinx-build does: the nodes, roles and directives this build registers are
    # unregistered afterwards, so a later Sphinx build in the same process is not
    # warned that they are registered already
    with patch_docutils(str(src)), docutils_namespace():
        app = sphinx.Sphinx(str(src), str(src), str(out), str(out / ".doctrees"), "xml",
                            status=None, warning=None, freshenv=True)
        app.build()
    return ET.parse(out / "index.xml").getroot()


def test_the_reference_renders_each_example_as_a_literal_block(rendered_reference):
    blocks = [b.text for b in rendered_reference.iter("literal_block")]
    for name, text in example_texts().items():
        assert text in blocks, name


def test_no_option_name_on_the_reference_is_smart_quoted(rendered_reference):
    text = "".join(rendered_reference.itertext())
    assert "--calibration-runs" in text
    assert not set(text) & set(SMART), sorted(set(text) & set(SMART))
