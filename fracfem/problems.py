"""The paper's examples (Section 8) built from their parameters, and the meshes of
their convergence series.

Each example is a small frozen dataclass holding its data; ``problem(mesh)``
assembles it on a mesh (Example 1: the P1 mesh; the mixed examples: the
multiplier mesh T_H, with T_h = refine_disk(T_H)); ``problem(mesh, operator=...)``
chooses the stiffness representation ('dense', 'compressed' or 'auto', as
:func:`fracfem.discretise`).  :func:`example` builds one from its name and
parameters, as a configuration file gives them.

A member of a series is named by a tag, one letter per family of meshes:

- ``L<level>``: family ``uniform``, disk_uniform(level);
- ``h<h>``: family ``graded``, the paper's anisotropic 2-graded meshes
  disk_graded_aniso(h, grading) (N ~ h⁻², halving h quadruples N);
- ``r<h>``: family ``graded-sr``, the shape-regular graded meshes
  disk_graded(h, grading) (N ~ h⁻²|log h|), kept to compare the two gradings.

:func:`series_mesh` is the mesh of Example 1 of that tag, :func:`multiplier_mesh`
the multiplier mesh T_H of the mixed examples: for ``L<level>`` the fine mesh is
disk_uniform(level), so T_H = disk_uniform(level − 1); for a graded tag T_H is
the graded mesh of h and T_h its refinement.
"""
from __future__ import annotations

import dataclasses
import numbers
import re
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from . import examples, vi
from .assembly import QuadratureOptions
from .exact import check_s, disk_energy
from .laplace import Discretisation, discretise
from .meshes import disk_graded, disk_graded_aniso, disk_uniform

__all__ = ["Example1", "Example2", "Example3", "Example4", "Example5", "ThinObstacleDemo",
           "ThinFrictionDemo", "EXAMPLES", "example", "series_tag", "parse_series_tag",
           "series_mesh", "multiplier_mesh", "SERIES_FAMILIES"]


def _finite(name: str, value) -> float:
    if (isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real)
            or not np.isfinite(value)):
        raise ValueError(f"{name}={value!r} must be a finite number")
    return float(value)


def _friction_bound(value) -> float:
    F = _finite("F", value)
    if F < 0:
        raise ValueError(f"friction bound F={value!r} must be >= 0")
    return F


# ------------------------------------------------------------------ the examples


@dataclass(frozen=True)
class Example1:
    """(−Δ)ˢu = 1 on the unit disk; exact solution C_s(1 − |x|²)ˢ₊."""

    s: float = 0.5
    f: ClassVar[float] = 1.0

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s))

    def problem(self, mesh, quadrature: QuadratureOptions | None = None,
                operator: str = "dense") -> Discretisation:
        """Free-node matrix and load on the P1 mesh ``mesh``."""
        return discretise(mesh, self.s, self.f, quadrature=quadrature, operator=operator)

    @property
    def exact_energy(self) -> float:
        """E(u) = ½a(u,u) − (f,u) = −½(f,u) of the exact solution."""
        return -0.5 * disk_energy(self.s)


@dataclass(frozen=True)
class Example2:
    """Obstacle problem (A): (−Δ)ˢu ≥ 1 above χ = height − slope|x|², mixed form."""

    s: float = 0.5
    height: float = 1.0
    slope: float = 4.0
    f: ClassVar[float] = 1.0
    exact_energy: ClassVar[None] = None

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s))
        examples.paraboloid_obstacle(self.height, self.slope)      # checks the data

    @property
    def obstacle(self):
        """χ(x) = height − slope |x|², a function of points x of shape (2, ...)."""
        return examples.paraboloid_obstacle(self.height, self.slope)

    def problem(self, coarse, quadrature: QuadratureOptions | None = None,
                operator: str = "dense"):
        """The mixed problem on T_H = coarse."""
        return examples.example2(coarse, s=self.s, height=self.height, slope=self.slope,
                                 quadrature=quadrature, operator=operator)[0]


