"""Evidence for a verdict of the FE limit search: a proved mechanism, or agreement with the rigid-block LP.

The search ends a bracket (or calls a ring unstable) on a failed load step that showed a mechanism. That is
evidence of collapse only when

1. the step's diverging mode *proves* it (:mod:`bridgefem.solver.newton`, *Mechanism verdicts*: an admissible
   rigid-block hinge mode on which the loads do positive work, so that no equilibrium with compressive joints
   exists); or
2. the rigid-block LP on the same joints (:func:`bridgefem.limit.collapse.collapse_load`, associative friction)
   gives the same verdict: the same status and, for a limit load, a level within ``AGREEMENT`` of the FE bracket; or
3. for a limit with sliding joints below the associative LP: the FE's last converged state is a *collapse state* of its
   rigid blocks (:class:`SlipCheck`). Its joint forces balance every voussoir under the FE's own loads at the bracket's
   lower end (the assembled self-weight and live load, :func:`bridgefem.analysis.static_bound.block_loads`) and obey no
   tension and Coulomb friction pair by pair, so they are statically admissible for the rigid blocks with each joint's
   shear capacity frozen at mu x the FE's normal force (:func:`bridgefem.limit.rigid_block.frozen_capacity_collapse`).
   That *frozen* LP has a shear limit independent of the normal force, hence normality and the bound theorems (Livesley
   1978): its level is at least the FE's lower end. When it lies within ``AGREEMENT`` of the bracket, the FE's forces
   are an optimal state of it to that tolerance: on its mechanism they do the mechanism's dissipation up to (level -
   lower) x the live load's unit work (virtual work; exactly, by complementary slackness, at equality), i.e. the sliding
   joints carry mu n_FE against the slip and the thrust sits at the hinges' edges. That mechanism strains no voussoir
   and its slips do not dilate (the FE's non-associative Coulomb law), so the blocks can move on it with the FE's forces
   unchanged at the FE's load: the load-deflection curve of the FE's state is flat there. The rule asks for that level
   within ``AGREEMENT`` of the bracket, a mechanism that slides somewhere and only at joints whose FE forces are at
   their Coulomb limit against the slip (:func:`coulomb_limited`), the same frozen LP under the scene's exact loads
   within ``AGREEMENT`` too (the meshed voussoirs carry the exact blocks' weights,
   :func:`bridgefem.fe.model.block_weight_shape`, but the live load acts on the mesh's straight-edged faces, and a
   limit small against the loads that decide it moves by far more than such a difference; otherwise the limit depends
   on the mesh and a finer one is tried),
   and the FE at most ``1 + AGREEMENT`` x the associative LP (the upper bound on any non-associative collapse,
   Radenkovic's first theorem). On a barrel of rings the LP cuts each curved ring interface into chords, whose forces
   the FE's pairs along the curve do not give, so the rule reads the FE's own blocks and pairs instead, each pair a
   point contact with its shear capacity frozen at the law's at the FE's normal force there
   (:class:`bridgefem.analysis.checks.PairCheck`, :mod:`bridgefem.limit.contacts`): the FE's forces satisfy those rows
   exactly, the joint's moment rows being its pairs' no-tension; a joint slides in that mechanism where its pairs do
   more than ``AGREEMENT`` of its friction dissipation, and is at its Coulomb limit where the FE's shears do all but
   ``AGREEMENT`` of its pairs' share. There the search uses it only to settle a closing trial that failed without
   proof (:mod:`bridgefem.search.target`, *Collapse state*, steps 4 and 5), not as its estimate of the limit, which
   would steer the path (``docs/robustness.md``, *Rings*).

4. on a bare ring, the *static theorem* (:class:`StaticBound`): the rigid-block LP on the same joints under the FE's own
   assembled block loads (:func:`bridgefem.analysis.static_bound.block_loads`) has the collapse level LP_fe. A converged
   FE state at level L balances every voussoir under those loads (to the solver's equilibrium residual) with pair forces
   that are compressive and within Coulomb's cone; summed per joint (n = sum lam_n, s = sum lam_t, m = sum (p - t/2)
   lam_n about the joint's centre, p the pair's distance from the intrados, 0 <= p <= t) they satisfy the LP's yield
   rows (n >= 0, |s| <= mu n, |m| <= n t/2) and its block equilibrium, so L <= LP_fe: no FE equilibrium exists above
   LP_fe, and the FE's limit lies in [L, LP_fe]. The LP has no cohesion; with a compressive strength its moment rows
   are the polygon of the FE's own pairs crushing one after another (:func:`bridgefem.laws.crushing.fe_stations`,
   the thrust within it by :func:`bridgefem.limit.rigid_block.statics`), and its rows are exactly the resultants of
   the pairs' laws (no row is stricter than the FE's law), so the bound holds on every bare ring, abutment
   bases included (the abutments are blocks of both). The search never tries a level above LP_fe and ends when a step
   converges within the bracket's width of it; the verdict is then a limit in [L, LP_fe] with the evidence "static
   theorem", after an explicit check (:func:`admissible`) that the converged state's joint resultants satisfy the LP's
   rows within the FE's own tolerances: a pair's residual is at most 10 x the solver's force tolerance delta, so per
   joint with k pairs sigma = k delta bounds the net tension, the Coulomb excess by (1 + mu) sigma and the moment's
   excess by sigma t; a block's equilibrium residual is at most its nodes x the solver's scaled residual
   (:data:`bridgefem.solver.newton.EQUILIBRIUM_RTOL`) x the largest applied nodal force eps (forces) and that x twice
   its radius about its reference point (moments). A state that waives the law at some pairs (bonded or frozen: an
   Alart-Curnier residual up to :data:`bridgefem.solver.newton.BOND_RTOL` x eps each) is refused: a joint tension of eps
   per waived pair can raise the LP's level by more than the bracket's tolerance. A refused state, like one outside the
   tolerances, voids the rule for the search (which goes on without the bound). The bound caps every search (no FE
   equilibrium exists above it, whatever the mesh), but the verdict asks for the bracket within ``AGREEMENT`` of the LP
   with the exact voussoirs' weights too (as evidence 3 does: the FE's live load acts on the mesh's straight-edged
   faces, which moves a limit small against the loads that decide it by far more); elsewhere the other rules decide
   (a finer mesh among them). Where LP_fe and that LP differ by more than ``AGREEMENT`` the cap still saves the trials
   above LP_fe, which could only fail. The bound is the FE's up to those tolerances (k delta per joint moves the LP's
   level by far less than the bracket's width). Under self-weight the same theorem reads: a converged FE state, with
   every pair of a joint waived at worst (sigma = k (delta + eps)), has per joint a net tension of at most sigma, |m| <=
   (n + 2 sigma) t/2 and |s| <= mu n + (1 + mu) sigma, so it is a point of the deficit programme with net tension
   allowed (:func:`bridgefem.limit.rigid_block.standing_deficit`) at tau = max(2, 1 + mu) sigma
   (``StaticBound.margin``). When the rigid blocks under the FE's dead loads need more than that, no FE equilibrium
   exists, so no retry or continuation can find one: "unstable under self-weight" with this evidence (and, as always,
   only where the rigid-block LP with the exact voussoirs agrees).

5. under an elastic fill, the *rings under the loads the fill transmits* (:mod:`bridgefem.analysis.interface`): the
   rigid-block LP of the rings with the interface forces of the settled state as dead load and their change up to
   a converged level L as live load collapses at lambda >= L (the FE's state is admissible for it, the static
   theorem as in 4). A converged state with lambda <= (1 + tolerance) L is a collapse state: its step counts as
   failed with a mechanism (:mod:`bridgefem.search.step`, *Collapse state*), so that the bracket rule closes on the
   first load at which the rings are a mechanism under the loads the fill passes on. An elastic fill has no
   strength to give way: past that load only its elasticity carries more, by changing how it loads the rings (a
   restraint without bound, in tension too), and its load-deflection curve need not flatten (the fill's stiffness
   stays in the tangent), so the flat curve cannot show that collapse, and a search that went on would creep up
   along the fill's elastic restraint wherever its Newton method let it. The verdict is the rings' collapse
   (``ring_under_transmitted_loads`` in results.json reads the same LP at the last converged state, below it). A
   plastic fill has its own failure (the flat curve's evidence and the conic bounds), so there the rule does not
   apply.

6. under a Mohr-Coulomb fill, a self-weight without an FE equilibrium (the search never settled, a solver failure)
   is "unstable under self-weight" when the *kinematic programme* of the conic bounds
   (:mod:`bridgefem.limit.bounds_upper`, ``fill_bounds`` in results.json) proves it: that programme, solved in its
   dual form (the largest load factor, free in sign, of a weakly equilibrated stress field within the Mohr-Coulomb
   set, joint forces within their limits), has no feasible point, and Clarabel's certificate of that (Farkas' lemma
   for cones) is a velocity field of the blocks and the fill, kinematically admissible (its strain rates and jumps in
   the flow cones), on which the dead load does more work than the field dissipates and the live load none. By the
   upper bound theorem the associative rigid-plastic bridge (rigid voussoirs, no-tension Coulomb joints, the fill's
   Mohr-Coulomb cone with its cut-off) cannot carry its own weight; by Radenkovic's first theorem the FE's
   non-associative joints and a fill dilating less than it rubs carry no more, and elasticity changes no collapse
   load (the limit theorems of elastic, perfectly plastic bodies). No FE equilibrium exists, so the failure was the
   solver's search for one that is not there. The FE's own reason stays its ``failure_reason``; where the rigid-block
   LP with the fill as dead load stands, the verdict warns that the fill gives way with the ring. A static programme
   without a feasible point is no proof (its stress fields are a subset of the admissible ones) and is not read.

Non-associative collapse states are not unique (non-associative friction has no bound theorems beyond the
associative upper bound): rule 3 says that the FE's limit is a collapse state of its own rigid blocks, the one its
elastic path reaches, never that no other path carries more. The Tresca fixed point (Gilbert, Casapulla & Ahmed
2006) from the FE's state is reported beside it, and a fixed point back at the associative level with the FE's
sliding joints marks a failure whose load depends on the mesh (docs/joints-and-lp.md, *Sliding collapses below
the associative LP*).

Otherwise the verdict is a solver failure that names the unproven mechanism and the LP's answer (a singular or
diverging solve alone is no proof: a wrong active set, or a linear solver that did not solve, looks the same).
A proved verdict that the LP contradicts (an FE limit above the LP's level by more than ``AGREEMENT``, or
"unstable" where the LP stands) is reported with a warning; "unstable" where the LP stands is never a verdict
(the LP's equilibrium of the same joints is a certificate that the ring stands, up to its rigid blocks).
Converged verdicts (stable, locked) are equilibria the search found; a contradicting LP gives a warning.

With a fill the LP carries the fill as dead load only: it ignores the fill's strength and stiffness, which
usually raise the collapse load, and the fill's own failure under the load (a bearing failure under a patch or a
point load), which can lower it far below the LP, even below the conic upper bound of the bridge with its fill.
So it cannot confirm an FE limit either way: the search's flat
load-deflection curve, or under an elastic fill evidence 5, is the FE's evidence, the conic bounds (``fill_bounds``,
:mod:`bridgefem.limit.bounds`) the independent check, and an FE limit below the LP gets a warning that names the
likely cause. A limit with neither (a mechanism without proof: every solver setting diverging, a singular system)
is a solver failure under a fill. Under self-weight
alone the LP standing means the ring carries the fill's weight as a pressure, so an FE mechanism under self-weight is
refused there as for a bare ring; only evidence 6, a proof that the bridge with its fill cannot stand, overrides it.

Safeguards:

- *No verdict without evidence*: a singular or diverging solve alone proves nothing (a wrong active set, or a linear
  solver that did not solve, looks the same), so an unproven mechanism needs the LP's agreement or a collapse state.
- *Exact loads* (rules 3 and 4): the meshed voussoirs carry the exact blocks' weights (their resultants), and a limit
  that the mesh's faces under the live load still move beyond ``AGREEMENT`` goes to a finer mesh instead.
- *Waived pairs refused* (rule 4): a state that bends the joint law at some pairs is no premise of the static
  theorem.
- *"Unstable" never where the LP stands*: the LP's equilibrium of the same joints certifies that the ring stands
  (with a fill, only that the ring carries the fill as a pressure: evidence 6's proof of the whole bridge decides).
- *Only a kinematic certificate* (rule 6): of the conic bounds, the programme whose infeasibility is a mechanism; the
  static programme's infeasibility depends on its mesh's stress fields.

References: R. K. Livesley (1978), Limit analysis of structures formed from rigid blocks, IJNME 12; M. Gilbert,
C. Casapulla & H. M. Ahmed (2006), Limit analysis of masonry block structures with non-associative frictional joints
using linear programming, Computers & Structures 84; D. Radenkovic (1961), the theorems of the limit load for
non-standard materials (the associative upper bound); A. Ben-Tal & A. Nemirovski (2001), Lectures on Modern Convex
Optimization, SIAM, sec. 2.3 (the conic theorem on alternatives: a certificate of infeasibility); A. Makrodimopoulos
& C. M. Martin (2007), IJNAMG 31 (the kinematic programme as a cone programme).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..limit.conic import INFEASIBLE
from ..limit.rigid_block import Statics
from ..status import FLAT_CURVE, RINGS_UNDER_FILL, Status

AGREEMENT = 0.005  # FE within this fraction of the LP's level agrees with it (the limit load's accuracy target)


@dataclass(frozen=True)
class SlipCheck:
    """The non-associative rigid-block check of an FE limit with sliding joints (evidence 3 of the module
    docstring), from the FE's last converged step: its sliding joints (``fe_sliding``); the *frozen* LP, the rigid
    blocks under the FE's own block loads with each joint's shear capacity frozen at mu x the FE's normal force
    (:func:`bridgefem.limit.rigid_block.frozen_capacity_collapse`): its ``frozen_level``, its mechanism's
    ``frozen_sliding`` and ``frozen_hinges`` joints, and ``fe_limited``, those of its sliding joints where the FE's
    joint forces are at their Coulomb limit in the sense of the slip (:func:`coulomb_limited`); ``exact_level``, the
    frozen LP under the scene's exact voussoir weights and loads; and the Tresca fixed point from the FE's normal
    forces (FE loads): ``converged``, its ``level``, ``sliding``, ``hinges`` and ``iterations`` (LPs). Levels in N
    per unit load factor (None without a limit)."""

    fe_sliding: tuple[int, ...]
    frozen_level: float | None
    frozen_sliding: tuple[int, ...]
    frozen_hinges: tuple[int, ...]
    fe_limited: tuple[int, ...]
    exact_level: float | None
    converged: bool
    level: float | None
    sliding: tuple[int, ...]
    hinges: tuple[int, ...]
    iterations: int

    def collapse_state(self, lower: float, upper: float) -> bool:
        """The FE's own state is a collapse state of its meshed voussoirs: the frozen LP within ``AGREEMENT`` of
        the bracket, its mechanism sliding (somewhere) only where the FE's joints are at their Coulomb limit."""
        return (self.frozen_level is not None and bool(self.frozen_sliding)
                and set(self.frozen_sliding) == set(self.fe_limited) and reaches(lower, upper, self.frozen_level))

    def agrees(self, lower: float, upper: float, lp_level: float) -> bool:
        """Evidence 3: a collapse state (:meth:`collapse_state`) that the exact voussoirs' weights keep within
        ``AGREEMENT`` of the bracket (``exact_level``), with the FE at most ``1 + AGREEMENT`` x the associative
        LP's ``lp_level`` (its upper bound)."""
        return (self.collapse_state(lower, upper) and self.exact_level is not None
                and reaches(lower, upper, self.exact_level) and lower <= (1 + AGREEMENT) * lp_level)

    def settles(self, lower: float, trial: float, lp_level: float, tolerance: float) -> bool:
        """A closing trial at ``trial`` that failed without proof from the FE's converged state at ``lower`` (this
        check's state) is decisive: the state is the collapse state that confirms the bracket [``lower``,
        ``trial``] (:meth:`agrees`, evidence 3), and its rigid blocks with the FE's friction capacities collapse
        within the bracket's width of ``lower`` (``frozen_level`` at most ``(1 + tolerance) lower``).

        Why that is the verdict's own proof: the bracket the search closes on the failure is the one evidence 3
        confirms from this state, whatever the failure's retries would have found; and the frozen LP's level is
        at least ``lower`` (the FE's forces are admissible for it, the bound theorem of its normality), so within
        the width of ``lower`` it says the state is at its collapse to within the bracket's tolerance: the blocks
        move on the mechanism with the FE's forces unchanged at the level where the curve is flat. A retry that
        converged at ``trial`` would have to raise the normal forces of the sliding joints beyond the state's along
        that flat curve: another non-associative collapse state (they are not unique, module docstring), which the
        search's path does not reach."""
        return self.agrees(lower, trial, lp_level) and self.frozen_level <= (1 + tolerance) * lower

    def upper_end(self, lower: float, trial: float, lp_level: float) -> float | None:
        """The bracket's upper end when the closing trial at ``trial`` failed without proof from this check's state
        at ``lower`` with every solver setting: the frozen LP's level, at least ``trial``, when the state is the
        collapse state that confirms [``lower``, ``trial``] (:meth:`agrees`, evidence 3: its rigid blocks with the
        FE's friction capacities collapse within ``AGREEMENT`` of the bracket); None otherwise (the failure stays a
        solver failure).

        Why the frozen level and not the trial: the FE found no equilibrium above ``lower``, but its state's blocks
        carry up to the frozen level with the state's normal forces; a bracket that ends there claims no more than
        the two readings give, and its width, wider than the search's tolerance, says how far they leave the limit
        (:func:`bridgefem.analysis.result.user_warnings`)."""
        if not self.agrees(lower, trial, lp_level):
            return None
        return max(trial, self.frozen_level)

    def back_at(self, lower: float, upper: float, lp_level: float) -> bool:
        """A limit that depends on the mesh: a fixed point that slides at the FE's sliding joints at the associative
        LP's level (within ``AGREEMENT``: the FE found the associative mechanism at a load its mesh moves), or a
        collapse state that the exact voussoirs' weights move by more than ``AGREEMENT`` (a limit much smaller than
        the forces that decide it, docs/joints-and-lp.md)."""
        associative = (self.converged and self.level is not None and bool(self.fe_sliding)
                       and set(self.sliding) == set(self.fe_sliding)
                       and abs(self.level - lp_level) <= AGREEMENT * lp_level)
        return associative or (self.collapse_state(lower, upper) and not self.agrees(lower, upper, lp_level)
                               and lower <= (1 + AGREEMENT) * lp_level)

    def describe(self, unit: float) -> str:
        """The check's answer in words (``unit``: N per unit level)."""
        if self.frozen_level is None:
            return "the non-associative rigid-block check finds no limit load"
        kn = unit / 1e3
        text = (f"the non-associative rigid-block check: the rigid blocks under the FE's loads with its friction "
                f"capacities (mu x its joint normal forces) collapse at {self.frozen_level * kn:.6g} kN, sliding at "
                f"joints {list(self.frozen_sliding)} (at the FE's Coulomb limit: {list(self.fe_limited)}; FE "
                f"sliding: {list(self.fe_sliding)}), hinges {list(self.frozen_hinges)}")
        if self.exact_level is not None:
            text += f"; {self.exact_level * kn:.6g} kN with the exact voussoirs' weights"
        if self.level is None:
            return text
        fixed = "its Tresca fixed point (Gilbert, Casapulla & Ahmed 2006)" + ("" if self.converged else
                                                                             f" (not reached in {self.iterations} LPs)")
        return f"{text}; {fixed} {self.level * kn:.6g} kN, sliding at joints {list(self.sliding)}"


