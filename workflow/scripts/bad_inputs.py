"""Bad input, tried: each invalid parameter or file and the error a user gets.

    python workflow/scripts/bad_inputs.py [--md out.md]
"""
import argparse
import logging
from pathlib import Path

import numpy as np
import yaml

import fracfem as ff
from fracfem import adaptive, examples, vi
from fracfem.meshes import mesh_from_arrays
from fracfem.solvers import ConvergenceError
from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger

logger = script_logger("bad_inputs")

ROOT = Path(__file__).resolve().parents[2]


def _mesh(p, triangles):
    """Mesh from node columns p (2, Nv) and triangles given row-wise."""
    return mesh_from_arrays(np.asarray(p, float), np.asarray(triangles).T)


P = [[0, 1, 0, 1], [0, 0, 1, 1]]          # the unit square ...
T = [[0, 1, 3], [0, 3, 2]]                # ... as two triangles (rows)


def _schema(override):
    import jsonschema
    cfg = yaml.safe_load((ROOT / "config.yaml").read_text())
    cfg.update(override)
    schema = yaml.safe_load((ROOT / "workflow/schemas/config.schema.yaml").read_text())
    try:
        jsonschema.validate(cfg, schema)
    except jsonschema.ValidationError as err:
        raise ValueError(f"config fails the schema at {list(err.absolute_path)}: "
                         f"{err.message}") from None


def _uzawa_two_steps():
    prob = vi.mixed_problem("obstacle", ff.disk_uniform(3), 0.5, 1.0,
                            chi=examples.paraboloid_obstacle())
    vi.solve(prob, "uzawa", maxiter=2)


def _steps(**kw):
    """Run a tiny unconstrained DG(0) problem with the given time arguments."""
    disc = ff.discretise(ff.disk_uniform(1), 0.5, 0.0)
    return list(ff.time_steps(disc, 1.0, **kw))


