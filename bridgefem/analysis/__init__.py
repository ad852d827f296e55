"""The FE limit analysis of a scene, its evidence (proofs, LP agreement) and mesh convergence."""
