"""Crafted PYON (a run's ``expid``): every text decodes or is refused with one PyonError
line, never another exception; through ``dpdfit import`` the refusal names the results
file and its dataset ``expid``, exit status 2, nothing written."""

from __future__ import annotations

import base64
import math
from fractions import Fraction

import numpy as np
import pytest

from dpdfit.recordings.pyon import PyonError, decode_pyon

_ZEROS = base64.b64encode(np.zeros(4).tobytes()).decode()            # four float64 zeros

CRAFTED = {
    "an unhashable key": ("{[1]: 2}", "not hashable (unhashable type: 'list')"),
    "a dictionary as a key": ('{{"a": 1}: 2}', "not hashable (unhashable type: 'dict')"),
    "an unhashable set member": ("{[1], 2}", "not hashable"),
    "Fraction(1, 0)": ("Fraction(1, 0)", "Fraction(...) cannot be built"),
    "a Fraction of text": ('Fraction("1", 2)', "Fraction(...) takes two integers"),
    "OrderedDict of a number": ("OrderedDict(5)", "OrderedDict(...) cannot be built"),
    "OrderedDict with a list key": ("OrderedDict([([1], 2)])", "OrderedDict(...) cannot be"),
    "an object array": (f'nparray((4,), "O", "{_ZEROS}")', "dtype 'O' is not one of"),
    "a structured array": (f'nparray((2,), "i4,i4", "{_ZEROS}")', "is not one of numbers"),
    "an unknown dtype": (f'nparray((4,), "float128x", "{_ZEROS}")', "is not a numpy dtype"),
    "a shape that does not fit": (f'nparray((5,), "<f8", "{_ZEROS}")',
                                  "nparray(...) cannot be built (cannot reshape"),
    "a shape of 10**18 points": (f'nparray((1000000000000000000,), "<f8", "{_ZEROS}")',
                                 "nparray(...) cannot be built"),
    "a shape of text": (f'nparray("4", "<f8", "{_ZEROS}")', "the shape is not a tuple"),
    "data that is no base64": ('nparray((1,), "<f8", 5)', "not base64 text"),
    "a scalar without bytes": ('npscalar("<f8", "")', "npscalar(...) cannot be built"),
    "a slice of lists": ("slice([1], {}, 2)", "slice(...) takes integers or null"),
    "a slice of four": ("slice(1, 2, 3, 4)", "unsupported call slice(...)"),
    "an integer beyond int64": ("9223372036854775808", "an integer beyond int64 (64 bits)"),
    "a hexadecimal of 100000 digits": ("0x" + "f" * 100_000, "an integer beyond int64"),
    "a decimal of 5000 digits": ("9" * 5000, "Exceeds the limit (4300 digits)"),
    "a long text": ("[" + "0, " * 400_000 + "]", "characters long (at most 1000000)"),
    "nested lists": ("[" * 150 + "]" * 150, "nested deeper than 100 levels"),
    "nested dictionaries": ('{"a": ' * 150 + "1" + "}" * 150, "nested deeper than 100"),
    "a chain of signs": ("-" * 100_000 + "1", "nested deeper than 100 levels"),
    "a chain of sums": ("1" + "+1" * 5000, "nested deeper than 100 levels"),
    "an ellipsis": ("...", "unsupported expression (...)"),
    "a dictionary unpacked": ("{**x}", "unsupported expression (** in a dictionary)"),
    "a NUL byte": ("{1: \x002}", "not PYON text"),
    "bytes that are not UTF-8": (b"\xff\xfe{}", "not UTF-8 text"),
    "a number, not text": (5, "not text (a int)"),
}


@pytest.mark.parametrize("case", list(CRAFTED))
def test_crafted_pyon_is_one_pyon_error(case):
    text, why = CRAFTED[case]
    with pytest.raises(PyonError) as exc:
        decode_pyon(text)
    assert why in str(exc.value) and "\n" not in str(exc.value), str(exc.value)
    assert "set_int_max_str_digits" not in str(exc.value)


def test_pyon_as_sipyco_writes_it_still_decodes():
    a = np.arange(6, dtype="<i4").reshape(2, 3)
    text = (f'{{"a": nparray((2, 3), "<i4", "{base64.b64encode(a.tobytes()).decode()}"), '
            f'"s": npscalar("<f8", "{base64.b64encode(np.float64(2.5).tobytes()).decode()}"), '
            '"f": Fraction(1, 3), "o": OrderedDict([("x", 1)]), "sl": slice(1, null, 2), '
            '"n": [-9223372036854775807, 9223372036854775807, -inf, nan, true], '
            f'"z": nparray([2, -1], "<f8", "{_ZEROS}")}}')
    v = decode_pyon(text)
    np.testing.assert_array_equal(v["a"], a)
    assert v["s"] == 2.5 and v["f"] == Fraction(1, 3) and v["o"] == {"x": 1}
    assert v["sl"] == slice(1, None, 2) and v["z"].shape == (2, 2)
    assert v["n"][:3] == [-(2**63 - 1), 2**63 - 1, -math.inf] and math.isnan(v["n"][3])


@pytest.mark.parametrize("case", ["an unhashable key", "Fraction(1, 0)", "an object array",
                                  "a shape that does not fit", "a slice of lists",
                                  "an integer beyond int64", "nested lists",
                                  "a chain of signs"])
def test_a_results_file_with_crafted_pyon_is_refused_in_one_line(tmp_path, capsys, case):
    h5py = pytest.importorskip("h5py")
    from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,
                                                      write_results_file)
    from tests.helpers.cli_refusal import assert_refused
    from tests.helpers.mapping_text import CALIBRATION_STUB
    lab = tmp_path / "lab"
    a = np.linspace(0, 1, 5)
    path = write_results_file(lab, 1, "AmplitudeCalibration", 1.76e9, ndscan_datasets(
        1, "lab.AmplitudeCalibration", [axis("amplitude", a)], {"pd_power": channel(a)}))
    with h5py.File(path, "r+") as f:
        del f["expid"]
        f["expid"] = '{"class_name": "AmplitudeCalibration", "arguments": {"x": %s}}' \
            % CRAFTED[case][0]
    mapping = lab / "map.toml"
    mapping.write_text(CALIBRATION_STUB.replace("A = 0.5\npower = 1.0",
                                                'A = { axis = "amplitude" }\n'
                                                'power = { channel = "pd_power" }'))
    out = tmp_path / "campaign"
    assert_refused(capsys, ["import", mapping, "-o", out],
                   ["000000001-AmplitudeCalibration.h5", "expid", CRAFTED[case][1]],
                   inputs=[mapping, path])
    assert not out.exists()
