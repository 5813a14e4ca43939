"""fracfem: finite elements for the integral fractional Laplacian and its
obstacle and friction problems (Gimperlein & Stocek)."""
from .assembly import (QuadratureOptions, energy, exterior_kernel, load_vector,
                       stiffness_matrix)
from .exact import c2s, disk_energy, disk_solution, disk_solution_constant
from .laplace import Discretisation, discretise, solve_laplace
from .meshes import (disk_graded, disk_graded_rings, disk_uniform, lshape,
                     refine_disk, square)

from .parabolic import (Stepper, TimeStep, initial_projection, solve_parabolic,
                        time_steps)
from .spacetime_adaptive import (IterationRecord, Slab, algorithm_c,
                                 algorithm_c_steps)
from .spacetime_estimators import space_time_indicators

__version__ = "0.1.0"

__all__ = [
    "QuadratureOptions", "stiffness_matrix", "load_vector", "energy", "exterior_kernel",
    "c2s", "disk_energy", "disk_solution", "disk_solution_constant",
    "Discretisation", "discretise", "solve_laplace",
    "disk_uniform", "disk_graded", "disk_graded_rings", "square", "lshape", "refine_disk",
    "Stepper", "TimeStep", "time_steps", "solve_parabolic", "initial_projection",
    "space_time_indicators", "algorithm_c", "algorithm_c_steps", "Slab", "IterationRecord",
]