def coulomb_limited(normal: np.ndarray, shear: np.ndarray, friction: np.ndarray, slip: np.ndarray,
                    sliding) -> tuple[int, ...]:
    """The joints among ``sliding`` whose forces are at their Coulomb limit against the slip, where the friction
    force dissipates ``mu n |slip|``: ``-shear sign(slip) >= (1 - AGREEMENT) mu normal`` (arrays over joints: normal
    and shear forces in N, the shear on the right block and its slip relative to the left one along the joint's
    tangent T of :mod:`bridgefem.limit.rigid_block`; mu)."""
    j = np.asarray(sliding, int)
    ok = -shear[j] * np.sign(slip[j]) >= (1 - AGREEMENT) * friction[j] * normal[j]
    return tuple(int(k) for k in j[ok])


def reaches(lower: float, upper: float, level: float) -> bool:
    """Whether the bracket [``lower``, ``upper``] comes within ``AGREEMENT`` of ``level`` (same unit): the FE limit,
    somewhere in its bracket, can be within that fraction of the LP's."""
    return lower <= (1 + AGREEMENT) * level and upper >= (1 - AGREEMENT) * level


@dataclass(frozen=True)
class StaticBound:
    """Evidence 4 (module docstring): the rigid-block LP on the FE's joints under the FE's own assembled block loads.
    ``level``: its collapse level (N per unit load factor; None without one); ``status``: its status; ``deficit``: the
    uniform joint tension and cohesion (N) that the FE's self-weight needs on these blocks (0: they stand;
    :func:`bridgefem.limit.rigid_block.standing_deficit`);
    ``margin``: the largest deficit that a converged FE state's tolerances can hide (N, module docstring)."""

    level: float | None
    status: str
    deficit: float
    margin: float

    @property
    def falls(self) -> bool:
        """No FE equilibrium under self-weight exists: the deficit exceeds the margin."""
        return bool(self.deficit > self.margin)

    def describe(self, unit: float) -> str:
        """The bound in words (``unit``: N per unit level)."""
        if self.falls:
            return (f"the rigid blocks under the FE's own self-weight need a joint tension and cohesion of "
                    f"{self.deficit:.4g} N, more than a converged FE state can hide ({self.margin:.3g} N): no FE "
                    "equilibrium exists (static theorem)")
        return (f"the rigid-block LP on the same joints under the FE's own loads collapses at "
                f"{self.level * unit / 1e3:.6g} kN, an upper bound on any FE equilibrium (static theorem)")


