"""Examples 4, 5 on space-time adaptive meshes: Algorithm C, error per iteration.

Each pass that does not end the run leaves what the next one needs in a checkpoint
file (its space-time mesh, the table rows and arrays so far); started again with the
same settings, the job continues from there, so a job ended by a time limit or a lost
machine loses at most the pass it was in.  The checkpoint goes when the outputs are
written.

A checkpoint can also be kept in the repository (parabolic.adaptive.committed_checkpoints,
written by ``python workflow/scripts/para_adaptive.py --keep CHECKPOINT COPY``): a job
without a checkpoint of its own it can continue, or with an earlier one, starts from a copy
of it, so a run longer than one allocation goes on in a fresh clone from where the last one
stopped.  The committed file itself is only read."""
import argparse
import hashlib
import json
import logging
import shutil
import time
from pathlib import Path

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem_workflow.io import (atomic_path, peak_memory_mb, provenance, save_arrays,
                                 with_provenance, write_table)
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import (family_error, key_differences, parameter_columns, start,
                                   stored_family)

logger = script_logger("para_adaptive")


def checkpoint_key(**settings) -> str:
    """What a checkpoint must have been made with to be continued (JSON): the settings
    that decide the passes and their errors; not the limits (max_spacetime_dofs,
    max_iterations), which only decide where the run ends."""
    return json.dumps(settings, sort_keys=True, default=str)


def _plain(value):
    """A numpy scalar as the Python number it holds (an integer stays one)."""
    return value.item() if hasattr(value, "item") else float(value)


# How far two stored runs' floating arrays may differ (relative to their norm) and still be
# one run: far above round-off (the same run computed with another thread count or on another
# processor), far below the errors the runs are measured to
RUN_RTOL = 1e-9


def run_fingerprint(path) -> dict:
    """What identifies a stored run (its ``.npz``) up to round-off, per array (``arrays``):
    its type and shape; of an integer, boolean or text array (a mesh's triangles) the SHA-256
    of its values; of a floating array its 2-norm and two fixed random projections, which
    same_run compares to RUN_RTOL (a run computed with another thread count is the same run;
    one that differs beyond round-off is another).  Not the per-step solver records
    (``step_*``: iteration counts, sizes of active sets), which round-off can move by one
    without changing the run.  ``sha256``: of all arrays' bits, as older checkpoints' keys
    held it.  Not the file's bytes, which hold the time it was written."""
    arrays, h = {}, hashlib.sha256()
    with np.load(path, allow_pickle=False) as d:
        for k in sorted(d.files):
            a = np.ascontiguousarray(d[k])
            h.update(f"{k}:{a.dtype.str}:{a.shape};".encode())
            h.update(a.tobytes())
            if k.startswith("step_"):
                continue
            entry = {"dtype": a.dtype.str, "shape": list(a.shape)}
            if a.dtype.kind in "fc":
                x = a.ravel()
                x = (np.concatenate([x.real, x.imag]) if a.dtype.kind == "c" else x).astype(float)
                finite = np.isfinite(x)
                if not finite.all():    # where and which NaN or ±inf: exactly
                    entry["nonfinite_sha256"] = hashlib.sha256(
                        np.flatnonzero(~finite).tobytes() + x[~finite].tobytes()).hexdigest()
                    x = np.where(finite, x, 0)
                # the weights a block at a time, from RandomState, whose stream numpy keeps
                # the same across its releases (Generator's may change)
                rng, proj = np.random.RandomState(2), np.zeros(2)
                for i in range(0, x.size, 2 ** 20):
                    part = x[i:i + 2 ** 20]
                    proj += rng.standard_normal((2, part.size)) @ part
                entry["norm"] = float(np.linalg.norm(x))
                entry["projections"] = [float(v) for v in proj]
            else:
                entry["sha256"] = hashlib.sha256(a.tobytes()).hexdigest()
            arrays[k] = entry
    return {"sha256": h.hexdigest(), "arrays": arrays}


