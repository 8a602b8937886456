"""Crafted mappings: every one refused by ``dpdfit import`` in one line naming the key and
its line, exit status 2, nothing written, and quickly (no format that pads to gigabytes,
no expression that recurses or overflows, no value taken for what it is not)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("h5py")

from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,  # noqa: E402
                                                  write_results_file)
from tests.helpers.cli_refusal import assert_refused  # noqa: E402

T0 = 1.76e9
#: line 9: the run format; line 12: the parity files; lines 15-19: the parity columns
MAPPING = '''\
[campaign]
nu_hz = 1.84e6

[[calibration_amplitude]]
files = "results/*/*/*-AmplitudeCalibration.h5"
[calibration_amplitude.columns]
A = { axis = "amplitude" }
power = { channel = "pd_power" }
run = { run = "rid", format = "R{:03d}" }
timestamp = { run = "start_time" }

[[parity]]
files = "results/*/*/*-ParityScan.h5"
[parity.columns]
A = { argument = "amplitude" }
dpd = { argument = "dpd" }
phase_rad = { axis = "phase" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }
'''
RUN = 'run = { run = "rid", format = "R{:03d}" }'
N_EVEN = 'n_even = { channel = "n_even" }'
A = 'A = { argument = "amplitude" }'


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> Path:
    """An amplitude calibration and a parity scan, as ARTIQ and ndscan write them; a
    second parity scan ('TextArguments') whose amplitude argument is the text "0.5"."""
    folder = tmp_path_factory.mktemp("crafted") / "lab"
    a = np.linspace(0, 1, 21)
    write_results_file(folder, 1, "AmplitudeCalibration", T0, ndscan_datasets(
        1, "lab.AmplitudeCalibration", [axis("amplitude", a)], {"pd_power": channel(a ** 2)}))
    for rid, name, amplitude in ((2, "ParityScan", 0.5), (3, "TextArguments", "0.5")):
        phase = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        write_results_file(folder, rid, name, T0 + 600 * rid, ndscan_datasets(
            rid, "lab.ParityScan", [axis("phase", phase, "rad")],
            {"n_even": channel(np.full(16, 300)), "shots": channel(np.full(16, 400))}),
            arguments={"amplitude": amplitude, "dpd": 1})
    return folder


def _refused(lab, tmp_path, capsys, text: str, needles) -> str:
    mapping = lab / f"{tmp_path.name}.toml"
    mapping.write_text(text)
    out = tmp_path / "campaign"
    before = sorted(p.relative_to(lab) for p in lab.rglob("*"))
    line = assert_refused(capsys, ["import", mapping, "-o", out], needles, inputs=[mapping])
    assert not out.exists()
    assert sorted(p.relative_to(lab) for p in lab.rglob("*")) == before
    return line


def _expr(text: str) -> str:
    return MAPPING.replace(N_EVEN, f'n_even = {{ expr = "{text}" }}')


FORMATS = {
    "a width of 300 million": ('"{:300000000}"', ["width of 300000000 (at most 100)"]),
    "a width with leading zeros": ('"{:0000000000300000000}"', ["width of 300000000"]),
    "a precision of a million": ('"{:.1000000f}"', ["precision of 1000000"]),
    "an attribute of the value": ('"{0.__class__.__mro__}"',
                                  ["the field '{0.__class__.__mro__}' names something other"]),
    "an item of the value": ('"{0[0]}"', ["the field '{0[0]}' names something other"]),
    "a keyword field": ('"{rid}"', ["the field '{rid}' names something other"]),
    "a second positional field": ('"{1}"', ["the field '{1}' names something other"]),
    "a conversion": ('"{!r}"', ["a conversion (!r) is not allowed"]),
    "a field inside the spec": ('"{:{}}"', ["is not a standard format spec"]),
    "a character of a number": ('"{:c}"', ["'c' is not a standard format spec"]),
    "no field": ('"R"', ["has 0 replacement fields"]),
    "two fields": ('"{}{}"', ["has 2 replacement fields"]),
    "a lone brace": ('"R{"', ["is not a str.format text"]),
    "a number": ("5", ["must be a string", "got int"]),
    "a list": ('["{}"]', ["must be a string", "got list"]),
    "too long": ('"' + "R" * 200 + '{}"', ["is 202 characters long (at most 100)"]),
    "a line break": ('"R\\n{}"', ["control character"]),
}


@pytest.mark.parametrize("case", list(FORMATS))
def test_a_format_beyond_one_bounded_number_field_is_refused(lab, tmp_path, capsys, case):
    fmt, needles = FORMATS[case]
    _refused(lab, tmp_path, capsys, MAPPING.replace(RUN, f'run = {{ run = "rid", format = '
                                                         f'{fmt} }}'),
             ["calibration_amplitude[1].columns.run.format", "(line 9)", *needles])


EXPRESSIONS = {
    "round to 10**20 digits": ("round(channel('n_even'), 10**20)",
                               ["round takes a value and optionally a whole number"]),
    "round to a literal 10**20 digits": ("round(channel('n_even'), 100000000000000000000)",
                                         ["an integer is larger than 9007199254740992"]),
    "round to 31 digits": ("round(channel('n_even'), 31)", ["round keeps at most 30 digits"]),
    "a 400-digit literal": ("9" * 400, ["an integer is larger than 9007199254740992"]),
    "a 10000-digit literal": ("9" * 10000, ["is 10000 characters long (at most 1000)"]),
    "a huge column index": ("channel('n_even')[:, 10000000000000000000000]",
                            ["an integer is larger than"]),
    "300 nested parentheses": ("(" * 300 + "1" + ")" * 300,
                               ["is not an expression (too many nested parentheses)"]),
    "999 nested signs": ("-" * 999 + "1", ["more than 32 levels deep"]),
    "5000 nested signs": ("-" * 5000 + "1", ["is 5001 characters long"]),
    "a chain of 400 sums": ("1" + "+1" * 400, ["more than 32 levels deep"]),
    "a sum of 300 numbers": ("sum([" + ", ".join(["1"] * 300) + "])", ["more than 250 parts"]),
    "nested negations": ("-(" * 40 + "channel('n_even')" + ")" * 40,
                         ["more than 32 levels deep"]),
    "a line break": ("channel('n_even')\\n *", ["\\n *' is not an expression"]),
    "a name read twice": ("channel('n_{scan}_{scan}')",
                          ["the placeholder '{scan}' appears twice"]),
}


@pytest.mark.parametrize("case", list(EXPRESSIONS))
def test_an_expression_beyond_its_bounds_is_refused_when_the_mapping_is_read(
        lab, tmp_path, capsys, case):
    text, needles = EXPRESSIONS[case]
    _refused(lab, tmp_path, capsys, _expr(text),
             ["key 'parity[1].columns.n_even.expr' (line 18)", *needles])


def test_an_expression_that_overflows_is_refused_as_not_finite(lab, tmp_path, capsys):
    # 10**10**10 is computed in float64: inf at once, refused with the results file
    _refused(lab, tmp_path, capsys, _expr("10**10**10"),
             ["000000002-ParityScan.h5", "point 1 is inf (values must be finite)",
              "mapping key 'parity[1].columns.n_even' (line 18)"])


TYPES = {
    "files = 5": (MAPPING.replace('files = "results/*/*/*-ParityScan.h5"', "files = 5"),
                  ["key 'parity[1].files' (line 12)", "must be a glob or a list of globs"]),
    "files = []": (MAPPING.replace('files = "results/*/*/*-ParityScan.h5"', "files = []"),
                   ["key 'parity[1].files' (line 12)", "must be a glob or a list of globs"]),
    "a file that is a number": (MAPPING.replace('files = "results/*/*/*-ParityScan.h5"',
                                                'files = ["results/*/*/*.h5", 5]'),
                                ["key 'parity[1].files'", "must be a glob or a list"]),
    "complete_only as text": ('[import]\ncomplete_only = "yes"\n' + MAPPING,
                              ["key 'import.complete_only' (line 2)",
                               'must be true or false, got "yes"']),
    "skip_bad_files as text": ('[import]\nskip_bad_files = "no"\n' + MAPPING,
                               ["key 'import.skip_bad_files' (line 2)",
                                "must be true or false"]),
    "synthetic as text": (MAPPING.replace("nu_hz = 1.84e6", 'synthetic = "no"'),
                          ["key 'campaign.synthetic' (line 2)",
                           'must be true or false, got "no"']),
    "nu_hz as text": (MAPPING.replace("nu_hz = 1.84e6", 'nu_hz = "1.84e6"'),
                      ["key 'campaign.nu_hz' (line 2)", 'must be a number, got "1.84e6"']),
    "order as a boolean": (MAPPING.replace("nu_hz = 1.84e6", "order = true"),
                           ["key 'campaign.order' (line 2)", "must be a number, got true"]),
    "a name that is a number": (MAPPING.replace("nu_hz = 1.84e6", "name = 5"),
                                ["key 'campaign.name' (line 2)", "must be a string, got 5"]),
    "a table that is text": (MAPPING.replace("nu_hz = 1.84e6",
                                             'predistortion_table = "R034"'),
                             ["key 'campaign.predistortion_table' (line 2)",
                              "must be a table"]),
    "an error model value as text": (MAPPING.replace("nu_hz = 1.84e6",
                                                     'error_model = { nbar = "0.1" }'),
                                     ["key 'campaign.error_model' (line 2)",
                                      "error_model key 'nbar' must be a number, got '0.1'"]),
    "an error model key unknown": (MAPPING.replace("nu_hz = 1.84e6",
                                                   "error_model = { nbarr = 0.1 }"),
                                   ["key 'campaign.error_model'", "did you mean 'nbar'"]),
    "a constant amplitude as text": (MAPPING.replace(A, 'A = "0.5"'),
                                     ["key 'parity[1].columns.A' (line 15)",
                                      'a constant of A must be a number, got "0.5"']),
    "a constant dpd as text": (MAPPING.replace('dpd = { argument = "dpd" }', 'dpd = "no"'),
                               ["key 'parity[1].columns.dpd' (line 16)",
                                'must be a number, got "no"']),
    "a constant dpd as a boolean": (MAPPING.replace('dpd = { argument = "dpd" }',
                                                    "dpd = true"),
                                    ["parity[1].columns.dpd", "must be a number, got true"]),
    "a value as text": (MAPPING.replace(A, 'A = { value = "0.5" }'),
                        ["key 'parity[1].columns.A.value' (line 15)", "must be a number"]),
    "a constant array": (MAPPING.replace(A, "A = [0.5, 0.6]"),
                         ["parity[1].columns.A", "must be a number, got an array"]),
    "a constant beyond int64": (MAPPING.replace(A, "A = 99999999999999999999"),
                                ["parity[1].columns.A", "got an integer beyond int64"]),
    "an integer of 5000 digits": (MAPPING.replace(A, "A = " + "9" * 5000),
                                  ["not valid TOML (an integer of more than 4300 digits)"]),
    "a count as a boolean": (MAPPING.replace(N_EVEN, 'n_even = { channel = "n_even", '
                                                     'count = true }'),
                             ["key 'parity[1].columns.n_even.count' (line 18)", "got true"]),
    "an empty count": (MAPPING.replace(N_EVEN, 'n_even = { channel = "n_even", count = [] }'),
                       ["parity[1].columns.n_even.count", "must be an integer outcome"]),
    "a count beyond int64": (MAPPING.replace(N_EVEN, 'n_even = { channel = "n_even", '
                                                     'count = [0, 99999999999999999999] }'),
                             ["parity[1].columns.n_even.count", "must be an integer"]),
    "a full scale as a boolean": (MAPPING.replace(A, 'A = { argument = "amplitude", '
                                                     'full_scale_dbm = true }'),
                                  ["parity[1].columns.A.full_scale_dbm",
                                   "must be a finite number (dBm), got true"]),
    "a full scale of nan": (MAPPING.replace(A, 'A = { argument = "amplitude", '
                                               'full_scale_dbm = nan }'),
                            ["parity[1].columns.A.full_scale_dbm", "got nan"]),
    "a label that is a number": (MAPPING.replace(A, 'A = { argument = "amplitude", '
                                                    'labels = { 0 = 1 } }'),
                                 ["parity[1].columns.A.labels", "each name a string"]),
    "a format on a number column": (MAPPING.replace(A, 'A = { argument = "amplitude", '
                                                       'format = "{:.2f}" }'),
                                    ["key 'parity[1].columns.A.format' (line 15)",
                                     "makes text, and A holds numbers"]),
    "labels on a number column": (MAPPING.replace(A, 'A = { argument = "amplitude", '
                                                     'labels = { 0 = "red" } }'),
                                  ["parity[1].columns.A.labels", "makes text"]),
    "a channel that is a number": (MAPPING.replace(N_EVEN, "n_even = { channel = 5 }"),
                                   ["parity[1].columns.n_even.channel", "must be a name"]),
    "a pattern reading one placeholder twice": (
        MAPPING.replace(N_EVEN, 'n_even = { channel = "n_{scan}_{scan}" }'),
        ["parity[1].columns.n_even.channel", "the placeholder '{scan}' appears twice"]),
    "a key with a line break": ('"a\\nb" = 1\n' + MAPPING,
                                ["unknown top-level key 'a\\nb'"]),
    "deeply nested arrays": (MAPPING.replace("nu_hz = 1.84e6",
                                             "notes = " + "[" * 5000 + "]" * 5000),
                             ["mapping is not valid TOML (arrays or tables nested too "
                              "deeply to read)"]),
}


@pytest.mark.parametrize("case", list(TYPES))
def test_a_value_of_the_wrong_type_is_refused_never_converted(lab, tmp_path, capsys, case):
    text, needles = TYPES[case]
    _refused(lab, tmp_path, capsys, text, needles)


def test_a_channel_name_with_a_line_break_stays_on_one_line(lab, tmp_path, capsys):
    line = _refused(lab, tmp_path, capsys,
                    MAPPING.replace(N_EVEN, 'n_even = { channel = "n_\\neven" }'),
                    ["no channel 'n_\\neven'", "parity[1].columns.n_even"])
    assert "\\n" in line


def test_an_argument_holding_text_is_no_number(lab, tmp_path, capsys):
    # numpy would read the text "0.5" as the number 0.5; the amplitude column takes none
    text = MAPPING.replace("*-ParityScan.h5", "*-TextArguments.h5")
    _refused(lab, tmp_path, capsys, text,
             ["000000003-TextArguments.h5", "values are text, not numbers (e.g. '0.5')",
              "mapping key 'parity[1].columns.A' (line 15)"])
    _refused(lab, tmp_path, capsys, text.replace(A, "A = { expr = \"argument('amplitude')\" }"),
             ["000000003-TextArguments.h5", "argument('amplitude') is not a number",
              "mapping key 'parity[1].columns.A'"])


def test_the_bounds_leave_the_lab_s_mapping_alone(lab, tmp_path, capsys):
    """The fixture's own mapping, with a computed column and a padded label, imports."""
    from dpdfit.cli.main import main
    mapping = lab / "good.toml"
    mapping.write_text(_expr("round(channel('n_even') * 1, 0)")
                       .replace('format = "R{:03d}"', 'format = "run {:>6d}"'))
    assert main(["import", str(mapping), "-o", str(tmp_path / "c")]) == 0
    capsys.readouterr()
    runs = (tmp_path / "c" / "calibration_amplitude.csv").read_text()
    assert "run      1" in runs
