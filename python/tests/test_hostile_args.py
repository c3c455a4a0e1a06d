"""The Python door against hostile or careless callers: arrays go through the loader's checks
and settings through the CLI flags' ranges (the same sentences: one check in the engine for
both doors), paths and lists of the wrong type get a sentence naming the argument, arrays are
not copied on the Python side, the new functions (noise, tempcal, correct) equal the command
line, the progress callback is called, and the namespace holds only the package's names.

Real recordings from $WIICAL_DATA; the CLI binary as in test_cli_parity.py."""

import math
import os
import pathlib
import subprocess
import sys
import tempfile
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import wiical

# The CLI helpers of the parity tests (a sibling module: under pytest's importlib mode, which
# scripts/test uses, the tests directory is not on the path by itself).
sys.path.insert(0, str(pathlib.Path(__file__).parent))
from test_cli_parity import _cli, cli_error, cli_json, data  # noqa: E402

XSENS = ("imu_tk_xsens", "xsens_acc.mat")


def _xsens() -> "wiical.Recording":
    return wiical.read(data(*XSENS))


def _csv(rows: "list[str]") -> str:
    f = tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False)
    f.write("t,x,y,z\n" + "".join(r + "\n" for r in rows))
    f.close()
    return f.name


# --- arrays through the loader's checks ---------------------------------------------------


def test_a_nan_row_is_refused_as_the_cli_refuses_it_in_a_file() -> None:
    xyz = np.tile([0.0, 0.0, 1.0], (50, 1))
    xyz[7, 1] = np.nan
    with pytest.raises(wiical.WiicalError) as e:
        wiical.fit(xyz)
    assert str(e.value) == "data, row 7, column y: value NaN is not finite"
    # The CLI on the same values in a file: the same refusal, by line.
    path = _csv([f"{i * 0.01},{r[0]},{r[1]},{r[2]}" for i, r in enumerate(xyz)])
    try:
        assert "column 'y': value 'nan' is not finite" in cli_error("fit", path)
    finally:
        os.unlink(path)


@pytest.mark.parametrize("bad", [np.inf, -np.inf])
def test_infinite_values_are_refused_naming_row_and_column(bad: float) -> None:
    xyz = np.tile([0.0, 0.0, 1.0], (20, 1))
    xyz[3, 0] = bad
    with pytest.raises(wiical.WiicalError, match=r"^data, row 3, column x: value -?inf is not finite$"):
        wiical.magfit(xyz)


def test_readings_beyond_1e12_and_all_zero_readings_are_refused() -> None:
    xyz = np.tile([0.0, 0.0, 1.0], (20, 1))
    xyz[5, 2] = 3e12
    with pytest.raises(wiical.WiicalError, match="row 5, column z.*beyond ±1e12"):
        wiical.fit(xyz)
    with pytest.raises(wiical.WiicalError, match="smaller than 1e-9"):
        wiical.fit(np.zeros((20, 3)))


def test_time_going_back_is_refused_as_in_a_file() -> None:
    rec = _xsens()
    t = rec.t.copy()
    t[100], t[101] = t[101], t[100]
    with pytest.raises(wiical.WiicalError) as e:
        wiical.fit(rec.xyz, t=t)
    msg = str(e.value)
    assert msg.startswith("t, row 101: time goes from")
    assert msg.endswith("rows must be in time order")
    path = _csv(["0,0,0,1", "0.02,0,0,1", "0.01,0,0,1"])
    try:
        assert "rows must be in time order" in cli_error("fit", path)
    finally:
        os.unlink(path)
    with pytest.raises(wiical.WiicalError, match="t, row 0, column t: value NaN"):
        wiical.fit(rec.xyz, t=np.full(len(rec.t), np.nan))


@pytest.mark.parametrize(
    "shape,text",
    [((10, 2), "(10, 2)"), ((10,), "(10)"), ((4, 3, 1), "(4, 3, 1)"), ((0, 3), None)],
)
def test_wrong_shapes_name_the_argument_and_its_shape(shape: tuple, text: str) -> None:
    with pytest.raises(wiical.WiicalError) as e:
        wiical.fit(np.ones(shape))
    if text is None:
        assert str(e.value) == "data has no rows: nothing to analyse"
    else:
        assert str(e.value) == f"data has shape {text}: give an array of shape (n, 3) (x, y, z per row)"