def admissible(st: Statics, sigma: np.ndarray, friction: np.ndarray, length: np.ndarray, block_force: np.ndarray,
               block_moment: np.ndarray) -> tuple[bool, str]:
    """Whether an FE state's joint resultants are statically admissible for the LP (:class:`StaticBound`) within
    the FE's tolerances (module docstring, evidence 4): ``st`` the LP's rows at the state
    (:func:`bridgefem.limit.rigid_block.statics`), ``sigma`` (nj,) the joint tolerance (N), ``friction`` mu and
    ``length`` t (m) per joint, ``block_force`` (nb,) N and ``block_moment`` (nb,) N·m the blocks' equilibrium
    tolerances. Returns the answer and the largest violation as a fraction of its tolerance, in words (a violation
    too large for a float against its tolerance, e.g. a bonded joint's Coulomb excess, is infinite: inadmissible)."""
    with np.errstate(over="ignore", divide="ignore"):
        ratios = {"net tension": st.tension / sigma, "Coulomb excess": st.friction / ((1 + friction) * sigma),
                  "thrust outside a joint": st.eccentricity / (sigma * length),
                  "block force residual": np.abs(st.equilibrium[:, :2]).max(axis=1) / block_force,
                  "block moment residual": np.abs(st.equilibrium[:, 2]) / block_moment}
    name, worst = max(((k, float(v.max(initial=-np.inf))) for k, v in ratios.items()), key=lambda kv: kv[1])
    return worst <= 1.0, f"largest violation: {name} at {worst:.3g} of its tolerance"


