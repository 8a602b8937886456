"""Golden files: texts a test pins in ``tests/golden/``, regenerated on purpose only.

After an intended change of such a text, regenerate the files with::

    DPDFIT_UPDATE_GOLDEN=1 python -m pytest tests/...

and review the diff of ``tests/golden/`` before committing.
"""

from __future__ import annotations

import os

from tests.helpers.paths import GOLDEN

__all__ = ["UPDATE", "check_golden"]

#: rewrite the golden files instead of comparing with them
UPDATE = os.environ.get("DPDFIT_UPDATE_GOLDEN") == "1"


def check_golden(name: str, text: str) -> None:
    """``text`` (plus a final line break) is the content of ``tests/golden/<name>``."""
    path = GOLDEN / name
    if UPDATE:
        GOLDEN.mkdir(exist_ok=True)
        path.write_text(text + "\n")
        return
    assert path.exists(), f"{path} missing: run with DPDFIT_UPDATE_GOLDEN=1"
    assert text + "\n" == path.read_text(), (
        f"text differs from {path}; if intended, regenerate with DPDFIT_UPDATE_GOLDEN=1")
