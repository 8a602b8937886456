#!/usr/bin/env python
"""How the readers and commands answer generated bad input.

    python benchmarks/property_counts.py [EXAMPLES]

Runs every property test of ``tests/test_properties.py`` and
``tests/test_properties_cli.py`` with EXAMPLES generated inputs each (default
150, random seeds), counting instead of stopping at a failure, and prints
one row per reader or command: examples tried, clean errors (one
``dpdfit: error:`` / DpdfitError line naming the file or option), valid
results, and tracebacks (an untyped exception, a message of several lines or
naming no file, or a NaN/empty result presented as valid).  Most examples are
mutations of a valid file, so most end in a clean error.
"""

import contextlib
import io
import os
import sys
import time

os.environ["PROPERTY_COUNT_ONLY"] = "1"
os.environ["HYPOTHESIS_PROFILE"] = "counts"
if len(sys.argv) > 1:
    os.environ["PROPERTY_EXAMPLES"] = sys.argv[1]
sys.path.insert(0, ".")

from tests.helpers import prop_mutations  # noqa: E402  (loads the 'counts' profile)
from tests import test_properties  # noqa: E402
from tests import test_properties_cli  # noqa: E402


def main() -> None:
    tests = [(m, n) for m in (test_properties, test_properties_cli) for n in sorted(vars(m))
             if n.startswith("test_") and hasattr(getattr(m, n), "hypothesis")]
    t0 = time.perf_counter()
    for module, name in tests:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            try:
                getattr(module, name)()
            except AssertionError as exc:       # e.g. a harmless edit changed a result
                print(f"{name}: {exc}", file=sys.__stderr__)
    tally = prop_mutations.TALLY
    width = max(len(k) for k in tally)
    print(f"{'reader / command':<{width}} | examples | clean errors | ok results | tracebacks")
    print(f"{'-' * width}-|----------|--------------|------------|-----------")
    total = [0, 0, 0, 0]
    for name in sorted(tally):
        c = tally[name]
        row = [sum(c.values()), c["clean"], c["ok"], c["traceback"]]
        total = [a + b for a, b in zip(total, row)]
        print(f"{name:<{width}} | {row[0]:8d} | {row[1]:12d} | {row[2]:10d} | {row[3]:10d}")
    print(f"{'total':<{width}} | {total[0]:8d} | {total[1]:12d} | {total[2]:10d} | "
          f"{total[3]:10d}")
    print(f"({os.environ.get('PROPERTY_EXAMPLES', 150)} examples per test requested; "
          f"{time.perf_counter() - t0:.0f} s)")
    for msg in sorted(set(m[:300] for m in prop_mutations.FAILURES)):
        print("traceback:", msg)


if __name__ == "__main__":
    main()
