#!/usr/bin/python3
"""bench/peer_chart.py keeps every finished run: each replicate's JSON line
is appended when it ends, a failed or stopped study keeps the others, and
the same command then runs only the missing replicates (docs/PEER.md,
"The full protocol on a cluster"). Fake runs stand in for ringsim and the
peer: a one-line Python program printing {"replicate": r, ...}."""
import concurrent.futures as cf
import importlib.util
import json
import pathlib
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("peer_chart", ROOT / "bench" / "peer_chart.py")
peer_chart = importlib.util.module_from_spec(spec)
spec.loader.exec_module(peer_chart)

FAKE = "import json, sys; r = int(sys.argv[1]); sys.exit(5) if r in {fail} else print(json.dumps({{'replicate': r, 'run': '{tag}'}}))"


def maker(tag, fail=()):
    code = FAKE.format(fail=set(fail) or "set()", tag=tag)
    return lambda r: [sys.executable, "-c", code, str(r)]


def lines(path):
    return [json.loads(x) for x in path.read_text().splitlines()]


def check(cond, what):
    if not cond:
        sys.exit(f"test_peer_chart: FAILED: {what}")


with tempfile.TemporaryDirectory() as d, cf.ThreadPoolExecutor(max_workers=2) as pool:
    path = pathlib.Path(d) / "runs" / "setting.jsonl"

    # A study whose replicate 2 fails: the other four are kept, then the error is raised.
    try:
        peer_chart.cached(pool, path, maker("first", fail=[2]), 5)
        check(False, "a failed run must raise")
    except RuntimeError as e:
        check("failed (5)" in str(e), f"the error names the exit status: {e}")
    kept = sorted(row["replicate"] for row in lines(path))
    check(kept == [0, 1, 3, 4], f"finished runs kept after a failure: {kept}")

    # A crash mid-write leaves a cut line: it is dropped and its replicate runs again.
    with path.open("a") as f:
        f.write('{"replicate": 2, "run": "cut')
    rows = peer_chart.cached(pool, path, maker("second"), 6)
    check([r["replicate"] for r in rows] == list(range(6)), f"rows in replicate order: {rows}")
    check([r["run"] for r in rows] == ["first", "first", "second", "first", "first", "second"],
          f"only the missing replicates ran again: {rows}")
    check(len(lines(path)) == 6, "the file holds one whole line per replicate")

    # Complete: nothing runs (a maker that always fails would raise).
    rows = peer_chart.cached(pool, path, maker("third", fail=range(6)), 6)
    check([r["run"] for r in rows].count("third") == 0, "a complete setting runs nothing")
    # Fewer asked than kept: the first R.
    check([r["replicate"] for r in peer_chart.cached(pool, path, maker("x"), 3)] == [0, 1, 2],
          "R below the kept count gives replicates 0..R-1")

print("test_peer_chart: passed")
