"""Where the bundled data sets are (under the repository's root, :mod:`tests.helpers.paths`)."""

from tests.helpers.paths import ROOT

#: the synthetic AOM calibration recordings (``datasets/synthetic_aom``)
AOM = ROOT / "datasets" / "synthetic_aom"
#: the synthetic campaign folder (``datasets/synthetic_campaign``)
CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
