#!/usr/bin/env python
"""How the readers and commands answer generated bad input.

    python benchmarks/property_counts.py [EXAMPLES] [--json PATH]

Runs every property test of ``tests/test_properties.py`` and
``tests/test_properties_cli.py`` with EXAMPLES generated inputs each (default
150, random seeds), counting instead of stopping at a failure, and prints
one row per reader or command: examples tried, clean errors (one
``dpdfit: error:`` / DpdfitError line naming the file or option), valid
results, and tracebacks (an untyped exception, a message of several lines or
naming no file, or a NaN/empty result presented as valid).  Most examples are
mutations of a valid file, so most end in a clean error.
"""

import argparse
import contextlib
import io
import os
import sys
import time

from record import add_json_option, summary_line, write_record  # noqa: E402


def _arguments():
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    ap.add_argument("examples", nargs="?", metavar="EXAMPLES",
                    help="generated inputs per test (default 150)")
    return ap.parse_args()


ARGS = _arguments()
os.environ["PROPERTY_COUNT_ONLY"] = "1"
os.environ["HYPOTHESIS_PROFILE"] = "counts"
if ARGS.examples is not None:
    os.environ["PROPERTY_EXAMPLES"] = ARGS.examples
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
    cols = ("reader / command", "examples", "clean errors", "ok results", "tracebacks")
    rows = []
    for name in sorted(tally):
        c = tally[name]
        row = [sum(c.values()), c["clean"], c["ok"], c["traceback"]]
        total = [a + b for a, b in zip(total, row)]
        print(f"{name:<{width}} | {row[0]:8d} | {row[1]:12d} | {row[2]:10d} | {row[3]:10d}")
        rows.append(dict(zip(cols, [name, *row])))
    print(f"{'total':<{width}} | {total[0]:8d} | {total[1]:12d} | {total[2]:10d} | "
          f"{total[3]:10d}")
    rows.append(dict(zip(cols, ["total", *total])))
    elapsed = time.perf_counter() - t0
    print(f"({os.environ.get('PROPERTY_EXAMPLES', 150)} examples per test requested; "
          f"{elapsed:.0f} s)")
    tracebacks = sorted(set(m[:300] for m in prop_mutations.FAILURES))
    for msg in tracebacks:
        print("traceback:", msg)
    write_record(ARGS.json, "property_counts", rows, description=summary_line(__doc__),
                 notes=[f"{os.environ.get('PROPERTY_EXAMPLES', 150)} examples per test "
                        f"requested; {elapsed:.0f} s"]
                 + [f"traceback: {msg}" for msg in tracebacks])


if __name__ == "__main__":
    main()
