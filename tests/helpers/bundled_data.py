"""Where the bundled data sets are: the tests' one spelling of their paths."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: the synthetic AOM calibration recordings (``datasets/synthetic_aom``)
AOM = ROOT / "datasets" / "synthetic_aom"
#: the synthetic campaign folder (``datasets/synthetic_campaign``)
CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
