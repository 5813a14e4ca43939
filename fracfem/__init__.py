"""fracfem: finite elements for the integral fractional Laplacian and its
obstacle and friction problems (Gimperlein & Stocek)."""
from .assembly import (QuadratureOptions, energy, exterior_kernel, load_vector,
                       stiffness_matrix)
from .exact import c2s, disk_energy, disk_solution, disk_solution_constant
from .laplace import Discretisation, discretise, solve_laplace
from .meshes import (disk_graded, disk_graded_rings, disk_uniform, lshape,
                     refine_disk, square)

from .parabolic import (IterationRecord, Slab, Stepper, TimeStep, algorithm_c,
                        algorithm_c_steps, initial_projection, solve_parabolic,
                        space_time_indicators, time_steps)

__version__ = "0.1.0"

__all__ = [
    "QuadratureOptions", "stiffness_matrix", "load_vector", "energy", "exterior_kernel",
    "c2s", "disk_energy", "disk_solution", "disk_solution_constant",
    "Discretisation", "discretise", "solve_laplace",
    "disk_uniform", "disk_graded", "disk_graded_rings", "square", "lshape", "refine_disk",
    "Stepper", "TimeStep", "time_steps", "solve_parabolic", "initial_projection",
    "space_time_indicators", "algorithm_c", "algorithm_c_steps", "Slab", "IterationRecord",
]

from . import problems  # noqa: E402
from .kkt import discrete_energy, friction_functional, kkt_report  # noqa: E402
from .problems import (EXAMPLES, Example1, Example2, Example3, Example4,  # noqa: E402
                       Example5, ThinFrictionDemo, ThinObstacleDemo, example,
                       multiplier_mesh, parse_series_tag, series_mesh, series_tag)
from .stepsize import time_step  # noqa: E402

__all__ += [
    "discrete_energy", "friction_functional", "kkt_report", "time_step",
    "EXAMPLES", "Example1", "Example2", "Example3", "Example4", "Example5",
    "ThinObstacleDemo", "ThinFrictionDemo", "example", "series_tag", "parse_series_tag",
    "series_mesh", "multiplier_mesh",
]
from .parabolic import heat_error, time_grid  # noqa: E402

__all__ += ["heat_error", "time_grid"]
