"""A results file is read only from itself, only where the mapping uses it, and never
beyond a size limit; a malformed one is refused in one line.

Each file is written as ARTIQ writes it, then changed with h5py: a dataset whose data
is in another file (external storage, a virtual dataset, an external link, a soft link
out of ``datasets/``), one that declares gigabytes it never wrote, values that are not
real numbers or text, and a run or an ndscan schema of the wrong type or shape.
"""

from __future__ import annotations

import hashlib
import json
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from dpdfit.errors import InputError  # noqa: E402
from dpdfit.recordings.artiq import read_results_file  # noqa: E402
from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.recordings.hdf5_contents import ResultsFileContents  # noqa: E402
from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,  # noqa: E402
                                                  pyon_encode, write_results_file)
from tests.helpers.cli_refusal import assert_refused  # noqa: E402
from tests.helpers.mapping_text import CALIBRATION_STUB  # noqa: E402

T0 = 1.76e9
PARITY = "results/2025-10-09/08/000000002-ParityScan.h5"
ROOT = "ndscan.rid_2."
N_EVEN = ROOT + "points.channel_n_even"
MAPPING = CALIBRATION_STUB + '''[[parity]]
files = "results/**/*-ParityScan.h5"
[parity.columns]
A = { argument = "amplitude" }
dpd = { argument = "dpd" }
phase_rad = { axis = "phase" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }
'''
#: counts a parity scan could hold (so that reading them would import without a word)
SECRET_COUNTS = np.array([397, 389, 383, 379, 373, 367, 359, 353, 349, 347, 337, 331, 317,
                          313, 311, 307], dtype="<i8")
SECRET_TEXT = b"SECRET-PAYLOAD-never-to-be-read!"


def _lab(tmp_path: Path, change=None, mapping: str = MAPPING) -> Path:
    """A lab folder with one ndscan parity scan (rid 2), changed by ``change(file,
    tmp_path)``, and its mapping; returns the mapping's path."""
    lab = tmp_path / "lab"
    phase = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    ds = ndscan_datasets(2, "lab.ParityScan", [axis("phase", phase, "rad")],
                         {"n_even": channel(np.full(16, 300)),
                          "shots": channel(np.full(16, 400))})
    path = write_results_file(lab, 2, "ParityScan", T0, ds,
                              arguments={"amplitude": 0.5, "dpd": 1})
    assert path == lab / PARITY
    if change is not None:
        with h5py.File(path, "a") as f:
            change(f, tmp_path)
    (lab / "map.toml").write_text(mapping)
    return lab / "map.toml"


def _outside(tmp_path: Path) -> Path:
    """A folder beside the lab, which the mapping does not name, with the secret in it:
    raw counts (``secret.bin``) and an HDF5 file holding them (``secret.h5``)."""
    out = tmp_path / "outside"
    if not out.exists():
        out.mkdir()
        (out / "secret.bin").write_bytes(SECRET_COUNTS.tobytes() + SECRET_TEXT)
        with h5py.File(out / "secret.h5", "w") as f:
            f["x"] = SECRET_COUNTS
    return out


def _replace(f, name: str, make) -> None:
    g = f["datasets"]
    del g[name]
    make(g, name)


def _refused(capsys, mapping: Path, needles: list) -> str:
    """Exit 2, one line with ``needles``, no campaign folder, and nothing of the secret."""
    out = mapping.parent.parent / "campaign"
    line = assert_refused(capsys, ["import", mapping, "-o", out], needles, inputs=[mapping],
                          no_partial_output_in=mapping.parent.parent)
    assert not out.exists()
    assert "SECRET" not in line
    return line


def _external_storage(f, tmp):
    secret = _outside(tmp) / "secret.bin"
    _replace(f, N_EVEN, lambda g, n: g.create_dataset(
        n, shape=(16,), dtype="<i8", external=[(str(secret), 0, SECRET_COUNTS.nbytes)]))


def _virtual(f, tmp):
    layout = h5py.VirtualLayout(shape=(16,), dtype="<i8")
    layout[:] = h5py.VirtualSource(str(_outside(tmp) / "secret.h5"), "x", shape=(16,))
    _replace(f, N_EVEN, lambda g, n: g.create_virtual_dataset(n, layout))


