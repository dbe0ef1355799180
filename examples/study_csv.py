#!/usr/bin/env python3
"""A study over many exams: `sqffd track ED ES --json` on each, in parallel, into one CSV.

    python3 examples/study_csv.py EXAMS_DIR -o study.csv [--jobs N] [--shard I/N] [--sqffd PATH] [-- TRACK OPTIONS]

An exam is any folder under EXAMS_DIR that holds ed.xyz and es.xyz (the end-diastolic and
end-systolic frames; e.g. ../shared/data/cardiac/A07/obs0_rep0). Its name in the CSV is its
path under EXAMS_DIR. Options after `--` go to every `sqffd track` (e.g. --mm-per-unit 0.38
--septum 1,0,0). One row per exam, in the exams' sorted order whatever order they finish in;
an exam sqffd refuses (a frame it could not follow, a bad file) gets status "failed" and
sqffd's message, and the script exits 1 after writing the others.

The library holds no global state, so the exams run side by side, one `sqffd track` process
each, --jobs at a time (default: the machine's cores). Over many machines, give each its
share of the sorted exam list, --shard I/N (I = 0..N-1: the exams whose index modulo N is I),
and concatenate the CSVs, the first header only:
    awk 'FNR > 1 || NR == 1' shard_*.csv > study.csv
"""
import argparse
import concurrent.futures
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

COLUMNS = ["exam", "status", "message", "edv_ml", "esv_ml", "ef_percent", "ed_index", "es_index",
           "ed_error_percent", "es_error_percent", "ed_error_mm", "es_error_mm", "ed_stop", "es_stop",
           "hypokinetic_count", "hypokinetic_segments", "mm_per_unit", "unit_source", "septum_given"]


def find_exams(root):
    """The folders under root holding ed.xyz and es.xyz, as sorted paths relative to root."""
    exams = []
    for folder, _, files in os.walk(root):
        if "ed.xyz" in files and "es.xyz" in files:
            exams.append(os.path.relpath(folder, root))
    return sorted(exams)


def shard(exams, spec):
    """The exams of shard 'I/N': those whose index modulo N is I (ValueError for a bad spec)."""
    try:
        i, n = (int(x) for x in spec.split("/"))
    except ValueError:
        raise ValueError("--shard takes I/N (two whole numbers), not %r" % spec)
    if not (n >= 1 and 0 <= i < n):
        raise ValueError("--shard %s: I must be 0..N-1" % spec)
    return exams[i::n]


def run_exam(sqffd, root, exam, work, extra):
    """One exam tracked (a worker process): its CSV row."""
    folder = os.path.join(root, exam)
    out = os.path.join(work, exam.replace(os.sep, "__"))
    summary = out + ".json"
    cmd = [sqffd, "track", os.path.join(folder, "ed.xyz"), os.path.join(folder, "es.xyz"), "-o", out,
           "--json", summary, "--quiet"] + extra
    done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    row = dict.fromkeys(COLUMNS, "")
    row["exam"] = exam
    if done.returncode != 0:
        row["status"] = "failed"
        row["message"] = " ".join(done.stderr.split())[:500] or "exit %d" % done.returncode
        return row
    with open(summary, encoding="utf-8") as f:
        s = json.load(f)
    ed, es = s["frames"][s["ed_index"]], s["frames"][s["es_index"]]
    hypokinetic = [str(g["index"]) for g in s["segments"] if g["hypokinetic"]]
    row.update(status="ok", edv_ml=s["edv_ml"], esv_ml=s["esv_ml"], ef_percent=s["ef_percent"],
               ed_index=s["ed_index"], es_index=s["es_index"],
               ed_error_percent=100.0 * ed["error_relative"], es_error_percent=100.0 * es["error_relative"],
               ed_error_mm=ed["error_mm"], es_error_mm=es["error_mm"], ed_stop=ed["stop"], es_stop=es["stop"],
               hypokinetic_count=len(hypokinetic), hypokinetic_segments=" ".join(hypokinetic),
               mm_per_unit=s["units"]["mm_per_unit"], unit_source=s["units"]["mm_per_unit_source"],
               septum_given=s["septum_given"])
    return row


def default_sqffd():
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "build", "sqffd")
    return here if os.access(here, os.X_OK) else (shutil.which("sqffd") or "sqffd")


def main(argv):
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    p = argparse.ArgumentParser(description="sqffd track over a folder of exams, in parallel, into one CSV "
                                            "(options after -- go to sqffd track)")
    p.add_argument("exams", help="a folder whose sub-folders (any depth) hold ed.xyz and es.xyz")
    p.add_argument("-o", "--output", help="the CSV (default: standard output)")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="exams at a time (default: the cores)")
    p.add_argument("--shard", default="0/1", help="I/N: this machine's share of the exams (default 0/1: all)")
    p.add_argument("--sqffd", default=default_sqffd(), help="the sqffd program (default: build/sqffd, else PATH)")
    p.add_argument("--keep", help="a folder to keep each exam's track output in (default: a temporary one)")
    a = p.parse_args(argv)
    if a.jobs < 1:
        p.error("--jobs takes a whole number >= 1")
    try:
        exams = shard(find_exams(a.exams), a.shard)
    except ValueError as e:
        p.error(str(e))
    if not exams:
        print("study_csv: no exam (a folder holding ed.xyz and es.xyz) under %s in shard %s" % (a.exams, a.shard),
              file=sys.stderr)
    work = a.keep or tempfile.mkdtemp(prefix="sqffd_study_")
    os.makedirs(work, exist_ok=True)
    try:
        with concurrent.futures.ProcessPoolExecutor(max_workers=a.jobs) as pool:
            rows = list(pool.map(run_exam, [a.sqffd] * len(exams), [a.exams] * len(exams), exams,
                                 [work] * len(exams), [extra] * len(exams)))
    finally:
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)
    out = open(a.output, "w", newline="", encoding="utf-8") if a.output else sys.stdout
    try:
        writer = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    finally:
        if a.output:
            out.close()
    failed = [r for r in rows if r["status"] != "ok"]
    for r in failed:
        print("study_csv: %s: %s" % (r["exam"], r["message"]), file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
