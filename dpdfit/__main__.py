"""``python -m dpdfit``: the ``dpdfit`` command line (:mod:`dpdfit.cli.main`)."""

import sys

from dpdfit.cli.main import main

__all__: list[str] = []

if __name__ == "__main__":
    sys.exit(main())
