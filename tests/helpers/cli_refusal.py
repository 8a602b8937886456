"""The command line's contract on bad input, asserted in one place."""

from __future__ import annotations

from pathlib import Path

from dpdfit.cli.main import main


def assert_refused(capsys, argv, needles, inputs=(), no_partial_output_in=None) -> str:
    """Exit 2, one stderr line naming ``needles``, every input file unchanged.

    ``needles`` is a list of strings (one string counts as a list of one).  With
    ``no_partial_output_in`` (a folder), the refusal also left no partial output there:
    no hidden file and no ``.json``, ``.npy`` or ``.part`` file.

    Returns the error line.
    """
    if isinstance(needles, str):
        needles = [needles]
    inputs = [Path(p) for p in inputs]
    before = {p: p.read_bytes() for p in inputs}
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert code == 2, (code, out, err)
    assert len(lines) == 1 and lines[0].startswith("dpdfit: error:"), err
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert "Traceback" not in err and "np.float64" not in lines[0]
    for p, b in before.items():
        assert p.read_bytes() == b, f"{p} changed"          # input untouched
    if no_partial_output_in is not None:
        leftovers = [q.name for q in Path(no_partial_output_in).iterdir()
                     if q.name.startswith(".") or q.suffix in (".json", ".npy", ".part")]
        assert not leftovers, leftovers                      # no partial output
    return lines[0]