@dataclass(frozen=True)
class Verdict:
    """A confirmed (or refused) status text, the bracket's upper end (None: no bracket), the evidence (empty for a
    failure) and warnings for the user; ``mesh_dependent``: a failure whose mechanism is the associative LP's at a
    level the mesh moves (:meth:`SlipCheck.back_at`), which a finer mesh can settle, or a collapse state of evidence
    3 more than ``AGREEMENT`` below the associative LP (its normal forces, and so its level, move with the mesh: a
    finer one can carry more, up to the LP); ``slides``: confirmed by evidence 3, a collapse state whose mechanism
    slides."""

    status: str
    upper: float | None
    evidence: str
    warnings: tuple[str, ...] = ()
    mesh_dependent: bool = False
    slides: bool = False


def needs_slip_check(status: str, lower: float, upper: float | None, proved: bool, lp_status: str | None,
                     lp_level: float | None, fill: bool, sliding: bool) -> bool:
    """Whether a search's verdict can only be confirmed by the non-associative check: an unproven limit of a bare
    ring with sliding joints (``sliding``: at its last converged step) that the associative LP does not confirm."""
    return (Status.of(status) is Status.LIMIT and not proved and not fill and sliding and upper is not None
            and lp_status == Status.LIMIT and lp_level is not None and not reaches(lower, upper, lp_level))


