"""The joint law as an object: the seam between the contact solver and what a joint does.

Every joint of the FE model is a set of node pairs (:mod:`bridgefem.fe.pairs`); per pair k the unknowns are the
relative displacement d = [d_n, d_t] (m; d_n > 0 opens, right face minus left) and the force lam = [lam_n, lam_t]
(N, on the right face, for the whole width; lam_n > 0 is compression). A *joint law* says which (d, lam) a pair may
take. The solver (:mod:`bridgefem.solver.newton`) knows no law: it is given a :class:`JointLaw` object and asks it,
one method per stage of the active-set Newton method, as deal.II's step-42 asks its constitutive law object:

1. **Vocabulary.** Each pair is in one of the law's *states* (:attr:`JointLaw.STATES`, stored as int8 codes in a
   :class:`ContactState` with a slip sign): their names for the progress line and results.json (:meth:`counts`),
   their codes in the output fields (:meth:`output_codes`), and which states are closed (carry a normal force) or
   sliding (:meth:`closed`, :meth:`sliding`). :meth:`bonded` is the start: every pair closed and holding.
2. **Classify.** :meth:`classify` proposes the state of each pair from a solution (the complementarity functions of
   the law; Alart & Curnier 1991) and how far each pair is from the law it leaves (its violation, N).
3. **Assemble.** For a given active set the law is linear: :meth:`rows` and :meth:`rhs` give its two rows per pair
   in the combined system (:class:`LawRows`); :meth:`free_directions` says which directions a proximal spring may
   hold.
4. **Converge.** :meth:`residual` is zero where the law holds (N per pair and direction).
5. **Safeguards.** The solver's path choices are expressed in the law's terms: hold closed pairs (:meth:`hold`),
   bond pairs closed (:meth:`bond`), open pairs (:meth:`release`), let a reversal pass through the holding state
   (:meth:`hold_reversals`), keep a joint from sliding both ways (:meth:`hold_opposed_slips`), close the pairs of a
   repair (:meth:`repaired`), the candidate states of an exact enumeration on a few pairs (:meth:`candidates`), the
   law as a complementarity problem (:meth:`complementarity`), the law at a subset of the pairs
   (:meth:`gathered`, :meth:`tiled`) and the shear a pair carries at a given normal force (:meth:`shear_capacity`,
   for the Tresca predictor).
6. **Verdicts.** What a diverging mode may not do at each pair (:meth:`mode_rules`: which pairs a closing mode
   penetrates, which slips run against the friction force, and the tension an open pair still carries, which a
   proof's load work must exceed) and the forces of the sliding rows (:meth:`sliding_forces`), for
   :mod:`bridgefem.solver.mechanism`.
7. **Limit analysis.** The law's yield conditions on a rigid-block joint's resultants (:meth:`block_yield`), the
   rows of the rigid-block LP and of the conic bounds (:mod:`bridgefem.limit`).

:class:`bridgefem.laws.coulomb.CoulombJoints` (unilateral contact, Coulomb friction) is the first law; a new law
(crushing, a tensile strength: ``tests/test_joint_law_seam.py``) is one more subclass and touches no other module.
The scene chooses the law (:func:`bridgefem.laws.crushing.scene_law`): the rigid-block LP, its deficit programmes
(:meth:`BlockYield.relaxations`), the static theorem's check (:meth:`JointLaw.moment_capacity`) and the conic bounds
take the scene's; an injected factory (``run_analysis(..., joint_law=...)``) changes the FE's law only. Still
Coulomb's, whatever law the solver is given: the Tresca fixed point's frozen shear rows (they replace the law's
shear rows and keep its others) and the Tresca predictor (:mod:`bridgefem.solver.tresca`: no crushing).
"""
from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, ClassVar, NamedTuple, TypeVar

import numpy as np

if TYPE_CHECKING:  # the laws run on numpy arrays; only their collective helpers are given a communicator
    from mpi4py import MPI

Law = TypeVar("Law", bound="JointLaw")


@dataclass
class ContactState:
    """The active set of this rank's pairs: ``state``, the law's state code of each pair (int8), and ``sign``, the
    slip sign (+1 / -1) of a sliding pair (for Coulomb's law also of an open pair with cohesion whose shear slides;
    2 for a released pair, :meth:`JointLaw.release`), 0 otherwise."""

    state: np.ndarray
    sign: np.ndarray

    def copy(self) -> "ContactState":
        return ContactState(self.state.copy(), self.sign.copy())

    def key(self) -> bytes:
        """The set's identity on this rank (the solver joins the ranks' keys)."""
        return self.state.tobytes() + self.sign.tobytes()

    def differs(self, other: "ContactState") -> np.ndarray:
        """The pairs whose state or slip sign differs between this set and ``other``."""
        return (self.state != other.state) | (self.sign != other.sign)


