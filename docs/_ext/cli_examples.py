"""The ``command-reference`` directive: sphinx-argparse's page, examples as literal code.

sphinx-argparse parses an epilog as reStructuredText, so the examples of ``dpdfit
COMMAND --help`` rendered as prose: a definition list where a line was indented,
``--`` turned into an en dash and quotes into curly ones by smartquotes, so a
pasted example failed.  This directive drops the epilogs from sphinx-argparse's
output and places each command's example, taken from
:data:`dpdfit.cli.help_texts.EXAMPLES`, as a literal block (copy button, ``--``
intact) at the end of the command's section; the overview's examples go before
the sub-commands.  Smartquotes is switched off for the whole generated reference:
option names appear in the commands' descriptions and help texts too.

``tests/docs/test_cli_examples_paste.py`` pastes :func:`example_texts` into the parser.
"""

from __future__ import annotations

from docutils import nodes
from sphinxarg.ext import ArgParseDirective

from dpdfit.cli.help_texts import EXAMPLES, OVERVIEW_EXAMPLES, OVERVIEW_NOTE

__all__ = ["example_texts", "example_block", "CommandReference", "setup"]

#: the key of :func:`example_texts` for the examples of ``dpdfit --help`` itself
OVERVIEW = "dpdfit"


def example_texts() -> dict:
    """Command -> the exact text of its rendered example block (``"dpdfit"``: the overview)."""
    return {OVERVIEW: OVERVIEW_EXAMPLES, **EXAMPLES}


def example_block(text: str) -> list:
    """The nodes of one example: a caption paragraph and the text as a bash literal block."""
    block = nodes.literal_block(text, text, language="bash")
    several = "\n" in text.replace("\\\n", "")  # a backslash continues a command's line
    return [nodes.paragraph(text="Examples:" if several else "Example:"), block]


def _command_sections(subcommands: nodes.section):
    """(command name, section) of each command's section directly under ``subcommands``."""
    for sec in subcommands.children:
        if isinstance(sec, nodes.section) and isinstance(sec[0], nodes.title):
            # the title is the command, or "dpdfit command" with full sub-command names
            yield sec[0].astext().split()[-1], sec


class CommandReference(ArgParseDirective):
    """``argparse``, with the examples as literal code and no smart quotes on the page."""

    def _print_subcommands(self, data, nested_content, markdown_help=False, settings=None):
        for child in data.get("children", []):
            child.pop("epilog", None)  # placed below as literal code, not parsed as reST
        items = super()._print_subcommands(data, nested_content, markdown_help, settings)
        texts = example_texts()
        for group in items:
            for name, sec in _command_sections(group):
                if name in texts:
                    sec.extend(example_block(texts[name]))
        return items

    def run(self):
        self.options["noepilog"] = ""  # the overview's examples are placed below
        items = super().run()
        overview = example_block(OVERVIEW_EXAMPLES) + [nodes.paragraph(text=OVERVIEW_NOTE)]
        at = next((i for i, n in enumerate(items) if isinstance(n, nodes.section)
                   and "Sub-commands" in n["ids"]), len(items))
        items[at:at] = overview
        for node in items:
            node["support_smartquotes"] = False  # sphinx.util.nodes.is_smartquotable
        return items


def setup(app):
    """Register the ``command-reference`` directive."""
    app.setup_extension("sphinxarg.ext")
    app.add_directive("command-reference", CommandReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