def same_run(a, b, rtol=RUN_RTOL) -> bool:
    """Whether two run_fingerprint records are of one run: the same arrays, types, shapes and
    exact values, and floating arrays whose norms and projections agree to ``rtol`` of their
    norm.  A SHA-256 string (an older checkpoint's key) is one run with a fingerprint of the
    same bits; anything else is compared as it is."""
    if isinstance(a, str) and isinstance(b, dict) or isinstance(a, dict) and isinstance(b, str):
        digest, record = (a, b) if isinstance(a, str) else (b, a)
        return digest == record.get("sha256")
    if not (isinstance(a, dict) and isinstance(b, dict)):
        return a == b
    a, b = a["arrays"], b["arrays"]
    if sorted(a) != sorted(b):
        return False
    for k, x in a.items():
        y = b[k]
        exact = (set(x) | set(y)) - {"norm", "projections"}
        if any(x.get(n) != y.get(n) for n in exact):
            return False
        if "norm" in x:
            bound = rtol * max(x["norm"], y["norm"])
            pairs = [(x["norm"], y["norm"])] + list(zip(x["projections"], y["projections"]))
            if len(x["projections"]) != len(y["projections"]) or any(
                    abs(u - v) > bound for u, v in pairs):
                return False
    return True


def checkpoint_differences(made: str, key: str) -> list[str]:
    """The settings in which a checkpoint's key ``made`` differs from ``key`` (sorted): the
    reference and the family's coarser runs by same_run, the others exactly."""
    return key_differences(made, key, same={
        "ref": same_run,
        "coarser": lambda x, y: (isinstance(x, list) and isinstance(y, list)
                                 and len(x) == len(y)
                                 and all(same_run(u, v) for u, v in zip(x, y)))})


def save_checkpoint(path, rec, key, rows, arrays, elapsed, t_eval, invocation):
    """The state after pass rec.iteration: the next pass's mesh and what was recorded."""
    with atomic_path(path, suffix=".npz") as tmp:
        ff.save_slabs(tmp, rec.next_slabs, **arrays,
                      checkpoint_iteration=np.array(rec.iteration + 1),
                      checkpoint_key=np.array(key),
                      checkpoint_rows=np.array(json.dumps(rows, default=_plain)),
                      checkpoint_elapsed=np.array(elapsed),
                      checkpoint_t_eval=np.array(t_eval),
                      checkpoint_invocation=np.array(invocation))


def log_next_pass(iteration, slabs, s, c_tau):
    """The size of the pass about to be solved, known before it is (for time limits)."""
    size = ff.pass_size(slabs, s, c_tau=c_tau)
    logger.info("pass %d will have %d space-time DOFs: %d slabs, %d time steps, at most "
                "%d DOFs per step", iteration, size["spacetime_dofs"], size["slabs"],
                size["steps"], size["max_dofs_per_step"])


def _stamp(path):
    """(key, next pass, rows) a checkpoint was saved with, without reading its meshes."""
    with np.load(path, allow_pickle=False) as d:
        return (str(d["checkpoint_key"]), int(d["checkpoint_iteration"]),
                json.loads(str(d["checkpoint_rows"])))


def why_not(path, key, max_spacetime_dofs, max_iterations):
    """(next pass, None) of a checkpoint this run can continue, else (-1, why not): none,
    made with other settings (named), or holding a pass at which this run would have
    stopped."""
    path = Path(path)
    if not path.exists():
        return -1, "no such file"
    made, first, rows = _stamp(path)
    differ = checkpoint_differences(made, key)
    if differ:
        hint = (f"; the reference or the family's coarser runs differ beyond round-off "
                f"(relative {RUN_RTOL:g}), or the checkpoint's key is of an older format that "
                "compared them bit for bit" if "coarser" in differ or "ref" in differ else "")
        return -1, f"made with other settings (differing in {differ}){hint}"
    if first >= max_iterations or max(r["spacetime_dofs"] for r in rows) >= max_spacetime_dofs:
        return -1, (f"goes beyond max_iterations={max_iterations} or "
                    f"max_spacetime_dofs={max_spacetime_dofs}")
    return first, None