# (parameter, what was passed, call)
CASES = [
    ("τ", "time step τ = 0", lambda: _steps(T=1.0, tau=0.0)),
    ("τ", "time step τ = −0.1", lambda: _steps(T=1.0, tau=-0.1)),
    ("τ", "time step τ = NaN", lambda: _steps(T=1.0, tau=float("nan"))),
    ("T", "final time T = 0", lambda: _steps(T=0.0, tau=0.1)),
    ("T", "final time T = inf", lambda: _steps(T=float("inf"), tau=0.1)),
    ("times", "time grid not increasing [0, 0.5, 0.4]",
     lambda: _steps(times=[0.0, 0.5, 0.4])),
    ("u0", "initial value u0 = NaN", lambda: list(ff.time_steps(
        ff.discretise(ff.disk_uniform(1), 0.5, 0.0), float("nan"), T=1.0, tau=0.5))),
    ("θ", "θ = 1 in Algorithm C", lambda: ff.algorithm_c(
        lambda c: None, ff.disk_uniform(1), 1.0, T=1.0, theta=1.0, iterations=1)),
    ("s", "s = 0", lambda: ff.stiffness_matrix(ff.disk_uniform(1), 0.0)),
    ("s", "s = 1.2", lambda: ff.stiffness_matrix(ff.disk_uniform(1), 1.2)),
    ("s", "s = NaN", lambda: ff.stiffness_matrix(ff.disk_uniform(1), float("nan"))),
    ("s", "s = '0.5' (a string)", lambda: ff.stiffness_matrix(ff.disk_uniform(1), "0.5")),
    ("s", "thin obstacle with s = 0.5", lambda: vi.mixed_problem(
        "thin_obstacle", ff.disk_uniform(2), 0.5, 1.0,
        edges=examples.segment_edges(ff.disk_uniform(2), -0.5, 0.5),
        height=lambda x: 0 * x[0])),
    ("θ", "θ = 1.5 (marking)", lambda: adaptive.mark_maximum(np.ones(4), 1.5)),
    ("θ", "θ = 0 (Dörfler)", lambda: adaptive.mark_doerfler(np.ones(4), 0.0)),
    ("grading", "disk_graded(0.2, grading=9)", lambda: ff.disk_graded(0.2, 9.0)),
    ("h", "disk_graded(h=0)", lambda: ff.disk_graded(0.0)),
    ("level", "disk_uniform(12)", lambda: ff.disk_uniform(12)),
    ("F", "friction bound F = −1", lambda: vi.mixed_problem(
        "friction", ff.disk_uniform(2), 0.6, 1.0, F=-1.0)),
    ("F", "friction bound F = NaN", lambda: vi.mixed_problem(
        "friction", ff.disk_uniform(2), 0.6, 1.0, F=float("nan"))),
    ("χ", "obstacle χ = 1 (positive on ∂Ω)", lambda: vi.mixed_problem(
        "obstacle", ff.disk_uniform(2), 0.5, 1.0, chi=lambda x: 1.0 + 0 * x[0])),
    ("χ", "paraboloid obstacle with slope < height", lambda: examples.paraboloid_obstacle(1, 0.5)),
    ("Γ̃", "segment [−0.3, 0.3] not made of coarse edges",
     lambda: examples.segment_edges(ff.disk_uniform(2), -0.3, 0.3)),
    ("p", "mesh coordinates with NaN", lambda: _mesh([[0, 1, np.nan, 1], [0, 0, 1, 1]], T)),
    ("p", "mesh coordinates of shape (3, Nv)", lambda: _mesh(np.zeros((3, 4)), T)),
    ("p", "duplicate nodes", lambda: _mesh([[0, 1, 0, 1, 1], [0, 0, 1, 1, 1]], [[0, 1, 3], [0, 3, 2]])),
    ("p", "unused node", lambda: _mesh([[0, 1, 0, 1, 5], [0, 0, 1, 1, 5]], T)),
    ("t", "zero-area triangle", lambda: _mesh([[0, 1, 2, 0], [0, 0, 0, 1]], [[0, 1, 2], [0, 1, 3]])),
    ("t", "triangle index out of range", lambda: _mesh(P, [[0, 1, 7], [0, 3, 2]])),
    ("f", "load f returning NaN", lambda: ff.load_vector(ff.disk_uniform(1),
                                                           lambda x: np.nan * x[0])),
    ("quadrature", "far_thresholds of the wrong length",
     lambda: ff.QuadratureOptions(far_orders=(0, 2), far_thresholds=(8.0, 4.0))),
    ("maxiter", "Uzawa stopped after 2 iterations", _uzawa_two_steps),
    ("config", "s_values: [1.5]", lambda: _schema({"s_values": [1.5]})),
    ("config", "example1.grading: 9", lambda: _schema(
        {"example1": {**yaml.safe_load((ROOT / 'config.yaml').read_text())["example1"],
                      "grading": 9}})),
    ("config", "unknown key 'sigma'", lambda: _schema({"sigma": 1})),
]


def run_cases():
    rows = []
    for param, what, call in CASES:
        try:
            call()
        except (ValueError, ConvergenceError) as err:
            rows.append((param, what, type(err).__name__, str(err).splitlines()[0]))
        else:
            rows.append((param, what, "NO ERROR", ""))
        logger.log(logging.INFO if rows[-1][2] != "NO ERROR" else logging.WARNING,
                "%s, %s: %s", param, what, rows[-1][2])
    return rows


def to_markdown(rows):
    lines = ["| parameter | input | error | message |", "|---|---|---|---|"]
    for param, what, kind, msg in rows:
        msg = msg.replace("|", "\\|")
        lines.append(f"| {param} | {what} | {kind} | {msg[:160]} |")
    return "\n".join(lines) + "\n"


def main(md):
    rows = run_cases()
    with atomic_path(md) as tmp:
        tmp.write_text(to_markdown(rows))
    bad = [r for r in rows if r[2] == "NO ERROR"]
    if bad:
        raise SystemExit(f"inputs accepted silently: {bad}")


if __name__ == "__main__":
    if "snakemake" in globals():
        log_to(snakemake.log[0])  # noqa: F821
        main(snakemake.output.md)  # noqa: F821
    else:
        ap = argparse.ArgumentParser()
        ap.add_argument("--md", default="/dev/stdout")
        main(ap.parse_args().md)
