"""The limit search: self-weight first, then the live load raised until no equilibrium exists.

- :mod:`.pathfollow`: the search (:func:`.pathfollow.find_limit_load`), its algorithm and its rules' overview;
- :mod:`.records`: what it takes (settings, guides, observers) and gives (load steps, the outcome);
- :mod:`.bracket`: the bracket, the rule that closes it, suspect failures and backtracking;
- :mod:`.schedule`: the step schedule and the trials' Newton iteration budgets;
- :mod:`.target`: the target set by a guess, and the collapse-state readings that move it;
- :mod:`.step`: one load step solved, judged for a flat load-deflection curve, and recorded;
- :mod:`.selfweight`: the self-weight state the live load starts from;
- :mod:`.coarser_path`: a re-run's trial starts from its coarser run's load path.

Importing it starts PETSc without the option files of the current folder
(:func:`bridgefem.petsc_start.start`).
"""
from ..petsc_start import start

start()
