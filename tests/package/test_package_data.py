"""Every file the package reads at run time is installed with it.

The test suite imports dpdfit from the source tree, so a data file missing from the
wheel would pass every other test and fail only for a user who installed dpdfit
(``pip install .``).  Every non-Python file under ``dpdfit/`` must therefore match a
``[tool.setuptools.package-data]`` pattern, and the example mappings users read in
``examples/import/`` must be the packaged files themselves.
"""

from __future__ import annotations

import tomllib
from fnmatch import fnmatch

from tests.helpers.paths import ROOT

PACKAGE = ROOT / "dpdfit"


def test_every_data_file_in_the_package_is_declared_package_data():
    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())[
        "tool"]["setuptools"]["package-data"]["dpdfit"]
    undeclared = [str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*")
                  if p.is_file() and p.suffix not in (".py", ".pyc")
                  and "__pycache__" not in p.parts
                  and not any(fnmatch(str(p.relative_to(PACKAGE)), pat) for pat in patterns)]
    assert not undeclared, f"not in [tool.setuptools.package-data]: {undeclared}"


def test_the_artiq_writer_reads_its_mappings_from_the_package():
    from dpdfit.simulation.artiq_results import MAPPINGS

    assert MAPPINGS.is_relative_to(PACKAGE)
    for name in ("ndscan_campaign.toml", "per_shot_campaign.toml"):
        assert (MAPPINGS / name).is_file()
        example = ROOT / "examples" / "import" / name
        assert example.resolve() == (MAPPINGS / name).resolve(), example
