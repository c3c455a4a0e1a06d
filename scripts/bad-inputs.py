"""The Python door's rows of docs/bad-inputs.md: each call with a hostile argument, the
exception it raises and its sentence, one tab-separated line each (scripts/bad-inputs runs
this in its scratch directory, beside its good.csv)."""

import numpy as np

import wiical

xyz = np.loadtxt("good.csv", delimiter=",", skiprows=1)[:, 1:4]
temp = np.zeros(len(xyz))
with_nan = np.vstack([xyz[:5], [[np.nan, 0.0, 1.0]], xyz[5:]])
back = np.arange(len(xyz)) * 0.01
back[100] = back[98]
masked = np.ma.masked_array(xyz, mask=np.zeros(xyz.shape, bool))
masked[100:103] = np.ma.masked
CASES = [
    ("data None", "wiical.fit(None)", lambda: wiical.fit(None)),
    ("a NaN row", "wiical.fit(xyz with a NaN row)", lambda: wiical.fit(with_nan)),
    ("time going back", "wiical.fit(xyz, t=t with a step back)", lambda: wiical.fit(xyz, t=back)),
    ("None in an object array", "wiical.fit(array holding None)", lambda: wiical.fit(np.array([[1.0, 2.0, None]] * 300, dtype=object))),
    ("complex numbers", "wiical.fit(xyz.astype(complex))", lambda: wiical.fit(xyz.astype(complex))),
    ("booleans", "wiical.fit(np.ones((300, 3), bool))", lambda: wiical.fit(np.ones((300, 3), bool))),
    ("numbers as text", "wiical.fit([['1', '2', '3']] * 300)", lambda: wiical.fit([["1", "2", "3"]] * 300)),
    ("transposed array", "wiical.fit(xyz.T)", lambda: wiical.fit(xyz.T)),
    ("window_s=0", "wiical.fit(xyz, window_s=0)", lambda: wiical.fit(xyz, window_s=0)),
    ("window_s=True", "wiical.fit(xyz, window_s=True)", lambda: wiical.fit(xyz, window_s=True)),
    ("rate_hz=2**64", "wiical.fit(xyz, rate_hz=2**64)", lambda: wiical.fit(xyz, rate_hz=2**64)),
    ("windows='no'", "wiical.fit(xyz, windows='no')", lambda: wiical.fit(xyz, windows="no")),
    ("columns as one string", "wiical.fit('good.csv', columns='xyz')", lambda: wiical.fit("good.csv", columns="xyz")),
    ("a directory", "wiical.read('outdir')", lambda: wiical.read("outdir")),
    ("a bytes path that is not UTF-8", "wiical.read(b'rec\\xff.csv') (read)", lambda: wiical.read(b"rec\xff.csv")),
    ("t of another length", "wiical.fit(xyz, t=np.arange(3.0))", lambda: wiical.fit(xyz, t=np.arange(3.0))),
    ("segments=2**70", "wiical.tempcal(xyz, temp=temp, segments=2**70)", lambda: wiical.tempcal(xyz, temp=temp, segments=2**70)),
    ("tempcal rate_hz=1e300", "wiical.tempcal(xyz, temp=temp, rate_hz=1e300)", lambda: wiical.tempcal(xyz, temp=temp, rate_hz=1e300)),
    ("decode_cal without a device", "wiical.decode_cal(None, '82')", lambda: wiical.decode_cal(None, "82")),
    ("correct without a calibration", "wiical.correct(None, xyz)", lambda: wiical.correct(None, xyz)),
    ("a masked array", "wiical.fit(xyz with 3 rows masked)", lambda: wiical.fit(masked)),
]
for desc, call, f in CASES:
    try:
        f()
        kind, msg = "returned", ""
    except BaseException as e:  # noqa: BLE001 - every exception is a row, a panic too
        kind, msg = type(e).__name__, str(e).replace("\n", " ").replace("\t", " ")
    print(f"{desc}\t{call}\t{kind}\t{msg}")
