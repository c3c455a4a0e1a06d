"""`wiical.read` of raw files (.cwa, .bin): the arrays the engine fills in two passes, against
the whole-file reader (the same file gzip-compressed, which is read whole) and, when it is
installed, cwa-reader-rs (PyPI); float32 against float64; times left out. Real recordings
from $WIICAL_DATA (GGIRread's test files)."""

import gzip
import os
import pathlib
import shutil

import numpy as np
import pytest

import wiical

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("WIICAL_DATA", ROOT.parent / "shared" / "data"))
RAW = ["ax3_testfile.cwa", "ax3_testfile_corrupt_blocks_0_13_14_142_143_144.cwa",
       "ax6_testfile.cwa", "GENEActiv_testfile.bin"]


def raw(name: str) -> str:
    p = DATA / "ggirread_testfiles" / name
    if not p.exists():
        pytest.fail(f"{p} is missing: set WIICAL_DATA to the shared data folder")
    return str(p)


def meta(rec: wiical.Recording) -> dict:
    return {k: v for k, v in rec.items() if k not in ("xyz", "t", "temp", "spans")}


@pytest.mark.parametrize("name", RAW)
def test_raw_read_is_the_whole_file_readers(name: str, tmp_path: pathlib.Path) -> None:
    path = raw(name)
    packed = tmp_path / (name + ".gz")
    with open(path, "rb") as src, gzip.open(packed, "wb") as dst:
        shutil.copyfileobj(src, dst)
    got, want = wiical.read(path), wiical.read(str(packed))
    assert got.xyz.dtype == np.float64 and got.xyz.shape == want.xyz.shape
    assert got.xyz.flags.c_contiguous
    assert np.array_equal(got.xyz, want.xyz)
    assert np.array_equal(got.t, want.t)
    assert np.array_equal(got.temp, want.temp)
    assert meta(got) == meta(want)


@pytest.mark.parametrize("cut", [600, 1024, 1024 + 3 * 512 + 100, -7])
def test_a_cut_cwa_reads_as_the_whole_file_reader(cut: int, tmp_path: pathlib.Path) -> None:
    """A .cwa (read from a mapping of it) cut inside its header block, right after it, inside
    its fourth data block or inside its last: the whole-file reader's samples, or its error."""
    with open(raw("ax3_testfile.cwa"), "rb") as f:
        data = f.read()
    cut = cut if cut >= 0 else len(data) + cut
    path = tmp_path / "cut.cwa"
    path.write_bytes(data[:cut])
    packed = tmp_path / "cut.cwa.gz"
    with gzip.open(packed, "wb") as dst:
        dst.write(data[:cut])
    if cut <= 1024:
        with pytest.raises(ValueError) as got:
            wiical.read(str(path))
        with pytest.raises(ValueError) as want:
            wiical.read(str(packed))
        said = str(got.value).replace(str(path), "FILE")
        assert said == str(want.value).replace(str(packed), "FILE")
        assert ("header block is cut short" in said) == (cut < 1024)
        return
    got, want = wiical.read(str(path)), wiical.read(str(packed))
    assert len(got.xyz) > 0 and np.array_equal(got.xyz, want.xyz)
    assert np.array_equal(got.t, want.t) and np.array_equal(got.temp, want.temp)
    assert meta(got) == meta(want) and any("cut short" in n for n in got.notes)


@pytest.mark.parametrize("name", RAW)
def test_float32_is_float64_rounded_and_exact_for_cwa(name: str) -> None:
    path = raw(name)
    f64 = wiical.read(path)
    f32 = wiical.read(path, dtype="float32", times=False)
    assert f32.xyz.dtype == np.float32 and f32.temp.dtype == np.float32
    assert f32.t is None
    assert meta(f32) == meta(f64)
    assert np.array_equal(f32.xyz, f64.xyz.astype(np.float32))
    assert np.array_equal(f32.temp, f64.temp.astype(np.float32))
    if name.endswith(".cwa"):
        # Counts times powers of two: nothing is lost in float32.
        assert np.array_equal(f32.xyz.astype(np.float64), f64.xyz)
        assert np.array_equal(f32.temp.astype(np.float64), f64.temp)
    gyro = wiical.read(path, dtype="float32", sensor="gyroscope") if "ax6" in name else None
    if gyro is not None:
        assert np.array_equal(
            gyro.xyz.astype(np.float64), wiical.read(path, sensor="gyroscope").xyz
        )