def confirm(status: str, lower: float, upper: float | None, proved: bool, lp_status: str | None,
            lp_level: float | None, unit: float = 1.0, fill: bool = False, slip: SlipCheck | None = None,
            static: StaticBound | None = None, closed: bool = False, failure: str = "") -> Verdict:
    """The evidence rule (module docstring) for a search's ``status`` and bracket [``lower``, ``upper``] (levels in N
    per unit load factor), ``proved`` when its last failed step proved the mechanism, against the LP's status and
    collapse level (same unit; None when the LP failed). ``unit``: N per unit level, for the messages (kN);
    ``fill``: the bridge has a fill, which the LP carries as dead load only; ``slip``: the non-associative check of
    a limit with sliding joints (:func:`needs_slip_check`), None when it did not run; ``static``: the static bound of
    a bare ring (evidence 4, None without one) and ``closed``: the search ended on it (a limit whose upper end is
    the bound after an admissibility check, or a self-weight that the bound shows cannot stand); ``failure``: the
    reason of the search's last failed step (evidence 5 names itself there:
    :data:`bridgefem.status.RINGS_UNDER_FILL`)."""
    kind = Status.of(status)
    lp = Status.of(lp_status) if lp_status in set(Status) else None
    lp_name = "the rigid-block LP on the same joints" + (" with the fill as dead load" if fill else "")
    lp_text = (f"{lp_name} gives {lp_level * unit / 1e3:.6g} kN" if lp is Status.LIMIT
               else f"{lp_name} finds '{lp_status}'" if lp_status else "no rigid-block LP answer")
    if kind is Status.LIMIT and fill:
        evidence = ("proof: an admissible rigid-block mode on which the loads do positive work" if proved else
                    f"collapse state: {RINGS_UNDER_FILL} collapse at the bracket's upper end, and an elastic fill has "
                    "no strength to give way (evidence 5; failure_reason, ring_under_transmitted_loads)"
                    if RINGS_UNDER_FILL in failure else "the search's load-deflection curve (with a fill the LP cannot "
                    "confirm it; the conic bounds fill_bounds are the check)" if failure.startswith(FLAT_CURVE)
                    else None)
        if evidence is None:  # a mechanism without proof, which no LP can confirm under a fill
            return Verdict(Status.failure(f"unproven mechanism at {upper * unit / 1e3:.6g} kN under a fill (no "
                                          "admissible mode with positive work, no flat load-deflection curve and no "
                                          f"collapse of {RINGS_UNDER_FILL}; {lp_text} cannot confirm it: {failure})"),
                           None, "")
        below = lp is Status.LIMIT and upper < (1 - AGREEMENT) * lp_level
        return Verdict(status, upper, evidence, (f"FE limit below {lp_text}: the fill fails before "
                       "the ring (e.g. a bearing failure under the load); compare fill_bounds",) if below else ())
    if kind is Status.LIMIT and closed and lp is Status.LIMIT and reaches(lower, upper, lp_level):
        return Verdict(status, upper, f"static theorem: the FE's equilibrium at {lower * unit / 1e3:.6g} kN (its "
                       f"joint resultants checked admissible for the LP) and {static.describe(unit)}; {lp_text} with "
                       "the exact voussoirs' weights")
    if kind is Status.LIMIT:
        agrees = lp is Status.LIMIT and reaches(lower, upper, lp_level)
        above = lp is Status.LIMIT and lower > (1 + AGREEMENT) * lp_level
        if proved:
            warn = (f"FE limit above the rigid-block LP by more than {AGREEMENT:.1%} ({lp_text})",) if above else ()
            return Verdict(status, upper, "proof: an admissible rigid-block mode on which the loads do positive work",
                           warn)
        if agrees:
            return Verdict(status, upper, f"agreement: {lp_text}")
        if slip is not None and lp is Status.LIMIT and slip.agrees(lower, upper, lp_level):
            return Verdict(status, upper, f"agreement: {slip.describe(unit)}: the FE's state is that collapse "
                           f"state (with associative friction {lp_text})",
                           mesh_dependent=upper < (1 - AGREEMENT) * lp_level, slides=True)
        checked = f"; {slip.describe(unit)}" if slip is not None else ""
        if slip is not None and slip.frozen_level is not None and slip.frozen_level > (1 + AGREEMENT) * upper:
            checked += (f"; the FE stopped with a reserve of {slip.frozen_level / upper - 1:.1%} at its own friction "
                        "capacities: its state is no collapse state")
        mesh_dependent = slip is not None and lp is Status.LIMIT and slip.back_at(lower, upper, lp_level)
        if mesh_dependent:
            checked += ("; the FE's mechanism is the associative one, at a load that depends on the mesh: raise "
                        "[mesh] elements_through_thickness")
        return Verdict(Status.failure(f"unproven mechanism at {upper * unit / 1e3:.6g} kN (no admissible mode with "
                                      f"positive work, and {lp_text}{checked})"), None, "",
                       mesh_dependent=mesh_dependent)
    if kind is Status.UNSTABLE:
        if lp is Status.UNSTABLE and closed:
            return Verdict(status, upper, f"static theorem: {static.describe(unit)}; {lp_text}")
        if lp is Status.UNSTABLE:
            return Verdict(status, upper, "proof: an admissible rigid-block mode on which the self-weight does "
                           "positive work" if proved else f"agreement: {lp_text}")
        reason = "contradicted" if proved else "unproven"
        if closed:
            lp_text += f", while {static.describe(unit)}: the mesh's voussoirs weigh differently"
        return Verdict(Status.failure(f"{reason} instability under self-weight ({lp_text})"), None, "",
                       (f"the FE found a mechanism under self-weight but {lp_text}",) if proved else ())
    if kind in (Status.STABLE, Status.LOCKED):
        warn = ()
        if lp is Status.UNSTABLE:
            warn = (f"the FE stands under self-weight but {lp_text}",)
        elif kind is Status.LOCKED and lp is Status.LIMIT and lower > (1 + AGREEMENT) * lp_level and not fill:
            warn = (f"the FE carries {lower * unit / 1e3:.6g} kN, above the collapse load: {lp_text}",)
        return Verdict(status, upper, "equilibrium found", warn)
    return Verdict(status, upper, "")