def test_columns_of_another_length_and_non_numbers_are_refused() -> None:
    xyz = np.tile([0.0, 0.0, 1.0], (20, 1))
    with pytest.raises(wiical.WiicalError, match="^t has 19 values but there are 20 samples$"):
        wiical.fit(xyz, t=np.arange(19) * 0.01)
    with pytest.raises(ValueError, match="t must be one-dimensional"):
        wiical.fit(xyz, t=np.zeros((20, 2)))
    with pytest.raises(TypeError, match="data holds text"):
        wiical.fit([["a", "b", "c"]])
    with pytest.raises(TypeError, match="data must be a path or an array"):
        wiical.fit(object())


# --- settings through the CLI flags' ranges -----------------------------------------------


@pytest.mark.parametrize(
    "kwarg,value,flag",
    [
        ("window_s", 0, "--window-s"),
        ("window_s", 1e-300, "--window-s"),
        ("init_s", -1.0, "--init-s"),
        ("min_static_s", 1e300, "--min-static-s"),
        ("threshold", 1.0, "--threshold"),
        ("threshold", math.nan, "--threshold"),
        ("rate_hz", 0.0, "--rate-hz"),
        ("rate_hz", 1e300, "--rate-hz"),
        ("rate_hz", 1e-300, "--rate-hz"),
        ("rate_hz", math.inf, "--rate-hz"),
    ],
)
def test_settings_are_refused_where_the_cli_flag_is(kwarg: str, value: float, flag: str) -> None:
    path = data(*XSENS)
    with pytest.raises(ValueError) as e:
        wiical.fit(path, **{kwarg: value})
    msg = str(e.value)
    assert msg.startswith(f"{kwarg} = "), msg
    # The CLI refuses the same value of its flag with the same range sentence.
    cli = cli_error("fit", path, flag, repr(value) if not math.isinf(value) else "inf")
    assert flag in cli
    assert msg.split(": ", 1)[1] in cli, (msg, cli)


@pytest.mark.parametrize(
    "kwarg,value,flag",
    [
        ("alpha", 1e-300, "--alpha"),
        ("alpha", 0.9, "--alpha"),
        ("cv_factor", 1e300, "--cv-factor"),
        ("cv_factor", 0.5, "--cv-factor"),
    ],
)
def test_the_rule_settings_are_refused_where_the_cli_flag_is(kwarg: str, value: float, flag: str) -> None:
    """`--alpha 1e-300` ran for over a minute (issue 49): both doors refuse it at once, with
    the same range sentence."""
    path = data(*XSENS)
    with pytest.raises(ValueError) as e:
        wiical.analyze(path, **{kwarg: value})
    msg = str(e.value)
    assert msg.startswith(f"{kwarg} = "), msg
    cli = cli_error("analyze", path, flag, repr(value))
    assert flag in cli
    assert msg.split(": ", 1)[1] in cli, (msg, cli)


def test_an_adc_range_must_be_two_finite_numbers_low_then_high() -> None:
    path = data(*XSENS)
    with pytest.raises(ValueError, match=r"^adc_range = \(5.0, 1.0\): need finite LO < HI$"):
        wiical.fit(path, adc_range=(5, 1))
    with pytest.raises(TypeError, match="adc_range takes two numbers"):
        wiical.fit(path, adc_range="0:1023")
    with pytest.raises(TypeError, match="adc_range must be a number"):
        wiical.fit(path, adc_range=("0", 1023))


def test_numbers_of_the_wrong_type_name_the_argument() -> None:
    path = data(*XSENS)
    with pytest.raises(TypeError, match="window_s must be a number, got str"):
        wiical.fit(path, window_s="1")
    with pytest.raises(TypeError, match="rate_hz must be a number, got bool"):
        wiical.fit(path, rate_hz=True)
    with pytest.raises(ValueError, match="the nominal sensitivity must be finite and non-zero"):
        wiical.gyrofit(data("mpu9150_mikoff_5units", "imu2.csv"), counts_per_dps=0)
    with pytest.raises(TypeError, match="scale takes one number or three, not the string"):
        wiical.gyrofit(data("mpu9150_mikoff_5units", "imu2.csv"), scale="1e-3")


# --- paths and lists ----------------------------------------------------------------------


def test_a_bytes_path_reads_the_same_file() -> None:
    path = data(*XSENS)
    assert wiical.fit(os.fsencode(path)) == wiical.fit(path)
    assert wiical.read(os.fsencode(path)).xyz.shape == (51175, 3)
    with pytest.raises(TypeError, match="path must be a path .* got int"):
        wiical.read(3)