def _external_link(f, tmp):
    target = str(_outside(tmp) / "secret.h5")
    _replace(f, N_EVEN, lambda g, n: g.__setitem__(n, h5py.ExternalLink(target, "/x")))


def _soft_link_out_of_datasets(f, tmp):
    f["archive"]["counts"] = SECRET_COUNTS
    _replace(f, N_EVEN, lambda g, n: g.__setitem__(n, h5py.SoftLink("/archive/counts")))


STORAGE_OUTSIDE = {
    "external storage": (_external_storage, "keeps its data outside the results file"),
    "a virtual dataset": (_virtual, "is a virtual dataset"),
    "an external link": (_external_link, "is an external link to '/x' in the file"),
    "a soft link out of datasets/": (_soft_link_out_of_datasets,
                                     "is a soft link to '/archive/counts', not to a dataset"),
}


@pytest.mark.parametrize("case", list(STORAGE_OUTSIDE))
def test_a_channel_whose_data_is_not_in_the_file_is_refused_unread(case, tmp_path, capsys):
    change, why = STORAGE_OUTSIDE[case]
    mapping = _lab(tmp_path, change)
    _refused(capsys, mapping, ["000000002-ParityScan.h5", f"dataset '{N_EVEN}'", why])
    with pytest.raises(InputError, match=why):        # the Python reader too
        read_results_file(mapping.parent / PARITY).scan().channel("n_even")


def test_a_run_key_kept_in_another_file_is_refused_and_its_text_never_shown(tmp_path,
                                                                              capsys):
    def expid_outside(f, tmp):
        secret = _outside(tmp) / "secret.bin"
        del f["expid"]
        # a size-1 array: HDF5 keeps a scalar's data in the file whatever it is told
        f.create_dataset("expid", shape=(1,), dtype=f"S{len(SECRET_TEXT)}",
                         external=[(str(secret), SECRET_COUNTS.nbytes, len(SECRET_TEXT))])

    mapping = _lab(tmp_path, expid_outside)
    _refused(capsys, mapping, ["000000002-ParityScan.h5", "dataset 'expid'",
                               "HDF5 external storage"])


def test_a_soft_link_to_another_dataset_of_the_run_is_read(tmp_path):
    def linked(f, tmp):
        f["datasets"]["n_even_copy"] = np.full(16, 300)
        _replace(f, N_EVEN, lambda g, n: g.__setitem__(n, h5py.SoftLink(
            "/datasets/n_even_copy")))

    parity = import_campaign(_lab(tmp_path, linked)).tables["parity"]
    assert parity["n_even"].tolist() == [300] * 16


