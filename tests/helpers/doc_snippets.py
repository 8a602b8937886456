"""The fenced snippets of the documentation pages, and running them as a reader would.

A page's ``bash``/``console``/``shell``/``python`` blocks (and ``{code-cell}`` ones) run in
page order in one fresh folder that holds the repository's ``datasets/``; its Python
blocks share one namespace (a reader's session).  A ``text`` block that follows an
executed snippet is what the page says the snippets printed: each of
its lines must appear in the page's output so far, every number within half a unit of
its last shown digit.
"""

from __future__ import annotations

import ast
import contextlib
import io
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from tests.helpers.paths import ROOT

DOCS = ROOT / "docs"
SNIPPET_LANGS = {"bash", "console", "shell", "python", "{code-cell}"}
SHELL_LANGS = {"bash", "console", "shell"}

# A snippet that cannot run on the bundled data says so in its first line, on the page.
LAB_ONLY = "# lab-only:"             # reads a lab's own files (paths start YOUR_LAB/)
NOT_RUN = "# not run by the docs tests:"   # hours of computing, or an edit of the package

# Parts of a shell line that are installation, not use: the tests run the checkout that
# is already installed, so these are dropped (only these, only at a command's start).
INSTALL_STEP = re.compile(r"^\s*(python3? -m venv\b|\. \.venv/bin/activate\b|source \.venv/"
                          r"|pip install\b|git clone\b|cd dpdfit\b)")
# Commands that are the test suite or the docs build themselves: running them from a
# test would recurse into the suite (or build the site inside a test).
SELF_COMMAND = re.compile(r"^\s*python3? -m (pytest|sphinx)\b")

NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


@dataclass
class Block:
    """One fenced block of a page: its language, first line number and text."""
    lang: str
    line: int
    text: str

    @property
    def first_line(self) -> str:
        """The block's first non-empty line: its name in the test's lists."""
        return next((ln.strip() for ln in self.text.splitlines() if ln.strip()), "")

    @property
    def marker(self) -> str | None:
        """``lab-only`` or ``not run`` when the block's first line says so, else None."""
        first = self.first_line
        if first.startswith(LAB_ONLY):
            return "lab-only"
        if first.startswith(NOT_RUN):
            return "not run"
        return None


def pages() -> list[Path]:
    """Every documentation page with fenced blocks: docs/**/*.md (not the changelog,
    which includes CHANGELOG.md) and README.md."""
    found = [p for p in sorted(DOCS.rglob("*.md"))
             if p.name != "changelog.md" and "_build" not in p.parts]
    return found + [ROOT / "README.md"]


def page_name(path: Path) -> str:
    """The page's path relative to the repository root."""
    return path.relative_to(ROOT).as_posix()


def blocks(path: Path) -> list[Block]:
    """The page's fenced blocks in order (any fence of three or more backticks)."""
    out, lines, i = [], path.read_text(encoding="utf-8").splitlines(), 0
    while i < len(lines):
        line = lines[i]
        m = re.match(r"^(\s*)(`{3,})\s*(\{[\w-]+\}|[\w-]*)", line)
        if not m:
            i += 1
            continue
        indent, fence, lang = len(m.group(1)), m.group(2), m.group(3)
        j = i + 1
        while j < len(lines) and not re.match(rf"^\s*{fence}\s*$", lines[j]):
            j += 1
        body = [ln[indent:] if ln[:indent].strip() == "" else ln for ln in lines[i + 1:j]]
        if lang == "{code-cell}":
            body = [ln for ln in body if not ln.startswith(":")]
        out.append(Block(lang, i + 1, "\n".join(body)))
        i = j + 1
    return out


def snippets(path: Path) -> list[Block]:
    """The page's shell and Python snippets."""
    return [b for b in blocks(path) if b.lang in SNIPPET_LANGS]


def shell_script(text: str) -> tuple[str, list[str]]:
    """The block as a bash script without its installation steps and self-commands
    (joined continuation lines split at ``&&``); returns (script, dropped parts)."""
    joined = re.sub(r"\\\n", " ", text)
    kept, dropped = [], []
    for line in joined.splitlines():
        parts = re.split(r"&&", line) if not line.lstrip().startswith("#") else [line]
        keep = []
        for part in parts:
            if INSTALL_STEP.match(part) or SELF_COMMAND.match(part):
                dropped.append(part.partition(" #")[0].strip())
            else:
                keep.append(part)
        if keep:
            kept.append("&&".join(keep))
    return "set -e\n" + "\n".join(kept) + "\n", dropped


