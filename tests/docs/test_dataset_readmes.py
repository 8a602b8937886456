"""The bundled datasets' READMEs cite module paths that exist, and the campaign
README template writes the bundled campaign's README."""

import importlib
import re

import pytest

from dpdfit.simulation.campaign.readme import README_TEMPLATE, campaign_readme
from tests.helpers.paths import ROOT

READMES = sorted((ROOT / "datasets").glob("*/README.md"))


def _cited(text):
    files = re.findall(r"\bdpdfit/[\w/]+(?:\.py|/)", text)
    dotted = re.findall(r"`(dpdfit(?:\.\w+)+)`", text)
    return files, dotted


def _resolves(name):
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr, None)
            if obj is None:
                return False
        return True
    return False


@pytest.mark.parametrize("path", READMES + [None], ids=lambda p: p.parent.name if p else "template")
def test_readme_module_paths_exist(path):
    text = README_TEMPLATE if path is None else path.read_text()
    files, dotted = _cited(text)
    assert files or dotted or path is not None
    for f in files:
        assert (ROOT / f).exists(), f"{path or 'README_TEMPLATE'} cites {f}, which does not exist"
    for d in dotted:
        assert _resolves(d), f"{path or 'README_TEMPLATE'} cites {d}, which does not exist"


def test_template_writes_the_bundled_readme():
    bundled = (ROOT / "datasets" / "synthetic_campaign" / "README.md").read_text()
    assert campaign_readme("Synthetic campaign (seed 20260329)", 20260329, {}) == bundled
