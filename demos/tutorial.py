# # From a scene to a limit load: bridgefem step by step
#
# This script walks the library through one analysis of the reference bare arch (a semicircular stone ring,
# 9 m span, 1 m thick, 16 voussoirs, a point load near quarter span) and prints its limit load beside the
# rigid-block LP. `bridgefem run` does all of this in one call (`bridgefem.analysis.runner.runner.run_analysis`); here each
# stage is one call, so that you can see and change what flows from one to the next:
#
#     scene -> ring geometry -> mesh -> elastic model -> joint pairs -> contact solver -> limit search
#
# Run it with `./run python demos/tutorial.py` (about a second; the same answer under `./run mpirun -n 2`).

# +
from bridgefem.analysis.runner.runner import joint_states, search_settings
from bridgefem.geometry.ring.ring import build_ring
from bridgefem.scene.schema.schema import scene_from_dict
from bridgefem.solver.newton.newton import ContactSolver
from mpi4py import MPI

from bridgefem.fe.mesh import build_block_mesh
from bridgefem.fe.model import build_elastic_model
from bridgefem.fe.pairs import build_pairs
from bridgefem.limit.rigid_block import collapse_load
from bridgefem.search.pathfollow import SearchGuides, find_limit_load, monitor_deflection

say = print if MPI.COMM_WORLD.rank == 0 else (lambda *args: None)  # print once under mpirun
# -

# ## 1. The scene
#
# A scene is what a TOML file holds, here as a dictionary; `scene_from_dict` checks every value (a bad one
# raises `SceneError` naming the key) and fills in the defaults (mesh: 4 elements through the thickness,
# bracket tolerance 1e-4). Units: m, Pa, kg/m^3; a load's `position` is a fraction of the span.

scene = scene_from_dict({
    "scene": {"name": "tutorial"},
    "arch": {"shape": "semicircular", "span": 9.0, "rise": 4.5, "thickness": 1.0, "voussoirs": 16},
    "masonry": {"young": 10e9, "poisson": 0.2, "density": 2000.0},
    "joints": {"friction": 0.6},
    "load": [{"kind": "point", "position": 0.22222}],
})
arch = scene.arch

# ## 2. The ring: voussoirs and joints
#
# The joints are perpendicular to the centreline and evenly spaced, with the nearest one moved under the load.
# The same polygons feed the FE mesh and the rigid-block LP.

ring = build_ring(arch.shape, arch.span, arch.rise, arch.thickness, arch.voussoirs, scene.load_edges_x())
say(f"{ring.n_voussoirs} voussoirs, {len(ring.joints)} joints (0 and {ring.n_voussoirs} on the springings)")

# ## 3. Mesh and elastic model
#
# Gmsh meshes each voussoir on its own, so that the nodes on a joint are duplicated, one copy per side. DOLFINx
# assembles the elastic stiffness K, the self-weight f_dead and the live load per unit load level f_live once.

block_mesh = build_block_mesh(ring, scene.mesh.elements_through_thickness, MPI.COMM_WORLD)
model = build_elastic_model(block_mesh, ring, scene)
say(f"{block_mesh.n_cells} triangles, ring weight {model.dead_weight / 1e3:.1f} kN")

# ## 4. Joint pairs: where contact and friction act
#
# Each node on a joint is paired with its partner across it (or with the ground on a springing), with its share
# of the joint's length. A pair is open, sticks or slips: unilateral contact and Coulomb friction.

pairs = build_pairs(model.V, block_mesh, ring, match_tol=1e-9 * arch.span)

# ## 5. The contact solver
#
# A semismooth Newton (primal-dual active-set) method solves the elastic voussoirs in contact for a given load
# level, with MUMPS for the linear systems. The Alart-Curnier constant c scales the joint laws like the
# masonry's stiffness across one element; contact states change with a hysteresis of 1e-10 x the weight.

c = arch.width * scene.masonry.young * pairs.length / block_mesh.element_size
solver = ContactSolver(model.K, model.f_dead, model.f_live, pairs, scene.joints.friction, c,
                       1e-10 * model.dead_weight, scene.solver.max_iterations, scene.solver.petsc)

# ## 6. The limit search
#
# Self-weight first, then the live load rises until a step finds no equilibrium. The last converged load and the
# first failed one bracket the limit load, to the relative tolerance. The scene's keys set the search
# (`search_settings`: the tolerance, the first step, the maximum load, the step budget); the rigid-block LP of the
# scene only guides it, as its first guess, never a bound.

lp = collapse_load(scene)
search = find_limit_load(solver, monitor_deflection(solver, model.monitor), search_settings(scene, model.dead_weight),
                         guides=SearchGuides(guess=lp.level))

# ## 7. The mechanism and the independent check
#
# At the last converged step, a joint open over half its length whose thrust is nearest a face is a hinge.
# The rigid-block LP on the same joints gives the classical collapse load: the FE, with stiff voussoirs, tends to
# it.

hinges = [j.id for j in joint_states(solver, pairs, ring, search.last) if j.hinge]
say(f"{search.status}: limit load in [{search.lower / 1e3:.3f}, {search.upper / 1e3:.3f}] kN "
    f"(tolerance {search.tolerance:g}) after {len(search.steps)} load steps; hinges at joints {hinges}")
say(f"rigid-block LP: {lp.load / 1e3:.3f} kN, hinges at joints {sorted(lp.hinges)}, sliding {sorted(lp.sliding)}")
