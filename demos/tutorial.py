# # From a scene to a limit load: bridgefem's Python API
#
# This script computes the limit load of the reference bare arch (a semicircular stone ring, 9 m span, 1 m thick,
# 16 voussoirs, a point load near quarter span), reads the result, compares it with the rigid-block limit analysis
# and sweeps the joints' friction. It uses only the public API, `import bridgefem`; `bridgefem run` does the same
# from the command line and also writes the results folder.
#
# Run it with `./run python demos/tutorial.py` (a few seconds). Under `./run mpirun -n 2 python demos/tutorial.py`
# each rank computes its part of the same analysis (`analyse` is collective) and gets the same result; rank 0
# prints.

# +
from mpi4py import MPI

import bridgefem

say = print if MPI.COMM_WORLD.rank == 0 else (lambda *args: None)
# -

# ## 1. The scene
#
# A scene is what a TOML file holds (`bridgefem.load_scene("demos/bare_arch.toml")` reads this one), here as a
# dictionary of the same sections. `scene_from_dict` checks every value and fills in the defaults (4 elements
# through the thickness, a bracket tolerance of 1e-4). Units: m, Pa, kg/m^3; a load's `position` is a fraction of
# the span from the left springing. Every key: docs/scene-keys.md.

scene = bridgefem.scene_from_dict({
    "scene": {"name": "tutorial"},
    "arch": {"shape": "semicircular", "span": 9.0, "thickness": 1.0, "voussoirs": 16},
    "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0},
    "joints": {"friction": 0.6},
    "load": [{"kind": "point", "position": 0.22222}],
})
say(f"{scene.name}: {scene.arch.shape} ring, span {scene.arch.span:g} m, rise {scene.arch.rise:g} m (derived), "
    f"{scene.mesh.elements_through_thickness} elements through the thickness")

# A bad value raises `SceneError` before anything is computed: one line naming the key, the value and what is
# allowed, the same line `bridgefem run` prints for a scene file. `edit` returns a changed copy of a scene,
# checked in the same way.

try:
    bridgefem.edit(scene, arch={"thickness": -1.0})
except bridgefem.SceneError as err:
    say(f"refused: {err}")

# ## 2. The limit load
#
# `analyse` applies the self-weight, then raises the live load until no equilibrium exists. The limit load lies
# in the bracket [lower, upper]: the ring carries `lower` (a converged equilibrium) and not `upper`, both in N for
# the scene's width, at most `tolerance` x `lower` apart. The hinges are read off the last converged state.

result = bridgefem.analyse(scene)
load = result.limit_load
say(f"{result.status}: limit load in [{load.lower / 1e3:.3f}, {load.upper / 1e3:.3f}] kN (relative tolerance "
    f"{load.tolerance:g}, width {load.width:g} m); hinges at joints {list(result.hinges)}, sliding "
    f"{list(result.sliding)}")
say(f"evidence: {result.evidence}")

# ## 3. The independent check
#
# The rigid-block limit analysis (a linear programme on the same joints, rigid voussoirs) gives the classical
# collapse load; with stiff voussoirs the FE tends to it. `bridgefem.lp(scene)` solves it alone, in milliseconds.
# A run prints a warning where the two disagree, or where the mesh or the deflections make the bracket doubtful.

lp = result.lp
say(f"rigid-block LP ({lp.model}): {lp.load / 1e3:.3f} kN, hinges {list(lp.hinges)}, sliding {list(lp.sliding)}; "
    f"FE/LP = {result.fe_lp_ratio:.4f}")
for warning in result.warnings:
    say(f"WARNING: {warning}")

# ## 4. Everything else
#
# `result.summary` holds all of results.json (joint forces, reactions, the load history, units and sign
# conventions); `result.to_json()` is its text.

history = result.summary["history"]
say(f"{len(history)} load steps, {sum(step['converged'] for step in history)} converged; forces in "
    f"{result.summary['units']['force']}")

# ## 5. A sweep is a loop
#
# The joints' friction coefficient from 0.4 to 0.8. With little friction the mechanism slides along the joint
# under the load (the LP's sliding joints), and the limit load falls with the friction; with enough of it the ring
# turns about four hinges. The rigid-block LP assumes associative friction (sliding with dilatancy), the FE
# Coulomb's law without it: where a joint slides the FE may stop below the LP.

say("friction   rigid-block LP (kN)   LP sliding joints   FE bracket (kN)        FE/LP")
for friction in (0.4, 0.5, 0.6, 0.8):
    r = bridgefem.analyse(bridgefem.edit(scene, joints={"friction": friction}))
    fe = f"[{r.limit_load.lower / 1e3:.2f}, {r.limit_load.upper / 1e3:.2f}]" if r.limit_load.upper else r.status
    say(f"{friction:8.1f}   {r.lp.load / 1e3:19.2f}   {str(list(r.lp.sliding)):17s}   {fe:20s}   "
        f"{r.fe_lp_ratio or float('nan'):.4f}")
