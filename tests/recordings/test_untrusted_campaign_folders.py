"""The campaign folder's readers on files from elsewhere: honest tables read as before,
crafted ones refused as a whole (:class:`~dpdfit.errors.RefusedFileError` naming the
file, the column and the row), nothing outside the folder read."""

from __future__ import annotations

import io
import os
import zipfile

import numpy as np
import pandas as pd
import pytest

from dpdfit.core.defaults import MAX_CSV_COLUMNS
from dpdfit.errors import InputError, RefusedFileError
from dpdfit.recordings.campaign_folder import CampaignFolder, check_campaign_folder
from dpdfit.recordings.columns import header_columns
from dpdfit.recordings.csv_text import parse_csv_strings
from dpdfit.recordings.tables import read_csv_strings, read_table
from dpdfit.recordings.traces import check_trace_file, load_trace
from tests.helpers.bundled_data import AOM, CAMPAIGN
from tests.helpers.untrusted_campaign import (
    SECRET, declaring_npy_bytes, list_traces, small_campaign, write_declaring_npz)


def _as_pandas_read_it(raw: bytes) -> pd.DataFrame:
    df = pd.read_csv(io.BytesIO(raw), comment="#", skipinitialspace=True, dtype=str,
                     keep_default_na=False)
    df.columns = [str(c).strip() for c in df.columns]
    return df


@pytest.mark.parametrize("path", sorted([*CAMPAIGN.glob("*.csv"), *AOM.glob("*.csv")]),
                         ids=lambda p: f"{p.parent.name}/{p.name}")
def test_an_honest_table_reads_as_pandas_read_it(path):
    raw = path.read_bytes()
    pd.testing.assert_frame_equal(read_csv_strings(path), _as_pandas_read_it(raw))


@pytest.mark.parametrize("text", [
    "A,power\n-1.5,+3\n-inf,-1e-3\n.5,-.25\n",          # signed numbers are numbers
    "# comment\n\nA, power , \n0.5,1,x\n0.6\n",          # comments, blanks, a short row
    "\ufeffrun,A\nR-1,0.5\n\"a, b\",0.6\n",            # a byte-order mark, a quoted comma
    "A,power\r\n0.5,-1\r\n0.6,\r\n",                     # CRLF, an empty last cell
])
def test_honest_shapes_read_as_pandas_read_them(text):
    raw = text.encode()
    pd.testing.assert_frame_equal(parse_csv_strings(raw, "t.csv"), _as_pandas_read_it(raw))


@pytest.mark.parametrize("text, where, what", [
    ("A,power,A\n1,2,3\n", dict(column="A"), "named twice in the header (columns 1 and 3)"),
    (" A,A \n1,2\n", dict(column="A"), "named twice"),
    ("A,power\n1,2,3\n4,5,6\n", dict(row=1), "3 fields, the header 2"),
    ("# c\nA,power\n\n1,2\n# d\n3,4,5\n", dict(row=2), "3 fields, the header 2"),
    ("A,run\n1,=HYPERLINK(\"x\")\n", dict(column="run", row=1), "starts with '='"),
    ("A,run\n1,R1\n2, +cmd|x\n", dict(column="run", row=2), "starts with '+'"),
    ("A,run\n1,\"-1+2\"\n", dict(column="run", row=1), "starts with '-'"),
    ("A,run\n1,@SUM(A1)\n", dict(column="run", row=1), "starts with '@'"),
    ("A,run\n1,\"\tx\"\n", dict(column="run", row=1), "starts with '\\t'"),
    ("A,run\n1,\"\rx\"\n", dict(column="run", row=1), "starts with '\\r'"),
    ("A,=1+1\n1,2\n", dict(column="=1+1"), "formula"),
    ("A,power\n1,2\x00\n", {}, "NUL byte (byte 12)"),
])
def test_a_crafted_table_is_refused_naming_file_column_and_row(tmp_path, text, where, what):
    path = tmp_path / "t.csv"
    path.write_bytes(text.encode())
    with pytest.raises(RefusedFileError) as exc:
        read_csv_strings(path)
    assert what in str(exc.value) and exc.value.file == str(path)
    for key, value in where.items():
        assert getattr(exc.value, key) == value, str(exc.value)


def test_a_header_wider_than_the_bound_is_refused_before_it_is_parsed():
    raw = (",".join(f"c{i}" for i in range(MAX_CSV_COLUMNS + 1)) + "\n").encode()
    with pytest.raises(RefusedFileError, match=f"{MAX_CSV_COLUMNS + 1} fields, more than"):
        parse_csv_strings(raw, "t.csv")
    at_bound = (",".join(f"c{i}" for i in range(MAX_CSV_COLUMNS)) + "\n").encode()
    assert parse_csv_strings(at_bound, "t.csv").shape == (0, MAX_CSV_COLUMNS)