@dataclass(frozen=True)
class Example3:
    """Interior friction (C) on Ω with f = a − b|x|² and bound F, mixed form.

    b = 0 is the paper's f ≡ 1 (with a = 1); b > a makes f change sign.
    """

    s: float = 0.6
    a: float = 1.0
    b: float = 0.0
    F: float = 0.5

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s))
        object.__setattr__(self, "a", _finite("a", self.a))
        object.__setattr__(self, "b", _finite("b", self.b))
        object.__setattr__(self, "F", _friction_bound(self.F))

    @property
    def f(self):
        return examples.radial_load(self.a, self.b)

    def problem(self, coarse, quadrature: QuadratureOptions | None = None,
                operator: str = "dense"):
        """The mixed problem on T_H = coarse."""
        return examples.example3(coarse, s=self.s, a=self.a, b=self.b, F=self.F,
                                 quadrature=quadrature, operator=operator)[0]

    @property
    def exact_energy(self) -> float | None:
        """The exact energy when it is known: f ≡ a > F (pure slip), else None."""
        if self.b == 0 and self.a > self.F:
            return examples.pure_slip_energy(self.s, self.F, self.a)
        return None


@dataclass(frozen=True)
class Example4:
    """Parabolic obstacle problem: f = 0, u₀ constant, obstacle χ of Example 2."""

    s: float = 0.5
    u0: float = 1.0
    height: float = 1.0
    slope: float = 4.0
    f: ClassVar[float] = 0.0

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s))
        object.__setattr__(self, "u0", _finite("u0", self.u0))
        examples.paraboloid_obstacle(self.height, self.slope)

    @property
    def initial_value(self) -> float:
        return self.u0

    @property
    def obstacle(self):
        """χ(x) = height − slope |x|², a function of points x of shape (2, ...)."""
        return examples.paraboloid_obstacle(self.height, self.slope)

    def problem(self, coarse, quadrature: QuadratureOptions | None = None,
                operator: str = "dense", stiffness=None):
        """The mixed problem of one time step's space discretisation on T_H = coarse;
        stiffness: the ``disc`` of a problem on the same mesh and s, to reuse its
        operator (:func:`fracfem.vi.mixed_problem`)."""
        return vi.mixed_problem("obstacle", coarse, self.s, self.f, chi=self.obstacle,
                                quadrature=quadrature, operator=operator,
                                stiffness=stiffness)


@dataclass(frozen=True)
class Example5:
    """Parabolic interior friction on Ω: f = 0, u₀ = (|x| − 1)(|x| − r0), bound F."""

    s: float = 0.6
    F: float = 0.1
    r0: float = 0.6
    f: ClassVar[float] = 0.0

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s))
        object.__setattr__(self, "F", _friction_bound(self.F))
        examples.ring_initial(self.r0)                                # checks r0

    @property
    def initial_value(self):
        return examples.ring_initial(self.r0)

    def problem(self, coarse, quadrature: QuadratureOptions | None = None,
                operator: str = "dense", stiffness=None):
        """The mixed problem of one time step's space discretisation on T_H = coarse;
        stiffness: the ``disc`` of a problem on the same mesh and s, to reuse its
        operator (:func:`fracfem.vi.mixed_problem`)."""
        return vi.mixed_problem("friction", coarse, self.s, self.f, F=self.F,
                                quadrature=quadrature, operator=operator,
                                stiffness=stiffness)


def _segment(value) -> tuple[float, float]:
    try:
        x0, x1 = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"segment={value!r} must be two numbers [x0, x1]") from None
    if not (np.isfinite(x0) and np.isfinite(x1) and x0 < x1):
        raise ValueError(f"segment={value!r} must be finite with x0 < x1")
    return x0, x1


@dataclass(frozen=True)
class ThinObstacleDemo:
    """Thin obstacle (Problem B): u ≥ height on Γ̃ = segment × {0}, load f (s > 1/2)."""

    s: float = 0.75
    f: float = -1.0
    height: float = -0.05
    segment: tuple = (-0.5, 0.5)
    exact_energy: ClassVar[None] = None

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s, name="s (thin problems need s > 1/2)",
                                              low=0.5))
        object.__setattr__(self, "f", _finite("f", self.f))
        object.__setattr__(self, "height", _finite("height", self.height))
        object.__setattr__(self, "segment", _segment(self.segment))

    def problem(self, coarse, quadrature: QuadratureOptions | None = None,
                operator: str = "dense"):
        """The mixed problem on T_H = coarse (Γ̃ must be made of its edges)."""
        h = self.height
        return vi.mixed_problem("thin_obstacle", coarse, self.s, self.f,
                                edges=examples.segment_edges(coarse, *self.segment),
                                height=lambda x: np.full(x.shape[1:], h),
                                quadrature=quadrature, operator=operator)