def test_a_text_file_in_float32_is_cast_once() -> None:
    path = str(DATA / "imu_tk_xsens" / "xsens_acc.mat")
    f64, f32 = wiical.read(path), wiical.read(path, dtype="float32")
    assert np.array_equal(f32.xyz, f64.xyz.astype(np.float32))
    assert np.array_equal(f32.t, f64.t)
    with pytest.raises(ValueError, match="dtype"):
        wiical.read(path, dtype="float16")


@pytest.mark.parametrize("name", ["ax3_testfile.cwa", "ax6_testfile.cwa"])
def test_cwa_samples_are_cwa_reader_rs_samples(name: str) -> None:
    """The same samples as cwa-reader-rs (PyPI), where it is installed: the accelerometer's
    values and the block temperatures, sample for sample, equal to its float32 columns; the
    gyroscope's within one float32 step (it scales in float32 arithmetic, wiical in float64
    and rounds once: `count · 125 / 2^(9+n)` is exact in float32, so wiical's are the exact
    values, as the float64 comparison above shows). It refuses the file with corrupt blocks
    ("Invalid block timestamp"), which wiical reads without them."""
    cwa_reader_rs = pytest.importorskip("cwa_reader_rs")
    path = raw(name)
    df = cwa_reader_rs.read_cwa_file(path, include_light=False, include_battery=False)
    ours = wiical.read(path, dtype="float32")
    assert np.array_equal(df[["acc_x", "acc_y", "acc_z"]].to_numpy(), ours.xyz)
    assert np.array_equal(df["temperature"].to_numpy(), ours.temp)
    if "gyro_x" in df:
        gyro = wiical.read(path, dtype="float32", sensor="gyroscope")
        np.testing.assert_array_max_ulp(
            df[["gyro_x", "gyro_y", "gyro_z"]].to_numpy(), gyro.xyz, maxulp=1
        )


@pytest.mark.parametrize("name", RAW)
def test_spans_expand_to_the_full_times(name: str) -> None:
    """`times="spans"` gives each block's start, duration and rows instead of a time a sample;
    `span_times` expands them into the float64 array `times=True` gives, bit for bit, and the
    values, temperatures and description are the same."""
    path = raw(name)
    full = wiical.read(path, dtype="float32")
    spans = wiical.read(path, dtype="float32", times="spans")
    assert spans.t is None and full.spans is None
    s = spans.spans
    assert s["start_s"].dtype == np.float64 and s["dur_s"].dtype == np.float64
    assert s["rows"].dtype == np.uint64
    assert len(s["rows"]) == len(s["start_s"]) + 1 == len(s["dur_s"]) + 1
    assert s["rows"][0] == 0 and s["rows"][-1] == len(full.xyz)
    assert np.all(np.diff(s["rows"].astype(np.int64)) > 0)
    assert len(s["start_s"]) < len(full.xyz) / 10  # a few numbers a block, not a sample
    t = wiical.span_times(spans)
    assert t.dtype == np.float64 and np.array_equal(t, full.t)
    assert wiical.span_times(full) is full.t
    # The expansion is the documented formula, evaluated in float64 in that order.
    n = np.diff(s["rows"]).astype(np.float64)
    k = 1 if len(n) > 1 else 0
    i = np.arange(n[k])
    want = s["start_s"][k] + i * s["dur_s"][k] / n[k]
    assert np.array_equal(t[int(s["rows"][k]):int(s["rows"][k + 1])], want)
    assert np.array_equal(spans.xyz, full.xyz) and np.array_equal(spans.temp, full.temp)
    assert meta(spans) == meta(full)


def test_spans_of_a_text_file_are_its_times_and_bad_arguments_are_refused() -> None:
    path = str(DATA / "imu_tk_xsens" / "xsens_acc.mat")
    rec = wiical.read(path, times="spans")
    assert rec.spans is None and rec.t is not None
    assert wiical.span_times(rec) is rec.t
    assert wiical.read(path, times=False).t is None
    with pytest.raises(ValueError, match="times"):
        wiical.read(path, times="half")
    with pytest.raises(ValueError, match="no times"):
        wiical.span_times(wiical.read(path, times=False))
    bad = {"t": None, "spans": {"start_s": [0.0], "dur_s": [1.0], "rows": [0, 3, 2]}}
    with pytest.raises(ValueError, match="spans"):
        wiical.span_times(bad)
