#!/usr/bin/env python
"""How the readers and commands answer generated bad input.

    python benchmarks/property_counts.py [EXAMPLES] [--json PATH]

Runs every property test of ``tests/recordings/test_reader_properties.py`` and
``tests/cli/test_command_properties.py`` (under pytest, in a child process) with
EXAMPLES generated inputs each (default 150, random seeds), counting instead
of stopping at a failure, and prints one row per reader or command: examples
tried, clean errors (one ``dpdfit: error:`` / DpdfitError line naming the file
or option), valid results, and tracebacks (an untyped exception, a message of several lines or
naming no file, or a NaN/empty result presented as valid).  Most examples are
mutations of a valid file, so most end in a clean error.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from record import add_json_option, summary_line, write_record

ROOT = Path(__file__).resolve().parents[1]
#: the property tests counted: run by path under pytest, not imported
TEST_FILES = ["tests/recordings/test_reader_properties.py", "tests/cli/test_command_properties.py"]


def _arguments():
    ap = add_json_option(argparse.ArgumentParser(description=summary_line(__doc__)))
    ap.add_argument("examples", nargs="?", metavar="EXAMPLES",
                    help="generated inputs per test (default 150)")
    return ap.parse_args()


ARGS = _arguments()
if ARGS.examples is not None:
    os.environ["PROPERTY_EXAMPLES"] = ARGS.examples


def _run_property_tests() -> dict:
    """Every Hypothesis test of TEST_FILES under pytest in a child process, counting
    (PROPERTY_COUNT_ONLY=1, profile 'counts'): its tally and failure messages.  The
    child's own output (an assertion of a test, e.g. a harmless edit that changed a
    result) goes to stderr."""
    with tempfile.TemporaryDirectory() as d:
        tally_json = Path(d) / "tally.json"
        env = dict(os.environ, PROPERTY_COUNT_ONLY="1", HYPOTHESIS_PROFILE="counts",
                   PROPERTY_TALLY_JSON=str(tally_json))
        subprocess.run([sys.executable, "-m", "pytest", *TEST_FILES, "-m", "hypothesis",
                        "-q", "--tb=line", "-p", "no:cacheprovider"],
                       cwd=ROOT, env=env, stdout=sys.stderr, check=False)
        if not tally_json.exists():
            sys.exit("property_counts: the property tests did not run (see above)")
        return json.loads(tally_json.read_text())


def main() -> None:
    t0 = time.perf_counter()
    counted = _run_property_tests()
    tally = {name: Counter(c) for name, c in counted["tally"].items()}
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
    tracebacks = sorted(set(m[:300] for m in counted["failures"]))
    for msg in tracebacks:
        print("traceback:", msg)
    write_record(ARGS.json, "property_counts", rows, description=summary_line(__doc__),
                 notes=[f"{os.environ.get('PROPERTY_EXAMPLES', 150)} examples per test "
                        f"requested; {elapsed:.0f} s"]
                 + [f"traceback: {msg}" for msg in tracebacks])


if __name__ == "__main__":
    main()