def dead_load_collapse(status: str, settled: bool, fill_bounds: dict | None, lp_status: str | None) -> Verdict | None:
    """Evidence 6 (module docstring): the verdict "unstable under self-weight" of a run with a fill whose search never
    ``settled`` under self-weight and ended in a solver failure (``status``), where the kinematic programme of its
    ``fill_bounds`` (results.json's entry; None without a fill) has no feasible point; None otherwise. ``lp_status``:
    the rigid-block LP's with the fill as dead load (a warning where it stands: a limit load, or no collapse)."""
    if settled or Status.of(status) is not Status.FAILURE or not fill_bounds:
        return None
    upper = (fill_bounds.get("programmes") or {}).get("upper") or {}
    if upper.get("status") != INFEASIBLE:
        return None
    warnings = () if lp_status not in (Status.LIMIT, Status.UNBOUNDED) else (
        f"the rigid-block LP with the fill as dead load finds '{lp_status}' (its ring carries the fill as a "
        "pressure), but the bridge with its fill cannot stand: the fill gives way with the ring (fill_bounds)",)
    return Verdict(Status.UNSTABLE, 0.0, "proof: the conic bounds' kinematic programme has no feasible point, "
                   "its certificate a mechanism of the blocks and the fill on which the dead load does more work than "
                   "it dissipates (upper bound theorem; the FE's non-associative joints carry no more)", warnings)