def test_a_string_given_for_a_list_is_answered_clearly() -> None:
    path = data("mpu6050_hmc5883l_sunsided_set2", "full-sphere_mpu6050.csv")
    with pytest.raises(TypeError) as e:
        wiical.fit(path, columns="acc_x_g,acc_y_g,acc_z_g")
    assert "columns takes a list of names" in str(e.value)
    assert "'acc_x_g,acc_y_g,acc_z_g'" in str(e.value)
    with pytest.raises(TypeError, match="candidates takes a list of names"):
        wiical.analyze(path, candidates="cubic")
    with pytest.raises(TypeError, match="columns takes names"):
        wiical.fit(path, columns=["acc_x_g", 2, "acc_z_g"])
    # A list works as the CLI's --columns.
    cols = ["acc_x_g", "acc_y_g", "acc_z_g"]
    assert wiical.fit(path, columns=cols) == cli_json("fit", path, "--columns", ",".join(cols))


# --- no copies ----------------------------------------------------------------------------


def test_fit_reads_an_array_in_place_without_a_python_side_copy() -> None:
    rec = _xsens()
    xyz = np.ascontiguousarray(rec.xyz)
    want = wiical.fit(xyz, t=rec.t)
    tracemalloc.start()
    got = wiical.fit(xyz, t=rec.t)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert got == want
    # tobytes() of the samples alone would be xyz.nbytes (1.2 MB) traced by numpy.
    assert peak < xyz.nbytes / 4, (peak, xyz.nbytes)
    # A strided view (every column of a wider array) is read in place too, with the same result.
    wide = np.zeros((len(xyz), 6))
    wide[:, ::2] = xyz
    assert wiical.fit(wide[:, ::2], t=rec.t) == want


def test_read_returns_the_engines_buffers_without_a_copy() -> None:
    path = data(*XSENS)
    tracemalloc.start()
    rec = wiical.read(path)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert rec.xyz.shape == (51175, 3) and rec.xyz.dtype == np.float64
    assert rec.xyz.flags.c_contiguous
    # Numpy allocating and filling arrays (a copy) is traced; adopting Rust's vectors is not.
    assert peak < rec.xyz.nbytes / 4, (peak, rec.xyz.nbytes)
    # The values are the loader's: the file's fit equals the arrays' fit.
    assert wiical.fit(rec.xyz, t=rec.t) == wiical.fit(path)


# --- noise, tempcal, correct --------------------------------------------------------------


def test_noise_equals_the_cli() -> None:
    path = data("adis16405_static_smac", "imu1.csv.gz")
    assert wiical.noise(path) == cli_json("noise", path)
    with pytest.raises(ValueError, match="rate_hz = 0.0"):
        wiical.noise(path, rate_hz=0)


def test_noise_streams_a_large_file_as_the_cli_does(tmp_path) -> None:
    # A plain text file from the size at which the CLI streams it (set to 0 here: every file;
    # a 128 MiB one by default) is streamed by Python too: the report says so, and equals the
    # CLI's. Python used to hold such a file, and refused one over 256 MiB.
    import gzip

    plain = tmp_path / "imu1.csv"
    plain.write_bytes(gzip.decompress(pathlib.Path(data("adis16405_static_smac", "imu1.csv.gz")).read_bytes()))
    got = wiical.noise(str(plain), stream_from_bytes=0)
    assert "streamed" in got, sorted(got)
    assert got == cli_json("noise", str(plain), "--stream-from-bytes", "0")
    assert "streamed" not in wiical.noise(str(plain)), "held by default"
    with pytest.raises(TypeError, match="stream_from_bytes"):
        wiical.noise(str(plain), stream_from_bytes=-1)


def test_tempcal_equals_the_cli_and_checks_its_settings() -> None:
    path = data("ggir_wrist_sphere_temp", "spheredata.csv")
    assert wiical.tempcal(path) == cli_json("tempcal", path)
    assert wiical.tempcal(path, segments=4, block_s=2.0) == cli_json(
        "tempcal", path, "--segments", "4", "--block-s", "2"
    )
    with pytest.raises(ValueError, match="the number of segments must be from 2 to 50"):
        wiical.tempcal(path, segments=1)
    with pytest.raises(ValueError, match="the pose angle must be above 0 and below 180"):
        wiical.tempcal(path, pose_deg=180)


