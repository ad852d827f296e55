"""The PETSc options a scene's [solver.petsc] may set: an allow-list of solver settings, each with its range
(:data:`PETSC_SCENE_OPTIONS`, the MUMPS controls), and the check of the table (:func:`check_petsc`)."""
from __future__ import annotations

import re
from typing import Any

from .keys import Key, SceneError, show_value

PETSC_PREFIX = "bridgefem_"
"""Options prefix of the contact solver's PETSc objects: ``-bridgefem_ksp_type ...`` on the command line."""

_KSP_TOLERANCE = dict(unit="", low=0.0, low_open=True, high=1.0)
PETSC_SCENE_OPTIONS: dict[str, Key] = {
    "ksp_type": Key(str, "Krylov method (preonly: the direct solve alone)", choices=("preonly", "gmres", "fgmres",
                                                                                    "bcgs", "richardson")),
    "pc_type": Key(str, "preconditioner (lu: direct solve)", choices=("lu", "ilu", "jacobi", "sor", "none")),
    "pc_factor_mat_solver_type": Key(str, "direct solver package", choices=("mumps", "petsc", "superlu_dist")),
    "pc_factor_mat_ordering_type": Key(str, "fill-reducing ordering of PETSc's own LU",
                                       choices=("nd", "natural", "rcm", "qmd", "1wd")),
    "pc_factor_shift_type": Key(str, "pivot shift", choices=("none", "nonzero", "positive_definite", "inblocks")),
    "pc_factor_shift_amount": Key(float, "pivot shift amount", low=0.0, high=1.0),
    "ksp_rtol": Key(float, "relative tolerance of an iterative solve", **_KSP_TOLERANCE),
    "ksp_atol": Key(float, "absolute tolerance of an iterative solve", low=0.0, low_open=True, high=1e10),
    "ksp_divtol": Key(float, "divergence tolerance of an iterative solve", low=1.0, high=1e30),
    "ksp_max_it": Key(int, "iterations of an iterative solve", low=1, high=1000000),
}
"""PETSc options a scene's [solver.petsc] may set: solver settings only. Viewers, monitors, anything that reads or
writes a file or opens a display or socket is refused here; the command line (--petsc) may pass any option."""
MUMPS_ICNTL = {6: (0, 7), 7: (0, 7), 8: (-2, 77), 10: (-100, 100), 12: (0, 3), 13: (-1, 100000), 14: (0, 1000),
               23: (0, 100000), 24: (0, 1), 25: (-1, 100000), 28: (0, 2), 29: (0, 2), 35: (0, 3), 36: (0, 1),
               38: (0, 1000)}
"""MUMPS integer controls a scene may set (mat_mumps_icntl_N: allowed range): orderings, scaling, pivoting,
workspace (14: extra %, 23: MB, bounded so that a scene cannot ask for the machine's memory), null pivots, low
rank; not 1-4 (output streams and verbosity) nor 22 (out-of-core files)."""
MUMPS_CNTL = (1, 2, 3, 4, 5, 7)
"""MUMPS real controls a scene may set (mat_mumps_cntl_N): pivoting thresholds, refinement, low-rank dropping."""


def petsc_key(name: str) -> Key | None:
    """The :class:`Key` of an allowed option, None for one a scene may not set."""
    if name in PETSC_SCENE_OPTIONS:
        return PETSC_SCENE_OPTIONS[name]
    m = re.fullmatch(r"mat_mumps_(icntl|cntl)_([0-9]{1,2})", name)
    if m and m[1] == "icntl" and int(m[2]) in MUMPS_ICNTL:
        low, high = MUMPS_ICNTL[int(m[2])]
        return Key(int, f"MUMPS ICNTL({int(m[2])})", low=low, high=high)
    if m and m[1] == "cntl" and int(m[2]) in MUMPS_CNTL:
        return Key(float, "MUMPS CNTL", low=-1e30, high=1e30)
    return None


def _petsc_allowed() -> str:
    return (", ".join(PETSC_SCENE_OPTIONS) + ", mat_mumps_icntl_N (N = " + ", ".join(map(str, MUMPS_ICNTL))
            + "), mat_mumps_cntl_N (N = " + ", ".join(map(str, MUMPS_CNTL)) + ")")


def check_petsc(table: dict[str, Any]) -> dict[str, Any]:
    """The scene's [solver.petsc] table, every key on the allow-list and its value checked."""
    out = {}
    for k, v in table.items():
        key = petsc_key(k)
        if key is None:
            name = k if re.fullmatch(r"[A-Za-z0-9_]{1,60}", k) else show_value(k)
            raise SceneError(f"[solver.petsc] {name}: not an allowed solver option; allowed in a "
                             f"scene are {_petsc_allowed()} (any other PETSc option only on the command line: --petsc)")
        out[k] = key.check(f"[solver.petsc] {k}", v)
    return out
