"""``wiical.calibrate`` against ``wiical calibrate --json`` on the real recordings in
$WIICAL_DATA (the same dictionary, key for key), the rate table's method with ``table_rate``,
its arguments refused naming them, and the fuzz of ``test_hostile_args.py`` over it.

The CLI binary and the data folder as in test_cli_parity.py ($WIICAL_BIN, $WIICAL_DATA)."""

import math
import pathlib
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import wiical

# The CLI helpers of the parity tests and the fuzz's values (sibling modules: under pytest's
# importlib mode, which scripts/test uses, the tests directory is not on the path by itself).
sys.path.insert(0, str(pathlib.Path(__file__).parent))
from test_cli_parity import cli_json, data  # noqa: E402
from test_hostile_args import _ANY  # noqa: E402

RATE_TABLE = ("apophis_bmi160_table", "rate_table.csv")


@pytest.mark.parametrize(
    "folder,name",
    [
        ("imucal_nilspod_ferraris", "ferraris_session.csv"),
        ("repoimu_xsens_static", "static.csv"),
        RATE_TABLE,
    ],
)
def test_calibrate_equals_cli(folder: str, name: str) -> None:
    path = data(folder, name)
    got = wiical.calibrate(path)
    assert got == cli_json("calibrate", path)
    assert got["sensors"] and "accelerometer" in got


def test_the_ferraris_session_is_calibrated_from_its_turns() -> None:
    got = wiical.calibrate(data("imucal_nilspod_ferraris", "ferraris_session.csv"))
    assert got["gyroscope"]["ok"]["method"] == "ferraris"


def test_table_rate_gives_the_rate_tables_method_as_the_flag_does() -> None:
    path = data(*RATE_TABLE)
    got = wiical.calibrate(path, table_rate=[25])
    gyro = got["gyroscope"]["ok"]
    assert gyro["method"] == "rate-table"
    assert got == cli_json("calibrate", path, "--table-rate", "25")
    # One number, a tuple and a numpy array are the same list of rates.
    assert wiical.calibrate(path, table_rate=25) == got
    assert wiical.calibrate(path, table_rate=np.array([25.0])) == got
    assert wiical.calibrate(path, table_rate=(25, 0)) == cli_json(
        "calibrate", path, "--table-rate", "25,0"
    )


def test_rotation_deg_follows_the_flag() -> None:
    path = data("imucal_nilspod_ferraris", "ferraris_session.csv")
    got = wiical.calibrate(path, rotation_deg=180.0)
    assert got == cli_json("calibrate", path, "--rotation-deg", "180")


@pytest.mark.parametrize(
    "kwargs,error,words",
    [
        ({"rotation_deg": -1}, ValueError, "rotation_deg"),
        ({"rotation_deg": 0.0}, ValueError, "rotation_deg"),
        ({"rotation_deg": math.nan}, ValueError, "rotation_deg"),
        ({"rotation_deg": math.inf}, ValueError, "rotation_deg"),
        ({"rotation_deg": "360"}, TypeError, "rotation_deg must be a number"),
        ({"rotation_deg": True}, TypeError, "rotation_deg must be a number"),
        ({"table_rate": [math.nan]}, ValueError, "table_rate"),
        ({"table_rate": [25, -5]}, ValueError, "table_rate"),
        ({"table_rate": [math.inf]}, ValueError, "table_rate"),
        ({"table_rate": []}, ValueError, "table_rate"),
        ({"table_rate": "25"}, TypeError, "table_rate takes a number or a list"),
        ({"table_rate": [["25"]]}, TypeError, "table_rate must be a number"),
        ({"table_rate": {25}}, TypeError, "table_rate must be a number"),
    ],
)
def test_bad_arguments_are_refused_naming_them(kwargs: dict, error: type, words: str) -> None:
    path = data(*RATE_TABLE)
    with pytest.raises(error) as e:
        wiical.calibrate(path, **kwargs)
    assert words in str(e.value)
    # The call was wrong, not the data: not a WiicalError.
    assert not isinstance(e.value, wiical.WiicalError)


def test_a_path_of_the_wrong_type_or_no_file_is_refused() -> None:
    with pytest.raises(TypeError, match="path must be a path .* got int"):
        wiical.calibrate(3)
    with pytest.raises(wiical.WiicalError, match="cannot read"):
        wiical.calibrate(str(pathlib.Path(data(*RATE_TABLE)).parent / "no-such-file.csv"))


def test_calibrate_is_a_public_name() -> None:
    assert "calibrate" in wiical.__all__ and "calibrate" in dir(wiical)


# The fuzz of test_hostile_args.py (whose table of entry points predates calibrate): any two
# arguments give a result, a TypeError or a ValueError with a sentence, nothing else.
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(a=_ANY, b=_ANY, c=_ANY, real=st.booleans())
def test_calibrate_answers_any_arguments_with_a_result_or_a_sentence(a, b, c, real: bool) -> None:
    path = data(*RATE_TABLE) if real else a
    try:
        out = wiical.calibrate(path, table_rate=b, rotation_deg=360.0 if c is None else c)
    except (TypeError, ValueError) as e:
        assert str(e).strip(), "an empty message"
        assert "PanicException" not in type(e).__name__
        return
    assert isinstance(out, dict)
