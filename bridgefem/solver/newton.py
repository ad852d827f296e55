"""Semismooth Newton (primal-dual active set) for elasticity with joint contact and friction.

One load step (:meth:`ContactSolver.solve_step`), from a converged state; each Newton iteration
(:meth:`ContactSolver._iteration`) is steps 2-6:

1. Take the start's active set (or the one a predicted state proposes; every joint closed and sticking with the
   retry setting ``fresh``): :meth:`ContactSolver._begin`.
2. Assemble the linear system of the active set (the joint law's rows, :class:`bridgefem.laws.coulomb.CoulombJoints`)
   and solve it with the reused factorisation, checked (:class:`bridgefem.solver.system.ContactSystem`,
   :mod:`bridgefem.solver.linear`: a solver that did not solve is a failure, never a mechanism):
   :meth:`ContactSolver._solve_set`.
3. A solution that diverges is judged by its mode (:meth:`bridgefem.solver.divergence.DivergenceTest.failure`): a proof of
   collapse ends the step; a wrong active set is solved again with a proximal term (*Proximal solves*,
   :meth:`ContactSolver._note_failure`), else damped (the half of the proposed changes farthest from the joint law
   they leave: :meth:`bridgefem.laws.coulomb.CoulombJoints.classify`) or repaired (:meth:`ContactSolver._recover`); an
   admissible mode is a mechanism without proof.
4. With a plastic fill (or the retry setting ``line_search``), backtrack the step (line search on the merit below):
   :meth:`ContactSolver._accept`.
5. Classify the solution with the joint law (a reversed slip is proposed as stick: *Reversed slips*; a joint
   proposed to slide both ways at once keeps its new slips only: *Opposed slips*; a solution
   that leaps far beyond the last one damps the proposal that led to it instead: *Leaps*):
   :meth:`ContactSolver._classify`. A cycle (:meth:`ContactSolver._break_cycle`) of a few pairs, with the pairs
   that keep changing (*Churning pairs*), is solved exactly on their condensed compliance (:mod:`bridgefem.solver.cycles`);
   in other cycles closed pairs that cycle between friction states are frozen to stick, pairs that cycle between
   open and closed are bonded (:meth:`ContactSolver._freeze`).
6. Stop when the active set is unchanged and equilibrium (:meth:`ContactSolver._balance`) and the joint law hold
   (:meth:`ContactSolver._test`); else go to 2 with the proposed set (:meth:`ContactSolver._advance`).
7. A step that failed without proof where its failure would end the search is solved again with other settings
   (:func:`retried`, *Retries* below).

Why this method: each iteration costs one sparse solve that reuses the symbolic factorisation, and on the seeded
campaign (``benchmarks/campaign.py``, ``docs/robustness.md``) a bare ring needs a median of about 30 solves per limit
load; its failures there are sliding stalls below the associative LP and, with an elastic fill, cycles of many pairs
at the ring's collapse under the loads the fill transmits, measured and listed in ``docs/robustness.md`` (*Solver
failures*). Cycles of up to ``CONDENSED_PAIRS`` pairs are solved exactly on their condensed compliance
(:mod:`bridgefem.solver.cycles`) rather than by a condensed (Schur complement) solver of the whole ring: the nonlinearity of
a cycle lives at a few pairs, so the small problem costs at most 2p + 1 solves with one factorisation, once per cycle.

Each Newton iteration solves the linear system of an active set (:class:`bridgefem.solver.system.ContactSystem`:
its unknowns, equations, units and signs), then re-derives the active set from the Alart-Curnier functions; a step
has converged when the active set no longer changes and the scaled equilibrium residual is small. Every stop
decision is collective over MPI.

With a Mohr-Coulomb fill (:mod:`bridgefem.fe.fill`) the stiffness block is the fill's consistent tangent at the
current displacements (:meth:`bridgefem.solver.system.ContactSystem.linearise`): each iteration is then a Newton
step for the fill and an active-set step for the joints at once, and a step has converged when the active
set is unchanged and the out-of-balance force ``f + G^T lam - f_int(u)`` is below ``EQUILIBRIUM_RTOL`` of
the largest applied nodal force. Newton iterations whose out-of-balance force ends larger than the largest applied
nodal force are reported as diverged, but not as proof of collapse: a smaller step may converge, and a yielding
fill's limit is where the load-deflection curve becomes flat (:mod:`bridgefem.search.pathfollow`).

**Line search.** With a plastic fill, every Newton step after the first (which starts from the elastic predictor,
at the step's start or at the load incrementation's secant estimate: :mod:`bridgefem.search.pathfollow`, *Predictor*)
is backtracked from the linearisation point x_k: the solution x of the linear system becomes x_k + a (x - x_k),
displacements and joint forces alike, for the first a = 1, 1/2, ... (at most ``LINE_SEARCH_HALVINGS`` halvings)
whose merit is at most (1 - ``ARMIJO`` a) times the merit at x_k, and stays the full step when none is. The merit is
the Euclidean norm of the whole residual of the convergence test, scaled by the largest applied nodal force: the
out-of-balance force (the fill's return map at the trial displacements) and the Alart-Curnier residual of the joints
(both in N); along a Newton direction (the active set classified at x_k, the fill's consistent tangent) it
decreases like 1 - a to first order, the natural merit of a semismooth Newton method (Facchinei & Pang 2003,
*Finite-Dimensional Variational Inequalities and Complementarity Problems*, chapter 8). The convergence test stays
on the largest entries. A step whose out-of-balance force exceeds ``DIVERGED_OUT_OF_BALANCE`` times the largest
applied nodal force fails at once as diverged (no proof of collapse: the load incrementation halves it): on the
campaign's Mohr-Coulomb fill scenes (seeds 1 and 2) and Prestwood no converged step ever went beyond 4.9 times, and
every trial that went beyond 100 (up to 5e4 times) failed after its whole budget. The next
active set is proposed from the damped iterate. Near the limit, where fill points yield and unload between
iterations, full steps overshoot: Prestwood with 0.3 m of fill went from a residual of 1e-3 to 16 times the largest
applied nodal force in one step, and then diverged.

Why the Euclidean norm and not the largest entry (measured per iteration on the campaign's Mohr-Coulomb fill
scenes): near a fill's collapse the consistent tangent (checked against differences of the internal force,
``tests/test_fill.py``) is nearly singular along the fill's plastic mechanism (a perfectly plastic point has no
stiffness along its flow), so a Newton step moves the yielding zone far (campaign seed 1, #145: strain steps of 0.1
in a load step of 4 %; #136: metres at the free surface of a passive zone) and the return map's curvature leaves
about an eighth of the step that decreases the residual at the worst node: there the full step's largest entry was
about four times the current one, and it fell by a few per cent per iteration for ten to twenty iterations with the
active set and the plastic points unchanged. The Euclidean norm weighs that node against the rest of the residual:
with the same brackets, seed 1 #125, 145, 276, seed 2 #40 and Prestwood took 2138 solves on it and 2568 on the
largest entry.

Without a plastic fill the line search is a retry's setting (below): every solution of an active set is in
equilibrium, so the merit is in effect the joints' Alart-Curnier residual, and the backtracked iterate is the damped
semismooth Newton method on it; its classification proposes the next active set, and a revisited active set is no
cycle (the iterate moved).

**Retries.** A load step that fails without proof where the failure would end the search (the limit search's
trial at the bracket's width, the self-weight after its continuation) is solved again from the same converged
start with other algorithmic settings (:class:`Setting`, ``RETRIES``, :func:`retried`): the Alart-Curnier constants
x 10 and x 0.1 (they weigh forces against displacements only in the classification, so they change the path of
the active sets, not the solution), a start from every joint closed and sticking instead of the start's active
set, the line search, unlimited damping chains. The first that converges or proves its mechanism is taken; every
outcome is judged as any other (a converged state is an equilibrium of the scene's laws, a mechanism still needs
its proof or the LP's agreement), so a retry changes how often the Newton method finds the answer, never what
counts as one. The last, unlimited damping chains from the fresh start, rescued no step in five campaign runs
(seeds 1 and 2: tried 32 times, up to 60 solves each) but is the only setting that carries the 15-voussoir
elliptical ring of ``tests/test_features.py`` (rise 3 m, t = 1 m) past 74.0 kN to the LP's limit (77.0 kN): without
it that ring is a solver failure 4 % below the LP. It proposes reversed slips as the law classifies them (*Reversed
slips*): through stick, its 56 iterations there reached another equilibrium (friction's are not unique), from which
every trial failed, and the ring ended a solver failure at 74.05 kN again; the plain proposal reaches the one from which
the search goes on to 76.93 kN. No other scene of the checks under *Reversed slips* reached that setting.

Closed pairs whose friction state cycles between Newton iterations (a slip direction that flips back and forth, or
stick and slip in turn: with large friction the discrete Coulomb law can have no consistent state at a pair next to a
crack tip, e.g. stick needing |lam_t| = 1.002 mu lam_n and slip going backwards at one springing pair of a thick ring
at mu = 10) are frozen to stick for the rest of the step; they still open under tension. The count is reported as
``frozen`` and only the friction law is waived at those pairs, by at most ``BOND_RTOL`` of the largest applied nodal
force like the bonded pairs' law (below): unbounded, a state held by a frozen pair's friction force far beyond mu
lam_n counted as converged (campaign seed 1, #270 crept on such states to its step budget). A cycle that returns to a
singular proposal after damping is a mechanism; a cycle that returns to a set whose diverging mode was inadmissible
goes to that set's repair (below); any other cycle is damped like a singular proposal (half of the changes from the
last solved active set). A cycle that cannot be damped and whose changes are all friction flips or open / closed
toggles bonds the toggling pairs: closed and sticking for the rest of the step, reported as ``bonded``, their joint
law waived; the step converges only if the waived Alart-Curnier residual there is at most ``BOND_RTOL`` of the largest
applied nodal force (at most the default bracket tolerance of the load), else it fails as active-set cycling. Such a
pair has no consistent state in the discrete law: e.g. a springing pair of an elliptical ring at mu = 6.4 (campaign
seed 1, #51) penetrated 1.4 mm when open and carried tension when closed; bonded, the step converged with a residual
of a few newtons and the search went on to a proved limit equal to the LP's. Other cycles fail as non-convergence.

**Mechanism verdicts.** A failure is reported as a mechanism (``StepOutcome.mechanism``: no equilibrium, which the
load incrementation may take for the limit) when MUMPS finds the system numerically singular (INFOG(1) = -10), when
a step ends on an active set that does not change but cannot be solved accurately, or when a solve diverges
(displacement beyond ``DIVERGENCE_FACTOR`` times the bonded self-weight response:
:class:`bridgefem.solver.divergence.DivergenceTest`) along an admissible mode: :func:`bridgefem.solver.mechanism.judge` decides
from the mode (the solution minus the step's converged start, at the pairs) whether it is a wrong active set (a
*flaw*: no work by the driving load, interpenetration, or a slip against the friction force; a failure without
proof, solved with a proximal term (below) or damped like any failed proposal, carrying a *repair* that closes the
offending pairs: sticking, or sliding on a sliding joint, *First contact*), a mechanism, or a *proof* of collapse
(``StepOutcome.proved``: an admissible rigid-block hinge mode on which the loads do positive work). A proof ends the
step at once whatever its history (a predicted or damped active set). The repair is tried when damping has nothing
left to halve, or when the iteration returns to that active set (e.g. the thin ring t/R = 0.11, where opening the
last pair of a joint gave a mode that rotates the springing voussoir into the ground: damping returns to it, the
repair converges; the thick semicircle at mu = 0.35, whose damped iterations returned to modes that slip pairs
backwards). Other admissible diverging modes (with slip, or positive work too small to resolve) are mechanisms
without proof: the damping chain or the cycle that returns to them decides, and the verdict needs other evidence
(:mod:`bridgefem.analysis.evidence`).

**First contact.** A repair closes the open pairs that close first when the structure moves from the step's start
along the diverging mode (:func:`bridgefem.solver.mechanism.first_contact`, given the start's gaps by
:meth:`bridgefem.solver.divergence.DivergenceTest.verdict`): each open pair closes at the mode's amplitude gap / closing
rate, the least sets the first contact, and every open pair closing within ``mechanism.FIRST_CONTACT`` of it is
closed (a hinge's pairs close together, up to the blocks' elastic strain: 4 to 10 % apart below), the others stay
open. A mode of free rigid-block motion (a mechanism of a wrong active set) moves the blocks until its first contact
stops it; closing a hinge that it would reach later imposes a rotation the blocks can only take by straining, and
the set's next solve puts other joints in tension. It changes the Newton iteration's path, never what counts as
converged. Campaign seed 1 #147 with its ``--options`` support movement (semicircle, 39 voussoirs; the right
springing 8.06 mm inwards, 9.43 mm down) is at its maximum thrust after the movement: hinges at both springings and
at joints 10 and 29, the thrust line through all four. A live load of 0.13 N opens the pair beside joint 29's hinge
pair (it carried 0.7 N); the four-hinge mode then closes joint 0 at an amplitude of 1.7e-5 and joint 10 at 2.3e-5
(their rates within ``mechanism.REPAIR`` of each other), and the repair of both failed at every level down to
0.13 N, a solver failure; closing joint 0 alone, the ring reaches the LP's limit (78.96 kN, 155 solves; 0.6 to 1.5 times
the movement, or in 1 or 16 increments: 107 to 182).
An open pair that a repair closes on a *sliding joint* (every other closed pair of that joint slipping one way:
:meth:`bridgefem.laws.coulomb.ContactState.sliding_joints`) closes sliding that way, not sticking: a new contact on a
joint that slides slides with it, so the joint's contact zone can widen while it slides. Sticking there ties the
joint at one pair while its others slide, a set that the loads pull open again. The two-voussoir ring of
``tests/test_extremes.py`` (a three-pin semicircle, mu = 0.6, its interior joint moved under the load) collapses
with its right voussoir hinged and sliding at that joint and at the right springing. At 163.4 kN both those hinges,
one pair each, reached the cone. The set with both sliding is a free slide and diverged; its repair closed the
springing's next pair sticking, and that pair went into tension (-71 kN). The iteration cycled between the two until
every trial failed: a solver failure at 0.65 of the LP. From that state, 729 active sets were solved at each of
163.5, 170, 200 and 250 kN: at both of the right voussoir's joints one closed zone at an edge (1 to 5 pairs), all
sticking or all sliding one way. Exactly one was consistent at each level; at 163.5 kN it is that pair closed and
sliding with the hinge (1.5 kN on it). Closed sliding, the ring reaches [252.84, 252.86] kN in 19 linear solves,
whose upper end is the static bound (the rigid-block LP under the FE's own loads; with the exact voussoirs' weights
the LP gives 252.08 kN). On campaign seed 1 (300 scenes) only two paths changed: #290 157 -> 107 and #119 58 -> 23
linear solves, with the same brackets.

**Proximal solves.** The system of a wrong active set can be exactly singular along a strain-free rigid slide:
campaign seed 1 #299 (semicircle, 90 voussoirs, mu = 0.338) stopped at 30.74 kN, 4.3 % below the LP, where a load
increment of 1e-5 proposed one more pair of joint 56 sliding: with every closed pair of joints 0, 56 and 57 sliding,
the blocks between them slide rigidly with their friction forces held at s mu lam_n (smallest singular value 1e-6
against 3e9; the loads' work on the mode 6 % of the friction dissipation): no mechanism, but damping and the repair
(the offending pairs closed and sticking) both return to the sets the iteration came from, and every trial failed
down to the bracket's width. So when the first proposal of a damping chain diverges along a mode that slips pairs
against their friction force (:func:`bridgefem.solver.mechanism.judge`), that set is solved again with a proximal term
(Rockafellar 1976, *Monotone operators and the proximal point algorithm*) anchored at the last solved iterate x_k:
a spring k = ``PROXIMAL`` c (:data:`bridgefem.solver.system.PROXIMAL`) against each free direction's relative
displacement from x_k,

    open pair:   lam + k (d - d_k) = 0                   (both directions)
    slip pair:   lam_t - s mu lam_n + k (d_t - d_t,k) = 0

Every pair is then held by a spring or a constraint, so the step is bounded: it goes along the mode as far as the
force that drives it over k, and the classification sees which pairs the mode closes or slips backwards and
proposes their change. The term vanishes at a fixed point (d = d_k), so it changes the iteration's path, never
what counts as converged: the convergence test stays on the law itself. A proximal iterate that proposes no change
while the law does not hold drifts along a mode nothing stops: the set's plain failure then stands (damping, repair,
verdicts as above), without another solve. Each limit was measured (solves per limit load): a proximal solve (k = c)
for every such divergence crawled through sets that each diverged (seed 1 #75: 385 -> 2419 solves, #182 lost); two
sets per step instead of ``PROXIMAL_SETS`` = 1 cost 7348 solves against 6042 on twelve of the scenes below; a set
far from the last solved one (more than ``PROXIMAL_CHANGES`` pairs changed: a step linearised at x_k says little
about it) and modes that only close open pairs (no slip) are left to damping: with them the fifty seed-1 scenes
below took 12611 solves against 10641 (k = c / 1000), seed 2 #3 and #5 18 -> 42 and 92 -> 128. k = c / 10^4: on
the twelve scenes 5454 solves, against 6042 at c / 1000 and 7390 at c / 100; with one set per step and no other
limit, every k from c to c / 10^6 confirmed #299, but c and c / 10^6 lost #182 (small steps crawl; large ones, 1.2 m on
#235, reach sets of hundreds of changes). Against the runs before (seed 1: 24 bare rings that failed or took more
than 150 solves per limit, and every tenth scene, 50 in all; seed 2: the first 30): #299 is confirmed (FE/LP
0.9992, 221 solves), no scene lost, seed 2 unchanged; seed 1 solves 11341 -> 9858 (#197 993 -> 242, #182
839 -> 395, #193 813 -> 610, #267 214 -> 106, #119 189 -> 52; #270 166 -> 405 and #297 379 -> 492, whose
proximal step at the limit leads to another path). #235 still stops 10 % below the LP.

**Damping chains.** A singular or diverging proposal starts a damping chain (:meth:`ContactSolver._recover`),
which ends when a damped active set solves. In a step the caller can retry with a smaller one (``give_up``), a
proposal that fails again after ``DAMPING_CHAINS`` such recoveries (or a cycle) ends the step as
non-convergence: repeated wandering into mechanisms is the Newton method failing on a large step, and the load
incrementation retries with a smaller one. It is reported as a mechanism *without proof* only when the failing
solve and an earlier one of the step were singular or diverged along admissible modes: the load incrementation then
takes it for the bracket's upper end only on a step within the width (:mod:`bridgefem.search.pathfollow`), and the
evidence rule accepts that bracket only when the rigid-block LP on the same joints agrees within 0.5 %
(:mod:`bridgefem.analysis.evidence`). That is sound because the verdict's evidence is the LP, as for any unproven mechanism:
the lower end is a converged equilibrium, and the associative LP bounds the non-associative collapse load from
above. The three-voussoir keystone pushed through by sliding (``tests/test_joint_loads.py``) ends that way at
0.9956 of the LP: the step's first proposal, every closed pair sliding, diverges along an admissible slip mode (no
hinge-mode proof exists for it), damping returns to the same sliding mechanism.

Once a step, a proposal that fails after the chains allowed is first followed by its repair (*First contact*: the pairs
that its inadmissible mode pushes into each other, closed), as in a damping chain with nothing left to halve: where
trials stall at one level, that is the change the path needs there. Campaign seed 4 #10, a 0.044 m parabolic ring of 134
voussoirs, stalled at 0.91 of the LP with 4 elements through the thickness (314 solves) and was re-run with 8 (508 in
all); with the repair its 4-element run reaches the static theorem's bracket at the LP in 33. Seed 1: the same classes
and limits, 64 bare-ring limits up by 1 to 9 solves and 11 down by 5 to 34, 9237 -> 9156 on its 251 limits; seed 4 #38
415 -> 159, seed 3 #60 153 -> 126.

**Predictor.** A step may start from a predicted active set: the Alart-Curnier classification of an estimate of the
solution (the load incrementation extrapolates the last two converged states, or a re-run transfers its coarser run's
path: :class:`PairPrediction`) against the converged start. The start's active set is then the base of the first
damping chain, and a failure before the step has solved any active set is no proof of a mechanism (the estimate, not
the Newton method, proposed it), unless its diverging mode proves collapse (*Mechanism verdicts*). Nor is it a visited
set of the step (it was solved at the start's load, not at this one): an iteration that returns to it, by damping or
as a repair, solves it and goes on, where a return to a visited set is a cycle. A block on the ground pushed by half
its sliding load, its predicted set every base pair sliding (free to slide: a divergence), is damped back to every
pair sticking, the start's set: counted as a cycle, that return would end the step as a mechanism ("damped iterations
return to it"); solved, it is the equilibrium (``tests/test_predicted_step.py``).

**Reversed slips.** A pair that slid in the last solved active set and whose Alart-Curnier function now asks it to
slide the other way is proposed to stick (:func:`_through_stick`): the incremental Coulomb law is a monotone graph,
slip one way, stick, slip the other way, and a Newton step taken on one slip branch that lands on the opposite one
has crossed the whole stick branch; the next iteration proposes the reversed slip if the sticking pair's friction
force leaves the cone again. Only the path changes: a proposal keeps a pair's state exactly where the law's
classification does (a reversal is a change either way), so the converged states are the law's own
(``tests/test_solver_reversed_slip.py``), though which of them a step reaches may change: friction's equilibria are
not unique (*Retries*). Taken at once, a reversal couples the two slip branches of neighbouring
pairs at a crack tip: campaign seed 1 #270 (parabolic, 18 voussoirs, mu = 0.349), where one springing pair's
reversed slip gave a solve whose proposal changed 52 pairs with violations of 1e9 N under a 2 kN load, failed 22 of
its 47 load steps, from half its limit on. Through stick, on every tenth scene of seeds 1 and 2 with seed 1 #48,
#75, #182, #235 and #270: classes and limits unchanged but #235's (a solver failure at 1887.55 kN, 815 solves; now
at the LP's limit, 2102.8 kN, 561 solves); seed 1 4663 -> 3602 solves on its 34 scenes (#270 391 -> 193, #75
398 -> 226, #182 391 -> 257, #230 359 -> 175, #260 241 -> 114; rises only #290 224 -> 277 and #48 438 -> 443),
seed 2 709 -> 650 on its 10.

**Opposed slips.** A proposal in which every closed pair of a joint slips, some the way they slipped before and the
others starting to slip (or reversing) the other way, slides the joint both ways at once: the friction forces of the
two groups cancel, so the joint slides freely and the next solve runs off or slips pairs backwards. The pairs still
slipping the old way are proposed to stick (:meth:`bridgefem.laws.coulomb.ContactState.opposed_slips`): the new slips are
the solution's own evidence of the way the joint goes, and the old ones stop through stick as a reversal does
(*Reversed slips*). Only the path changes; the converged states are the law's own. Campaign seed 3 #35 (parabolic,
8 voussoirs, mu = 0.366) hinged at its right springing on two closed pairs, the inner slipping inwards and the next
sticking. The next converged state has them the other way round, the next pair slipping outwards: at 220 kN that
set is consistent from the state at 217.1 kN. The Newton iteration proposed the next pair's slip with the inner
one's kept; both slid, the joint ran 0.12 mm, and the next pair slipped against its friction force. It cycled, and ended with a
pair frozen to stick whose law was waived by 0.25 N per N of load step. The search crawled 400 N in steps of 5 to
40 N: 523 solves, 299 of them the cycles' condensations. With the inner pair stuck, 15 solves, the same bracket.

**Churning pairs.** A cycle is condensed (:mod:`bridgefem.solver.cycles`) with the pairs that changed in two or more of
the step's proposals as well as those its returning proposal changes (:meth:`ContactSolver._cycle`), when they are at most
``ENUMERATED_PAIRS`` in all (every combination of their states is tried: :mod:`bridgefem.solver.condensation`): a
return may change one pair of the cycle only. At the loaded springing of campaign seed 1
#270 three pairs went stick / slip in turn, each return changing one, whose condensation alone found only states
already solved; frozen to stick, they broke the friction law by more the larger the load step (2.2 kN at a step of
3.4 %, halving with each halving of the step), and eleven trials failed. With the churning pairs condensed too, the
first such trial converges (193 -> 52 solves). Up to ``CONDENSED_PAIRS`` churning pairs instead, the elastic fill
scene seed 1 #181 (247 voussoirs, mu = 1.529; a solver failure either way) condensed cycles of up to 24 pairs again and
again: 3613 -> 6838 solves (4009 of them condensing) until its step budget ran out; with at most four, 2295.

**Pairs on the cone.** A damping chain whose last change left is a friction flip of a closed pair (stick to slip,
or a slip sign) within the law residual waived at frozen pairs (``BOND_RTOL`` of the largest applied nodal force),
and whose set still fails along a wrong active set's mode (no mechanism), freezes that pair to stick and solves the
set that proposed the flip again (:meth:`ContactSolver._freeze_at_cone`); the step converges only if the waived
residual stays within that bound, as for any frozen pair. Such a pair is on its friction cone: campaign seed 1 #297
(elliptical, 47 voussoirs, mu = 0.376) stands under self-weight with both springings sliding outwards (thrust
mu W / 2 at each); its continuation step reached every pair of both springings sliding but one, whose stick force
exceeded the cone by 0.09 N, and sliding it too let the ring translate freely (singular). The repair of that
divergence stuck the whole springing, whose pairs then slid again one at a time until a cycle froze one 5.3 kN over
its cone, and the step failed; the one step from the bonded start spent its 60 iterations the same way. Frozen on
its cone, the one step converges in 20 iterations (the coarse run 134 -> 35 solves). A flip beyond that bound goes
to the repair as before (seed 1 #193's first live step: 443 N against 0.45 N), and a flip whose set runs along an
admissible mode is the collapse, never frozen: a block pushed just past mu W, its last sticking pair 1.4 N over its
cone, would otherwise converge above the sliding load (``tests/test_block.py`` brackets mu W exactly).

**Leaps.** Without a line search, a solved active set that still proposes changes and whose solution moves the
structure more than ``LEAP`` times as far as the last solved iterate and the step's start (largest displacement) is
not classified: the proposal that led to it is damped as if its solve had diverged (:meth:`ContactSolver._damp`,
no damping chain counted). Such a set is nearly a mechanism below the divergence cap, and the Alart-Curnier
classification of its solution proposes changes with violations thousands of times the load: campaign seed 1 #224
(elliptical, 219 voussoirs, E = 1.2e8 Pa) moved 31 m against 0.2-0.4 m at the other sets of its step, proposed 36
open / closed toggles with violations of 3.7e8 N under a 60 kN load, and came back to a near copy of that set every
four iterations, for up to 22 iterations a trial (five failed trials between 60 and 65 kN); damped, the trials there
converge in 3 to 6.
A set that a cycle's condensation proposed (:mod:`bridgefem.solver.cycles`: consistent at the cycle's pairs) is classified
even when it leaps: campaign seed 2 #41 (elliptical, 76 voussoirs, mu = 8.25, E = 2.6e9 Pa) cycled at 188 kN on four
crack-tip pairs whose condensed state opened one of them by 0.38 m with the other pairs held; damped, the iteration
came back to the cycle, bonded its pairs in tension (the law violated by 8.8 kN) and three trials failed. Classified,
the next trials reach the state where that pair opens by 0.4 mm (170 -> 105 solves; seed 1 #224 194 -> 185).
A converged set proposes no change, so it is never rejected: only the path changes, never what counts as converged.
Measured (solves per limit load, classes and limits unchanged): seed 1, the twelve bare rings above 150 solves
2955 -> 2644 (#104 184 -> 79, #144 152 -> 84, #230 244 -> 162; #290 203 -> 312) and every fifteenth scene
1208 -> 1063; seed 2, the nine scenes above 150 solves 2313 -> 1940 (#24 184 -> 31, #26 178 -> 46; the three with a
plastic fill unchanged); at 3 and 100 times instead of 10: 2675 and 3156 on the twelve.

**Refinement.** The equilibrium test scales the out-of-balance force by the largest applied nodal force. A support
movement can load a stiff, thin ring with forces far above its weight, and the rounding of the solve, relative to
those forces, then exceeds ``EQUILIBRIUM_RTOL`` of the applied ones: campaign seed 1 with ``--options``, #270 (a
0.09 m parabolic ring, E = 6.3e10 Pa, its right springing settling 1.3 mm), every pair sticking, the scaled
residual grew with the movement, 2.8e-9, 5.8e-9, 8.6e-9, 1.16e-8, and the last increment was "inaccurate" (a
mechanism without proof): a solver failure where the LP gives 2.12 kN. So before an unchanged active set whose
iterate fails the test is called singular, one step of iterative refinement with the same factorisation
(:meth:`bridgefem.solver.linear.CheckedSolve.correction`) estimates the solve's forward error: a correction within
``REFINED_RTOL`` of the iterate says the solve is exact to working precision, and the iterate is in equilibrium
as far as the arithmetic resolves (#270: 1.3e-9 of the iterate; its limit then equals the LP's); a singular system
leaves a correction of the order of 1e-3 of the iterate (seed 1 #193 on two ranks) and stays a mechanism without
proof. The joint law is still checked at the (refined) iterate.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Callable, NamedTuple

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..fe.pairs import JointPairs
from ..laws.coulomb import OPEN, SLIP, STICK, ContactState, CoulombJoints
from .condensation import ENUMERATED_PAIRS
from .cycles import CycleCondenser
from .divergence import ActiveSetFailure, DivergenceTest
from .system import ContactSystem

if TYPE_CHECKING:
    from ..fe.fill import FillResponse, PlasticFill

EQUILIBRIUM_RTOL = 1e-8  # scaled residual |K u - G^T lam - f|_inf / |f|_inf for a converged step
LINE_SEARCH_HALVINGS = 5  # with a plastic fill, a Newton step is halved at most this many times by the line search
ARMIJO = 1e-4  # sufficient decrease of the line search's merit, per unit step length
DIVERGED_OUT_OF_BALANCE = 100.0  # with a plastic fill, an out-of-balance force beyond this multiple of the largest
# applied nodal force ends the step as diverged (module's *Line search*)
DAMPING_CHAINS = 1  # damping chains that may recover per step; a failure after that ends it (no proof)
BOND_RTOL = 1e-4  # joint-law residual (N) waived at bonded and frozen pairs, of the largest applied nodal force
# (the default bracket tolerance: a force below the load resolution the search is asked for)
PROXIMAL_SETS = 1  # active sets per load step whose diverging solve is replaced by a proximal solve
PROXIMAL_CHANGES = 24  # ... only when the set differs from the last solved one at no more than this many pairs
REFINED_RTOL = 1e-6  # an iterative refinement's correction below this fraction of the iterate (largest entries):
# the solve is exact to working precision (module's *Refinement*)
LEAP = 10.0  # a solution moving the structure beyond this multiple of the last solved iterate and the step's start
# is not classified: the proposal that led to it is damped (module's *Leaps*)


@dataclass(frozen=True)
class Setting:
    """The algorithmic choices of a load step that decide only how the Newton iteration searches, never what
    counts as converged (the module's *Retries*): ``scale`` multiplies the Alart-Curnier constants (they weigh
    forces against displacements in the classification only), ``fresh`` starts from every joint closed and sticking
    instead of the converged start's active set, ``patient`` lets damping chains recover without limit,
    ``line_search`` backtracks every Newton step of a ring without a plastic fill too (the module's *Line search*:
    a damped semismooth Newton method on the Alart-Curnier residual), ``through_stick`` proposes a reversed slip as
    stick (the module's *Reversed slips*; without it, as the law classifies it)."""

    scale: float = 1.0
    fresh: bool = False
    patient: bool = False
    line_search: bool = False
    through_stick: bool = True


DEFAULT_SETTING = Setting()
RETRIES = (Setting(fresh=True), Setting(scale=10.0), Setting(scale=0.1), Setting(line_search=True),
           Setting(fresh=True, patient=True, through_stick=False))
# the settings a load step that failed without proof is solved again with, in this order (module's *Retries*)


@dataclass(frozen=True)
class PairPrediction:
    """An estimate of this rank's joint pairs at a step's level: forces ``lam`` (N) and relative displacements ``d``
    (m), each (pairs, 2) as (normal, tangential) like :meth:`bridgefem.solver.system.ContactSystem.split`'s. A step
    starts from its classification as from a predicted combined vector's (the module's *Predictor*)."""

    lam: np.ndarray
    d: np.ndarray


@dataclass
class Iterate:
    """A (possibly converged) solution: combined vector x = [u; lam], the active set it satisfies and, with a
    plastic fill, the fill's plastic strain at its quadrature points."""

    x: PETSc.Vec
    active: ContactState
    slip_ref: np.ndarray
    plastic_strain: np.ndarray | None = None


@dataclass
class StepOutcome:
    """Result of one load step; ``reason`` is empty when converged. A failure with ``mechanism`` set showed
    a singular system or a response unbounded along an admissible mode (no equilibrium; the module's *Mechanism
    verdicts*); other failures are non-convergence."""

    converged: bool
    reason: str
    iterations: int
    residual: float
    factorisations: int
    iterate: Iterate | None = None
    counts: dict = field(default_factory=dict)
    mechanism: bool = False
    proved: bool = False
    unbounded: bool = False  # the failed step ended on a solve that was singular or diverged (along any mode)
    diverged: bool = False  # some solve of the failed step was singular or diverged


class _Proposal(NamedTuple):
    """A solved (good) active set, the set it proposed, the proposed changes still applied, the violations (N)."""

    good: ContactState
    proposal: ContactState
    pending: np.ndarray
    violation: np.ndarray


@dataclass(frozen=True)
class _StepTask:
    """What one load step solves, and its limits: fixed for the step."""

    level: float  # live-load level (N per unit load factor)
    start: Iterate  # the converged start
    f_scale: float  # the largest applied nodal force (N)
    budget: int  # Newton iterations
    chains: float  # recovered damping chains after which a failure ends the step
    searching: bool  # every Newton step is line searched (the module's *Line search*)
    first_factorisation: int  # the solver's factorisations before the step


@dataclass
class _Recovery:
    """A step's failed solves and their recovery (the module's *Damping chains* and *Mechanism verdicts*)."""

    damping: bool = False  # in a damping chain
    recovered: int = 0  # damping chains that ended with a solved active set
    mechanisms: int = 0  # failed solves that were singular or diverged along an admissible mode
    singular: ActiveSetFailure | None = None  # the last singular proposal
    fix: ContactState | None = None  # the repair of the set whose solve failed last
    repairs: dict = field(default_factory=dict)  # global key of a set whose diverging mode was inadmissible -> repair
    last_repair: bool = False  # the repair solved in place of giving up (the module's *Damping chains*)

    def solved(self) -> None:
        """A set solved: the damping chain, if one was open, ended and recovered."""
        self.recovered, self.damping = self.recovered + self.damping, False


@dataclass
class _CycleMemory:
    """The active sets a step visited and the pairs its cycles held (the module's step 5), per local pair."""

    frozen: np.ndarray  # local pairs whose friction state cycled: kept sticking while closed
    bonded: np.ndarray  # local pairs whose open / closed state cycled: kept closed and sticking
    churn: np.ndarray  # the proposals of this step that changed each local pair
    seen: set = field(default_factory=set)  # global keys of the active sets visited at this level
    condensed: int | None = None  # global key of the last set a cycle's condensation proposed (no leap test)

    @classmethod
    def empty(cls, pairs: int) -> "_CycleMemory":
        """No pair held or changed yet, for ``pairs`` local pairs."""
        return cls(np.zeros(pairs, dtype=bool), np.zeros(pairs, dtype=bool), np.zeros(pairs, dtype=np.int64))


@dataclass
class _ProximalSolves:
    """The active sets a step solved with the proximal term (the module's *Proximal solves*)."""

    sets: dict = field(default_factory=dict)  # global key -> the set's plain failure
    count: int = 0  # sets solved with the proximal term in this step
    drift: ActiveSetFailure | None = None  # the plain failure of a proximal set that drifts along its mode


@dataclass
class _NewtonStep:
    """The state of one load step's Newton iteration (:meth:`ContactSolver._newton`): its task, the iterate and
    what the iteration remembers of its failed solves, its cycles and its proximal solves."""

    task: _StepTask
    x: PETSc.Vec  # the current iterate [u; lam]
    active: ContactState  # the active set solved next
    near: PETSc.Vec  # the last solved iterate: the proximal term's anchor
    anchor: PETSc.Vec | None  # the line search's linearisation point
    plastic: np.ndarray | None  # the fill's trial plastic strain at x
    memory: _CycleMemory
    it: int = 0  # the current iteration
    key: int = 0  # the global key of the set solved in this iteration
    base: _Proposal | None = None  # the last good active set and what it proposed
    predicted: _Proposal | None = None  # the predictor's proposal, until an active set solves
    merit: float = np.inf  # the line search's merit at anchor: the first Newton step is taken in full
    residual: float = np.inf  # the scaled out-of-balance force of the last solved iterate
    recovery: _Recovery = field(default_factory=_Recovery)
    proximal: _ProximalSolves = field(default_factory=_ProximalSolves)


class ContactSolver:
    """Solves load steps with the active-set Newton method on the linear systems of a
    :class:`bridgefem.solver.system.ContactSystem` (built once) and the joint law
    :class:`bridgefem.laws.coulomb.CoulombJoints`."""

    def __init__(self, K: PETSc.Mat, f_dead: PETSc.Vec, f_live: PETSc.Vec, pairs: JointPairs,
                 friction: float | np.ndarray, c: np.ndarray, force_tol: float, max_iterations: int,
                 petsc_options: dict, material: "PlasticFill | None" = None,
                 support_motion: np.ndarray | None = None):
        self.pairs = pairs
        self.friction = np.broadcast_to(np.asarray(friction, dtype=float), (len(pairs),))  # the scene's
        self.law, self.friction_factor = CoulombJoints(self.friction.copy(), c, force_tol), 1.0
        self.system = ContactSystem(K, f_dead, f_live, pairs, self.law, petsc_options, material, support_motion)
        self.comm, self.n_u, self.material = self.system.comm, self.system.n_u, material
        self.linear, self.stats = self.system.linear, self.system.stats
        # of the solves: those that condensed cycles (:mod:`bridgefem.solver.cycles`) and those of retries (:meth:`use`)
        self.stats.update(condensation_solves=0, retry_solves=0)
        self.cycles = CycleCondenser(self.system, reuse=material is None)  # the module's step 5
        self.max_iterations = max_iterations
        self.divergence = DivergenceTest(self.system, provable=material is None)  # step 3
        self.setting, self._setting_from = DEFAULT_SETTING, 0  # the setting, and the solves made before it was set
        self._unbounded = self._diverged = False  # the last / any solve of the current step was unbounded
        self._full, self._step = self.system.vector(), self.system.vector()  # the line search's full step

    def set_friction(self, mu: np.ndarray, factor: float) -> None:
        """Solve with the joints' Coulomb coefficients ``factor`` x ``mu`` (per local pair) from now on."""
        self.law.mu, self.friction_factor = factor * np.asarray(mu), factor
        self.system.law_changed()  # the slip rows hold mu
        self.cycles.forget()

    def use(self, setting: Setting) -> None:
        """Solve the next load steps with ``setting`` (the module's *Retries*; ``DEFAULT_SETTING`` restores); the solves
        made with another setting count as ``retry_solves``."""
        if self.setting != DEFAULT_SETTING:
            self.stats["retry_solves"] += self.stats["solves"] - self._setting_from
        self._setting_from = self.stats["solves"]
        self.law.c = self.law.c * (setting.scale / self.setting.scale)
        self.setting = setting
        self.system.law_changed()  # the law's rows hold c
        self.cycles.forget()

    @property
    def movement(self) -> float:
        """The fraction of the support movement imposed (:meth:`set_support_movement`)."""
        return self.system.movement

    def set_support_movement(self, fraction: float) -> None:
        """Impose ``fraction`` of the support movement (offsets ``support_motion``, m per pair) from now on."""
        self.system.set_support_movement(fraction)

    # ----------------------------------------------------------------- Newton
    def initial_iterate(self) -> Iterate:
        """Every joint closed and sticking, zero state: the start of the self-weight step."""
        plastic = self.material.initial_plastic_strain() if self.material is not None else None
        return Iterate(self.system.vector(), ContactState.all_stick(len(self.pairs)), np.zeros(len(self.pairs)),
                       plastic)

    def _counts(self, active: ContactState) -> dict:
        local = np.bincount(active.state, minlength=3)
        total = self.comm.allreduce(local)
        return {"open": int(total[OPEN]), "stick": int(total[STICK]), "slip": int(total[SLIP])}

    def _any(self, flag: bool) -> bool:
        return bool(self.comm.allreduce(int(flag), op=MPI.MAX))

    def _count(self, mask: np.ndarray) -> int:
        """The number of pairs set in a local mask, over all ranks."""
        return self.comm.allreduce(int(np.count_nonzero(mask)))

    def _solve_active(self, level: float, active: ContactState, slip_ref: np.ndarray, x: PETSc.Vec,
                      origin: PETSc.Vec, near: PETSc.Vec | None = None, forces: PETSc.Vec | None = None):
        """Solve the linear system of an active set into x (with ``near``: its proximal system anchored there,
        :meth:`bridgefem.solver.system.ContactSystem.solve_set`); returns None or the
        :class:`bridgefem.solver.divergence.ActiveSetFailure`. A displacement beyond the cap is a mechanism only when the
        diverging direction from ``origin`` (the step's converged start) is admissible
        (:meth:`bridgefem.solver.divergence.DivergenceTest.failure`, with the normal forces of ``forces``, the last solved
        iterate; by default ``origin``)."""
        failure = self.system.solve_set(level, active, slip_ref, x, near)
        if failure is not None:
            return ActiveSetFailure(failure.message, failure.singular)
        return self.divergence.failure(level, active, x, origin, origin if forces is None else forces)

    def live_load_tangent(self, it: Iterate) -> Iterate | None:
        """The response to a unit increment of the live-load level at the converged ``it`` with its active set
        held (open pairs open, closed pairs keep their gap, stick pairs their slip, slip pairs their friction
        law) and, with a plastic fill, the fill's consistent tangent at the converged displacements (the return map
        from the step's start, as the convergence test evaluated it: call this right after the step that converged
        to ``it``): displacements in m per N of live load, the tangent of the load-deflection curve. One solve (with
        a plastic fill after a factorisation of that tangent:
        :meth:`bridgefem.solver.system.ContactSystem.live_load_tangent`). None when that system cannot be solved."""
        dx = self.system.live_load_tangent(it.active)
        return None if dx is None else Iterate(dx, it.active, it.slip_ref, it.plastic_strain)

    def _damp(self, base: "_Proposal") -> "tuple[ContactState, _Proposal] | None":
        """Keep the half of the pending changes with the largest violations (at least one): the damped active
        set and the proposal with its pending changes reduced; None when a single change is left."""
        ranked = np.concatenate(self.comm.allgather(base.violation[base.pending]))
        if len(ranked) <= 1:
            return None
        threshold = np.sort(ranked)[::-1][max(len(ranked) // 2, 1) - 1]
        keep = base.pending & (base.violation >= threshold)
        damped = base.good.copy()
        damped.state[keep], damped.sign[keep] = base.proposal.state[keep], base.proposal.sign[keep]
        return damped, base._replace(pending=keep)

    def solve_step(self, level: float, start: Iterate, predictor: PETSc.Vec | PairPrediction | None = None,
                   give_up: bool = False, iterations: int | None = None) -> StepOutcome:
        """One load step (:meth:`_newton`); a failure says whether its last solve and whether any solve was unbounded
        (singular, or diverging along any mode)."""
        self._unbounded = self._diverged = False
        out = self._newton(level, start, predictor, give_up, iterations)
        return out if out.converged else replace(out, unbounded=out.mechanism or self._unbounded,
                                                 diverged=out.mechanism or self._diverged)

    def _newton(self, level: float, start: Iterate, predictor: PETSc.Vec | PairPrediction | None,
                give_up: bool, iterations: int | None) -> StepOutcome:
        """Solve for live-load level ``level`` (N per unit load factor) from a converged ``start``: the module's
        steps 1-6, one Newton iteration (:meth:`_iteration`) at a time within the step's budget.

        With ``give_up`` (the caller can retry a smaller step), a failure after ``DAMPING_CHAINS`` recovered chains
        ends the step at once, as non-convergence, and so does a cycle. ``iterations``: this step's Newton iteration
        budget (default ``max_iterations``). ``predictor``: an estimate of the solution at ``level`` (combined
        vector, or its joint pairs'); the first active set solved is its classification against ``start`` (the
        module's *Predictor*).
        """
        step = self._begin(level, start, predictor, give_up, iterations)
        for it in range(1, step.task.budget + 1):
            step.it = it
            outcome = self._iteration(step)
            if outcome is not None:
                return outcome
        if self.material is not None and step.residual > 1.0:
            return self._ended(step, f"diverged: out-of-balance force {step.residual:.3g} x the largest applied "
                                     f"nodal force after {step.task.budget} iterations")
        return self._ended(step, f"max iterations ({step.task.budget}) reached with the active set still changing")

    def _begin(self, level: float, start: Iterate, predictor: PETSc.Vec | PairPrediction | None, give_up: bool,
               iterations: int | None) -> _NewtonStep:
        """Step 1: the step's state at its start, with the start's active set (every joint closed and sticking with
        the setting ``fresh``) or the one ``predictor`` proposes (the module's *Predictor*). Collective."""
        active = start.active.copy()
        if self.setting.fresh:
            active = ContactState.all_stick(len(self.pairs))
            predictor = None
        searching = self.material is not None or self.setting.line_search  # the module's *Line search*
        x = self.system.vector()
        start.x.copy(x)
        task = _StepTask(
            level, start, f_scale=max(self.system.norm_inf(self.system.loads(level)), 1e-300),
            budget=self.max_iterations if iterations is None else min(iterations, self.max_iterations),
            chains=DAMPING_CHAINS if give_up and not self.setting.patient else np.inf, searching=searching,
            first_factorisation=self.stats["factorisations"])
        memory = _CycleMemory.empty(len(self.pairs))
        step = _NewtonStep(task, x, active, near=start.x.copy(), anchor=start.x.copy() if searching else None,
                           plastic=start.plastic_strain, memory=memory)
        if self.material is not None:  # the elastic predictor: robust at unloading points
            self.system.linearise(x, start.plastic_strain, elastic=True)
        if predictor is not None:
            step.predicted = self._predict(predictor, active, start.slip_ref, step.memory.frozen)
        if step.predicted is not None:  # no solved active set yet: a failure proves nothing
            step.base, step.active = step.predicted, step.predicted.proposal
        step.memory.seen = {self._global_key(step.active)}  # the start's set: visited only once solved at this level
        return step

    def _iteration(self, step: _NewtonStep) -> StepOutcome | None:
        """One Newton iteration, the module's steps 2-6: the outcome when it ends the step, else None (go to 2)."""
        failure = self._solve_set(step)  # 2
        if failure is not None and failure.proof:  # 3: a proved mechanism ends the step
            return self._ended(step, failure.message, mechanism=True, proved=True)
        if failure is not None:
            failure = self._note_failure(step, failure)  # 3: a proximal solve may still solve it
        if failure is not None:
            return self._recover(step, failure)  # 3: damping, repair
        accepted = self._accept(step)  # 4
        classified = self._classify(step)  # 5
        if classified is None:  # a leap: the proposal that led to it is damped
            return None
        proposal, changed = classified
        outcome = self._balance(step, accepted)  # 6
        if outcome is not None:
            return outcome
        if not changed:
            return self._test(step)  # 6
        return self._advance(step, proposal, changed)  # 6, with step 5's cycles

    def _solve_set(self, step: _NewtonStep) -> ActiveSetFailure | None:
        """Step 2: solve the active set's system into x (a set with a proximal failure: its proximal system,
        anchored at the last solved iterate), checked; a proximal set that drifts keeps its plain failure without a
        solve (the module's *Proximal solves*). Returns None or the failure. Collective."""
        step.key = self._global_key(step.active)
        if step.proximal.drift is not None:
            return step.proximal.drift
        return self._solve_current(step, step.key in step.proximal.sets)

    def _solve_current(self, step: _NewtonStep, proximal: bool) -> ActiveSetFailure | None:
        """Solve the active set's system at the step's level into x, checked against the step's start (with
        ``proximal``: its proximal system anchored at the last solved iterate). Collective."""
        task = step.task
        return self._solve_active(task.level, step.active, task.start.slip_ref, step.x, task.start.x,
                                  step.near if proximal else None, step.near)

    def _note_failure(self, step: _NewtonStep, failure: ActiveSetFailure) -> ActiveSetFailure | None:
        """Step 3: note a failed solve without proof (the last singular one, unbounded solves, mechanisms, the
        repair of an inadmissible mode); a set whose first failure diverges along a mode that slips pairs against
        their friction force is solved again with the proximal term (the module's *Proximal solves*). Returns
        the failure that stands, or None. Collective."""
        recovery, proximal = step.recovery, step.proximal
        if proximal.drift is not None:  # a proximal set that drifts: its plain failure, no solve
            recovery.fix, proximal.drift, self._unbounded = recovery.repairs.get(step.key), None, True
            return failure
        recovery.singular = failure if failure.mechanism else recovery.singular
        self._unbounded = failure.mechanism or failure.unbounded
        self._diverged |= self._unbounded
        recovery.mechanisms += failure.mechanism
        recovery.fix = self._repaired(step.active, failure.repair, step.memory.frozen)
        if recovery.fix is not None:
            recovery.repairs[step.key] = recovery.fix
        if not recovery.damping and failure.slides and proximal.count < PROXIMAL_SETS and (
                step.base is None or self._count(_changes(step.active, step.base.good)) <= PROXIMAL_CHANGES):
            proximal.sets[step.key], proximal.count = failure, proximal.count + 1
            return self._solve_current(step, True)
        return failure

    def _recover(self, step: _NewtonStep, failure: ActiveSetFailure) -> StepOutcome | None:
        """Step 3: recover from a failed solve (the module's *Damping chains*): from the last good active set, apply
        the half of its proposed changes with the largest violations (:meth:`_damp`); with nothing left to halve,
        a friction flip on its cone frozen (:meth:`_freeze_at_cone`), else the failed set's repair (the pairs an
        inadmissible diverging mode pushes into each other, closed and sticking); else the failure ends the step
        (a mechanism without proof, unless the set was predicted), as it does once ``chains`` damping chains have
        recovered (after that repair, once a step). Collective."""
        recovery = step.recovery
        if recovery.recovered >= step.task.chains and not recovery.damping:
            if not recovery.last_repair and self._take_repair(step):  # the module's *Damping chains*: once a step
                recovery.last_repair = True
                return None
            return self._ended(step, f"no convergence: a proposed active set failed again after {recovery.recovered} "
                                     f"damping chain(s): {failure.message}",
                               mechanism=failure.mechanism and recovery.mechanisms > 1)
        recovery.damping = True
        damped = self._damp(step.base) if step.base is not None else None
        if damped is None and not failure.mechanism and self._freeze_at_cone(step):
            return None
        if damped is None and self._take_repair(step):
            return None
        if damped is None:
            return self._ended(step, failure.message, mechanism=failure.mechanism and step.predicted is None)
        step.active, step.base = damped
        return None

    def _take_repair(self, step: _NewtonStep) -> bool:
        """Make the failed set's repair the next active set, unless the step has none or visited it already; returns
        whether it did. Collective (the global key)."""
        if step.recovery.fix is None:
            return False
        fix = self._global_key(step.recovery.fix)
        if fix in step.memory.seen:
            return False
        step.memory.seen.add(fix)
        step.active = step.recovery.fix
        return True

    def _accept(self, step: _NewtonStep) -> "FillResponse | None":
        """Step 4: a solved set ends the damping chain; with a line search (the module's *Line search*) the step is
        backtracked from the linearisation point, which moves to the accepted iterate. Returns the fill's response
        there (None without a plastic fill). Collective."""
        step.recovery.solved()
        step.predicted, self._unbounded, task = None, False, step.task
        if not task.searching:
            return None
        step.merit, accepted = self._line_search(task.level, step.x, step.anchor, step.merit, task.start.plastic_strain,
                                                 task.start.slip_ref, step.memory.frozen, task.f_scale)
        step.x.copy(step.anchor)
        return accepted

    def _classify(self, step: _NewtonStep) -> tuple[_Proposal, int] | None:
        """Step 5: the active set the joint law proposes from the solution (:meth:`_propose`) and the number of
        pairs it changes; None when the solution leaps (:meth:`_leaps`, the module's *Leaps*) and the proposal
        that led to it was damped instead. Collective."""
        task, memory = step.task, step.memory
        _, lam, d = self.system.split(step.x)
        proposal = self._propose(step.active, lam, d, task.start.slip_ref, memory.frozen, memory.bonded)
        changed = self._count(proposal.pending)
        if changed and not task.searching and step.base is not None and step.key != memory.condensed and \
                self._leaps(step.x, step.near, task.start.x):
            damped = self._damp(step.base)
            if damped is not None:
                step.active, step.base = damped
                return None
        step.x.copy(step.near)
        memory.churn += proposal.pending
        return proposal, changed

    def _balance(self, step: _NewtonStep, accepted: "FillResponse | None") -> StepOutcome | None:
        """Step 6's equilibrium: the scaled out-of-balance force at x (with a plastic fill, the fill linearised there
        for the next solve); the step ends as diverged beyond ``DIVERGED_OUT_OF_BALANCE`` (the module's *Line
        search*). Collective."""
        if self.material is None:
            step.residual = self.system.equilibrium_residual(step.x, step.task.f_scale)
            return None
        f_int, step.plastic = self.system.linearise(step.x, step.task.start.plastic_strain, response=accepted)
        step.residual = self.system.material_residual(step.x, f_int, step.task.level, step.task.f_scale)
        if step.residual > DIVERGED_OUT_OF_BALANCE:  # no recovery from here
            return self._ended(step, f"diverged: out-of-balance force {step.residual:.3g} x the largest applied "
                                     f"nodal force after {step.it} iterations")
        return None

    def _test(self, step: _NewtonStep) -> StepOutcome | None:
        """Step 6, the active set unchanged: converged when equilibrium (:meth:`_in_equilibrium`) and the joint law
        hold (the law waived at frozen pairs' friction and at bonded pairs, by at most ``BOND_RTOL`` of the largest
        applied nodal force); a proximal set's plain failure when it drifts; with a line search the next iteration;
        else the set is singular (a mechanism without proof). Collective."""
        balanced = self._in_equilibrium(step)
        waived, comp = self._law_residuals(step)
        if waived > BOND_RTOL * step.task.f_scale:
            return self._ended(step, f"active set cycling: the joint law is violated by {waived:.3g} N at the "
                                     "bonded or frozen pairs")
        if balanced and comp <= 10 * self.law.force_tol:
            counts = {**self._counts(step.active), "frozen": self._count(step.memory.frozen),
                      "bonded": self._count(step.memory.bonded)}
            return StepOutcome(True, "", step.it, step.residual, self._factorisations(step),
                               Iterate(step.x, step.active, step.task.start.slip_ref, step.plastic), counts)
        if step.key in step.proximal.sets:  # a drift along the mode that changes no pair
            step.proximal.drift = step.proximal.sets.pop(step.key)
            return None
        if step.task.searching:
            return None  # same active set, damped step or fill not in equilibrium
        return self._ended(step, f"inaccurate linear solve: scaled equilibrium residual {step.residual:.2e}, "
                                 f"complementarity residual {comp:.2e} N (singular system)", mechanism=True)

    def _law_residuals(self, step: _NewtonStep) -> tuple[float, float]:
        """The joint law's Alart-Curnier residual at the iterate (N): the largest where it is waived (frozen pairs'
        friction, bonded pairs), and the largest elsewhere. Collective."""
        memory, norm_inf = step.memory, self.system.norm_inf
        _, lam, d = self.system.split(step.x)
        ncp = self.law.residual(lam, d, step.task.start.slip_ref)
        waived = max(norm_inf(ncp[memory.bonded].ravel()), norm_inf(ncp[memory.frozen, 1]))
        ncp[memory.frozen, 1] = 0.0  # the normal law is still checked there
        ncp[memory.bonded] = 0.0
        return waived, norm_inf(ncp.ravel())

    def _in_equilibrium(self, step: _NewtonStep) -> bool:
        """The iterate of an unchanged active set is in equilibrium: its scaled out-of-balance force is below
        ``EQUILIBRIUM_RTOL``, or (the plain system of a ring without a line search) one step of iterative
        refinement shows the solve exact to working precision (the module's *Refinement*); the refined iterate is
        kept when its out-of-balance force is smaller. Collective."""
        if step.residual < EQUILIBRIUM_RTOL:
            return True
        if step.task.searching or step.key in step.proximal.sets:
            return False
        dx = self.system.refinement(step.x)
        if not isinstance(dx, PETSc.Vec):
            return False
        exact = self.system.norm_inf(dx.array) <= REFINED_RTOL * self.system.norm_inf(step.x.array)
        refined = step.x.copy()
        refined.axpy(1.0, dx)
        residual = self.system.equilibrium_residual(refined, step.task.f_scale)
        if residual < step.residual:
            refined.copy(step.x)
            step.residual = residual
        return exact or step.residual < EQUILIBRIUM_RTOL

    def _advance(self, step: _NewtonStep, proposal: _Proposal, changed: int) -> StepOutcome | None:
        """Step 6, the active set changed: go to 2 with the proposed set; a proposal that returns to a set visited at
        this level is a cycle (:meth:`_break_cycle`), except with a line search (the iterate moves between visits:
        no cycle; the budget bounds it). Collective."""
        key = self._global_key(proposal.proposal)
        if key in step.memory.seen and not step.task.searching:
            return self._break_cycle(step, proposal, changed, key)
        if key in step.memory.seen:
            step.memory.seen.clear()
        self._take(step, proposal, key)
        return None

    def _break_cycle(self, step: _NewtonStep, proposal: _Proposal, changed: int, key: int) -> StepOutcome | None:
        """Step 5's cycles, the proposal returning to a visited set (global key ``key``), in this order: a return to
        a set whose diverging mode was inadmissible goes to its repair; a cycle after a singular proposal is a
        mechanism without proof; the cycle's pairs are solved exactly on their condensed compliance (:meth:`_cycle`,
        the module's *Churning pairs*); else :meth:`_freeze`. Collective."""
        task, memory, recovery = step.task, step.memory, step.recovery
        fix = recovery.repairs.pop(key, None)
        if fix is not None and self._visit(step, fix, proposal.violation):
            return None
        if recovery.singular is not None:
            return self._ended(step, f"{recovery.singular.message}; confirmed: damped iterations return to it",
                               mechanism=True)
        solved = self.cycles.condensed(task.level, step.active, self._cycle(proposal.pending, memory.churn),
                                       task.start.slip_ref, task.start.active)
        if solved is not None and self._visit(step, solved, proposal.violation):
            memory.frozen &= ~step.base.pending  # the condensed pairs' friction state is now exact
            memory.condensed = self._global_key(solved)
            return None
        return self._freeze(step, proposal, changed)

    def _freeze(self, step: _NewtonStep, proposal: _Proposal, changed: int) -> StepOutcome | None:
        """A cycle that is not only friction flips (stick / slip, slip sign) of closed pairs is damped
        (:meth:`_damp`) while damping chains may recover; undamped, its open / closed toggles are bonded if they
        and the flips are all its changes, else it ends the step as active-set cycling. The flips are frozen to
        stick and the proposal, frozen and bonded, is taken. Collective."""
        new, pending, memory = proposal.proposal, proposal.pending, step.memory
        flips = pending & ~memory.frozen & (new.state != OPEN) & (step.active.state != OPEN)
        if self._count(flips) != changed:
            damped = self._damp(proposal) if step.recovery.recovered < step.task.chains else None
            toggles = pending & ~memory.bonded & ((new.state == OPEN) != (step.active.state == OPEN))
            if damped is None and self._count(toggles | flips) == changed:
                memory.bonded |= toggles  # no consistent open / closed state: kept closed, its law waived
            elif damped is None:
                return self._ended(step, f"active set cycling ({changed} pairs changing)")
            else:
                step.recovery.damping = True
                step.active, step.base = damped
                return None
        memory.frozen |= flips
        _stick(new, memory.frozen)
        _bond(new, memory.bonded)
        self._take(step, proposal, self._global_key(new))
        return None

    def _freeze_at_cone(self, step: _NewtonStep) -> bool:
        """Whether the last change left of a proposal whose set failed without showing a mechanism is a friction flip
        (stick / slip, slip sign) of a closed pair within the law residual waived at frozen pairs (``BOND_RTOL`` of
        the largest applied nodal force); if so it is frozen to stick and the set that proposed it is solved next
        (the module's *Pairs on the cone*). Collective."""
        base, memory = step.base, step.memory
        if base is None:
            return False
        flips = base.pending & ~memory.frozen & (base.proposal.state != OPEN) & (base.good.state != OPEN)
        if not self._any(flips.any()) or self._count(flips) != self._count(base.pending):
            return False
        violation = self.comm.allreduce(float(base.violation[flips].max(initial=0.0)), op=MPI.MAX)
        if violation > BOND_RTOL * step.task.f_scale:
            return False
        memory.frozen |= flips
        step.active = base.good.copy()
        _stick(step.active, memory.frozen)
        return True

    def _take(self, step: _NewtonStep, proposal: _Proposal, key: int) -> None:
        """The proposed set (global key ``key``) is solved next; the set that proposed it is the good one."""
        step.memory.seen.add(key)
        step.base, step.active = proposal, proposal.proposal

    def _visit(self, step: _NewtonStep, target: ContactState, violation: np.ndarray) -> bool:
        """Whether ``target`` is new at this level; if so it is solved next, as the proposal of the current set
        with ``violation``. Collective."""
        key = self._global_key(target)
        if key in step.memory.seen:
            return False
        self._take(step, _Proposal(step.active, target, _changes(target, step.active), violation), key)
        return True

    def _ended(self, step: _NewtonStep, reason: str, mechanism: bool = False, proved: bool = False) -> StepOutcome:
        """The failed outcome of the step at its current iteration."""
        return StepOutcome(False, reason, step.it, step.residual, self._factorisations(step), mechanism=mechanism,
                           proved=proved)

    def _factorisations(self, step: _NewtonStep) -> int:
        """The factorisations made since the step began."""
        return self.stats["factorisations"] - step.task.first_factorisation

    def _leaps(self, x: PETSc.Vec, near: PETSc.Vec, start: PETSc.Vec) -> bool:
        """Whether the solution ``x`` moves the structure more than ``LEAP`` times as far as the last solved iterate
        ``near`` and the step's start (largest displacement, m): the module's *Leaps*. Collective."""
        norm_inf = self.system.norm_inf
        largest = norm_inf(x.array[:self.n_u])
        return largest > LEAP * max(norm_inf(near.array[:self.n_u]), norm_inf(start.array[:self.n_u]))

    def _cycle(self, pending: np.ndarray, churn: np.ndarray) -> np.ndarray:
        """The pairs of a cycle to condense (the module's *Churning pairs*): those the returning proposal changes,
        with those that changed in two or more of the step's proposals (``churn``: counts per local pair) when they
        are at most ``ENUMERATED_PAIRS`` in all, else the returning proposal's alone. Collective."""
        cycle = pending | (churn >= 2)
        return cycle if self._count(cycle) <= ENUMERATED_PAIRS else pending

    def _repaired(self, active: ContactState, repair: np.ndarray | None, frozen: np.ndarray
                  ) -> ContactState | None:
        """``active`` with the ``repair`` pairs closed and sticking, except that an open one on a sliding joint
        (:meth:`bridgefem.laws.coulomb.ContactState.sliding_joints`) closes sliding with it (the module's *First
        contact*); None without a repair anywhere. Collective."""
        if not self._any(repair is not None and bool(repair.any())):
            return None
        repair = np.zeros(len(self.pairs), bool) if repair is None else repair
        fixed = active.copy()
        fixed.state[repair], fixed.sign[repair] = STICK, 0
        slide = active.sliding_joints(self.pairs.joint, repair, self.comm)
        closing = repair & (active.state == OPEN) & (slide != 0)
        fixed.state[closing], fixed.sign[closing] = SLIP, slide[closing]
        _stick(fixed, frozen)
        return fixed

    def _predict(self, predictor: PETSc.Vec | PairPrediction, active: ContactState, slip_ref: np.ndarray,
                 frozen: np.ndarray) -> "_Proposal | None":
        """The active set an estimate of the solution (a combined vector or its pairs') proposes from the converged
        ``active``, as a proposal whose good set is ``active``; None when it proposes no change."""
        if isinstance(predictor, PairPrediction):
            lam, d = predictor.lam, predictor.d
        else:
            _, lam, d = self.system.split(predictor)
        proposal = self._propose(active, lam, d, slip_ref, frozen)
        return proposal if self._any(proposal.pending.any()) else None

    def _propose(self, active: ContactState, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray,
                 frozen: np.ndarray, bonded: np.ndarray | None = None) -> "_Proposal":
        """The active set the Alart-Curnier functions propose from ``active`` for multipliers ``lam`` and relative
        displacements ``d`` (frozen pairs kept sticking, bonded ones closed and sticking, reversed slips sticking
        with the setting's ``through_stick``: :func:`_through_stick`), with the changed pairs and their violations."""
        new, violation = self.law.classify(active, lam, d, slip_ref)
        if self.setting.through_stick:
            _through_stick(new, active)
        opposed = new.opposed_slips(active, self.pairs.joint, self.comm)  # the module's *Opposed slips*
        new.state[opposed], new.sign[opposed] = STICK, 0
        _stick(new, frozen)
        if bonded is not None:
            _bond(new, bonded)
        return _Proposal(active, new, _changes(new, active), violation)

    def converged_slip_reference(self, it: Iterate) -> Iterate:
        """The converged state becomes the reference for the incremental slip of the next step."""
        _, _, d = self.system.split(it.x)
        return Iterate(it.x, it.active, d[:, 1].copy(), it.plastic_strain)

    def _global_key(self, active: ContactState) -> int:
        return hash(tuple(self.comm.allgather(active.key())))

    def _merit(self, level: float, x: PETSc.Vec, plastic_strain: np.ndarray, slip_ref: np.ndarray,
               frozen: np.ndarray, f_scale: float) -> "tuple[float, FillResponse | None]":
        """The line search's merit at x: the Euclidean norm of the whole residual, the out-of-balance force
        f + G^T lam - f_int(u) (the fill's return map at the displacements of x, from the step's converged
        ``plastic_strain``; without a plastic fill f + G^T lam - K u) and the Alart-Curnier residual of the joints
        (friction law waived at ``frozen`` pairs), scaled by f_scale; and the fill's response at x (no tangent; None
        without a plastic fill). Collective."""
        _, lam, d = self.system.split(x)
        ncp = self.law.residual(lam, d, slip_ref)
        ncp[frozen, 1] = 0.0
        if self.material is None:
            out, response = self.system.elastic_out_of_balance(x), None
        else:
            response = self.material.evaluate(x.array[:self.n_u], plastic_strain, tangent=False)
            out = self.system.out_of_balance(x, response.f_int, level)
        squares = self.comm.allreduce(float(out @ out) + float(np.sum(ncp * ncp)))
        return np.sqrt(squares) / f_scale, response

    def _line_search(self, level: float, x: PETSc.Vec, anchor: PETSc.Vec, merit: float, plastic_strain: np.ndarray,
                     slip_ref: np.ndarray, frozen: np.ndarray, f_scale: float) -> "tuple[float, FillResponse | None]":
        """Backtrack the Newton step from ``anchor`` (the linearisation point, merit ``merit``) to the solution in
        x: x becomes anchor + a (x - anchor) for the first a = 1, 1/2, ... (at most ``LINE_SEARCH_HALVINGS``
        halvings) whose merit is at most (1 - ``ARMIJO`` a) ``merit``, or stays the full step when none is.
        Returns the merit and the fill's response at the new x (linearised there next). Collective."""
        x.copy(self._full)
        self._step.waxpy(-1.0, anchor, x)
        a = 1.0
        value, response = full = self._merit(level, x, plastic_strain, slip_ref, frozen, f_scale)
        while value > (1.0 - ARMIJO * a) * merit and a > 0.5 ** LINE_SEARCH_HALVINGS:
            a *= 0.5
            anchor.copy(x)
            x.axpy(a, self._step)
            value, response = self._merit(level, x, plastic_strain, slip_ref, frozen, f_scale)
        if value > (1.0 - ARMIJO * a) * merit:
            self._full.copy(x)
            return full
        return value, response



def retried(solver: ContactSolver, solve: Callable[[], StepOutcome], failed: StepOutcome,
            settings: tuple[Setting, ...] = RETRIES) -> StepOutcome:
    """A load step that ended in ``failed`` without proof, solved again by ``solve()`` (which records it) with each of
    ``settings`` in turn (the module's *Retries*): the first outcome that converged or proved a mechanism, else the
    first that showed a mechanism where ``failed`` showed none, else ``failed`` (its reason saying so); when
    ``failed`` ended on an unbounded solve (singular, or diverging along any mode) and every retry met one,
    ``failed`` as a mechanism without proof (no setting found an equilibrium, each found the system unbounded: the
    verdict needs the LP's agreement, :mod:`bridgefem.analysis.evidence`). A setting that changes nothing for this solver (the
    line search alone, with a plastic fill) is skipped. Restores the default setting."""
    searching = solver.material is not None  # a plastic fill's steps are line searched already
    settings = tuple(st for st in settings if not (searching and replace(st, line_search=False) == DEFAULT_SETTING))
    best, unbounded = failed, failed.unbounded
    try:
        for setting in settings:
            solver.use(setting)
            out = solve()
            if out.converged or out.proved:
                return out
            best = out if out.mechanism and not best.mechanism else best
            unbounded = unbounded and out.diverged
    finally:
        solver.use(DEFAULT_SETTING)
    if unbounded and not best.mechanism:
        return replace(failed, mechanism=True, reason=f"{failed.reason}; no equilibrium with any of {len(settings)} "
                                                       "other solver settings, each diverging (no proof)")
    if best is failed:
        return replace(failed, reason=f"{failed.reason} (and with each of {len(settings)} other solver settings)")
    return best


def _stick(active: ContactState, frozen: np.ndarray) -> None:
    """Frozen pairs that are closed stick (their slip direction cycled); open ones stay open."""
    fix = frozen & (active.state != OPEN)
    active.state[fix], active.sign[fix] = STICK, 0


def _through_stick(new: ContactState, old: ContactState) -> None:
    """A pair that slid in ``old`` and is proposed to slide the other way sticks instead (the module's *Reversed
    slips*): the reversal passes through stick, and the next iteration proposes the reversed slip if the stick
    state's friction force leaves the cone again."""
    reversed_slip = (old.state == SLIP) & (new.state == SLIP) & (new.sign != old.sign)
    new.state[reversed_slip], new.sign[reversed_slip] = STICK, 0


def _bond(active: ContactState, bonded: np.ndarray) -> None:
    """Bonded pairs are closed and stick (their open / closed state cycled)."""
    active.state[bonded], active.sign[bonded] = STICK, 0


def _changes(new: ContactState, old: ContactState) -> np.ndarray:
    """Local pairs whose state or slip sign differs between two active sets."""
    return (new.state != old.state) | (new.sign != old.sign)