class LawRows(NamedTuple):
    """The two rows of a pair's law in the linear system of an active set (per local pair), with G the relative
    displacement operator and c the Alart-Curnier constant:

        normal:     a_n c G_n u + b_n lam_n              = r_n
        tangential: a_t c G_t u + b_t lam_t + e_t lam_n  = r_t
    """

    a_n: np.ndarray
    a_t: np.ndarray
    b_n: np.ndarray
    b_t: np.ndarray
    e_t: np.ndarray


class ModeRules(NamedTuple):
    """What a diverging mode may not do at the pairs of an active set (:func:`bridgefem.solver.mechanism.judge`):
    ``open``, the pairs whose normal direction is free (a mode closing one of them interpenetrates);
    ``backwards``, per pair the factor f such that f d_t > 0 is a slip against the pair's friction force (the friction
    work per unit normal force, mu s), NaN where the pair follows no slip law; ``rough``, the pairs with friction
    (mu > 0: a hinge mode may not slip them); ``tension``, the tension (N) an open pair still carries, whose work on
    the mode's opening the loads must exceed for a proof of collapse (0 for no-tension joints); ``crushing``, the
    compression (N) a crushed pair carries while the mode may close it further (its work on the closing is dissipated
    too; None: no pair crushes)."""

    open: np.ndarray
    backwards: np.ndarray
    rough: np.ndarray
    tension: np.ndarray
    crushing: np.ndarray | None = None


class BlockYield(NamedTuple):
    """A law's yield conditions on the resultants q = (n, s, m) of rigid-block joints (N, N, N m; the rows of
    :mod:`bridgefem.limit.rigid_block`): per joint j, ``k`` inequalities sum_i vals[j, i] q[j, cols[i]] <= rhs[j, row]
    for the entries i of ``rows[i]`` (the same pattern for every joint, ``cols`` 0: n, 1: s, 2: m), and the least
    normal force ``n_min`` (N, per joint)."""

    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    rhs: np.ndarray
    n_min: np.ndarray

    @property
    def per_joint(self) -> int:
        """The inequalities of one joint."""
        return int(self.rows.max()) + 1

    def relaxations(self) -> tuple[np.ndarray, np.ndarray]:
        """Per joint and row (nj, k), the coefficient of the deficit tau (N) of the dead-load programmes
        (:mod:`bridgefem.limit.rigid_block`): every row on the moment relaxed by tau at the joint's edge, the
        largest |coefficient of n| of its moment rows (t/2: for Coulomb |m| <= (n + tau) t/2; with crushing the
        whole polygon raised by tau t/2, n <= N_c + tau among its rows), any other row by the cohesion tau (-1);
        and the same with the normal force n = nu - tau written in nu >= 0 (the net tension tau allowed)."""
        nj, k = self.vals.shape[0], self.per_joint
        normal, moment = np.zeros((nj, k)), np.zeros(k, dtype=bool)
        for i, (row, col) in enumerate(zip(self.rows, self.cols)):
            if col == 0:
                normal[:, row] += self.vals[:, i]
            moment[row] |= col == 2
        edge = np.max(np.abs(normal), axis=1, where=moment, initial=0.0)[:, None]
        deficit = np.where(moment, -edge, -1.0)
        return deficit, deficit - normal


def joint_counts(joint: np.ndarray, masks: tuple[np.ndarray, ...], comm: MPI.Comm) -> np.ndarray:
    """For each local pair mask, the number of its pairs per ring joint over all ranks ((masks, joints); ids
    ``joint``, the arch-fill interface's negative id left out). Collective."""
    ring = joint >= 0
    n = max(comm.allgather(int(joint.max(initial=-1)))) + 1
    return comm.allreduce(np.stack([np.bincount(joint[ring & m], minlength=n) for m in masks]))


