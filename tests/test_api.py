"""The public API of ``import fracfem``: every advertised name exists, the list is
complete, and importing the library pulls in no workflow or plotting packages."""
import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import fracfem

ROOT = Path(__file__).resolve().parents[1]

# the paper's path through the library, elliptic and parabolic side by side
PAPER_NAMES = [
    # Example 1: the fractional Laplacian
    "stiffness_matrix", "load_vector", "discretise", "solve_laplace",
    # Problem 5.15 (obstacle, friction, thin problems) and Algorithm A / PDAS
    "mixed_problem", "MixedProblem", "solve_mixed", "uzawa", "pdas", "ConvergenceError",
    "Obstacle", "Friction", "ThinObstacle", "ThinFriction", "friction_bound",
    "obstacle_from_function", "coupling_matrix",
    # Section 7 and Algorithm B
    "estimate", "estimate_laplace", "algorithm_b", "algorithm_b_steps",
    "mark_maximum", "mark_doerfler",
    # Problem 6.11, Theorem 6.18 and Algorithm C
    "time_grid", "Stepper", "TimeStep", "time_steps", "solve_parabolic",
    "initial_projection", "heat_error", "space_time_indicators",
    "algorithm_c", "algorithm_c_steps", "Slab", "IterationRecord",
]


def test_every_name_in_all_resolves():
    missing = [name for name in fracfem.__all__ if not hasattr(fracfem, name)]
    assert missing == []
    assert len(set(fracfem.__all__)) == len(fracfem.__all__)


def test_all_lists_every_public_name():
    public = {name for name, value in vars(fracfem).items()
              if not name.startswith("_") and not inspect.ismodule(value)}
    assert public == set(fracfem.__all__)


def test_the_paper_path_is_at_the_top_level():
    assert [name for name in PAPER_NAMES if name not in fracfem.__all__] == []


def test_import_pulls_in_no_workflow_or_plotting_package():
    code = ("import json, sys; import fracfem; "
            "print(json.dumps([fracfem.__file__, sorted({m.split('.')[0] for m in sys.modules} "
            "& {'snakemake', 'matplotlib', 'pandas'})]))")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout
    path, heavy = json.loads(out.strip().splitlines()[-1])
    assert Path(path).resolve() == ROOT / "fracfem" / "__init__.py"
    assert heavy == []


def test_warm_up_compiles_every_kernel_called_from_python():
    """fracfem.warmup leaves no kernel that fracfem's Python code calls uncompiled: run in
    a process of its own, every such numba dispatcher has a signature afterwards."""
    import subprocess
    import sys
    code = r"""
import pathlib, re
import fracfem
from fracfem import _aniso_kernels, _h2_kernels, _kernels, _pointwise_kernels
from fracfem.warmup import warm_up
from numba.core.registry import CPUDispatcher
warm_up()
root = pathlib.Path(fracfem.__file__).parent
callers = "".join(p.read_text() for p in root.glob("*.py") if not p.name.endswith("_kernels.py"))
called = missing = 0
for m in (_kernels, _aniso_kernels, _h2_kernels, _pointwise_kernels):
    for name, f in vars(m).items():
        if isinstance(f, CPUDispatcher) and re.search(r"\." + name + r"\(", callers):
            called += 1
            if not f.signatures:
                print("missing", m.__name__, name)
                missing += 1
print("called", called, "missing", missing)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    last = out.stdout.strip().splitlines()[-1]
    called, missing = int(last.split()[1]), int(last.split()[3])
    assert called >= 20 and missing == 0, out.stdout      # 28 when written
