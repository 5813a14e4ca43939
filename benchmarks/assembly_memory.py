"""Where the compressed operator's assembly holds its memory: peak RSS by phase.

For each mesh, in a process of its own, ``fracfem.compressed.stiffness_operator``
is assembled (s = 0.5, default QuadratureOptions) while a thread samples the
resident set every 10 ms.  Per phase of the assembly (``info["timings"]``) the
table gives its seconds and the largest resident set seen in it, above the
process's resident set before the assembly; beside them the memory the finished
operator holds (``nbytes``) and the near field's entries.

Meshes: ``ex2-step<k>`` the fine mesh of step k of the committed Example 2
reference series (workflow/data/reference/ex2-meshes.npz keeps steps 0, 2, 7
and 10), ``uniform<L>`` disk_uniform(L), ``graded<h>`` disk_graded_aniso(h).

    python benchmarks/assembly_memory.py ex2-step7 --compare <checkout> --md benchmarks/assembly-memory.md
    python benchmarks/assembly_memory.py ex2-step7 --kappa-chunk 262144
    python benchmarks/assembly_memory.py ex2-step7 --compare /path/to/other/checkout
    python benchmarks/assembly_memory.py ex2-step7 --threads 8 --compare <checkout>

``--compare`` measures fracfem of another checkout (its root) as well, to set one
version of the code beside another on the same mesh; ``--kappa-chunk`` sets
``fracfem.assembly.KAPPA_CHUNK`` (points per κ evaluation); ``--threads`` numba's
threads (NUMBA_NUM_THREADS of the case's process; more than the cores is allowed,
to see how memory grows with the threads of a larger machine).  The sampling
thread can miss a short peak: every 10 ms, and not at all while a serial numba
kernel holds the interpreter (the parallel ones release it).  A phase without a
sample shows nan.  Run a checkout once before measuring it, so that its numba
kernels come from the cache rather than being compiled inside a phase.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PHASES = ("trees", "near", "singular", "coupling", "far_diagonal", "exterior",
          "restrict_leaf")


def mesh_of(name: str):
    import numpy as np
    import skfem

    from fracfem import meshes
    from fracfem.vi import fine_mesh
    if name.startswith("ex2-step"):
        k = int(name[len("ex2-step"):])
        d = np.load(ROOT / "workflow/data/reference/ex2-meshes.npz")
        if f"pc{k}" not in d:
            kept = sorted(int(x[2:]) for x in d if x.startswith("pc") and x[2:].isdigit())
            raise SystemExit(f"mesh {name!r}: the committed series keeps steps {kept}")
        return fine_mesh(skfem.MeshTri(d[f"pc{k}"], d[f"tc{k}"]))
    if name.startswith("uniform"):
        return meshes.disk_uniform(int(name[len("uniform"):]))
    if name.startswith("graded"):
        return meshes.disk_graded_aniso(float(name[len("graded"):]))
    raise SystemExit(f"mesh {name!r}: expected ex2-step<k>, uniform<L> or graded<h>")


def run_case(name: str, kappa_chunk: int | None) -> dict:
    import resource
    import threading
    import time

    samples = []

    def sampler():
        while True:
            with open("/proc/self/status") as fh:
                for line in fh:
                    if line.startswith("VmRSS"):
                        samples.append((time.perf_counter(), int(line.split()[1]) / 1024))
            time.sleep(0.01)

    threading.Thread(target=sampler, daemon=True).start()
    import fracfem as ff
    from fracfem import assembly, compressed
    if kappa_chunk:
        assembly.KAPPA_CHUNK = int(kappa_chunk)
    mesh = mesh_of(name)
    time.sleep(0.05)
    base = samples[-1][1]
    t0 = time.perf_counter()
    op = compressed.stiffness_operator(mesh, 0.5, quadrature=ff.QuadratureOptions())
    t1 = time.perf_counter()
    time.sleep(0.05)
    tim = op.info["timings"]
    ends = [t0]
    for k in PHASES[:-1]:
        ends.append(ends[-1] + tim[k])
    ends.append(t1)
    import numba
    row = dict(mesh=name, kappa_chunk=assembly.KAPPA_CHUNK, threads=numba.get_num_threads(),
               dofs=op.shape[0],
               near_nnz=op.info["near_nnz"], held_mb=op.nbytes / 2**20,
               assembly_s=t1 - t0)
    for i, ph in enumerate(PHASES):
        seen = [r for tt, r in samples if ends[i] <= tt <= ends[i + 1]]
        row[f"{ph}_s"] = ends[i + 1] - ends[i]
        row[f"{ph}_mb"] = (max(seen) - base) if seen else float("nan")
    seen = [ph for ph in PHASES if row[f"{ph}_mb"] == row[f"{ph}_mb"]]   # not NaN
    row["peak_phase"] = max(seen, key=lambda ph: row[f"{ph}_mb"])
    row["peak_mb"] = row[f"{row['peak_phase']}_mb"]
    row["ru_maxrss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return row


def commit_of(root: Path) -> str:
    """The short commit of a checkout (with '+' when its fracfem/ has changes)."""
    def git(*args):
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True,
                              text=True).stdout.strip()
    head = git("rev-parse", "--short", "HEAD") or root.name
    return head + ("+" if git("status", "--porcelain", "--", "fracfem") else "")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--kappa-chunk", type=int, default=None)
    ap.add_argument("--compare", type=Path, default=None,
                    help="root of another checkout whose fracfem is measured as well")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--md", type=Path, default=None)
    ap.add_argument("--case", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.kappa_chunk is not None and a.kappa_chunk < 1:
        ap.error(f"--kappa-chunk {a.kappa_chunk}: must be a positive number of points")
    if a.threads is not None and not 1 <= a.threads <= 256:
        ap.error(f"--threads {a.threads}: must be in [1, 256]")
    if a.case:
        print(json.dumps(run_case(a.meshes[0], a.kappa_chunk)))
        return
    for name in a.meshes:
        if not re.fullmatch(r"ex2-step\d+|uniform\d+|graded[0-9.]+", name):
            ap.error(f"mesh {name!r}: expected ex2-step<k>, uniform<L> or graded<h>")
    checkouts = [ROOT] + ([a.compare.resolve()] if a.compare else [])
    for code in checkouts:
        if not (code / "fracfem" / "__init__.py").exists():
            raise SystemExit(f"{code}: no fracfem package under it")
    load = os.getloadavg()[0]
    rows = []
    for name in a.meshes:
        for code in checkouts:
            env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(code), str(ROOT)]))
            if a.threads:
                env["NUMBA_NUM_THREADS"] = str(a.threads)
            cmd = [sys.executable, __file__, name, "--case"]
            if a.kappa_chunk:
                cmd += ["--kappa-chunk", str(a.kappa_chunk)]
            run = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, text=True)
            if run.returncode:   # its message went to this stderr
                raise SystemExit(f"{name} ({code}): the case failed (exit {run.returncode})")
            out = run.stdout
            row = json.loads(out.strip().splitlines()[-1])
            row["code"] = commit_of(code)
            rows.append(row)
            print(f"{name} ({row['code']}): {row['dofs']} DOFs, held {row['held_mb']:.0f} MB, "
                  f"peak {row['peak_mb']:.0f} MB above the start ({row['peak_phase']}), "
                  f"{row['assembly_s']:.1f} s on {row['threads']} threads", flush=True)
    if a.md:
        cols = ["mesh", "code", "threads", "dofs", "near_nnz", "held_mb", "phase", "phase_s",
                "phase_mb"]
        lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        for r in rows:
            for ph in PHASES + ("whole",):
                sec = r["assembly_s"] if ph == "whole" else r[f"{ph}_s"]
                mb = r["peak_mb"] if ph == "whole" else r[f"{ph}_mb"]
                lines.append(f"| {r['mesh']} | {r['code']} | {r['threads']} | {r['dofs']} | "
                             f"{r['near_nnz']} | "
                             f"{r['held_mb']:.0f} | {ph} | {sec:.1f} | {mb:.0f} |")
        head = (f"# Compressed operator: memory by assembly phase\n\n"
                f"`python benchmarks/assembly_memory.py {' '.join(a.meshes)}"
                + (f" --kappa-chunk {a.kappa_chunk}" if a.kappa_chunk else "")
                + (f" --threads {a.threads}" if a.threads else "")
                + (" --compare <checkout>" if a.compare else "")
                + f"`, {datetime.date.today()}, 1-minute load average {load:.1f} at the "
                  f"start (2 cores). `phase_mb`: the largest resident set seen in the phase, "
                  f"above the one before the assembly (`whole`: over the assembly); "
                  f"`held_mb`: the finished operator (nbytes).\n\n")
        a.md.write_text(head + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
