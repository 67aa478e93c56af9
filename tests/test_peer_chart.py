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
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("peer_chart", ROOT / "bench" / "peer_chart.py")
peer_chart = importlib.util.module_from_spec(spec)
spec.loader.exec_module(peer_chart)

FAKE = ("import json, sys, time; r = int(sys.argv[1]); time.sleep({sleep} if r in {slow} else 0); "
        "sys.exit(5) if r in {fail} else print(json.dumps({{'replicate': r, 'run': '{tag}'}}))")


def maker(tag, fail=(), slow=(), sleep=0):
    code = FAKE.format(fail=set(fail) or "set()", slow=set(slow) or "set()", sleep=sleep, tag=tag)
    return lambda r: [sys.executable, "-c", code, str(r)]


def cached(pool, path, make_cmd, reps):
    """One setting alone: its replicates 0..reps-1."""
    return peer_chart.gather([peer_chart.start(pool, path, make_cmd, reps)])[0]


def lines(path):
    return [json.loads(x) for x in path.read_text().splitlines()]


def check(cond, what):
    if not cond:
        sys.exit(f"test_peer_chart: FAILED: {what}")


with tempfile.TemporaryDirectory() as d, cf.ThreadPoolExecutor(max_workers=2) as pool:
    path = pathlib.Path(d) / "runs" / "setting.jsonl"

    # A study whose replicate 2 fails: the other four are kept, then the error is raised.
    try:
        cached(pool, path, maker("first", fail=[2]), 5)
        check(False, "a failed run must raise")
    except RuntimeError as e:
        check("failed (5)" in str(e), f"the error names the exit status: {e}")
    kept = sorted(row["replicate"] for row in lines(path))
    check(kept == [0, 1, 3, 4], f"finished runs kept after a failure: {kept}")

    # A crash mid-write leaves a cut line: it is dropped and its replicate runs again.
    with path.open("a") as f:
        f.write('{"replicate": 2, "run": "cut')
    rows = cached(pool, path, maker("second"), 6)
    check([r["replicate"] for r in rows] == list(range(6)), f"rows in replicate order: {rows}")
    check([r["run"] for r in rows] == ["first", "first", "second", "first", "first", "second"],
          f"only the missing replicates ran again: {rows}")
    check(len(lines(path)) == 6, "the file holds one whole line per replicate")

    # Complete: nothing runs (a maker that always fails would raise).
    rows = cached(pool, path, maker("third", fail=range(6)), 6)
    check([r["run"] for r in rows].count("third") == 0, "a complete setting runs nothing")
    # Fewer asked than kept: the first R.
    check([r["replicate"] for r in cached(pool, path, maker("x"), 3)] == [0, 1, 2],
          "R below the kept count gives replicates 0..R-1")

    # Settings queued together (--jobs N): one setting's failure keeps every
    # other setting's finished runs, each in its own file.
    a_path, b_path = pathlib.Path(d) / "runs" / "a.jsonl", pathlib.Path(d) / "runs" / "b.jsonl"
    try:
        peer_chart.gather([peer_chart.start(pool, a_path, maker("a", fail=[0]), 3),
                           peer_chart.start(pool, b_path, maker("b"), 4)])
        check(False, "a failed run among several settings must raise")
    except RuntimeError:
        pass
    check(sorted(r["replicate"] for r in lines(a_path)) == [1, 2], "setting a keeps its finished runs")
    check(sorted(r["replicate"] for r in lines(b_path)) == [0, 1, 2, 3], "setting b is whole")
    got = peer_chart.gather([peer_chart.start(pool, a_path, maker("a2"), 3),
                             peer_chart.start(pool, b_path, maker("b2", fail=range(4)), 4)])
    check([[r["run"] for r in rows] for rows in got] == [["a2", "a", "a"], ["b"] * 4],
          f"the rerun runs only a's missing replicate: {got}")

    # A run that ends is in its file while an earlier-queued setting's run
    # is still under way (a kill at that moment loses only the latter).
    c_path, e_path = pathlib.Path(d) / "runs" / "c.jsonl", pathlib.Path(d) / "runs" / "e.jsonl"
    with cf.ThreadPoolExecutor(max_workers=1) as waiter:
        slow = waiter.submit(peer_chart.gather, [peer_chart.start(pool, c_path, maker("c", slow=[0], sleep=6), 1),
                                                 peer_chart.start(pool, e_path, maker("e"), 3)])
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not (e_path.exists() and len(lines(e_path)) == 3):
            time.sleep(0.05)
        check(not slow.done() and e_path.exists() and len(lines(e_path)) == 3,
              "a later setting's finished runs are written while an earlier one still runs")
        check(not c_path.exists(), "the run under way has no line yet")
        slow.result()

print("test_peer_chart: passed")
