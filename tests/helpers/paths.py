"""Where the repository's files are: the tests' one spelling of their paths.

Test modules sit at different depths under ``tests/`` (one folder per layer of the
package, some with subfolders), so none computes the repository's root from its own
``__file__``; each imports it from here.
"""

from pathlib import Path

#: the repository's root (the folder that holds ``dpdfit/``, ``tests/``, ``docs/``)
ROOT = Path(__file__).resolve().parents[2]
#: the test suite (``tests/``)
TESTS = ROOT / "tests"
#: files the tests read: real results files, validation campaigns (``tests/data``)
TEST_DATA = TESTS / "data"
#: the texts the tests pin (``tests/golden``, :mod:`tests.helpers.golden`)
GOLDEN = TESTS / "golden"