def reader_env(folder: Path) -> dict:
    """The environment of a reader's shell: ``dpdfit`` and ``python`` are this checkout's."""
    bin_dir = folder / ".bin"
    bin_dir.mkdir(exist_ok=True)
    for name, cmd in (("dpdfit", f'"{sys.executable}" -m dpdfit'),
                      ("python", f'"{sys.executable}"'), ("python3", f'"{sys.executable}"')):
        shim = bin_dir / name
        shim.write_text(f'#!/bin/sh\nexec {cmd} "$@"\n')
        shim.chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
               PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return env


def run_shell(text: str, folder: Path) -> str:
    """Run a shell snippet in folder; its stdout and stderr, or AssertionError."""
    script, _ = shell_script(text)
    proc = subprocess.run(["bash", "-c", script], cwd=folder, env=reader_env(folder),
                          capture_output=True, text=True, timeout=1800)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"exit status {proc.returncode}:\n{output[-3000:]}"
    return output


def _shown(value) -> list[str]:
    """What a notebook shows for an expression's value, as lines."""
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, str) for v in value):
        return list(value)
    return repr(value).splitlines()


@dataclass
class Session:
    """A reader's Python session: one namespace for a page's Python blocks."""
    namespace: dict = field(default_factory=lambda: {"__name__": "__main__"})
    checked: list = field(default_factory=list)   # (comment, numbers shown, values)

    def run(self, text: str) -> str:
        """Run a block statement by statement; printed text and the shown values of
        expression statements (as a notebook displays them)."""
        tree = ast.parse(text)
        lines, out = text.splitlines(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            for node in tree.body:
                if isinstance(node, ast.Expr):
                    code = compile(ast.Expression(node.value), "<snippet>", "eval")
                    value = eval(code, self.namespace)
                    if value is not None:
                        print("\n".join(_shown(value)))
                    self._note(lines[node.end_lineno - 1], value)
                else:
                    exec(compile(ast.Module([node], []), "<snippet>", "exec"), self.namespace)
        return out.getvalue()

    def _note(self, last_line: str, value) -> None:
        """Keep an expression's value with the numbers its comment quotes as the result
        (a comment that starts with a number)."""
        parts = re.split(r"\s#\s", last_line, maxsplit=1)
        comment = parts[1].strip() if len(parts) == 2 else ""
        if not NUMBER.match(comment.lstrip("~")):
            return
        values = value if isinstance(value, tuple) else (value,)
        try:
            values = [float(v) for v in values]
        except (TypeError, ValueError):
            return
        self.checked.append((comment, NUMBER.findall(comment)[:len(values)], values))


def half_unit(shown: str) -> float:
    """Half a unit of the last digit of a number as shown."""
    mant, _, exp = shown.lower().lstrip("+-").partition("e")
    decimals = len(mant.partition(".")[2])
    return 0.5 * 10.0 ** (-decimals + (int(exp) if exp else 0))


def close(shown: str, value: float) -> bool:
    """Whether value rounds to the number as shown."""
    return abs(float(shown) - value) <= half_unit(shown) * (1 + 1e-9) + 1e-300


def _skeleton(line: str) -> tuple[str, list[str]]:
    line = " ".join(line.split())
    return NUMBER.sub("#", line), NUMBER.findall(line)


def line_shown(expected: str, output_lines: list[str]) -> bool:
    """Whether some output line has the same words as expected and its numbers round
    to expected's."""
    skel, nums = _skeleton(expected)
    for line in output_lines:
        s, got = _skeleton(line)
        if s == skel and all(close(e, float(g)) for e, g in zip(nums, got)):
            return True
    return False


def unmatched_lines(shown_text: str, output: str) -> list[str]:
    """The lines of a shown output block that the snippets did not print ("..." lines,
    which stand for rows left out, excepted)."""
    out_lines = output.splitlines()
    return [ln for ln in shown_text.splitlines()
            if ln.strip() and ln.strip() != "..." and not line_shown(ln, out_lines)]
