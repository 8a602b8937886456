"""Interrupt real ``dpdfit analyze`` reruns while they write; the results folder must not change.

    python scripts/interrupt_analyze.py RESULTS_DIR [DELAYS]   # DELAYS: seconds, e.g. 0,1,2,4

Runs ``analyze`` of the bundled campaign (``--no-diagnosis``) into RESULTS_DIR once,
then again and again, sending SIGINT (Ctrl-C) DELAY seconds after the log line
"writing results".  After each run it compares every file of RESULTS_DIR with the
state before the run: an interrupted run (exit 130) must leave it unchanged and no
``.part`` temporaries; a run that finished first (exit 0) has published everything.
"""

import hashlib
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def main(results: str, delays: str = "0,1,2,4") -> int:
    out = Path(results)
    cmd = [sys.executable, "-m", "dpdfit", "analyze", str(ROOT / "datasets" / "synthetic_campaign"),
           "-o", str(out), "--no-diagnosis", "--no-progress"]
    subprocess.run(cmd, capture_output=True, check=True)
    bad = 0
    for delay in (float(x) for x in delays.split(",")):
        before = snapshot(out)
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for line in p.stderr:
            if "writing results" in line:
                time.sleep(delay)
                p.send_signal(signal.SIGINT)
                break
        p.communicate()
        after = snapshot(out)
        changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
        parts = [k for k in after if k.endswith(".part")]
        ok = (p.returncode == 130 and not changed or p.returncode == 0) and not parts
        bad += not ok
        print(f"SIGINT {delay:.1f} s after 'writing results': exit {p.returncode}, "
              f"{len(changed)} files changed, {len(parts)} .part files: {'ok' if ok else 'WRONG'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
