"""Shared helpers of the Python benchmark drivers (speed_accuracy.py,
scaling.py): run `ringsim replicate --json` with overrides, cache the JSON
lines of a setting so an interrupted benchmark resumes."""
import json
import subprocess


def run_replicate(ringsim, scenario_file, seed, rep, sets):
    """One replicate; returns its --json object. scenario_file may be None
    (built-in defaults). A replicate that fails in the simulation (exit
    status 3 with termination "error" in its JSON) is returned like any
    other, for the caller to count; any other failure raises with the
    command and ringsim's message."""
    cmd = [str(ringsim), "replicate"] + ([str(scenario_file)] if scenario_file else [])
    cmd += ["--seed", str(seed), "--replicate", str(rep), "--json"]
    for k, v in sets.items():
        cmd += ["--set", f"{k}={v}"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode == 3 and p.stdout.strip():
        row = json.loads(p.stdout)
        if row.get("termination") == "error":
            return row
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()}")
    return json.loads(p.stdout)


def run_cached(pool, path, ringsim, scenario_file, seed, reps, sets):
    """Replicates 0..reps-1 of one setting on the thread pool, stored as JSON
    lines in path; an existing file with at least reps lines is reused."""
    if path.exists():
        rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
        if len(rows) >= reps:
            return rows[:reps]
    futures = [pool.submit(run_replicate, ringsim, scenario_file, seed, r, sets) for r in range(reps)]
    rows = [f.result() for f in futures]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return rows
