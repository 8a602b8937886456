"""Every TOML block of the import guide is a mapping dpdfit reads (a block showing one
table gets the amplitude calibration every mapping needs)."""

from __future__ import annotations

import re

import pytest

from dpdfit.recordings.mapping import read_mapping
from tests.helpers.paths import ROOT

GUIDE = ROOT / "docs" / "guide" / "import.md"
BLOCKS = re.findall(r"^( *)```toml\n(.*?)^\1```", GUIDE.read_text(encoding="utf-8"),
                    flags=re.S | re.M)
CALIBRATION = ('[[calibration_amplitude]]\nfiles = "x.h5"\n[calibration_amplitude.columns]\n'
               'A = 0.5\npower = 1.0\n\n')


def test_the_guide_has_its_mapping_examples():
    assert len(BLOCKS) >= 5


@pytest.mark.parametrize("block", range(len(BLOCKS)))
def test_a_guide_mapping_is_read(block, tmp_path):
    indent, text = BLOCKS[block]
    text = "\n".join(line[len(indent):] for line in text.splitlines())
    if "[[calibration_amplitude]]" not in text:
        text = CALIBRATION + text
    path = tmp_path / "map.toml"
    path.write_text(text, encoding="utf-8")
    mapping = read_mapping(path)
    assert mapping.sources
