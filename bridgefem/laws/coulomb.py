"""Unilateral contact with Coulomb friction at every joint pair: the first joint law (:mod:`bridgefem.laws.base`).

Per pair, with d = [d_n, d_t] (m; d_n > 0 opens) and lam = [lam_n, lam_t] (N; lam_n > 0 compression) as in
:mod:`bridgefem.fe.pairs` (the seed paper, eqs. 1-6):

    d_n >= 0,  lam_n >= 0,  lam_n d_n = 0                          (no penetration, no tension)
    |lam_t| <= mu lam_n + k;  Delta d_t = 0 while |lam_t| < mu lam_n + k;
    lam_t = -(mu lam_n + k) sign(Delta d_t) when it slips

with Delta d_t the slip since the last converged load step (``slip_ref``: incremental friction, path following) and
the pair's cohesion k (N; zero but on the ring interfaces of a scene with ``[joints] ring_cohesion``: k = that
cohesion (Pa) x the width x the pair's tributary length, :meth:`CoulombJoints.for_pairs`): the shear a pair carries
at no normal force. It holds no tension, and the shear bound is the same open or closed: a Mohr-Coulomb line with a
tension cut-off at zero, the convex set of the rigid-block rows |s| <= mu n + k, n >= 0 (an opening cohesive pair
keeps its shear strength k; without cohesion an open pair carries no force at all).

**States.** ``OPEN`` (lam_n = 0), ``STICK`` (closed: d_n and Delta d_t held) and ``SLIP`` (closed, lam_t = s (mu lam_n
+ k) with the slip sign s: the slip goes the other way, -s). The slip sign also gives an open pair's shear: an open
pair with cohesion holds Delta d_t with sign 0 and slides with lam_t = s k with sign s; without cohesion it carries
lam_t = 0 (sign 0). Sign ``RELEASED`` marks a pair free in both directions (:meth:`CoulombJoints.release`).

**Classification** (Alart & Curnier 1991, *A mixed formulation for frictional contact problems prone to Newton like
solution methods*, CMAME 92): with the constant c (N/m per pair)

    sigma_n = lam_n - c d_n,   sigma_t = lam_t - c Delta d_t

a pair is closed iff sigma_n > 0 and slips iff |sigma_t| > mu sigma_n + k, in the direction s = sign(sigma_t). The
law holds iff lam_n = max(sigma_n, 0) and lam_t = clip(sigma_t, -b, b) with the shear bound b = mu lam_n + k
(:meth:`CoulombJoints.residual`):
a semismooth equation, whose Newton method is the primal-dual active-set method (Hintermüller, Ito & Kunisch 2002,
SIAM J. Optim. 13; with Coulomb friction Hüeber, Stadler & Wohlmuth 2008, SIAM J. Sci. Comput. 30). A hysteresis of ``force_tol`` keeps a pair that carries no
force from chattering between states.

**The safeguards' operations** on the Coulomb states: holding a closed pair is sticking it; a reversed slip passes
through stick (the incremental law is a monotone graph: slip one way, stick, slip the other way); a joint is
*sliding* when every closed pair of it outside some held ones slips one way (:meth:`CoulombJoints.sliding_joints`),
and a repair closes an open pair on a sliding joint sliding with it, others sticking (a new contact on a joint
that slides slides with it).

**Rigid-block rows** (:meth:`CoulombJoints.block_yield`): a joint of length t with resultants (n, s, m) carries no
tension, its thrust lies within it and it obeys Coulomb's law: |m| <= n t / 2, |s| <= mu n + capacity, n >= 0
(the rows of the rigid-block LP, Gilbert & Melbourne 1994, and of the conic bounds).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI

from .base import BlockYield, ContactState, JointLaw, LawRows, ModeRules, joint_counts


@dataclass
class CoulombJoints(JointLaw):
    """Unilateral contact with Coulomb friction at every pair (module docstring), with the Coulomb coefficients
    ``mu``, the Alart-Curnier constants ``c`` (N/m per pair), a hysteresis ``force_tol`` (N) against chattering and
    the ``cohesion`` k (N per pair; None: none)."""

    cohesion: np.ndarray | None = None

    OPEN: ClassVar[int] = 0
    STICK: ClassVar[int] = 1
    SLIP: ClassVar[int] = 2
    STATES: ClassVar[tuple[str, ...]] = ("open", "stick", "slip")
    OUTPUT_CODES: ClassVar[dict[str, int]] = {"stick": 1, "slip": 2, "open": 3}
    CANDIDATES: ClassVar[tuple[tuple[int, int], ...]] = ((OPEN, 0), (STICK, 0), (SLIP, 1), (SLIP, -1))
    """(state, slip sign) each pair may take: open, stick, slip +, slip -."""
    OPEN_SLIDES: ClassVar[tuple[tuple[int, int], ...]] = ((OPEN, 1), (OPEN, -1))
    """The candidates an open pair with cohesion adds: open and sliding either way."""
    RELEASED: ClassVar[int] = 2
    """The slip sign of a released pair: free in both directions."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.cohesion is None:
            self.cohesion = np.zeros(len(self.mu))

    @classmethod
    def for_pairs(cls, pairs, friction: float | np.ndarray, c: np.ndarray, force_tol: float, *,
                  ring_cohesion: float = 0.0, width: float = 1.0) -> "CoulombJoints":
        """The law at ``pairs`` (a :class:`bridgefem.fe.pairs.JointPairs`) with the Coulomb coefficient(s)
        ``friction`` (one, or one per pair), the Alart-Curnier constants ``c`` and the hysteresis ``force_tol``; the
        pairs of the ring interfaces (kind "ring") have the cohesion k = ``ring_cohesion`` (Pa) x ``width`` (m) x
        their tributary length, the others none."""
        law = cls(np.broadcast_to(np.asarray(friction, dtype=float), (len(pairs),)).copy(), c, force_tol)
        if ring_cohesion:
            law.cohesion = ring_cohesion * width * np.where(pairs.kind == "ring", pairs.length, 0.0)
        return law

    # ----------------------------------------------------------------- vocabulary
    def closed(self, active: ContactState) -> np.ndarray:
        return active.state != self.OPEN

    def sliding(self, active: ContactState) -> np.ndarray:
        return active.state == self.SLIP

    @classmethod
    def bonded(cls, n: int) -> ContactState:
        """``n`` pairs closed and sticking."""
        return ContactState(np.full(n, cls.STICK, dtype=np.int8), np.zeros(n, dtype=np.int8))

    # ----------------------------------------------------------------- classify, assemble, converge
    def classify(self, prev: ContactState, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray
                 ) -> tuple[ContactState, np.ndarray]:
        """New active set from the Alart-Curnier functions, with a hysteresis of ``force_tol`` so that pairs carrying
        no force do not chatter between states. ``lam``, ``d``: (m, 2) arrays; ``slip_ref``: d_t at the last
        converged step. Also returns each pair's violation (N), which ranks changes for damping: how far the pair
        is from the law it leaves, |sigma_n| for a pair that opens or closes, the friction cone's excess or slack
        | |sigma_t| - mu sigma_n | for a closed pair (a change of its friction state); a closed pair's |sigma_n| is its
        normal force, which would rank the most compressed pairs first rather than the most violated ones."""
        sig_n = lam[:, 0] - self.c * d[:, 0]
        sig_t = lam[:, 1] - self.c * (d[:, 1] - slip_ref)
        tol = self.force_tol
        was_closed = prev.state != self.OPEN
        closed = np.where(was_closed, sig_n >= -tol, sig_n > tol)
        excess = np.abs(sig_t) - self.shear_capacity(sig_n)
        was_slip = np.abs(prev.sign) == 1
        sign = np.sign(sig_t).astype(np.int8)
        reversed_slip = was_slip & (sign != prev.sign)
        slip = np.where(was_slip & ~reversed_slip, excess > -tol, excess > tol)
        state = np.where(~closed, self.OPEN, np.where(slip, self.SLIP, self.STICK)).astype(np.int8)
        violation = np.where(closed != was_closed, np.abs(sig_n), np.abs(excess))
        shears = closed | (self.cohesion > 0)
        return ContactState(state, np.where(slip & shears, sign, 0).astype(np.int8)), violation

    def residual(self, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray) -> np.ndarray:
        """Alart-Curnier residual (N) per pair: zero iff the law holds."""
        return self._residual(lam, d, slip_ref, np.inf)

    def _residual(self, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray, capacity) -> np.ndarray:
        """The residual (N) with the normal force projected on [0, ``capacity``] (N) and the shear on the bound
        mu lam_n + k (module docstring)."""
        sig_n = np.clip(lam[:, 0] - self.c * d[:, 0], 0.0, capacity)
        bound = self.shear_capacity(sig_n)
        sig_t = lam[:, 1] - self.c * (d[:, 1] - slip_ref)
        return np.column_stack([lam[:, 0] - sig_n, lam[:, 1] - np.clip(sig_t, -bound, bound)])

    def rows(self, active: ContactState) -> LawRows:
        """The law's rows for an active set: closed pairs keep d_n (open ones carry lam_n = 0), sticking pairs keep
        d_t, sliding pairs carry lam_t = s (mu lam_n + k) (open ones lam_t = 0; the s k in :meth:`rhs`)."""
        closed, stick = active.state != self.OPEN, self._holding(active)
        return LawRows(closed.astype(float), stick.astype(float), (~closed).astype(float), (~stick).astype(float),
                       -self.mu * active.sign * (active.state == self.SLIP))

    def rhs(self, active: ContactState, slip_ref: np.ndarray, ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Right-hand sides (r_n, r_t) of the rows: a closed pair's gap and a sticking pair's slip stay those of the
        last converged step, d = G u + ``ground`` (the imposed ground movement, m, (m, 2)); a sliding pair's shear
        has the cohesion's part s k (N)."""
        return (np.where(active.state != self.OPEN, -self.c * ground[:, 0], 0.0), self._shear_rhs(active, slip_ref,
                                                                                                    ground))

    def _shear_rhs(self, active: ContactState, slip_ref: np.ndarray, ground: np.ndarray) -> np.ndarray:
        """r_t: c (slip_ref - ground_t) at the holding pairs, s k at the sliding ones (open or closed), 0 elsewhere."""
        return np.where(self._holding(active), self.c * (slip_ref - ground[:, 1]),
                        np.where(self._slides(active), active.sign * self.cohesion, 0.0))

    def _sticking(self, state: np.ndarray) -> np.ndarray:
        """The closed pairs whose shear row holds d_t."""
        return state == self.STICK

    def _holding(self, active: ContactState) -> np.ndarray:
        """The pairs whose shear row holds d_t: the sticking ones and the open ones with cohesion and sign 0."""
        cohesive_open = (active.state == self.OPEN) & (self.cohesion > 0)
        return self._sticking(active.state) | (cohesive_open & (active.sign == 0))

    def _slides(self, active: ContactState) -> np.ndarray:
        """The pairs whose shear is on its bound, s (mu lam_n + k): the sliding ones and the open ones with cohesion
        and a slip sign."""
        return np.abs(active.sign) == 1

    def free_directions(self, active: ContactState) -> tuple[np.ndarray, np.ndarray]:
        """Open pairs are free normally, all but the holding ones (:meth:`_holding`) tangentially."""
        return active.state == self.OPEN, ~self._holding(active)

    # ----------------------------------------------------------------- the solver's safeguards
    def shear_capacity(self, normal: np.ndarray) -> np.ndarray:
        """mu max(n, 0) + k (N): friction and the pair's cohesion, which an open pair keeps."""
        return self.mu * np.maximum(normal, 0.0) + self.cohesion

    def hold(self, active: ContactState, pairs: np.ndarray) -> None:
        """The closed ones of ``pairs`` stick; open ones stay open, holding their shear if they have cohesion."""
        fix = pairs & (active.state != self.OPEN)
        active.state[fix] = self.STICK
        active.sign[pairs] = 0

    def bond(self, active: ContactState, pairs: np.ndarray) -> None:
        """``pairs`` closed and sticking."""
        active.state[pairs], active.sign[pairs] = self.STICK, 0

    def release(self, active: ContactState, pairs: np.ndarray) -> None:
        """``pairs`` open and free in both directions (sign ``RELEASED``), whatever their cohesion."""
        active.state[pairs], active.sign[pairs] = self.OPEN, self.RELEASED

    def hold_reversals(self, new: ContactState, old: ContactState) -> None:
        """A pair that slid in ``old`` and is proposed to slide the other way sticks instead: the reversal passes
        through stick, and the next classification proposes the reversed slip if the stick force leaves the cone."""
        reversed_slip = self._slides(old) & self._slides(new) & (new.sign != old.sign)
        new.sign[reversed_slip] = 0
        new.state[reversed_slip & (new.state == self.SLIP)] = self.STICK

    def hold_opposed_slips(self, new: ContactState, old: ContactState, joint: np.ndarray, comm: MPI.Comm) -> None:
        """The pairs of ``new`` that still slip as in ``old`` on a ring joint whose closed pairs all slip, some
        starting to slip (or reversing) one way and these the other way, stick (:meth:`opposed_slips`)."""
        opposed = self.opposed_slips(new, old, joint, comm)
        new.state[opposed], new.sign[opposed] = self.STICK, 0

    @classmethod
    def opposed_slips(cls, new: ContactState, old: ContactState, joint: np.ndarray, comm: MPI.Comm) -> np.ndarray:
        """The local pairs of the proposed set ``new`` that still slip as in ``old`` on a ring joint (ids ``joint``)
        whose closed pairs all slip, the ones that start slipping (or reverse) one way and these the other way: a
        joint sliding both ways at once, its friction forces cancelling. Collective."""
        ring = joint >= 0
        slips = ring & (new.state == cls.SLIP)
        kept = slips & (old.state == cls.SLIP) & (old.sign == new.sign)
        closed = ring & (new.state != cls.OPEN)
        up, down = slips & (new.sign > 0), slips & (new.sign < 0)
        counts = joint_counts(joint, (closed, up, down, up & ~kept, down & ~kept), comm)
        total, n_up, n_down, new_up, new_down = counts
        all_slip = (total > 0) & (n_up + n_down == total)
        old_down = all_slip & (new_up == n_up) & (new_up > 0) & (new_down == 0) & (n_down > 0)  # new +, old -
        old_up = all_slip & (new_down == n_down) & (new_down > 0) & (new_up == 0) & (n_up > 0)  # new -, old +
        at = np.maximum(joint, 0)
        return ring & kept & ((down & old_down[at]) | (up & old_up[at]))

    @classmethod
    def sliding_joints(cls, active: ContactState, joint: np.ndarray, held: np.ndarray, comm: MPI.Comm) -> np.ndarray:
        """Per local pair (ring joint ids ``joint``), the slip sign (+1/-1) of its joint when every closed pair of
        that joint outside the mask ``held`` (at least one) slips that way, else 0; 0 on the arch-fill interface.
        Collective: a joint's pairs may lie on several ranks."""
        ring = joint >= 0
        closed = ring & (active.state != cls.OPEN) & ~held
        slips = closed & (active.state == cls.SLIP)
        counts = joint_counts(joint, (closed, slips & (active.sign > 0), slips & (active.sign < 0)), comm)
        sliding = counts[0] > 0
        sign = np.where(sliding & (counts[1] == counts[0]), 1, np.where(sliding & (counts[2] == counts[0]), -1, 0))
        return np.where(ring, sign[np.maximum(joint, 0)], 0).astype(np.int8)

    def repaired(self, active: ContactState, repair: np.ndarray, joint: np.ndarray, comm: MPI.Comm
                 ) -> ContactState:
        """``active`` with the ``repair`` pairs closed and sticking, except that an open one on a sliding joint
        (:meth:`sliding_joints`) closes sliding with it. Collective."""
        fixed = active.copy()
        fixed.state[repair], fixed.sign[repair] = self.STICK, 0
        slide = self.sliding_joints(active, joint, repair, comm)
        closing = repair & (active.state == self.OPEN) & (slide != 0)
        fixed.state[closing], fixed.sign[closing] = self.SLIP, slide[closing]
        return fixed

    def candidates(self) -> tuple[tuple[int, int], ...]:
        """:data:`CANDIDATES`, and with cohesion at some pair :data:`OPEN_SLIDES` (an open state the others may not
        take: their rows are those of open)."""
        return self.CANDIDATES + (self.OPEN_SLIDES if np.any(self.cohesion > 0) else ())

    def complementarity(self, d0: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The law at the pairs on ``d = d0 + C lam`` as the LCP ``w = q + M z``, w, z >= 0, w z = 0 (Stewart &
        Trinkle 1996; exact in 2-D), (M (4p, 4p), q (4p,)), unknowns per pair (lam_n, lam_+, lam_-, beta) with
        lam_t = lam_+ - lam_- and the slip magnitude beta:

            d_n                          >= 0  _|_  lam_n >= 0   (contact)
            Delta d_t + beta             >= 0  _|_  lam_+ >= 0   (lam_t = +(mu lam_n + k) only when slipping by -beta)
            -Delta d_t + beta            >= 0  _|_  lam_- >= 0   (lam_t = -(mu lam_n + k) only when slipping by +beta)
            mu lam_n + k - lam_+ - lam_- >= 0  _|_  beta  >= 0   (slip only on the friction bound)

        equilibrated: each force component i is measured in units of 1 / sqrt(|C_ii|) N and each displacement in
        sqrt(|C_ii|) m, so that the compliance has a unit diagonal (a pair that is nearly a mechanism has C_nn a
        million times C_tt), the friction coefficient becomes mu sqrt(|C_tt| / |C_nn|) per pair, and q is divided by
        its largest entry (the problem is homogeneous in (q, z)). The solution's zero pattern, hence its active set,
        is that of the unscaled problem."""
        p = len(d0)
        scale = 1.0 / np.sqrt(np.maximum(np.abs(np.diag(C)), 1e-300))  # N per unit force, per pair and direction
        compliance = scale[:, None] * C * scale[None, :]
        expand = np.zeros((2 * p, 4 * p))  # lam = expand z
        k = np.arange(p)
        expand[2 * k, 4 * k] = 1.0
        expand[2 * k + 1, 4 * k + 1], expand[2 * k + 1, 4 * k + 2] = 1.0, -1.0
        A = compliance @ expand
        M = np.zeros((4 * p, 4 * p))
        M[0::4], M[1::4], M[2::4] = A[0::2], A[1::2], -A[1::2]
        M[4 * k + 1, 4 * k + 3] = M[4 * k + 2, 4 * k + 3] = 1.0
        M[4 * k + 3, 4 * k] = self.mu * scale[0::2] / scale[1::2]
        M[4 * k + 3, 4 * k + 1] = M[4 * k + 3, 4 * k + 2] = -1.0
        q = np.zeros(4 * p)
        gap = scale.reshape(p, 2) * d0
        q[0::4], q[1::4], q[2::4] = gap[:, 0], gap[:, 1], -gap[:, 1]
        q[3::4] = self.cohesion / scale[1::2]  # k in the shear's unit
        return M, q / max(np.abs(q).max(), 1e-300)

    def lcp_state(self, z: np.ndarray, tol: float) -> ContactState:
        """Closed where lam_n > ``tol``, sliding where beta > ``tol`` with the sign of lam_t (open pairs too, where
        they have cohesion)."""
        lam_n, lam_t, beta = z[0::4], z[1::4] - z[2::4], z[3::4]
        closed, slip = lam_n > tol, beta > tol
        state = np.where(~closed, self.OPEN, np.where(slip, self.SLIP, self.STICK)).astype(np.int8)
        shears = closed | (self.cohesion > 0)
        return ContactState(state, np.where(slip & shears, np.sign(lam_t), 0).astype(np.int8))

    # ----------------------------------------------------------------- verdicts
    def mode_rules(self, active: ContactState) -> ModeRules:
        """A mode may not close an open pair, nor slip a sliding pair (open or closed) against its friction force:
        s d_t > 0 (the slip law assumes a slip of sign -s), measured by mu s d_t, the friction's work per unit normal
        force (mu = 0 pairs slip freely), and on a cohesive pair by at least s d_t (its cohesion works on any slip).
        Pairs with friction or cohesion are rough: a hinge mode may not slip them. An open pair carries no
        tension."""
        factor = np.where(self.cohesion > 0, np.maximum(self.mu, 1.0), self.mu)
        return ModeRules(active.state == self.OPEN, np.where(self._slides(active), factor * active.sign, np.nan),
                         (self.mu > 0) | (self.cohesion > 0), np.zeros(len(active.state)))

    def sliding_forces(self, active: ContactState, lam_n: np.ndarray) -> np.ndarray:
        """lam_t = s (mu lam_n + k) at the sliding pairs, open or closed."""
        return np.where(self._slides(active), active.sign * (self.mu * lam_n + self.cohesion), 0.0)

    # ----------------------------------------------------------------- limit analysis
    @classmethod
    def moment_capacity(cls, length: np.ndarray, n: np.ndarray) -> np.ndarray:
        """|m| <= n t/2: the thrust within the joint."""
        return n * length / 2

    @classmethod
    def block_yield(cls, length: np.ndarray, mu: np.ndarray, capacity: np.ndarray) -> BlockYield:
        """Per joint the rows +-m - n t/2 <= 0 and +-s - mu n <= capacity, and n >= 0 (module docstring)."""
        n = len(length)
        one, half = np.ones(n), length / 2
        rhs = np.zeros((n, 4))
        rhs[:, 2] = rhs[:, 3] = capacity
        return BlockYield(np.array([0, 0, 1, 1, 2, 2, 3, 3]), np.array([2, 0, 2, 0, 1, 0, 1, 0]),
                          np.column_stack([one, -half, -one, -half, one, -mu, -one, -mu]), rhs, np.zeros(n))