def test_a_device_is_refused_without_being_read():
    with pytest.raises(InputError, match="character device"):
        read_table("/dev/zero", ["A"])


def test_header_columns_reads_only_the_header(tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(b"# provenance\n A ,power\n" + b"\x00" * 2**20)   # no table after it
    assert header_columns(path) == ["A", "power"]
    path.write_bytes(b"A,A\n")
    with pytest.raises(RefusedFileError, match="named twice"):
        header_columns(path)


# ------------------------------------------------------------------- campaign folders

def test_an_honest_link_inside_the_folder_is_read(tmp_path):
    camp = small_campaign(tmp_path)
    (camp / "raw").mkdir()
    os.replace(camp / "gate_rates.csv", camp / "raw" / "gate_rates.csv")
    os.symlink("raw/gate_rates.csv", camp / "gate_rates.csv")
    cf = CampaignFolder(camp)
    cf.check_plausible()
    assert len(cf.gate_rates) == len(CampaignFolder(CAMPAIGN).gate_rates)


def test_a_table_linked_out_is_refused_when_the_folder_is_opened(tmp_path):
    """Even one no analysis reads yet: nothing of it is read."""
    camp = small_campaign(tmp_path)
    os.remove(camp / "time_scans.csv")
    os.symlink(tmp_path / "outside" / "secret.csv", camp / "time_scans.csv")
    with pytest.raises(InputError, match="leads out of") as exc:
        CampaignFolder(camp)
    assert SECRET not in str(exc.value)


def test_the_listed_traces_are_checked_inside_the_folder(tmp_path):
    camp = small_campaign(tmp_path)
    (camp / "traces").mkdir()
    with zipfile.ZipFile(CAMPAIGN / "traces" / "trace_A0.500_dpd0.npz") as zf:
        trace = np.load(zf.open("trace.npy"))[:4096]
    np.savez_compressed(camp / "traces" / "t.npz", trace=trace)
    list_traces(camp, "./traces/../traces/t.npz", "traces/absent.npz")
    cf = CampaignFolder(camp)
    assert list(cf.traces["file"]) == ["./traces/../traces/t.npz", "traces/absent.npz"]
    np.testing.assert_array_equal(load_trace(camp / cf.traces["file"][0], within=camp),
                                  trace)
    list_traces(camp, "traces/t.npz", "traces/../../outside/secret.csv")
    with pytest.raises(RefusedFileError, match="leads out of") as exc:
        CampaignFolder(camp).traces
    assert (exc.value.column, exc.value.row) == ("file", 2)


@pytest.mark.parametrize("make", ["folder", "file", "loop", "fifo"])
def test_the_campaign_path_is_checked_before_it_is_read(tmp_path, make):
    path = tmp_path / "camp"
    expected = {"folder": None, "file": "is a file", "loop": "symbolic link loop",
                "fifo": "not a folder"}[make]
    if make == "folder":
        path.mkdir()
        assert check_campaign_folder(path) == path
        return
    if make == "file":
        path.write_text("{}")
    elif make == "loop":
        os.symlink(path, path)
    else:
        os.mkfifo(path)                  # stat only: never opened
    with pytest.raises(InputError, match=expected):
        check_campaign_folder(path)


# ----------------------------------------------------------------------------- traces

def test_a_trace_declaring_more_than_the_bound_is_refused_from_its_header(tmp_path):
    npz = write_declaring_npz(tmp_path / "t.npz", 200_000_000)
    assert npz.stat().st_size < 2000
    with pytest.raises(InputError, match="declares 200,000,000 samples of 8 bytes"):
        load_trace(npz)
    npy = tmp_path / "t.npy"
    npy.write_bytes(declaring_npy_bytes(200_000_000))
    with pytest.raises(InputError, match=r"declares 200,000,000 samples .*1 GiB"):
        check_trace_file(npy)


def test_a_scale_of_many_values_is_refused_from_its_header(tmp_path):
    path = tmp_path / "t.npz"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("trace.npy", declaring_npy_bytes(8)[:-64] + bytes(64))
        zf.writestr("scale.npy", declaring_npy_bytes(10**9))
    with pytest.raises(InputError, match="'scale' must be one real number"):
        check_trace_file(path)


def test_a_damaged_archive_is_refused_in_one_line(tmp_path):
    path = tmp_path / "t.npz"
    np.savez(path, trace=np.arange(10_000, dtype=float))
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match="not a readable .npz archive .*CRC"):
        load_trace(path)


def test_a_trace_outside_the_folder_is_refused(tmp_path):
    camp = small_campaign(tmp_path)
    np.save(tmp_path / "outside" / "t.npy", np.ones(8))
    with pytest.raises(InputError, match="leads out of"):
        load_trace(camp / ".." / "outside" / "t.npy", within=camp)