def load_checkpoint(path, key, max_spacetime_dofs, max_iterations):
    """(slabs, first iteration, rows, arrays, elapsed, t_eval, invocation) of a checkpoint
    made with ``key``; None if there is none, or it was made with other settings or
    holds a pass at which this run would have stopped (then it is removed: those passes
    are not this run's)."""
    path = Path(path)
    if not path.exists():
        return None
    first, why = why_not(path, key, max_spacetime_dofs, max_iterations)
    if why is not None:
        logger.warning("%s %s: starting from pass 0", path, why)
        path.unlink()
        return None
    slabs, d = ff.load_slabs(path)
    for k in ("checkpoint_iteration", "checkpoint_key"):
        d.pop(k)
    rows = json.loads(str(d.pop("checkpoint_rows")))
    elapsed, t_eval = float(d.pop("checkpoint_elapsed")), float(d.pop("checkpoint_t_eval"))
    invocation = int(d.pop("checkpoint_invocation")) + 1
    logger.info("continuing from %s: pass %d on %d slabs (passes 0-%d recorded, %.1f s)",
                path, first, len(slabs), first - 1, elapsed)
    return slabs, first, rows, d, elapsed, t_eval, invocation


def next_pass(path) -> int:
    """The pass a checkpoint continues with (-1: no such file)."""
    return _stamp(path)[1] if Path(path).exists() else -1


def seed_checkpoint(checkpoint, committed, key, max_spacetime_dofs, max_iterations):
    """Copy the committed checkpoint to the job's own path when this run can continue it
    (why_not) and the job's own is missing, not continuable, or at an earlier pass.  A
    committed checkpoint that cannot be continued is named in the log with the reason,
    and neither it nor the job's own checkpoint is touched.  Returns whether it copied."""
    if committed is None or not Path(committed).exists():
        return False
    kept, why = why_not(committed, key, max_spacetime_dofs, max_iterations)
    if why is not None:
        logger.warning("the committed checkpoint %s is not continued: %s", committed, why)
        return False
    ours, _ = why_not(checkpoint, key, max_spacetime_dofs, max_iterations)
    if kept <= ours:
        return False
    Path(checkpoint).parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(checkpoint, suffix=".npz") as tmp:
        shutil.copyfile(committed, tmp)
    logger.info("starting from the committed checkpoint %s (pass %d; the job's own: %s)",
                committed, kept, "none usable" if ours < 0 else f"pass {ours}")
    return True


def keep_checkpoint(checkpoint, copy, force=False):
    """Write a job's checkpoint, deflated, to ``copy`` (the file kept in the repository
    for parabolic.adaptive.committed_checkpoints); the same slabs and records.  An
    existing copy that is further on, or was made with other settings, is replaced only
    with ``force`` (else ValueError)."""
    if Path(copy).exists() and not force:
        (made, kept, _), (key, ours, _) = _stamp(copy), _stamp(checkpoint)
        differ = checkpoint_differences(made, key)
        if differ:
            raise ValueError(f"{copy} was made with other settings than {checkpoint} "
                             f"(differing in {differ}): --force replaces it")
        if kept > ours:
            raise ValueError(f"{copy} continues with pass {kept}, {checkpoint} "
                             f"with pass {ours}: --force replaces it")
    slabs, arrays = ff.load_slabs(checkpoint)
    Path(copy).parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(copy, suffix=".npz") as tmp:
        ff.save_slabs(tmp, slabs, compress=True, **arrays)
    rows = json.loads(str(arrays["checkpoint_rows"]))
    logger.info("%s -> %s: passes 0-%d recorded, pass %d next (%d slabs), %.1f MB",
                checkpoint, copy, len(rows) - 1, int(arrays["checkpoint_iteration"]),
                len(slabs), Path(copy).stat().st_size / 1e6)