@dataclass
class JointLaw(ABC):
    """A joint law at this rank's pairs (module docstring): the Coulomb coefficients ``mu`` (per pair), the
    Alart-Curnier constants ``c`` (N/m per pair), which weigh forces against displacements when the active set is
    classified, and the hysteresis ``force_tol`` (N) within which a pair carrying no force keeps its state;
    ``scene_mu``, the scene's coefficients (default: ``mu``), which :meth:`set_friction_factor` scales. Every per-pair
    field is an array; :meth:`gathered` and :meth:`tiled` map them all."""

    mu: np.ndarray
    c: np.ndarray
    force_tol: float
    scene_mu: np.ndarray | None = None
    friction_factor: float = 1.0

    STATES: ClassVar[tuple[str, ...]] = ()
    """The names of the states, indexed by their codes (the progress line, results.json)."""
    OUTPUT_CODES: ClassVar[dict[str, int]] = {}
    """The code of each state in the output fields (0 is a node on no joint)."""

    def __post_init__(self) -> None:
        if self.scene_mu is None:
            self.scene_mu = self.mu.copy()

    # ----------------------------------------------------------------- 1. vocabulary
    def counts(self, active: ContactState, comm: MPI.Comm) -> dict[str, int]:
        """The number of pairs in each state over all ranks, by the state's name. Collective."""
        total = comm.allreduce(np.bincount(active.state, minlength=len(self.STATES)))
        return {name: int(total[code]) for code, name in enumerate(self.STATES)}

    def output_codes(self) -> np.ndarray:
        """The output code of each state code (int32)."""
        return np.array([self.OUTPUT_CODES[name] for name in self.STATES], dtype=np.int32)

    @abstractmethod
    def closed(self, active: ContactState) -> np.ndarray:
        """The pairs in contact: their normal row keeps the gap and they may carry a normal force."""

    @abstractmethod
    def sliding(self, active: ContactState) -> np.ndarray:
        """The closed pairs on their slip branch (sign ``active.sign``)."""

    def crushed(self, active: ContactState) -> np.ndarray:
        """The closed pairs whose normal force has reached the law's compressive bound (none: the joints are
        infinitely strong in compression)."""
        return np.zeros(len(active.state), dtype=bool)

    @property
    def crushes(self) -> bool:
        """Whether the law has a compressive strength (:meth:`stress_block_depth`)."""
        return self.stress_block_depth(1.0) is not None

    def stress_block_depth(self, normal_force: float) -> float | None:
        """The depth (m) of the rectangular stress block at the compressive strength that carries ``normal_force``
        (N) over the joints' width, N / (f_c w); None for a law without a compressive strength."""
        return None

    @abstractmethod
    def bonded(self, n: int) -> ContactState:
        """``n`` pairs closed and holding (the start of the self-weight step)."""

    # ----------------------------------------------------------------- 2.-4. classify, assemble, converge
    @abstractmethod
    def classify(self, prev: ContactState, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray
                 ) -> tuple[ContactState, np.ndarray]:
        """The active set the law proposes for forces ``lam`` (N) and relative displacements ``d`` (m), each (m, 2),
        from the set ``prev`` (hysteresis), with ``slip_ref`` the tangential displacement of the last converged step;
        and each pair's violation (N) of the law it leaves, which ranks the changes when they are damped."""

    @abstractmethod
    def residual(self, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray) -> np.ndarray:
        """The law's residual (N, (m, 2): normal, tangential), zero where it holds."""

    @abstractmethod
    def rows(self, active: ContactState) -> LawRows:
        """The law's rows for an active set (:class:`LawRows`)."""

    @abstractmethod
    def rhs(self, active: ContactState, slip_ref: np.ndarray, ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The right-hand sides (r_n, r_t) of the rows, with d = G u + ``ground`` (imposed ground movement, m)."""

    @abstractmethod
    def free_directions(self, active: ContactState) -> tuple[np.ndarray, np.ndarray]:
        """The pairs whose normal / tangential row imposes no displacement (the directions a proximal term holds)."""

    # ----------------------------------------------------------------- 5. the solver's safeguards
    @abstractmethod
    def hold(self, active: ContactState, pairs: np.ndarray) -> None:
        """The closed ones of ``pairs`` keep their tangential position (they hold); open ones stay open. In place."""

    @abstractmethod
    def bond(self, active: ContactState, pairs: np.ndarray) -> None:
        """``pairs`` closed and holding, whatever their state. In place."""

    @abstractmethod
    def release(self, active: ContactState, pairs: np.ndarray) -> None:
        """``pairs`` open, whatever their state (a cycle's condensation applies their forces itself). In place."""

    @abstractmethod
    def hold_reversals(self, new: ContactState, old: ContactState) -> None:
        """The pairs of ``new`` that reverse a slip of ``old`` hold instead. In place."""

    @abstractmethod
    def hold_opposed_slips(self, new: ContactState, old: ContactState, joint: np.ndarray, comm: MPI.Comm) -> None:
        """On a ring joint (ids ``joint``) proposed to slide both ways at once, the pairs that keep ``old``'s slip
        hold. In place; collective."""

    @abstractmethod
    def repaired(self, active: ContactState, repair: np.ndarray, joint: np.ndarray, comm: MPI.Comm
                 ) -> ContactState:
        """``active`` with the ``repair`` pairs closed (a mode pushed them into each other). Collective."""

    @abstractmethod
    def candidates(self) -> tuple[tuple[int, int], ...]:
        """Every (state, slip sign) a pair may take, for an exact enumeration on a few pairs."""

    def complementarity(self, d0: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The law on the pairs of ``d = d0 + C lam`` as a linear complementarity problem (M, q), or None: a law
        without one is condensed by enumeration only (:mod:`bridgefem.solver.condensation`)."""
        return None

    def lcp_state(self, z: np.ndarray, tol: float) -> ContactState:
        """The active set of a solution z of :meth:`complementarity` (entries below ``tol`` are zero)."""
        raise TypeError(f"{type(self).__name__} has no complementarity problem")

    def gathered(self: Law, pairs: np.ndarray, comm: MPI.Comm) -> Law:
        """The law at the ``pairs`` (a local mask) of every rank, in global order. Collective."""
        return self._mapped(lambda a: np.concatenate(comm.allgather(a[pairs])))

    def tiled(self: Law, n: int) -> Law:
        """The law at its pairs repeated ``n`` times (n combinations of their states at once)."""
        return self._mapped(lambda a: np.tile(a, n))

    def _mapped(self: Law, take: Callable[[np.ndarray], np.ndarray]) -> Law:
        """This law with every per-pair array mapped by ``take``."""
        return dataclasses.replace(self, **{f.name: take(getattr(self, f.name)) for f in dataclasses.fields(self)
                                            if isinstance(getattr(self, f.name), np.ndarray)})

    def scale_constants(self, factor: float) -> None:
        """The Alart-Curnier constants multiplied by ``factor`` (a retry's setting)."""
        self.c = self.c * factor

    def shear_capacity(self, normal: np.ndarray) -> np.ndarray:
        """The shear (N) each pair carries before it slides under the normal forces ``normal`` (N, compression
        positive): mu max(n, 0) here; a law with cohesion adds it. The Tresca fixed point's capacities
        (:mod:`bridgefem.solver.tresca`)."""
        return self.mu * np.maximum(normal, 0.0)

    def set_friction_factor(self, factor: float) -> None:
        """The Coulomb coefficients ``factor`` x the scene's from now on (the self-weight's friction continuation)."""
        self.mu, self.friction_factor = factor * self.scene_mu, factor

    # ----------------------------------------------------------------- 6. verdicts
    @abstractmethod
    def mode_rules(self, active: ContactState) -> ModeRules:
        """What a diverging mode of ``active``'s system may not do at each pair (:class:`ModeRules`)."""

    @abstractmethod
    def sliding_forces(self, active: ContactState, lam_n: np.ndarray) -> np.ndarray:
        """The tangential forces (N) the sliding rows of ``active`` impose for normal forces ``lam_n``; 0 elsewhere."""

    # ----------------------------------------------------------------- 7. limit analysis
    @abstractmethod
    def moment_capacity(self, length: np.ndarray, n: np.ndarray) -> np.ndarray:
        """The largest |m| (N m) that the law's rows let rigid-block joints of ``length`` (m) carry at normal forces
        ``n`` (N) (the static theorem's check, :func:`bridgefem.limit.rigid_block.statics`)."""

    @abstractmethod
    def block_yield(self, length: np.ndarray, mu: np.ndarray, capacity: np.ndarray) -> BlockYield:
        """The yield conditions of rigid-block joints of ``length`` (m) and Coulomb coefficients ``mu``, with an
        added shear ``capacity`` (N; the Tresca fixed point's fixed capacities)."""

    @classmethod
    def conic(cls) -> "type[JointLaw] | JointLaw":
        """The law of the conic bounds' joints (:func:`bridgefem.limit.bounds_model.joint_rows`): its linear rows
        (:meth:`block_yield`) with its cones (:meth:`block_cones`) there; the law itself where its rows are exact."""
        return cls

    @classmethod
    def block_cones(cls, length: np.ndarray) -> tuple[np.ndarray, ...] | None:
        """Second-order cones on the resultants of rigid-block joints of ``length`` (m): per joint the local rows,
        columns (0: n, 1: s, 2: m), values and right-hand sides of consecutive triples (s_0 >= |(s_1, s_2)| for
        s = rhs - A q, :meth:`bridgefem.limit.conic.ConicProgramme.add`); None: no cones."""
        return None