def _never_read(f, tmp):
    """What the mapping does not name, each of which would fail or be refused if read: a
    channel of the used root that declares 80 GB and one that is an external link,
    external storage and links to files that do not exist, a virtual dataset of one, a
    second ndscan root whose schema is not JSON."""
    g = f["datasets"]
    g.create_dataset(ROOT + "points.channel_camera", shape=(16, 10**9 // 16 * 10), dtype="f8",
                     chunks=(1, 4096))
    channels = json.loads(g[ROOT + "channels"][()])
    channels["camera"] = {"path": "camera", "type": "opaque", "description": "camera"}
    channels["elsewhere"] = {"path": "elsewhere", "type": "float"}
    g[ROOT + "channels"][()] = json.dumps(channels)
    g[ROOT + "points.channel_elsewhere"] = h5py.ExternalLink(
        str(tmp / "outside" / "missing.h5"), "/x")
    missing = str(tmp / "outside" / "missing.bin")
    g.create_dataset("raw_trace", shape=(1000,), dtype="f8", external=[(missing, 0, 8000)])
    g["other_run"] = h5py.ExternalLink(str(tmp / "outside" / "missing.h5"), "/datasets")
    g["archived"] = h5py.SoftLink("/archive")
    layout = h5py.VirtualLayout(shape=(4,), dtype="f8")
    layout[:] = h5py.VirtualSource(str(tmp / "outside" / "missing.h5"), "x", shape=(4,))
    g.create_virtual_dataset("stitched", layout)
    g["ndscan.rid_9.ndscan_schema_revision"] = 2
    g["ndscan.rid_9.axes"] = "not JSON"


ROOTED = MAPPING.replace("[[parity]]\n", '[[parity]]\nroot = "ndscan.rid_2."\n')


def test_only_what_the_mapping_uses_is_read(tmp_path, monkeypatch):
    mapping = _lab(tmp_path, _never_read, ROOTED)
    read = []
    real_read, real_top = ResultsFileContents.read, ResultsFileContents.read_top
    monkeypatch.setattr(ResultsFileContents, "read",
                        lambda self, name: read.append(name) or real_read(self, name))
    monkeypatch.setattr(ResultsFileContents, "read_top",
                        lambda self, key: read.append(key) or real_top(self, key))
    parity = import_campaign(mapping).tables["parity"]
    assert parity["n_even"].tolist() == [300] * 16
    structure = {ROOT + k for k in ("axes", "channels", "points.axis_0", "completed",
                                    "ndscan_schema_revision", "source_id", "fragment_fqn")}
    run = {"expid", "rid", "artiq_version", "start_time", "run_time"}
    assert set(read) == run | structure | {N_EVEN, ROOT + "points.channel_shots"}


def test_campaign_json_lists_only_the_results_files_read(tmp_path, capsys):
    from dpdfit.cli.main import main
    mapping = _lab(tmp_path, _never_read, ROOTED)
    out = tmp_path / "campaign"
    assert main(["import", str(mapping), "-o", str(out), "--no-progress"]) == 0
    meta = json.loads((out / "campaign.json").read_text())
    sources = meta["imported"]["sources"]
    assert [s["file"] for s in sources] == [PARITY]
    assert sources[0]["sha256"] == hashlib.sha256((mapping.parent / PARITY).read_bytes()) \
        .hexdigest()
    assert sources[0]["rid"] == 2 and set(sources[0]["tables"]) == {"calibration_amplitude",
                                                                    "parity"}
    written = "".join(p.read_text() for p in out.iterdir())
    assert "outside" not in written and "missing" not in written


def test_listing_follows_no_link(tmp_path):
    mapping = _lab(tmp_path, _never_read, ROOTED)
    rf = read_results_file(mapping.parent / PARITY)
    names = set(rf.datasets)
    assert {"other_run", "archived", "stitched", "raw_trace"} <= names
    assert not [n for n in names if n.startswith(("other_run/", "archived/"))]
    assert list(rf.scans) == ["ndscan.rid_2.", "ndscan.rid_9."]
    with pytest.raises(InputError, match="ndscan.rid_9.axes' is not JSON"):
        rf.scans["ndscan.rid_9."]


def _never_written(shots: int):
    """Per-shot counts of 16 points x ``shots`` float64, chunked and never written."""
    def change(f, tmp):
        _replace(f, N_EVEN, lambda g, n: g.create_dataset(n, shape=(16, shots), dtype="f8",
                                                          chunks=(1, 1 << 16)))
    return change


def test_a_dataset_declaring_gigabytes_it_never_wrote_is_refused_in_small_memory(
        tmp_path, capsys):
    mapping = _lab(tmp_path, _never_written(11_718_750))         # 1.5e9 bytes
    assert (mapping.parent / PARITY).stat().st_size < 100_000
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as refused:
            import_campaign(mapping)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6, peak                                  # nothing near 1.5 GB
    msg = str(refused.value)
    for needle in (f"dataset '{N_EVEN}' declares 1.5 GB", "(shape (16, 11718750) of float64)",
                   "over the limit of 268 MB (268435456 bytes)",
                   "'[import] max_dataset_bytes = N' in the mapping"):
        assert needle in msg, msg
    _refused(capsys, mapping, [PARITY, f"dataset '{N_EVEN}' declares 1.5 GB"])


def test_ten_billion_floats_are_refused_by_their_declared_size(tmp_path):
    mapping = _lab(tmp_path, _never_written(625_000_000))            # 1e10 float64
    with pytest.raises(InputError, match=r"declares 80 GB \(shape \(16, 625000000\) of "):
        read_results_file(mapping.parent / PARITY).scan().channel("n_even")


def test_the_mapping_sets_the_size_limit(tmp_path, capsys):
    lowered = "[import]\nmax_dataset_bytes = 64\n\n" + MAPPING
    mapping = _lab(tmp_path, mapping=lowered)
    # the phase axis, 16 float64 values, is the first dataset over 64 bytes
    _refused(capsys, mapping, [f"dataset '{ROOT}points.axis_0' declares 128 bytes",
                               "over the limit of 64 bytes (64 bytes)"])
    mapping.write_text(lowered.replace("= 64", "= 1_000_000"))
    assert len(import_campaign(mapping).tables["parity"]) == 16
    mapping.write_text(lowered.replace("= 64", '= "64 MB"'))
    _refused(capsys, mapping, ["map.toml", "key 'import.max_dataset_bytes'",
                               "must be a whole number of bytes"])


def test_variable_length_text_is_counted_as_it_is_read(tmp_path):
    def notes(f, tmp):
        f["datasets"]["notes"] = np.array(["x" * 1000] * 10, dtype=h5py.string_dtype())

    path = _lab(tmp_path, notes).parent / PARITY
    assert read_results_file(path).datasets["notes"][0][9] == "x" * 1000
    # 10 elements pass the bound on their count (64 bytes each); their 10 kB do not
    with pytest.raises(InputError, match="'notes' holds more than 2 kB of variable-length"):
        read_results_file(path, max_dataset_bytes=2000).datasets["notes"]


def test_a_sparse_file_of_gigabytes_that_is_not_hdf5_is_refused_on_its_first_bytes(
        tmp_path, capsys):
    mapping = _lab(tmp_path)
    sparse = mapping.parent / "results/2025-10-09/08/000000003-ParityScan.h5"
    with open(sparse, "wb") as fh:
        fh.truncate(1_500_000_000)                # 1.5 GB of holes: nothing on disk
    io = Path("/proc/self/io")
    if io.exists():                         # bytes this process read, by the kernel's count
        def read_so_far():
            return int(io.read_text().split("rchar:")[1].split()[0])
        before = read_so_far()
        with pytest.raises(InputError, match="not an HDF5 file"):
            read_results_file(sparse)
        assert read_so_far() - before < 1_000_000
    _refused(capsys, mapping, ["000000003-ParityScan.h5", "not an HDF5 file"])


def _channel_of(values):
    return lambda f, tmp: _replace(f, N_EVEN, lambda g, n: g.__setitem__(n, values))


def _dataset(key, value):
    def change(f, tmp):
        del f[key]
        f[key] = value
    return change


def _json_of(key, edit):
    def change(f, tmp):
        d = f["datasets"][ROOT + key]
        d[()] = json.dumps(edit(json.loads(d[()])))
    return change


def _expid(value):
    return _dataset("expid", pyon_encode(value))


def _records(f, tmp):
    _replace(f, N_EVEN, lambda g, n: g.__setitem__(
        n, np.zeros(16, dtype=[("count", "i8"), ("flag", "i1")])))


def _references(f, tmp):
    ref = f["archive"].ref
    _replace(f, N_EVEN, lambda g, n: g.create_dataset(n, data=[ref] * 16,
                                                      dtype=h5py.ref_dtype))


MALFORMED = {
    "complex counts": (_channel_of(np.full(16, 300 + 1j)),
                       [f"dataset '{N_EVEN}'", "values are complex numbers (complex128)"]),
    "counts as records": (_records, [f"dataset '{N_EVEN}' holds records of several fields"]),
    "counts as references": (_references, [f"dataset '{N_EVEN}' holds HDF5 references"]),
    "counts with no dataspace": (_channel_of(h5py.Empty("f8")),
                                 [f"dataset '{N_EVEN}' holds no value"]),
    "counts as one number": (_channel_of(300), ["points.channel_n_even' has 1"]),
    "an axis of 4 x 4": (lambda f, tmp: _replace(f, ROOT + "points.axis_0", lambda g, n: (
        g.__setitem__(n, np.zeros((4, 4))))), ["points.axis_0' has 4"]),
    "datasets a dataset": (lambda f, tmp: (f.__delitem__("datasets"),
                                           f.__setitem__("datasets", np.arange(3))),
                           ["'datasets' is a dataset, not a group"]),
    "expid an integer": (_dataset("expid", 5),
                         ["dataset 'expid' is not PYON text but int 5"]),
    "expid a group": (lambda f, tmp: (f.__delitem__("expid"), f.create_group("expid")),
                      ["dataset 'expid' is a group, not a value"]),
    "expid an array": (_dataset("expid", np.array(["{}", "{}"], dtype=h5py.string_dtype())),
                       ["dataset 'expid' is an array of shape (2,), not one value"]),
    "expid arguments a list": (_expid({"class_name": "ParityScan", "arguments": [1, 2]}),
                               ["dataset 'expid': its 'arguments' is not a dictionary"]),
    "rid text": (_dataset("rid", "two"), ["dataset 'rid' is not an integer: str 'two'"]),
    "rid a fraction": (_dataset("rid", 2.5), ["dataset 'rid' is not an integer: float 2.5"]),
    "start_time complex": (_dataset("start_time", T0 + 1j),
                           ["dataset 'start_time' is not a time"]),
    "artiq_version a number": (_dataset("artiq_version", 8),
                               ["dataset 'artiq_version' is not text: int 8"]),
    "axes not JSON": (lambda f, tmp: f["datasets"][ROOT + "axes"].__setitem__((), "[{"),
                      [f"dataset '{ROOT}axes' is not JSON"]),
    "axes an object": (_json_of("axes", lambda a: {"0": a[0]}),
                       [f"dataset '{ROOT}axes' is a JSON object where ndscan writes a list"]),
    "channels a list": (_json_of("channels", lambda c: list(c.values())),
                        [f"dataset '{ROOT}channels' is a JSON list where ndscan writes an "
                         "object"]),
    "an axis a string": (_json_of("axes", lambda a: ["phase"]),
                         [f"root '{ROOT}', dataset '{ROOT}axes': axis 0 is a JSON string, "
                          "not an object"]),
    "an axis param a list": (_json_of("axes", lambda a: [{"param": [1]}]),
                             ["axis 0 'param' is a JSON list, not an object"]),
    "a channel a list": (_json_of("channels", lambda c: {**c, "n_even": [1]}),
                         [f"dataset '{ROOT}channels': channel 'n_even' is a JSON list, not "
                          "an object"]),
    "a unit not text": (_json_of("channels", lambda c: {**c, "shots": {"unit": 5}}),
                        ["channel 'shots': its unit is not text but a JSON number"]),
    "a scale not a number": (_json_of("channels", lambda c: {**c, "shots": {"scale": "1"}}),
                             ["channel 'shots': its scale is not a number"]),
    "completed an array": (lambda f, tmp: _replace(f, ROOT + "completed", lambda g, n: (
        g.__setitem__(n, np.array([True, False])))),
        [f"dataset '{ROOT}completed' is an array of shape (2,), not one value"]),
    "schema revision text": (lambda f, tmp: _replace(f, ROOT + "ndscan_schema_revision",
                                                     lambda g, n: g.__setitem__(n, "2")),
                             [f"dataset '{ROOT}ndscan_schema_revision' is not an integer"]),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_a_malformed_results_file_is_one_line(case, tmp_path, capsys):
    change, needles = MALFORMED[case]
    _refused(capsys, _lab(tmp_path, change), ["000000002-ParityScan.h5", *needles])


def test_a_file_is_open_once_for_a_with_block_and_read_again_after(tmp_path, monkeypatch):
    path = _lab(tmp_path).parent / PARITY
    rf = read_results_file(path)
    opened = []
    real = h5py.File
    monkeypatch.setattr(h5py, "File", lambda *a, **kw: opened.append(a[0]) or real(*a, **kw))
    with rf:
        scan = rf.scan()
        assert scan.channel("n_even").values.tolist() == [300] * 16
        assert scan.channel("shots").values.tolist() == [400] * 16
    assert opened == [path]
    assert rf.datasets[ROOT + "seed"][0] == 0
    assert opened == [path, path]