@dataclass(frozen=True)
class ThinFrictionDemo:
    """Thin friction (Problem D) on Γ̃ = segment × {0} with bound F, load f (s > 1/2)."""

    s: float = 0.75
    f: float = 1.0
    F: float = 0.8
    segment: tuple = (-0.5, 0.5)
    exact_energy: ClassVar[None] = None

    def __post_init__(self):
        object.__setattr__(self, "s", check_s(self.s, name="s (thin problems need s > 1/2)",
                                              low=0.5))
        object.__setattr__(self, "f", _finite("f", self.f))
        object.__setattr__(self, "F", _friction_bound(self.F))
        object.__setattr__(self, "segment", _segment(self.segment))

    def problem(self, coarse, quadrature: QuadratureOptions | None = None,
                operator: str = "dense"):
        """The mixed problem on T_H = coarse (Γ̃ must be made of its edges)."""
        return vi.mixed_problem("thin_friction", coarse, self.s, self.f,
                                edges=examples.segment_edges(coarse, *self.segment),
                                F=self.F, quadrature=quadrature, operator=operator)


EXAMPLES = {"ex1": Example1, "ex2": Example2, "ex3": Example3, "ex4": Example4,
            "ex5": Example5, "thin-obstacle": ThinObstacleDemo,
            "thin-friction": ThinFrictionDemo}


def example(name: str, **parameters):
    """The example called ``name`` (a key of :data:`EXAMPLES`) with these parameters."""
    if name not in EXAMPLES:
        raise ValueError(f"example name={name!r} must be one of {sorted(EXAMPLES)}")
    cls = EXAMPLES[name]
    allowed = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(parameters) - set(allowed))
    if unknown:
        raise ValueError(f"{name} has no parameter(s) {unknown}; allowed: {allowed}")
    return cls(**parameters)


# ------------------------------------------------------------------ series members


# family of a series -> the letter of its tags
SERIES_FAMILIES = {"uniform": "L", "graded": "h", "graded-sr": "r"}
_FAMILY_OF_LETTER = {letter: family for family, letter in SERIES_FAMILIES.items()}
_TAG = re.compile(r"^(?:L(?P<level>[0-9]+)|(?P<letter>[hr])(?P<h>[0-9]*\.?[0-9]+(?:e-?[0-9]+)?))$")


def series_tag(family: str, value) -> str:
    """The tag of a series member: ``L<level>`` (uniform), ``h<h>`` (graded) or
    ``r<h>`` (graded-sr).

    A graded tag writes h with format ``g``, so h = 0.2 and h = 0.20 share a tag.
    """
    if family == "uniform":
        if (isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real)
                or int(value) != value or value < 0):
            raise ValueError(f"uniform level={value!r} must be an integer >= 0")
        return f"L{int(value)}"
    if family in SERIES_FAMILIES:
        h = _finite("h", value)
        if not h > 0:
            raise ValueError(f"{family} h={value!r} must be > 0")
        return f"{SERIES_FAMILIES[family]}{h:g}"
    raise ValueError(f"family={family!r} must be one of {sorted(SERIES_FAMILIES)}")


def parse_series_tag(tag: str) -> tuple[str, float | int]:
    """(family, level or h) from a tag of :func:`series_tag`."""
    m = _TAG.match(tag) if isinstance(tag, str) else None
    if m is None:
        raise ValueError(f"tag={tag!r} must be L<level> (e.g. L3), h<h> (e.g. h0.1, "
                         "anisotropic graded) or r<h> (e.g. r0.35, shape-regular graded)")
    if m["level"] is not None:
        return "uniform", int(m["level"])
    return _FAMILY_OF_LETTER[m["letter"]], float(m["h"])


def _graded_mesh(family, h, grading):
    return disk_graded_aniso(h, grading) if family == "graded" else disk_graded(h, grading)


def series_mesh(tag: str, grading: float = 2.0):
    """Example 1's mesh of a tag: disk_uniform(level), disk_graded_aniso(h, grading)
    or disk_graded(h, grading)."""
    family, value = parse_series_tag(tag)
    if family == "uniform":
        return disk_uniform(value)
    return _graded_mesh(family, value, grading)


def multiplier_mesh(tag: str, grading: float = 2.0):
    """T_H of a tag: disk_uniform(level − 1) (so that T_h = disk_uniform(level)) or the
    graded mesh of h (T_h its refinement)."""
    family, value = parse_series_tag(tag)
    if family == "uniform":
        if value < 1:
            raise ValueError(f"tag={tag!r}: the fine mesh of a mixed problem is "
                             "disk_uniform(level) with level >= 1")
        return disk_uniform(value - 1)
    return _graded_mesh(family, value, grading)
