"""``benchmark-table`` and ``benchmark-history``: the Benchmarks page, generated from JSON.

Every number on ``docs/benchmarks.md`` is read at build time from a file in
``benchmarks/``; nothing is typed into the page.  Usage (MyST)::

    ```{benchmark-table} ../benchmarks/counts_speed.json
    ```

    ```{benchmark-history} ../benchmarks/harness_report*.json
    ```

``benchmark-table`` renders one file: a caption (what was measured, the command,
the machine, the date) followed by the file's rows, one table per ``"table"`` value
of the rows.  Files written by a benchmark script with ``--json PATH``
(``benchmarks/record.py``) carry all of that.  Four older kinds of report, written
before that record existed, are read too -- their headline numbers are turned into
rows here:

* ``dpdfit harness`` reports (``harness_report*.json``),
* ``dpdfit validate``-style reports against a truth file (``validation*_report.json``),
* ``benchmarks/scale.py --out`` reports (``scale_report*.json``).

Where such a file does not record the machine or the date, the caption says so
("machine and date not recorded in the file"); the date shown then is the commit
date of the file (``git log -1 --format=%cI -- FILE``), labelled as such, and only
when git can tell it (not in a shallow clone, not for a file with uncommitted
changes).

``benchmark-history`` renders one row per file matching a glob (the headline
numbers of each, e.g. every harness run kept in the repository).

Each file read is registered as a dependency of the page, so a rebuild picks up new
numbers (a file newly matching a ``benchmark-history`` glob appears when the page is
read again: after a change of the page or of one of its files, or in a fresh build).
"""

from __future__ import annotations

import datetime as _dt
import glob
import json
import math
import os
import subprocess
from pathlib import Path

from docutils import nodes
from sphinx.util import logging
from sphinx.util.docutils import SphinxDirective

logger = logging.getLogger(__name__)

#: fields a record written by ``benchmarks/record.py`` must have
RECORD_FIELDS = ("benchmark", "command", "date", "machine", "rows")
NOT_RECORDED = "machine and date not recorded in the file"
DASH = "\u2013"


class RecordError(ValueError):
    """A benchmark file that cannot be rendered (the message names the file)."""


# ------------------------------------------------------------------ reading
def _kind(data) -> str:
    if not isinstance(data, dict):
        return "unknown"
    if all(k in data for k in RECORD_FIELDS):
        return "record"
    if "named_correctly_overall" in data and "confusion" in data:
        return "harness"
    if "truth_file" in data and "n_campaigns" in data:
        return "validation"
    if "campaigns" in data and "traces" in data and "exponents" in data:
        return "scale"
    return "unknown"


def git_commit_date(path: Path) -> tuple[str | None, str]:
    """(ISO commit date of the last commit touching ``path``, None) or (None, why not)."""
    path = Path(path).resolve()
    cwd = str(path.parent)

    def git(*args):
        return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True,
                              timeout=20)

    try:
        shallow = git("rev-parse", "--is-shallow-repository")
        if shallow.returncode:
            return None, "not in a git checkout"
        if shallow.stdout.strip() == "true":
            return None, "shallow git clone: the file's commit date is not known"
        if git("status", "--porcelain", "--", path.name).stdout.strip():
            return None, "the file has uncommitted changes"
        out = git("log", "-1", "--format=%cI", "--", path.name)
        if out.returncode or not out.stdout.strip():
            return None, "the file is not committed"
        return out.stdout.strip(), ""
    except (OSError, subprocess.SubprocessError):
        return None, "git not available"


def _pct(x):
    return None if x is None else 100.0 * x


def _confusion_text(row: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in sorted(row.items(), key=lambda kv: (-kv[1], kv[0])))


def _quantities(table: str, pairs) -> list[dict]:
    """Rows ``{"table", "quantity", "value"}`` for the pairs whose value is recorded."""
    return [{"table": table, "quantity": q, "value": v} for q, v in pairs if v is not None]


