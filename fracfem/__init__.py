"""fracfem: finite elements for the integral fractional Laplacian and its
obstacle and friction problems (Gimperlein & Stocek).

The top level holds the paper's path through the library: meshes, the
fractional Laplacian (assembly, exact solutions, the unconstrained problem),
the elliptic variational inequalities in mixed form (Problem 5.15) with their
solvers, a posteriori indicators and Algorithm B, and the parabolic problems
(DG(0) in time, Problem 6.11) with their indicators and Algorithm C.

Long computations report progress through the ``logging`` module (loggers
``fracfem.<module>``); nothing is shown unless the application configures
logging, e.g. ``logging.basicConfig(level=logging.INFO)``.
"""
from .meshes import (disk_graded, disk_graded_aniso, disk_graded_rings, disk_uniform,
                     graded_ring_count, lshape, refine_disk, square)

from .assembly import (QuadratureOptions, energy, exterior_kernel, load_vector,
                       stiffness_matrix)
from .exact import (c2s, disk_energy, disk_solution, disk_solution_constant,
                    heat_error, heat_solution, heat_source)
from .laplace import Discretisation, discretise, solve_laplace
from .opcache import operator_cache
from .compressed import CompressedOperator, stiffness_operator
from .krylov import pcg
from .memory import DenseMemoryError
from .preconditioners import multilevel_preconditioner

from .mixed import (Friction, Obstacle, ThinFriction, ThinObstacle, coupling_matrix,
                    friction_bound, obstacle_from_function)
from .solvers import ConvergenceError, pdas, uzawa
from .vi import MixedProblem, mixed_problem
from .vi import solve as solve_mixed
from .kkt import contact_set, discrete_energy, friction_functional, kkt_report

from .adaptive import algorithm_b, algorithm_b_steps, mark_doerfler, mark_maximum
from .estimators import estimate, estimate_laplace

from .parabolic import (Stepper, TimeStep, initial_projection, solve_parabolic,
                        time_grid, time_steps)
from .spacetime_adaptive import (IterationRecord, Slab, algorithm_c,
                                 algorithm_c_steps, load_slabs, pass_size, save_slabs,
                                 solve_slabs)
from .spacetime_estimators import space_time_indicators
from .stepsize import time_step

from .problems import (EXAMPLES, Example1, Example2, Example3, Example4, Example5,
                       ThinFrictionDemo, ThinObstacleDemo, example, multiplier_mesh,
                       parse_series_tag, series_mesh, series_tag)

__version__ = "0.1.0"

# silent unless the application configures logging
import logging as _logging  # noqa: E402

_logging.getLogger(__name__).addHandler(_logging.NullHandler())

__all__ = [
    # meshes
    "disk_uniform", "disk_graded", "disk_graded_aniso", "disk_graded_rings", "graded_ring_count",
    "square", "lshape", "refine_disk",
    # the fractional Laplacian: assembly, exact solutions, the unconstrained problem
    "QuadratureOptions", "stiffness_matrix", "load_vector", "energy", "exterior_kernel",
    "c2s", "disk_energy", "disk_solution", "disk_solution_constant",
    "Discretisation", "discretise", "solve_laplace", "operator_cache", "DenseMemoryError",
    # the compressed operator and its solvers
    "stiffness_operator", "CompressedOperator", "pcg", "multilevel_preconditioner",
    # obstacle and friction problems in mixed form (Problem 5.15) and their solvers
    "mixed_problem", "MixedProblem", "solve_mixed",
    "Obstacle", "Friction", "ThinObstacle", "ThinFriction",
    "coupling_matrix", "obstacle_from_function", "friction_bound",
    "uzawa", "pdas", "ConvergenceError",
    "contact_set", "discrete_energy", "friction_functional", "kkt_report",
    # a posteriori indicators (Section 7) and Algorithm B
    "estimate", "estimate_laplace",
    "mark_maximum", "mark_doerfler", "algorithm_b", "algorithm_b_steps",
    # parabolic problems: DG(0) time stepping (Problem 6.11)
    "time_grid", "time_step", "Stepper", "TimeStep", "time_steps", "solve_parabolic",
    "initial_projection", "heat_solution", "heat_source", "heat_error",
    # space-time indicators (Theorem 6.18, Lemma 6.20) and Algorithm C
    "space_time_indicators", "algorithm_c", "algorithm_c_steps", "solve_slabs", "Slab",
    "IterationRecord", "save_slabs", "load_slabs", "pass_size",
    # the paper's examples, built from their parameters, and series meshes
    "EXAMPLES", "Example1", "Example2", "Example3", "Example4", "Example5",
    "ThinObstacleDemo", "ThinFrictionDemo", "example", "series_tag", "parse_series_tag",
    "series_mesh", "multiplier_mesh",
]
