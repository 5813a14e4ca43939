"""Interrupted pipeline runs (SIGINT, SIGKILL): a restart finishes without
recomputing finished jobs and no result file is truncated or stale."""
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(shutil.which("snakemake") is None, reason="no snakemake")]
TARGET = "out/ex1-errors.md"  # Example 1 only: uniform, graded and adaptive series


def setup_workdir(tmp_path):
    cfg = yaml.safe_load((ROOT / "config" / "ci.yaml").read_text())
    cfg.update(results_dir="res", output_root="out", s_values=[0.5])
    cfg["example1"].update(uniform_levels=[2, 3, 4], graded_h=[0.5, 0.35, 0.25])
    (tmp_path / "cfg.yaml").write_text(yaml.safe_dump(cfg))
    shutil.copy(ROOT / "config.yaml", tmp_path / "config.yaml")
    return ["snakemake", "-s", str(ROOT / "Snakefile"), "--directory", str(tmp_path),
            "--configfile", str(tmp_path / "cfg.yaml"), "--cores", "2"]


def start(cmd):
    return subprocess.Popen(cmd + [TARGET], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)


def result_rows(tmp_path):
    """The finished runs' rows (not a writer's temporary file: pathlib's * matches
    hidden names)."""
    return sorted(f for f in (tmp_path / "res").glob("ex1/*/*/*.csv")
                  if not f.name.startswith(".tmp-"))


def wait_for_rows(tmp_path, n, proc, timeout=240):
    t0 = time.time()
    while time.time() - t0 < timeout:
        rows = result_rows(tmp_path)
        if len(rows) >= n:
            return rows
        assert proc.poll() is None, "pipeline ended before it could be interrupted"
        time.sleep(0.2)
    raise AssertionError("no finished job to interrupt after")


def wait_group_gone(pgid, timeout=60):
    """Jobs clean up their temporary files on SIGINT; wait until all have exited."""
    t0 = time.time()
    while time.time() - t0 < timeout:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.2)
    os.killpg(pgid, signal.SIGKILL)


def check_results_intact(tmp_path, temporaries=True):
    leftovers = list((tmp_path / "res").rglob(".tmp-*")) + list((tmp_path / "out").rglob(".tmp-*"))
    assert not temporaries or leftovers == [], f"temporary files left behind: {leftovers}"
    for f in (tmp_path / "res").rglob("*.csv"):
        if f.name.startswith(".tmp-"):           # a killed writer's, never a result
            continue
        df = pd.read_csv(f)                      # parses: not truncated
        assert len(df) >= 1 and "git_commit" in df.columns   # provenance present


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL])
def test_interrupted_pipeline_restarts_cleanly(tmp_path, sig):
    cmd = setup_workdir(tmp_path)
    proc = start(cmd)
    # two jobs run at once (job_threads: 1), so at most two rows belong to jobs whose end
    # Snakemake has not recorded: four rows leave at least two finished jobs, whichever
    # jobs the scheduler started first (the long adaptive one has priority)
    wait_for_rows(tmp_path, 4, proc)
    os.killpg(proc.pid, sig)                     # the scheduler and its running job
    proc.wait(timeout=60)
    wait_group_gone(proc.pid)
    # SIGKILL can land between a job's temporary file and its rename: that file may stay
    # until the job is rerun (atomic_path removes its target's stale ones)
    check_results_intact(tmp_path, temporaries=sig != signal.SIGKILL)
    if sig == signal.SIGKILL:                    # a killed scheduler leaves its lock
        subprocess.run(cmd + ["--unlock"], check=True, capture_output=True)
    # a job whose completion Snakemake had not recorded is rerun; all others are kept
    plan = subprocess.run(cmd + ["-n", "--rerun-incomplete", TARGET], capture_output=True,
                          text=True, timeout=300).stdout
    planned = {path.strip() for line in plan.splitlines() if line.strip().startswith("output:")
               for path in line.split("output:", 1)[1].split(",")}
    rows = result_rows(tmp_path)
    finished = [f for f in rows if str(f.relative_to(tmp_path)) not in planned]
    assert len(finished) >= 2, (rows, plan[-2000:])
    stamps = {f: f.stat().st_mtime_ns for f in finished}
    out = subprocess.run(cmd + ["--rerun-incomplete", TARGET], capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    check_results_intact(tmp_path)
    assert (tmp_path / TARGET).exists()
    for f, stamp in stamps.items():              # finished jobs were not recomputed
        assert f.stat().st_mtime_ns == stamp, f"{f} was recomputed"
    again = subprocess.run(cmd + ["-n", TARGET], capture_output=True, text=True, timeout=300)
    assert "Nothing to be done" in again.stdout + again.stderr
