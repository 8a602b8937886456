"""``dpdfit add`` on a collaborator's campaign folder and recordings, crafted or damaged.

Every case ends in one line on stderr with exit 2 -- or exit 0 where a file is rightly
left out, named in the report -- never a traceback or the internal-error line, with
nothing written (OUT absent, no staged folder left) and CAMPAIGN, NEW and the files
outside them unchanged (:func:`tests.helpers.untrusted_campaign.tree_state`).  Cases that
could block (a FIFO) or never end (``/dev/zero``) run the command line in a child process
killed after a timeout; the others in this process.  Each command is timed only as a
guard against a hang (in the child, from the call of ``main`` on, the interpreter's start
left out).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time

import pytest

from dpdfit.cli.main import main
from tests.helpers.further_campaign import simulate
from tests.helpers.paths import ROOT
from tests.helpers.untrusted_campaign import tree_state

POPULATIONS = "A,dpd,scan,n00,n01_10,n11,n_even,shots\n0.4,1,1,100,2,198,298,300\n"
SECRET = b"SECRET-of-the-reader: never in the new folder\n"
#: a refusal (or a run) this slow is a hang, not a slow machine
GUARD_S = 5.0
#: the child process is killed after this (its interpreter's start included): a hang
CHILD_TIMEOUT_S = 60.0


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory):
    return simulate(tmp_path_factory.mktemp("untrusted") / "campaign")


@pytest.fixture
def camp(small_campaign, tmp_path):
    """A copy of the small campaign to craft (its traces folder holds nothing)."""
    return shutil.copytree(small_campaign, tmp_path / "camp")


@pytest.fixture
def new(tmp_path):
    """NEW: one population scan, honest."""
    folder = tmp_path / "new"
    folder.mkdir()
    (folder / "populations.csv").write_text(POPULATIONS)
    return folder


@pytest.fixture
def outside(tmp_path):
    """A folder outside CAMPAIGN and NEW with a secret file and a secret folder."""
    folder = tmp_path / "outside"
    (folder / "private").mkdir(parents=True)
    (folder / "secret.txt").write_bytes(SECRET)
    (folder / "private" / "key").write_bytes(SECRET)
    (folder / "populations.csv").write_text(POPULATIONS)
    return folder


def snapshot(*folders) -> dict:
    """Every entry under the folders, links not followed, nothing opened but regular
    files (:func:`~tests.helpers.untrusted_campaign.tree_state`)."""
    return {str(top): tree_state(top) for top in folders}


def run_here(capsys, *argv):
    """``dpdfit add ...`` in this process: (exit code, stdout, stderr, seconds)."""
    t = time.monotonic()
    code = main(["add", *map(str, argv)])
    seconds = time.monotonic() - t
    out, err = capsys.readouterr()
    return code, out, err, seconds


#: the child's command line: ``main`` timed in the child (the interpreter's start and
#: imports of the test harness are not the command's), the seconds on stdout's last line
_TIMED_MAIN = ("import sys, time\n"
               "from dpdfit.cli.main import main\n"
               "t = time.monotonic()\n"
               "code = main(sys.argv[1:])\n"
               "print(f'\\nseconds {time.monotonic() - t!r}', flush=True)\n"
               "sys.exit(code)\n")


def run_child(*argv, env=None):
    """``dpdfit add ...`` in a child process, killed after CHILD_TIMEOUT_S (a hang fails
    the test instead of blocking the suite): (exit code, stdout, stderr, seconds of
    ``main`` in the child)."""
    environ = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]), **(env or {})}
    try:
        p = subprocess.run([sys.executable, "-c", _TIMED_MAIN, "add", *map(str, argv)],
                           capture_output=True, text=True, env=environ,
                           timeout=CHILD_TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail(f"dpdfit add {' '.join(map(str, argv))} hung")
    stdout, _, last = p.stdout.rstrip("\n").rpartition("\n")
    assert last.startswith("seconds "), p.stdout
    return p.returncode, stdout, p.stderr, float(last.split()[1])


def assert_refused(result, out, needles, before, folders) -> str:
    """Exit 2, one line naming ``needles``, nothing written, the folders unchanged."""
    code, stdout, err, seconds = result
    lines = err.strip().splitlines()
    assert code == 2, (code, stdout, err)
    assert len(lines) == 1 and lines[0].startswith("dpdfit: error:"), err
    assert "internal error" not in err and "Traceback" not in err
    assert lines[0].isprintable() and not re.search(r"\bnp\.\w+\(", lines[0])
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert seconds < GUARD_S, seconds
    assert not os.path.lexists(out)
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]
    assert snapshot(*folders) == before
    return lines[0]


def assert_left_out(result, out, names, before, folders) -> str:
    """Exit 0, nothing on stderr, each of ``names`` left out (said in the report, absent
    from OUT), the secret nowhere in OUT, the folders unchanged."""
    code, stdout, err, seconds = result
    assert code == 0 and not err.strip(), (code, stdout, err)
    assert seconds < GUARD_S, seconds
    for name in names:
        assert f"left out: {name}" in stdout, stdout
        assert not os.path.lexists(out / name)
    for p in out.rglob("*"):
        assert not p.is_symlink(), p                   # every copy a file of its own
        if p.is_file():
            assert SECRET not in p.read_bytes(), p
    assert snapshot(*folders) == before
    return stdout


# ---------------------------------------------------------------------------- leaks
def test_a_link_to_a_secret_file_is_left_out_unread(camp, new, outside, tmp_path, capsys):
    os.symlink(outside / "secret.txt", camp / "notes.txt")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    report = assert_left_out(run_here(capsys, camp, new, "-o", out), out, ["notes.txt"],
                             before, [camp, new, outside])
    assert "not a file of the campaign layout" in report
    assert (out / "populations.csv").is_file() and (out / "README.md").is_file()


def test_a_link_to_a_secret_folder_is_left_out_not_copied(camp, new, outside, tmp_path,
                                                         capsys):
    os.symlink(outside / "private", camp / "docs")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    assert_left_out(run_here(capsys, camp, new, "-o", out), out, ["docs"], before,
                    [camp, new, outside])


def test_a_table_linked_out_of_the_campaign_is_refused(camp, new, outside, tmp_path,
                                                      capsys):
    (camp / "gate_rates.csv").unlink()
    os.symlink(outside / "populations.csv", camp / "gate_rates.csv")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'gate_rates.csv'}", "leads out of", "follows no link out"],
                   before, [camp, new, outside])


def test_a_readme_linked_to_a_secret_is_refused(camp, new, outside, tmp_path, capsys):
    (camp / "README.md").unlink()
    os.symlink(outside / "secret.txt", camp / "README.md")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    line = assert_refused(run_here(capsys, camp, new, "-o", out), out,
                          [f"{camp / 'README.md'}", "leads out of"], before,
                          [camp, new, outside])
    assert SECRET.decode().strip() not in line


def test_a_new_table_linked_out_of_new_is_refused(camp, new, outside, tmp_path, capsys):
    os.symlink(outside / "populations.csv", new / "parity.csv")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'parity.csv'}", "leads out of"], before, [camp, new, outside])


def test_new_campaign_json_linked_to_a_secret_is_refused(camp, new, outside, tmp_path,
                                                         capsys):
    os.symlink(outside / "secret.txt", new / "campaign.json")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    line = assert_refused(run_here(capsys, camp, new, "-o", out), out,
                          [f"{new / 'campaign.json'}", "leads out of"], before,
                          [camp, new, outside])
    assert "SECRET" not in line


def test_a_trace_named_outside_the_campaign_is_refused(camp, new, outside, tmp_path,
                                                       capsys):
    (camp / "traces.csv").write_text("file,A,dpd,fs,fdet,nu,xi0\n"
                                     "../outside/secret.txt,0.5,0,1e9,2e7,1.84e6,2e4\n")
    before = snapshot(camp, new, outside)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / '../outside/secret.txt'}", "leads out of"], before,
                   [camp, new, outside])


def test_links_inside_the_campaign_are_copied_as_files_of_their_own(camp, new, tmp_path,
                                                                   capsys):
    """A link to another file of CAMPAIGN is no leak: the file is copied, written
    fresh (not a link); traces named by traces.csv are copied, the others left out."""
    (camp / "traces" / "t0.npy").write_bytes(b"\x93NUMPY trace 0")
    (camp / "traces" / "t1.npy").write_bytes(b"\x93NUMPY trace 1")
    (camp / "traces" / "old.npy").write_bytes(b"\x93NUMPY not listed")
    (camp / "traces.csv").write_text("file,A,dpd,fs,fdet,nu,xi0\n"
                                     "traces/t0.npy,0.5,0,1e9,2e7,1.84e6,2e4\n"
                                     "traces/t1.npy,0.5,1,1e9,2e7,1.84e6,2e4\n")
    (camp / "docs").mkdir()
    shutil.move(camp / "README.md", camp / "docs" / "readme.txt")
    os.symlink("docs/readme.txt", camp / "README.md")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_left_out(run_here(capsys, camp, new, "-o", out), out, ["docs/", "traces/old.npy"],
                    before, [camp, new])
    assert not (out / "README.md").is_symlink()
    assert (out / "README.md").read_bytes() == (camp / "docs" / "readme.txt").read_bytes()
    for t in ("t0.npy", "t1.npy"):
        assert (out / "traces" / t).read_bytes() == (camp / "traces" / t).read_bytes()


# ---------------------------------------------------------------------------- hangs
def test_a_fifo_as_the_readme_is_refused(camp, new, tmp_path):
    (camp / "README.md").unlink()
    os.mkfifo(camp / "README.md")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_child(camp, new, "-o", out), out,
                   [f"{camp / 'README.md'}", "FIFO", "regular files only"], before,
                   [camp, new])


def test_a_fifo_as_a_campaign_table_is_refused(camp, new, tmp_path):
    (camp / "parity.csv").unlink()
    os.mkfifo(camp / "parity.csv")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_child(camp, new, "-o", out), out,
                   [f"{camp / 'parity.csv'}", "FIFO"], before, [camp, new])


def test_a_fifo_as_the_campaign_json_of_campaign_is_refused(camp, new, tmp_path):
    (camp / "campaign.json").unlink()
    os.mkfifo(camp / "campaign.json")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_child(camp, new, "-o", out), out,
                   [f"{camp / 'campaign.json'}", "FIFO"], before, [camp, new])


def test_a_fifo_as_a_new_table_or_campaign_json_is_refused(camp, new, tmp_path):
    os.mkfifo(new / "parity.csv")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_child(camp, new, "-o", out), out, [f"{new / 'parity.csv'}", "FIFO"],
                   before, [camp, new])
    (new / "parity.csv").unlink()
    os.mkfifo(new / "campaign.json")
    before = snapshot(camp, new)
    assert_refused(run_child(camp, new, "-o", out), out,
                   [f"{new / 'campaign.json'}", "FIFO"], before, [camp, new])


def test_a_fifo_as_a_named_trace_is_refused(camp, new, tmp_path):
    os.mkfifo(camp / "traces" / "t0.npy")
    (camp / "traces.csv").write_text("file,A,dpd,fs,fdet,nu,xi0\n"
                                     "traces/t0.npy,0.5,0,1e9,2e7,1.84e6,2e4\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_child(camp, new, "-o", out), out,
                   [f"{camp / 'traces/t0.npy'}", "FIFO", "not a trace"], before, [camp, new])


def test_a_fifo_of_unknown_name_is_left_out_unopened(camp, new, tmp_path):
    os.mkfifo(camp / "pipe")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_left_out(run_child(camp, new, "-o", out), out, ["pipe"], before, [camp, new])


# ------------------------------------------------------------- unbounded memory or disk
def test_a_link_to_dev_zero_is_left_out_not_copied_without_end(camp, new, tmp_path):
    os.symlink("/dev/zero", camp / "blob.bin")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_left_out(run_child(camp, new, "-o", out), out, ["blob.bin"], before, [camp, new])


def test_dev_zero_as_a_layout_file_is_refused(camp, new, tmp_path):
    os.symlink("/dev/zero", camp / "budget.toml")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_child(camp, new, "-o", out), out,
                   [f"{camp / 'budget.toml'}", "leads out of"], before, [camp, new])


def test_a_sparse_table_beyond_the_bound_is_refused_unread(camp, new, tmp_path, capsys):
    with open(new / "parity.csv", "wb") as fh:
        fh.write(b"A,dpd,scan,phase_rad,n_even,shots\n")
        fh.truncate(2**31)                       # 2 GiB declared, nothing on disk
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'parity.csv'}", "more than the 1 GiB", "DPDFIT_MAX_INPUT_BYTES"],
                   before, [camp, new])


def test_a_sparse_campaign_json_beyond_the_json_bound_is_refused(camp, new, tmp_path,
                                                                 capsys):
    with open(camp / "campaign.json", "r+b") as fh:
        fh.truncate(100 * 2**20)
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'campaign.json'}", "more than the 64 MiB"], before, [camp, new])


def test_a_trace_beyond_the_bound_set_for_the_run_is_refused(camp, new, tmp_path, capsys,
                                                             monkeypatch):
    with open(camp / "traces" / "t0.npy", "wb") as fh:
        fh.truncate(2 * 10**6)
    (camp / "traces.csv").write_text("file,A,dpd,fs,fdet,nu,xi0\n"
                                     "traces/t0.npy,0.5,0,1e9,2e7,1.84e6,2e4\n")
    monkeypatch.setenv("DPDFIT_MAX_INPUT_BYTES", str(10**6))
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'traces/t0.npy'}", "2 MB, more than the 1 MB"], before,
                   [camp, new])


def test_a_header_of_300008_fields_is_refused_before_it_is_parsed(camp, new, tmp_path,
                                                                  capsys):
    (new / "populations.csv").write_text(",".join(f"c{i}" for i in range(300_008)) + "\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "300008 fields", "1000 columns"], before,
                   [camp, new])


def test_a_row_of_300008_fields_is_refused_where_it_is_met(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_text(POPULATIONS + ",".join(["1"] * 300_008) + "\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "row 2", "the row has 300008 fields"],
                   before, [camp, new])


def test_a_sparse_readme_is_refused_not_copied(camp, new, tmp_path, capsys):
    with open(camp / "README.md", "r+b") as fh:
        fh.truncate(2**31)                       # 2 GiB declared: copied, it fills a disk
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'README.md'}", "more than the 1 GiB"], before, [camp, new])


# -------------------------------------------------------------------- internal errors
@pytest.mark.parametrize("n00, n11, shown", [("nan", "198", "n00 = 'nan'"),
                                             ("", "198", "n00 is empty"),
                                             ("100", "1e400", "n11 = '1e400'")])
def test_counts_that_are_no_counts_without_n_even(camp, new, tmp_path, capsys, n00, n11,
                                                  shown):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,shots\n"
                                         "0.4,1,1,100,2,198,300\n"
                                         f"0.4,1,2,{n00},2,{n11},300\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    column = "n11" if shown.startswith("n11") else "n00"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", f"column '{column}'", "row 2", shown,
                    "n_even = n00 + n11"], before, [camp, new])


def test_a_campaign_table_without_a_column_the_merge_needs(camp, new, tmp_path, capsys):
    text = (camp / "populations.csv").read_text().splitlines()
    (camp / "populations.csv").write_text(
        "\n".join(",".join(f for i, f in enumerate(line.split(",")) if i != 2)
                  for line in text) + "\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'populations.csv'}", "column 'scan'", "required column"],
                   before, [camp, new])


@pytest.mark.parametrize("which", ["campaign", "new"])
def test_a_symlink_loop_as_campaign_or_new(camp, new, tmp_path, capsys, which):
    loop = tmp_path / "loop"
    os.symlink(loop, loop)
    before = snapshot(camp, new)
    out = tmp_path / "out"
    argv = (loop, new) if which == "campaign" else (camp, loop)
    assert_refused(run_here(capsys, *argv, "-o", out), out,
                   [f"{loop}", "symbolic link loop"], before, [camp, new])


@pytest.mark.parametrize("which", ["campaign", "new"])
def test_a_campaign_json_with_an_integer_too_long_to_read(camp, new, tmp_path, capsys,
                                                          which):
    folder = camp if which == "campaign" else new
    (folder / "campaign.json").write_text('{"nu_hz": ' + "1" * 5000 + "}")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{folder / 'campaign.json'}", "a number too long to read"], before,
                   [camp, new])


# ------------------------------------------------ silent acceptance: no table a lab writes
def test_a_first_row_with_one_field_more_than_its_header(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots\n"
                                         "0.4,1,1,100,2,198,298,300,7\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "row 1", "the row has 9 fields, the header 8"],
                   before, [camp, new])


def test_a_later_row_wider_than_its_header_is_refused(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_text(POPULATIONS + "0.4,1,2,100,2,198,298,300\n"
                                         "0.4,1,3,100,2,198,298,300,9\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "row 3", "the row has 9 fields, the header 8"],
                   before, [camp, new])


def test_a_column_named_twice_in_new_is_refused(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots, shots\n"
                                         "0.4,1,1,100,2,198,298,300,200\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "column 'shots'", "named twice"], before,
                   [camp, new])


def test_a_column_named_twice_in_the_campaign_is_refused(camp, new, tmp_path, capsys):
    (camp / "parity.csv").write_text(
        (camp / "parity.csv").read_text().replace("\n", ",A\n", 1))
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'parity.csv'}", "column 'A'", "named twice"], before,
                   [camp, new])


def test_a_nul_byte_in_new_is_refused(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_bytes(POPULATIONS.encode() + b"0.4,1,2,1\x0000,2\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "NUL byte"], before, [camp, new])


# ------------------------------------------ silent acceptance: cells a spreadsheet runs
@pytest.mark.parametrize("cell", ["=cmd|' /C calc'!A0", "@SUM(1+1)", "+cmd", "-2+3+cmd",
                                  "\t=1+1", "\r=1+1"])
def test_a_formula_cell_of_new_is_refused(camp, new, tmp_path, capsys, cell):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots,note\n"
                                         "0.4,1,1,100,2,198,298,300,ok\n"
                                         f'0.4,1,2,100,2,198,298,300,"{cell}"\n')
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "column 'note'", "row 2"], before,
                   [camp, new])


def test_a_formula_cell_of_the_campaign_is_refused(camp, new, tmp_path, capsys):
    (camp / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots,note\n"
                                          "0.4,0,1,139,0,161,300,300,=1+2\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'populations.csv'}", "column 'note'", "row 1"], before,
                   [camp, new])


def test_a_formula_cell_of_a_campaign_table_copied_unmerged_is_refused(camp, new, tmp_path,
                                                                       capsys):
    """spectra.csv gets no rows from NEW: it is copied, after being parsed as read."""
    lines = (camp / "spectra.csv").read_text().splitlines()
    lines[0] += ",note"
    lines[1:] = [line + ",ok" for line in lines[1:]]
    lines[2] = lines[2][:-len(",ok")] + ',"=HYPERLINK(""http://x"")"'
    (camp / "spectra.csv").write_text("\n".join(lines) + "\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{camp / 'spectra.csv'}", "column 'note'", "row 2", "spreadsheet"],
                   before, [camp, new])


def test_a_formula_column_name_of_new_is_refused(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots,=cmd\n"
                                         "0.4,1,1,100,2,198,298,300,1\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    assert_refused(run_here(capsys, camp, new, "-o", out), out,
                   [f"{new / 'populations.csv'}", "=cmd"], before, [camp, new])


def test_negative_numbers_and_plain_text_are_written_as_they_are(camp, new, tmp_path,
                                                                 capsys):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots,note\n"
                                         "0.4,1,1,100,2,198,298,300,-1.5\n"
                                         "0.4,1,2,100,2,198,298,300,+3e-4\n"
                                         "0.4,1,3,100,2,198,298,300,a = b\n")
    out = tmp_path / "out"
    code, _, err, _ = run_here(capsys, camp, new, "-o", out)
    assert code == 0, err
    text = (out / "populations.csv").read_text()
    assert ",-1.5," in text and ",+3e-4," in text and ",a = b," in text


# ---------------------------------------------------------------------- unclear lines
def test_escape_sequences_in_new_s_folder_name_are_shown_escaped(camp, tmp_path, capsys):
    new = tmp_path / "new\x1b[2J\x1b[31mred"
    new.mkdir()
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,shots\n"
                                         "0.4,1,1,abc,2,198,300\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    line = assert_refused(run_here(capsys, camp, new, "-o", out), out,
                          ["new\\x1b[2J\\x1b[31mred", "column 'n00'", "row 1"], before,
                          [camp, new])
    assert "\x1b" not in line


def test_control_characters_in_a_cell_are_shown_escaped(camp, new, tmp_path, capsys):
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,shots\n"
                                         "0.4,1,1,\x1b]0;owned\x07,2,198,300\n")
    before = snapshot(camp, new)
    out = tmp_path / "out"
    line = assert_refused(run_here(capsys, camp, new, "-o", out), out,
                          [f"{new / 'populations.csv'}", "column 'n00'",
                           "\\x1b]0;owned\\x07"], before, [camp, new])
    assert "\x1b" not in line and "\x07" not in line


def test_a_campaign_folder_named_over_two_lines_gives_one_line(camp, new, tmp_path):
    odd = camp.rename(tmp_path / "camp\nsecond line")
    (odd / "parity.csv").unlink()
    os.mkfifo(odd / "parity.csv")
    before = snapshot(odd, new)
    out = tmp_path / "out"
    assert_refused(run_child(odd, new, "-o", out), out,
                   ["camp\\nsecond line/parity.csv", "FIFO"], before, [odd, new])