def test_correct_equals_the_cli_output() -> None:
    path = data(*XSENS)
    with tempfile.TemporaryDirectory() as d:
        cal, out = os.path.join(d, "cal.json"), os.path.join(d, "out.csv")
        subprocess.run([_cli(), "fit", path, "--out", cal], check=True, capture_output=True)
        subprocess.run([_cli(), "correct", cal, path, "--out", out], check=True, capture_output=True)
        want = np.loadtxt(out, delimiter=",", skiprows=1)
        got = wiical.correct(cal, path)
        # The arrays' route gives the same.
        rec = wiical.read(path)
        again = wiical.correct(cal, rec.xyz, t=rec.t)
    assert got["accel"].shape == (len(want), 3)
    np.testing.assert_array_equal(got["t"], want[:, 0])
    # The CLI prints each f32 value in its shortest form: equal to f32 precision.
    np.testing.assert_allclose(got["accel"], want[:, 1:], rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(again["accel"], got["accel"])
    assert got["applied"] and all(isinstance(a, str) for a in got["applied"])


# --- progress, namespace ------------------------------------------------------------------


def test_progress_is_reported_and_its_exception_raised() -> None:
    path = data(*XSENS)
    seen = []
    wiical.analyze(path, progress=lambda stage, done, total: seen.append((stage, done, total)))
    stages = [s for s, _, _ in seen]
    assert stages[0] == "reading" and ("reading", 51175, 51175) in seen
    assert "detecting static windows" in stages
    assert any(s.startswith("step 1") for s in stages)
    seen.clear()
    wiical.read(path, progress=lambda *a: seen.append(a))
    assert seen == [("reading", 0, 0), ("reading", 51175, 51175)]

    def boom(*_a: object) -> None:
        raise KeyboardInterrupt("stop")

    with pytest.raises(KeyboardInterrupt):
        wiical.fit(path, progress=boom)
    with pytest.raises(TypeError, match="progress must be callable"):
        wiical.fit(path, progress=3)


def test_the_namespace_holds_only_the_packages_names() -> None:
    names = set(dir(wiical))
    assert names == set(wiical.__all__) | {"__version__"}
    for leaked in ("np", "os", "json", "Any", "Optional", "annotations"):
        assert leaked not in names
    for f in ("noise", "tempcal", "correct"):
        assert callable(getattr(wiical, f))


# --- the argument path, fuzzed ------------------------------------------------------------

_VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.binary(max_size=8),
    st.lists(st.floats(), max_size=4),
    st.tuples(st.floats(), st.floats()),
)

