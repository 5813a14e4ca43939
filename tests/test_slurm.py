"""One job of the pipeline through a real SLURM (profiles/slurm) and the same job run
locally give the same result.  Opt-in:

    workflow/cluster/local-slurm.sh        # a single-node SLURM on this machine (root)
    FRACFEM_SLURM=1 python -m pytest tests/test_slurm.py

Account and partition come from FRACFEM_SLURM_ACCOUNT / FRACFEM_SLURM_PARTITION
(default: any name, and the cluster's default partition).  About a minute on two cores.
"""
import importlib.util
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]


def _sinfo_works():
    if shutil.which("sinfo") is None:
        return False
    return subprocess.run(["sinfo", "-h"], capture_output=True).returncode == 0


pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(os.environ.get("FRACFEM_SLURM") != "1",
                       reason="set FRACFEM_SLURM=1 to run jobs through SLURM"),
    pytest.mark.skipif(os.environ.get("FRACFEM_SLURM") == "1" and not _sinfo_works(),
                       reason="sinfo does not answer (no SLURM cluster)"),
]

_spec = importlib.util.spec_from_file_location(
    "compare_outputs", ROOT / "workflow" / "cluster" / "compare_outputs.py")
compare_outputs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(compare_outputs)

TARGET = "res/ex1/uniform/s0.5/L2.csv"     # one ex1_solve job: seconds, not a localrule


def _default_partition():
    out = subprocess.run(["sinfo", "-h", "-o", "%P"], capture_output=True, text=True).stdout
    names = out.split()
    return next((p.rstrip("*") for p in names if p.endswith("*")), names[0].rstrip("*"))


def _workdir(path):
    path.mkdir()
    cfg = yaml.safe_load((ROOT / "config" / "ci.yaml").read_text())
    cfg.update(results_dir="res", output_root="out")
    (path / "cfg.yaml").write_text(yaml.safe_dump(cfg))
    shutil.copy(ROOT / "config.yaml", path / "config.yaml")
    return ["snakemake", "-s", str(ROOT / "Snakefile"), "--directory", str(path),
            "--configfile", str(path / "cfg.yaml")]


def test_a_job_through_slurm_matches_the_local_run(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    env.setdefault("FRACFEM_SLURM_ACCOUNT", "fracfem")
    env.setdefault("FRACFEM_SLURM_PARTITION", _default_partition())
    # the jobs import fracfem from this checkout, whatever is installed
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "workflow" / "lib"),
                                         env.get("PYTHONPATH", "")])

    local = _workdir(tmp_path / "local")
    out = subprocess.run(local + ["--profile", str(ROOT / "profiles" / "default"), TARGET],
                         capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]

    slurm = _workdir(tmp_path / "slurm")
    extra = []
    if subprocess.run(["sacct", "-n", "-X"], capture_output=True).returncode != 0:
        extra = ["--slurm-status-command", "squeue"]    # no slurmdbd: ask slurmctld
    out = subprocess.run(slurm + ["--profile", str(ROOT / "profiles" / "slurm"),
                                  "--workflow-profile", "none",
                                  "--slurm-init-seconds-before-status-checks", "5",
                                  *extra, TARGET],
                         capture_output=True, text=True, env=env, timeout=900)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text[-3000:]
    ids = re.findall(r"submitted with SLURM jobid (\d+)", text)
    assert len(ids) == 1, text[-3000:]
    state = subprocess.run(["scontrol", "show", "job", ids[0]], capture_output=True,
                           text=True).stdout
    if state:                       # still known to slurmctld (MinJobAge)
        assert "JobState=COMPLETED" in state, state

    rows = compare_outputs.compare_dirs(tmp_path / "local" / "res", tmp_path / "slurm" / "res")
    assert [r for r in rows if r[1].isupper()] == []
    assert {r[0] for r in rows} >= {"ex1/uniform/s0.5/L2.csv", "ex1/uniform/s0.5/L2.npz"}