def _harness(d: dict) -> tuple[list[dict], dict, list[str]]:
    med_diag = d.get("seconds_diagnosis_median", d.get("median_seconds_diagnosis"))
    max_diag = d.get("seconds_diagnosis_max", d.get("max_seconds_diagnosis"))
    runs = d.get("n_runs")
    head = "headline"
    rows = _quantities(head, [
        ("seed", d.get("seed")),
        ("campaigns run", runs),
        ("campaigns planned", d.get("n_planned")),
        ("failed runs", d.get("n_failed")),
        ("single effects named correctly [%]", _pct(d.get("named_correctly_overall"))),
        ("pairs: both effects named [%]", _pct(d.get("pairs_both_named"))),
        ("pairs: at least one named [%]", _pct(d.get("pairs_one_named"))),
        ("false-alarm rate on the nulls [%]", _pct(d.get("false_alarm_rate"))),
        ("median reduced chi2 before the diagnosis", d.get("median_redchi_before")),
        ("median reduced chi2 after", d.get("median_redchi_after")),
        ("diagnosis within 60 s [%]", _pct(d.get("diagnosis_within_60s"))),
        ("diagnosis time, median [s]", med_diag),
        ("diagnosis time, 90th percentile [s]", d.get("seconds_diagnosis_p90")),
        ("diagnosis time, max [s]", max_diag),
        ("time per run, median [s]", d.get("median_seconds_per_run")),
        ("wall time of the whole run [s]", d.get("seconds")),
        ("workers", d.get("workers")),
    ])
    per = "per concealed effect"
    recovery = d.get("recovery") or {}
    named = d.get("named_correctly") or {}
    for effect, row in sorted((d.get("confusion") or {}).items()):
        rec = recovery.get(effect) or {}
        rows.append({"table": per, "concealed": effect, "campaigns": sum(row.values()),
                     "named correctly [%]": _pct(named.get(effect)),
                     "verdicts (confusion matrix)": _confusion_text(row),
                     "all parameters within 2 sigma [%]":
                         _pct(rec.get("all_params_within_2sigma"))})
    headline = {"seed": d.get("seed"), "campaigns": runs,
                "single effects named [%]": _pct(d.get("named_correctly_overall")),
                "false alarms [%]": _pct(d.get("false_alarm_rate")),
                "pairs both named [%]": _pct(d.get("pairs_both_named")),
                "median diagnosis [s]": med_diag,
                "median per run [s]": d.get("median_seconds_per_run")}
    notes = ["The confusion matrix counts each run's verdict (its leading effect); a run is "
             "named correctly only when the effects it names are the concealed ones, so a "
             "right verdict with an extra effect named counts as a miss."]
    if d.get("timing_note"):
        notes.append(f"Timing: {d['timing_note']}")
    return rows, headline, notes


def _validation(d: dict) -> tuple[list[dict], dict, list[str]]:
    head = "headline"
    rows = _quantities(head, [
        ("campaigns", d.get("n_campaigns")),
        ("with one concealed effect", d.get("n_concealed")),
        ("with a pair of effects", d.get("n_pairs")),
        ("nulls", d.get("n_nulls")),
        ("refused", d.get("n_refused")),
        ("concealed effects named correctly [%]", _pct(d.get("named_correctly"))),
        ("pairs: both effects named [%]", _pct(d.get("pairs_both_named"))),
        ("pairs: at least one named [%]", _pct(d.get("pairs_one_named"))),
        ("pairs called none", d.get("pairs_called_none")),
        ("false-alarm rate on the nulls [%]", _pct(d.get("false_alarm_rate"))),
        ("time per campaign, median [s]", d.get("median_seconds")),
        ("time per campaign, max [s]", d.get("max_seconds")),
        ("wall time of the whole run [s]", d.get("seconds")),
        ("workers", d.get("workers")),
    ])
    per = "per campaign"
    for run in d.get("runs") or []:
        rows.append({"table": per, "campaign": run.get("campaign"), "truth": run.get("truth"),
                     "named": ", ".join(run.get("named") or []) or run.get("verdict"),
                     "named correctly": run.get("named_correctly"),
                     "time [s]": run.get("seconds"), "error": run.get("error")})
    headline = {"campaigns": d.get("n_campaigns"),
                "named correctly [%]": _pct(d.get("named_correctly")),
                "false alarms [%]": _pct(d.get("false_alarm_rate")),
                "pairs both named [%]": _pct(d.get("pairs_both_named")),
                "median [s]": d.get("median_seconds")}
    notes = []
    if d.get("campaigns") or d.get("truth_file"):
        notes.append(f"campaigns {d.get('campaigns')}, truth file {d.get('truth_file')} "
                     "(paths as recorded; the campaigns are not part of the repository)")
    return rows, headline, notes


def _exponent(sizes, values) -> float | None:
    pts = [(math.log(s), math.log(v)) for s, v in zip(sizes, values)
           if v is not None and isinstance(v, (int, float)) and math.isfinite(v) and v > 0]
    if len(pts) < 2:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    return sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx if sxx else None


def _mib(b):
    return None if b is None else b / 2**20