def main(problem, example, data, T, theta, start_level, c_tau, max_spacetime_dofs,
         max_iterations, figure_iterations, output_times, tol, quadrature, ref, table, npz,
         log=None, threads=None, operator="dense", ref_operator=None, checkpoint=None,
         coarser=(), family=None, committed=None):
    """problem: the run's name; example, data: fracfem.example(example, **data); ref: the
    reference run the errors are measured against, coarser: the coarser runs of its family
    (coarsest first; the error is the distance to the family's limit, runs.family_error),
    family: para_reference_family's file of them (read instead of built);
    operator: each slab's stiffness ('dense', 'compressed', 'auto'); ref_operator: the reference's operator, saved by
    para_reference_operator (None: assembled here); checkpoint: the file each pass that
    does not end the run is saved to, and continued from when the job starts again
    (None: none); committed: a checkpoint kept in the repository, continued from when it
    is further on than the job's own (seed_checkpoint; None: none)."""
    start(log, threads, operator_cache=False)   # its own meshes; it times each step
    quad = ff.QuadratureOptions(**quadrature)
    ex = ff.example(example, **data)
    obstacle = example == "ex4"
    key = checkpoint_key(
        problem=problem, example=example, data=data, T=T, theta=theta,
        start_level=start_level, c_tau=c_tau, figure_iterations=sorted(figure_iterations),
        output_times=list(output_times), tol=tol, quadrature=quadrature, operator=operator,
        ref=run_fingerprint(ref), coarser=[run_fingerprint(c) for c in coarser])
    if checkpoint is not None:
        seed_checkpoint(checkpoint, committed, key, max_spacetime_dofs, max_iterations)
    state = (None if checkpoint is None else
             load_checkpoint(checkpoint, key, max_spacetime_dofs, max_iterations))
    slabs, first, rows, arrays, elapsed, t_done_eval, invocation = (
        state or (None, 0, [], {}, 0.0, 0.0, 0))
    if slabs is not None:
        log_next_pass(first, slabs, ex.s, c_tau)
    t0 = time.perf_counter()
    reference, s = stored_family(ref, list(coarser), quad, ref_operator, family)
    t_ref = time.perf_counter() - t0
    t_start = time.perf_counter() - elapsed     # all invocations' passes count
    keep = {int(k) for k in figure_iterations}
    t_eval = [t_done_eval]  # time spent measuring errors, not part of the method's cost
    commit = provenance()["git_commit"]    # the code this start runs, for all its passes

    def record(rec):
        t0 = time.perf_counter()
        measured = family_error(reference, rec.pieces)
        err = measured["error"]
        t_eval[0] += time.perf_counter() - t0
        rec.pieces = None                          # the steps are not needed any more
        rows.append({
            "problem": problem, "example": int(example[2:]),
            "variant": problem[4:] if obstacle else "",
            "family": "adaptive", "tag": f"it{rec.iteration}", "s": s,
            "dofs": max(sl.n_free for sl in rec.slabs), "slabs": len(rec.slabs),
            "steps": int(sum(sl.n_steps for sl in rec.slabs)),
            "spacetime_dofs": rec.dofs, **measured, "eta": rec.eta,
            **{f"eta2_{k}": v for k, v in rec.eta_parts.items()},
            # the time term with the energy norm instead of its h^{−2s}‖·‖_{L²} proxy
            "eta2_time_anorm": float(np.sum(rec.steps["time_anorm"])),
            "first_contact": (np.nan if rec.first_contact_time is None
                              else rec.first_contact_time),
            **{f"t_{k}": v for k, v in rec.timings.items()},
            # all passes so far, without the error measurement (as for the other families)
            "t_wall": time.perf_counter() - t_start - t_eval[0],
            "t_error_measurement": t_eval[0], "peak_mem_mb": peak_memory_mb(),
            # a run continued from a checkpoint: which start computed the pass, at which commit
            "invocation": invocation, "pass_commit": commit})
        logger.info("iteration %d: %d space-time DOFs, %d slabs, eta %.4e, error %.4e "
                    "(measured in %.1f s)", rec.iteration, rec.dofs, len(rec.slabs), rec.eta,
                    err, time.perf_counter() - t0)
        st = rec.steps
        arrays.update({f"t_it{rec.iteration}": st["t"], f"tau_it{rec.iteration}": st["tau"],
                       f"eta2_it{rec.iteration}": st["total"],
                       f"time_it{rec.iteration}": st["time"]})
        if rec.iteration in keep:
            for j, (t_out, snap) in enumerate(sorted(rec.outputs.items())):
                m = snap["mesh"]
                arrays.update({f"p_it{rec.iteration}_{j}": m.p, f"t_it{rec.iteration}_{j}": m.t,
                               f"time_it{rec.iteration}_{j}": t_out})
        return rec.dofs >= max_spacetime_dofs

    last = None
    for rec in ff.algorithm_c_steps(
            lambda coarse: ex.problem(coarse, quad, operator=operator),
            ff.disk_uniform(start_level),
            ex.initial_value, T=T, theta=theta, iterations=max_iterations, c_tau=c_tau,
            marking="maximum", solver="pdas", output_times=output_times, callback=record,
            keep_steps=True, solver_options={"tol": tol}, slabs=slabs,
            first_iteration=first):
        last = rec
        if checkpoint is not None and rec.next_slabs is not None:
            save_checkpoint(checkpoint, rec, key, rows, arrays,
                            time.perf_counter() - t_start, t_eval[0], invocation)
            logger.info("pass %d saved to %s", rec.iteration, checkpoint)
            log_next_pass(rec.iteration + 1, rec.next_slabs, ex.s, c_tau)
    for j, (t_out, snap) in enumerate(sorted(last.outputs.items())):
        # the last pass's state at each output time (Figure 14): u_hτ on that slab's T_h,
        # λ_H on its T_H (none at t = 0)
        arrays.update({f"p_last_{j}": snap["mesh"].p, f"t_last_{j}": snap["mesh"].t,
                       f"time_last_{j}": t_out, f"u_last_{j}": snap["u"], f"pc_last_{j}": snap["coarse"].p,
                       f"tc_last_{j}": snap["coarse"].t})
        if snap["lam"] is not None:
            arrays[f"lam_last_{j}"] = snap["lam"]
    arrays["last_iteration"] = last.iteration
    fin = last.final
    done = set(range(last.iteration + 1))
    arrays.update(p=fin["mesh"].p, t=fin["mesh"].t, pc=fin["coarse"].p, tc=fin["coarse"].t,
                  u=fin["u"], lam=fin["lam"], s=s, T=T,
                  iterations=np.array(sorted(done)),
                  figure_iterations=np.array(sorted(keep & done)))
    save_arrays(npz, **arrays)
    df = pd.DataFrame(rows)
    df["t_reference_assembly"] = t_ref
    df = df.assign(**parameter_columns(
        quadrature=quad, T=T, theta=theta, marking="maximum", c_tau=c_tau,
        start_level=start_level, solver="pdas", tol=tol, operator=operator))
    write_table(with_provenance(df), table)
    if checkpoint is not None:
        Path(checkpoint).unlink(missing_ok=True)   # the run is complete: nothing to continue


