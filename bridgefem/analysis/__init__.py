"""The FE limit analysis of a scene, its evidence (proofs, LP agreement) and mesh convergence.

- :mod:`.runner`: :func:`.runner.run_analysis`, the analysis of a scene, and its algorithm;
- :mod:`.build`: the FE model of a scene, scene -> ring -> mesh -> model -> pairs -> solver;
- :mod:`.checks`: the rigid-block LP on the same joints and the non-associative checks of converged states;
- :mod:`.static_bound`: the static theorem's bound on a bare ring's FE;
- :mod:`.evidence`: the rules that make a search's outcome a verdict;
- :mod:`.refinement`: re-runs on finer meshes;
- :mod:`.mechanism`: the mechanism read off a converged state (resultants, hinges, sliding, reactions, motion);
- :mod:`.interface`: the arch-fill interface forces and the ring under the loads the fill transmits;
- :mod:`.result`: what a run produced (:class:`.result.Analysis`) and its warnings;
- :mod:`.convergence`: the limit load on nested meshes, its order and extrapolation.

Importing it starts PETSc without the option files of the current folder
(:func:`bridgefem.petsc_start.start`).
"""
from ..petsc_start import start

start()
