"""What Al-Oraiqat's paper reported ("Parallel implementation of the coupled harmonic oscillator"), for the
side-by-side tables, and the model's own values.

The model's constants and normal modes are the run's (a run file's lockstep_model, a verify trajectory's exact_x
columns) where the file states them; for a file written before it they are computed here as lockstep's kernel
defines them (kernels/oscillator.hpp, kernels/normal_modes.hpp): a copy that the file's values replace."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# The model's case: m1 = m2, C1 = C2, C/m = 1012.5 s^-2 (m = 0.02 kg, C = 20.25 N/m; the paper's printed
# units would give 10^7, its roots fix 1012.5), x1(0) = 2, x2(0) = -3, velocities 0.
C_OVER_M = 1012.5
INITIAL_POSITIONS = (2.0, -3.0)

# The roots the paper prints (rad/s, purely imaginary, each with its conjugate).
PAPER_ROOTS = (51.47, 19.66)

# Per-derivative evaluation times (s), high-resolution performance counter, Core i5-2400.
PAPER_EQUATION_TIMES_S = {"D1": 4.12e-7, "D2": 4.12e-7, "D3": 5.24e-7, "D4": 5.24e-7}

# Figure 5 (Concurrency Visualizer): cross-core context switches / total / percent.
PAPER_FIGURE5 = (
    ("main", 23, 47, 48.94),
    ("worker 1", 0, 30691, 0.0),
    ("worker 2", 0, 29225, 0.0),
    ("worker 3", 0, 27146, 0.0),
    ("worker 4", 0, 26903, 0.0),
)
PAPER_MACHINE = "Intel Core i5-2400, 3.1 GHz, 4 cores, Windows 10, Visual Studio 2013"


# A serial RK4 step of the two-mass system evaluates D1..D4 once per stage.
EVALUATIONS_PER_STEP = 16


@dataclass(frozen=True)
class ModelValues:
    """C/m, the model's normal modes (fast, slow, rad/s), the paper's printed ones, the C/m those imply, and the
    derivative evaluations of a serial step."""
    c_over_m: float
    roots: tuple[float, float]
    paper_roots: tuple[float, float]
    paper_implied_c_over_m: float
    evaluations_per_step: int


def model_values(run_files) -> ModelValues:
    """The model as the first run file that states it says (run_file.ModelConstants); without one (files written
    before lockstep_model) computed here (model_roots, c_over_m_from_roots)."""
    stated = next((run_file.model for run_file in run_files if run_file.model is not None), None)
    if stated is not None:
        return ModelValues(stated.c_over_m, stated.roots_rad_s, stated.paper_roots_rad_s,
                           stated.paper_implied_c_over_m, stated.evaluations_per_step)
    return ModelValues(C_OVER_M, model_roots(), PAPER_ROOTS, c_over_m_from_roots(), EVALUATIONS_PER_STEP)


def model_roots(c_over_m: float = C_OVER_M) -> tuple[float, float]:
    """|lambda| of m^2 l^4 + 3 m C l^2 + C^2 = 0: l^2 = (C/m)(-3 -+ sqrt 5)/2, the faster mode first."""
    fast = math.sqrt(c_over_m * (3.0 + math.sqrt(5.0)) / 2.0)
    slow = math.sqrt(c_over_m * (3.0 - math.sqrt(5.0)) / 2.0)
    return fast, slow


def c_over_m_from_roots(roots=PAPER_ROOTS) -> float:
    """The C/m that the paper's printed roots imply (least squares over both roots)."""
    factors = ((3.0 + math.sqrt(5.0)) / 2.0, (3.0 - math.sqrt(5.0)) / 2.0)
    return sum(r * r * f for r, f in zip(roots, factors)) / sum(f * f for f in factors)


def analytic_trajectory(t, c_over_m: float = C_OVER_M, start=INITIAL_POSITIONS):
    """x1(t), x2(t) of the normal-mode solution (velocities 0 at t = 0)."""
    stiffness = np.array([[2.0 * c_over_m, -c_over_m], [-c_over_m, c_over_m]])
    eigenvalues, modes = np.linalg.eigh(stiffness)
    frequencies = np.sqrt(eigenvalues)
    amplitudes = modes.T @ np.asarray(start, dtype=float)
    t = np.asarray(t, dtype=float)
    positions = modes @ (amplitudes[:, None] * np.cos(np.outer(frequencies, t)))
    return positions[0], positions[1]


def trajectory_reference(verify):
    """x1 and x2 of the analytic solution at the times of a verify trajectory (verify_reader.VerifyFile): the
    file's own exact columns where it has them; a file written before them gets the two-mass solution computed
    here (analytic_trajectory)."""
    if verify.exact is not None:
        return np.asarray(verify.exact[0]), np.asarray(verify.exact[1])
    return analytic_trajectory(verify.t)


def trajectory_deviation(verify, reference) -> float:
    """The largest deviation of a trajectory from its reference (trajectory_reference)."""
    reference_x1, reference_x2 = reference
    return float(max(np.max(np.abs(np.asarray(verify.x1) - reference_x1)),
                     np.max(np.abs(np.asarray(verify.x2) - reference_x2))))
