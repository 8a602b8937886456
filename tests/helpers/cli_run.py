"""Running the command line in-process, as the CLI tests do."""

from __future__ import annotations

from dpdfit.cli.main import main


def run(argv, capsys):
    """``dpdfit <argv>`` in this process: (exit code, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err