def _scale(d: dict) -> tuple[list[dict], dict, list[str]]:
    """The table ``benchmarks/scale.py`` prints, from its ``--out`` report."""
    rows = []
    camp = {int(k): v for k, v in (d.get("campaigns") or {}).items()}
    sizes = sorted(camp)
    stages = ("calibration", "stability", "sweep", "spectra", "traces", "gates",
              "propagation", "budget", "diagnosis")
    steps = "analyze per step: median wall time and traced peak above the step's start"
    exps = d.get("exponents") or {}
    for st in (*stages, "analyze"):
        if st == "analyze":
            t = [camp[k].get("total_s") for k in sizes]
            m = [camp[k].get("maxrss_bytes") for k in sizes]
            et, em = _exponent(sizes, t), _exponent(sizes, m)
        else:
            t = [camp[k].get("time_s", {}).get(st) for k in sizes]
            m = [camp[k].get("peak_bytes", {}).get(st) for k in sizes]
            if all(x is None for x in t):
                continue
            et = (exps.get("time") or {}).get(st)
            em = (exps.get("memory") or {}).get(st)
        row = {"table": steps, "step": "analyze (memory: ru_maxrss)" if st == "analyze" else st}
        row.update({f"time {k}x [s]": v for k, v in zip(sizes, t)})
        row["time exponent"] = et
        row.update({f"memory {k}x [MiB]": _mib(v) for k, v in zip(sizes, m)})
        row["memory exponent"] = em
        rows.append(row)
    for k in sizes:
        r = (camp[k].get("size") or {}).get("rows") or {}
        rows.append({"table": "campaign sizes", "size": f"{k}x",
                     "diagnosis": camp[k].get("diagnosis"),
                     **{f"{f} rows": r.get(f) for f in
                        ("calibration_amplitude.csv", "calibration_phase.csv", "spectra.csv",
                         "populations.csv", "parity.csv")}})
    traces = {int(k): v for k, v in (d.get("traces") or {}).items()}
    for m in sorted(traces):
        tr = traces[m]
        rows.append({"table": "trace (load_trace + trace_tone_powers)", "samples": f"2^{m}",
                     "time [s]": tr.get("total_s"), "load [s]": tr.get("load_s"),
                     "tones [s]": tr.get("tones_s"),
                     "traced peak [MiB]": _mib(tr.get("peak_bytes")),
                     "maxrss [MiB]": _mib(tr.get("maxrss_bytes"))})
    if len(traces) > 1:
        ms = sorted(traces)
        rows.append({"table": "trace growth exponents (log-log slope against samples)",
                     "time exponent": _exponent([2.0 ** m for m in ms],
                                                [traces[m].get("total_s") for m in ms]),
                     "traced peak exponent": _exponent([2.0 ** m for m in ms],
                                                       [traces[m].get("peak_bytes") for m in ms])})
    headline = {"sizes": ", ".join(f"{k}x" for k in sizes),
                "analyze time exponent": _exponent(sizes, [camp[k].get("total_s")
                                                           for k in sizes])}
    notes = [f"medians of {d.get('repeat')} child run(s) per point; growth exponent = "
             "least-squares slope of log(value) against log(size) (target <= 1.1)"]
    if d.get("wall_s") is not None:
        notes.append(f"total wall time of the benchmark {d['wall_s']:.0f} s")
    return rows, headline, notes