def cli(argv=None):
    ap = argparse.ArgumentParser(description=keep_checkpoint.__doc__)
    ap.add_argument("--keep", nargs=2, metavar=("CHECKPOINT", "COPY"), required=True,
                    help="a job's checkpoint.npz and the committed copy to write")
    ap.add_argument("--force", action="store_true",
                    help="replace a copy that is further on or of other settings")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if not Path(a.keep[0]).exists():
        ap.error(f"--keep: no checkpoint {a.keep[0]}")
    try:
        keep_checkpoint(*a.keep, force=a.force)
    except ValueError as e:
        ap.error(str(e))


if __name__ == "__main__" and "snakemake" not in globals():
    cli()
elif __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.params.example,  # noqa: F821
         snakemake.params.data, snakemake.params.T, snakemake.params.theta,  # noqa: F821
         snakemake.params.start_level, snakemake.params.c_tau,  # noqa: F821
         snakemake.params.max_spacetime_dofs, snakemake.params.max_iterations,  # noqa: F821
         snakemake.params.figure_iterations, snakemake.params.output_times,  # noqa: F821
         snakemake.params.tol, snakemake.params.quadrature, snakemake.input.ref,  # noqa: F821
         snakemake.output.table, snakemake.output.npz, snakemake.log[0],  # noqa: F821
         snakemake.threads, snakemake.params.operator,  # noqa: F821
         snakemake.input.operator, snakemake.params.checkpoint,  # noqa: F821
         list(snakemake.input.coarser), snakemake.input.get("family"),  # noqa: F821
         snakemake.params.committed)  # noqa: F821