_KWARGS = st.fixed_dictionaries(
    {},
    optional={
        k: _VALUES
        for k in ("window_s", "init_s", "min_static_s", "threshold", "rate_hz", "adc_range", "columns", "t", "temp")
    },
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(
    rows=st.integers(min_value=0, max_value=40),
    fill=st.floats(allow_nan=True, allow_infinity=True),
    kwargs=_KWARGS,
)
def test_any_arguments_give_a_result_or_a_type_or_value_error(rows: int, fill: float, kwargs: dict) -> None:
    """Whatever the arguments, fit answers with a report, a TypeError or a ValueError
    (WiicalError is one): never a panic, an OverflowError or a SystemError."""
    xyz = np.tile([0.01, -0.02, 1.0], (rows, 1))
    if rows:
        xyz[rows // 2, 1] = fill
    try:
        out = wiical.fit(xyz, **kwargs)
    except (TypeError, ValueError):
        return
    assert isinstance(out, dict)


# --- what numpy would turn into numbers silently ------------------------------------------


@pytest.mark.parametrize(
    "data, words",
    [
        (None, "data must be a path or an array of numbers, got NoneType"),
        (5, "got int 5"),
        (np.array([[1.0, 2.0, None]] * 300, dtype=object), "data[0, 2] is None"),
        (np.zeros((300, 3), complex), "complex"),
        (np.ones((300, 3), bool), "booleans"),
        ([["1", "2", "3"]] * 300, "text"),
    ],
)
def test_values_numpy_would_convert_silently_are_refused_naming_them(data, words: str) -> None:
    with pytest.raises(TypeError, match=words.replace("[", r"\[").replace("(", r"\(")):
        wiical.fit(data)


def test_a_switch_and_a_name_must_be_of_their_type() -> None:
    xyz = np.tile([0.0, 0.0, 1.0], (300, 1))
    with pytest.raises(TypeError, match="windows must be True or False"):
        wiical.fit(xyz, windows="no")
    with pytest.raises(TypeError, match="device must be a str"):
        wiical.decode_cal(None, "82 82")
    with pytest.raises(ValueError, match="segments = 1180591620717411303424"):
        wiical.tempcal(xyz, temp=np.zeros(300), segments=2**70)


# --- every function's argument path, fuzzed (the Python door's fuzz target: cargo-fuzz
# cannot drive the interpreter, so this is a hypothesis property over every entry point) --

_ANY = st.one_of(
    _VALUES,
    st.just(np.zeros((0, 3))),
    st.just(np.full((50, 3), np.nan)),
    st.just(np.zeros((4, 3, 3))),
    st.just(np.array([[1, None, 2]], dtype=object)),
    st.just(np.ones((60, 3), complex)),
)

_CALLS = {
    "fit": lambda a, b: wiical.fit(a, rate_hz=b),
    "analyze": lambda a, b: wiical.analyze(a, alpha=b),
    "magfit": lambda a, b: wiical.magfit(a, model=b),
    "noise": lambda a, b: wiical.noise(a, rate_hz=b),
    "tempcal": lambda a, b: wiical.tempcal(a, temp=b),
    "correct": lambda a, b: wiical.correct(a, b),
    "gyrofit": lambda a, b: wiical.gyrofit(a, b),
    "six_position": lambda a, b: wiical.six_position(a, estimator=b),
    "decode_cal": lambda a, b: wiical.decode_cal(a, b),
    "read": lambda a, b: wiical.read(a, sensor=b),
}


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(name=st.sampled_from(sorted(_CALLS)), a=_ANY, b=_ANY)
def test_every_function_answers_any_arguments_with_a_result_or_a_sentence(name: str, a, b) -> None:
    """Whatever two arguments each entry point is given, it answers with a result, a
    TypeError or a ValueError (WiicalError is one) whose text is a sentence: never a panic,
    an OverflowError, a SystemError or a numpy warning turned into a wrong answer."""
    try:
        _CALLS[name](a, b)
    except (TypeError, ValueError) as e:
        assert str(e).strip(), f"{name}: an empty message"
        assert "PanicException" not in type(e).__name__


# --- masked arrays and Ctrl-C (issue 49) ---------------------------------------------------


def test_a_masked_array_is_refused_not_read_as_if_unmasked() -> None:
    """numpy hands over the values under a mask as if unmasked: the glitches a user masked
    out were fitted (bias 33196.9 against 33123.8). A masked value is refused, naming how
    many; a mask hiding nothing reads as the plain array."""
    rec = _xsens()
    xyz = np.ma.masked_array(rec["xyz"], mask=np.zeros(rec["xyz"].shape, dtype=bool))
    xyz[100:110, 0] = np.ma.masked
    with pytest.raises(ValueError) as e:
        wiical.fit(xyz)
    assert str(e.value).startswith("data is a masked array with 10 masked value(s)")
    assert not isinstance(e.value, wiical.WiicalError)
    with pytest.raises(ValueError, match="t is a masked array with 1 masked"):
        wiical.fit(rec["xyz"], t=np.ma.masked_array(rec["t"], mask=np.arange(len(rec["t"])) == 5))
    clear = np.ma.masked_array(rec["xyz"], mask=False)
    assert wiical.fit(clear)["bias"] == wiical.fit(rec["xyz"])["bias"]


def test_ctrl_c_during_the_first_read_raises_keyboard_interrupt() -> None:
    """SIGINT while the first ``wiical.read`` of a process runs (the numpy API not yet looked
    up) is a KeyboardInterrupt, not a pyo3 PanicException from the lookup."""
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "big.csv")
        block = "".join(f"{0.01 * (i % 7)},{-0.02},{1.0 + 1e-4 * (i % 13)}\n" for i in range(10_000))
        with open(path, "w") as f:
            f.write("x,y,z\n")
            for _ in range(400):
                f.write(block)
        script = (
            "import os, signal, sys, threading, time, wiical\n"
            "threading.Timer(0.05, lambda: os.kill(os.getpid(), signal.SIGINT)).start()\n"
            "t0 = time.monotonic()\n"
            "try:\n"
            "    wiical.read(sys.argv[1])\n"
            "    print('read finished', time.monotonic() - t0)\n"
            "    time.sleep(5)\n"
            "except KeyboardInterrupt:\n"
            "    print('KeyboardInterrupt', time.monotonic() - t0)\n"
        )
        out = subprocess.run(
            [sys.executable, "-c", script, path], capture_output=True, text=True, timeout=120
        )
    assert "PanicException" not in out.stderr and "panicked" not in out.stderr, out.stderr
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("KeyboardInterrupt"), out.stdout