def load_record(path) -> dict:
    """Read one benchmark file and return it in the form the directives render.

    Keys: ``benchmark``, ``description``, ``command`` (or None), ``date`` (or None),
    ``date_note`` (how the date was obtained, or why there is none), ``machine``
    (dict, str or None), ``rows``, ``notes``, ``headline`` (dict), ``kind``, ``path``.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RecordError(f"{path}: cannot read the benchmark file: {exc}") from exc
    kind = _kind(data)
    if kind == "unknown":
        raise RecordError(f"{path}: not a benchmark record (needs the fields "
                          f"{', '.join(RECORD_FIELDS)}) nor a known report")
    if kind == "record":
        rows = data["rows"]
        if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
            raise RecordError(f"{path}: 'rows' must be a list of objects")
        if not isinstance(data["machine"], dict):
            raise RecordError(f"{path}: 'machine' must be an object")
        quantity_rows = [r for r in rows if "quantity" in r and "value" in r]
        headline = {r["quantity"]: r["value"] for r in quantity_rows[:3]}
        return {"kind": kind, "path": path, "benchmark": data["benchmark"],
                "description": data.get("description") or "", "command": data["command"],
                "date": data["date"], "date_note": "", "machine": data["machine"],
                "rows": rows, "notes": list(data.get("notes") or []), "headline": headline}
    rows, headline, notes = {"harness": _harness, "validation": _validation,
                             "scale": _scale}[kind](data)
    date, why = git_commit_date(path)
    descriptions = {
        "harness": "Injection-recovery harness: simulated campaigns with a concealed effect "
                   "(or none), diagnosed, the verdict compared with the truth.",
        "validation": "Diagnosis of campaigns made independently of the harness, compared "
                      "with a truth file kept apart.",
        "scale": "How dpdfit analyze scales with the size of a campaign, and trace analysis "
                 "with trace length (benchmarks/scale.py).",
    }
    return {"kind": kind, "path": path, "benchmark": path.stem,
            "description": descriptions[kind], "command": data.get("command"),
            "date": date,
            "date_note": "commit date of the file (git log), not the date of the run"
                         if date else why,
            "machine": data.get("machine") if isinstance(data.get("machine"), str) else None,
            "python": data.get("python"),
            "rows": rows, "notes": notes, "headline": headline}


# ------------------------------------------------------------------ formatting
def fmt(value) -> str:
    """One cell: 4 significant digits (3 above 10^6), thousands separated from 10^4 on,
    a dash for none; integers as they are."""
    if value is None:
        return DASH
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return DASH
        a = abs(value)
        if a == 0:
            return "0"
        if a >= 1e6:
            return f"{value:.3g}"
        if a >= 1e4:
            return f"{value:,.0f}"
        if a >= 1e-3:
            return f"{value:.4g}"
        return f"{value:.2e}"
    if isinstance(value, (list, dict)):
        return json.dumps(value)
    return str(value)


def format_date(iso: str) -> str:
    try:
        t = _dt.datetime.fromisoformat(iso)
    except (TypeError, ValueError):
        return str(iso)
    if t.tzinfo is not None:
        t = t.astimezone(_dt.timezone.utc)
        return t.strftime("%Y-%m-%d %H:%M UTC")
    return t.strftime("%Y-%m-%d %H:%M")


def machine_text(machine) -> str:
    """The machine on one line."""
    if isinstance(machine, str):
        return " ".join(machine.split())
    m = machine or {}
    parts = [str(m.get("processor") or "unknown processor")]
    if m.get("cores") is not None:
        parts.append(f"{m['cores']} cores")
    if m.get("memory_gib") is not None:
        parts.append(f"{m['memory_gib']} GiB")
    text = ", ".join(parts)
    if m.get("platform"):
        text += f"; {m['platform']}"
    versions = [f"{name} {m[key]}" for name, key in (("Python", "python"), ("numpy", "numpy"),
                                                    ("dpdfit", "dpdfit")) if m.get(key)]
    if versions:
        text += "; " + ", ".join(versions)
    if m.get("dpdfit_git"):
        text += f" (git {m['dpdfit_git']})"
    if m.get("load_average"):
        text += "; load average " + " / ".join(str(x) for x in m["load_average"])
        text += " (1 / 5 / 15 min, when written)"
    return text


def split_tables(rows: list[dict]) -> list[tuple[str | None, list[str], list[dict]]]:
    """(title, columns, rows) per ``"table"`` value, in order of first appearance.

    Columns are the union of the rows' keys in order of appearance, without the ones
    that are empty in every row.
    """
    groups: dict = {}
    for r in rows:
        groups.setdefault(r.get("table"), []).append(r)
    out = []
    for title, rs in groups.items():
        cols: list[str] = []
        for r in rs:
            cols += [k for k in r if k != "table" and k not in cols]
        cols = [c for c in cols if any(r.get(c) is not None for r in rs)]
        out.append((title, cols, rs))
    return out


# ------------------------------------------------------------------ nodes
def table_node(title, columns: list[str], rows: list[dict]) -> nodes.table:
    table = nodes.table(classes=["benchmark-table"])
    if title:
        table += nodes.title(text=str(title))
    group = nodes.tgroup(cols=len(columns))
    table += group
    for _ in columns:
        group += nodes.colspec(colwidth=1)
    head = nodes.thead()
    group += head
    hrow = nodes.row()
    head += hrow
    for c in columns:
        hrow += nodes.entry("", nodes.paragraph(text=c))
    body = nodes.tbody()
    group += body
    for r in rows:
        row = nodes.row()
        body += row
        for c in columns:
            row += nodes.entry("", nodes.paragraph(text=fmt(r.get(c))))
    return table


def _field(name: str, *body: nodes.Node) -> nodes.field:
    return nodes.field("", nodes.field_name(text=name), nodes.field_body("", *body))


def caption_nodes(rec: dict, shown_path: str) -> list[nodes.Node]:
    """What, command, machine, date (and the file) of one record."""
    out: list[nodes.Node] = []
    if rec.get("description"):
        out.append(nodes.paragraph(text=rec["description"]))
    fields = nodes.field_list(classes=["benchmark-caption"])
    if rec.get("command"):
        fields += _field("Command", nodes.paragraph("", "", nodes.literal(text=rec["command"])))
    else:
        fields += _field("Command", nodes.paragraph(text="not recorded in the file"))
    if rec["kind"] == "record":
        fields += _field("Machine", nodes.paragraph(text=machine_text(rec["machine"])))
        fields += _field("Date", nodes.paragraph(text=format_date(rec["date"])))
    else:
        if rec.get("machine"):
            text = machine_text(rec["machine"]) + " (as recorded in the file)"
            if rec.get("python"):
                text += f"; Python {rec['python']}"
        else:
            text = NOT_RECORDED
        fields += _field("Machine", nodes.paragraph(text=text))
        date_text = "not recorded in the file"
        if rec.get("date"):
            date_text += f"; {rec['date_note']}: {format_date(rec['date'])}"
        elif rec.get("date_note"):
            date_text += f" ({rec['date_note']})"
        fields += _field("Date", nodes.paragraph(text=date_text))
    fields += _field("File", nodes.paragraph("", "", nodes.literal(text=shown_path)))
    out.append(fields)
    return out


def record_nodes(rec: dict, shown_path: str | None = None) -> list[nodes.Node]:
    """The caption and the tables of one record."""
    shown = shown_path or str(rec["path"])
    # a record's text is written by a program (commands, options such as --no-diagnosis):
    # smart quotes would turn its "--" into a dash
    box = nodes.container(classes=["benchmark-record"], support_smartquotes=False)
    box += caption_nodes(rec, shown)
    for title, columns, rows in split_tables(rec["rows"]):
        box += table_node(title, columns, rows)
    if rec.get("notes"):
        notes = nodes.bullet_list()
        for n in rec["notes"]:
            notes += nodes.list_item("", nodes.paragraph(text=n))
        box += nodes.paragraph(text="Notes:")
        box += notes
    return [box]


def history_rows(records: list[tuple[str, dict]]) -> list[dict]:
    rows = []
    for shown, rec in records:
        row = {"file": shown}
        row.update(rec["headline"])
        if rec["kind"] == "record":
            row["date"] = format_date(rec["date"])
        else:
            row["date"] = (format_date(rec["date"]) + " (commit)" if rec.get("date")
                           else "not recorded")
        rows.append(row)
    return rows


# ------------------------------------------------------------------ directives
class _Base(SphinxDirective):
    required_arguments = 1
    final_argument_whitespace = False
    has_content = False

    def _shown(self, path: str) -> str:
        root = Path(self.env.srcdir).resolve().parent
        try:
            return str(Path(path).resolve().relative_to(root))
        except ValueError:
            return os.path.basename(path)

    def _load(self, path: str) -> dict | None:
        self.env.note_dependency(path)
        try:
            return load_record(path)
        except RecordError as exc:
            logger.warning(str(exc), location=self.get_location())
            return None


class BenchmarkTable(_Base):
    """Caption and tables of one benchmark file."""

    def run(self) -> list[nodes.Node]:
        _, path = self.env.relfn2path(self.arguments[0], self.env.docname)
        if not os.path.isfile(path):
            logger.warning(f"benchmark file not found: {self.arguments[0]} ({path})",
                           location=self.get_location())
            return []
        rec = self._load(path)
        return [] if rec is None else record_nodes(rec, self._shown(path))


class BenchmarkHistory(_Base):
    """One row of headline numbers per file matching a glob."""

    def run(self) -> list[nodes.Node]:
        _, pattern = self.env.relfn2path(self.arguments[0], self.env.docname)
        paths = sorted(glob.glob(pattern))
        if not paths:
            logger.warning(f"no benchmark file matches {self.arguments[0]}",
                           location=self.get_location())
            return []
        records = []
        for p in paths:
            rec = self._load(p)
            if rec is not None:
                records.append((self._shown(p), rec))
        rows = history_rows(records)
        (_, columns, rows), = split_tables(rows)
        table = table_node(None, columns, rows)
        table["support_smartquotes"] = False       # program-written text, as in a record
        return [table]


def setup(app):
    app.add_directive("benchmark-table", BenchmarkTable)
    app.add_directive("benchmark-history", BenchmarkHistory)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
