"""Writes the peer comparison's summary tables into BENCHMARKS.md (between the markers
<!-- peers:begin --> and <!-- peers:end -->) from target/peers/results.json, which
scripts/peers/bench.py writes. Run by scripts/bench-peers after bench.py."""
import json
import sys


def fmt(x, nd=4):
    return "—" if x is None else f"{x:.{nd}f}"


def main(results_path, doc_path):
    d = json.load(open(results_path))
    out = []
    out.append("Accuracy (accelerometer: RMS of ‖a‖ − 1 g over the static windows, in-sample / "
               "leave-one-window-out, mg; magnetometer: fit error % / RMS radius error, counts):")
    out.append("")
    out.append("| dataset | tool | error | LOWO / RMS radius |")
    out.append("|---|---|---|---|")
    for ds in d["acc"]:
        for r in ds["rows"]:
            err = fmt(r.get("own_rms")) + " mg"
            if r.get("own_rms") is None and r.get("shared_rms") is not None:
                err = fmt(r["shared_rms"]) + " mg (on wiical's windows)"
            out.append(f"| {ds['name']} | {r['tool']} | {err} | {fmt(r.get('lowo'))} mg |")
    for ds in d["mag"]:
        for r in ds["rows"]:
            tool = r["tool"] + (f" ({r['model']})" if r.get("model") else "")
            out.append(f"| {ds['name']} | {tool} | {fmt(r.get('fit_pct'), 2)} % | "
                       f"{fmt(r.get('rms_rad'), 1)} |")
    out.append("")
    out.append("Wall time, end to end (fresh process, file loading included), median of the runs:")
    out.append("")
    out.append("| dataset | command | median (s) | min (s) |")
    out.append("|---|---|---|---|")
    for ds in d["acc"] + d["mag"]:
        for t in ds.get("timing", []):
            out.append(f"| {ds['name']} | {t['label']} | {t['median']:.4f} | {t['min']:.4f} |")
    out.append("")
    for g in d.get("goals", []):
        out.append(f"* {'holds' if g.get('holds') else 'does NOT hold'}: {g['text']}")
    table = "\n".join(out)
    doc = open(doc_path).read()
    begin, end = "<!-- peers:begin -->", "<!-- peers:end -->"
    head, rest = doc.split(begin, 1)
    _, tail = rest.split(end, 1)
    open(doc_path, "w").write(head + begin + "\n" + table + "\n" + end + tail)
    print(f"wrote the peer tables into {doc_path}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
