"""TODO docstring"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

OPEN, STICK, SLIP = 0, 1, 2


@dataclass
class ContactState:
    """Active set of the local pairs: ``state`` in {OPEN, STICK, SLIP} and the slip sign (+1/-1) for SLIP."""

    state: np.ndarray
    sign: np.ndarray

    @classmethod
    def all_stick(cls, n: int) -> "ContactState":
        return cls(np.full(n, STICK, dtype=np.int8), np.zeros(n, dtype=np.int8))

    def copy(self) -> "ContactState":
        return ContactState(self.state.copy(), self.sign.copy())

    def key(self) -> bytes:
        return self.state.tobytes() + self.sign.tobytes()

    def sliding_joints(self, joint: np.ndarray, held: np.ndarray, comm: MPI.Comm) -> np.ndarray:
        """Per local pair (ring joint ids ``joint``), the slip sign (+1/-1) of its joint when every closed pair of
        that joint outside the mask ``held`` (at least one) slips that way, else 0; 0 on the arch-fill interface.
        Collective: a joint's pairs may lie on several ranks."""
        ring = joint >= 0
        closed = ring & (self.state != OPEN) & ~held
        slips = closed & (self.state == SLIP)
        counts = joint_counts(joint, (closed, slips & (self.sign > 0), slips & (self.sign < 0)), comm)
        sliding = counts[0] > 0
        sign = np.where(sliding & (counts[1] == counts[0]), 1, np.where(sliding & (counts[2] == counts[0]), -1, 0))
        return np.where(ring, sign[np.maximum(joint, 0)], 0).astype(np.int8)

    def opposed_slips(self, previous: "ContactState", joint: np.ndarray, comm: MPI.Comm) -> np.ndarray:
        """The local pairs of this proposed set that still slip as in ``previous`` on a ring joint (ids ``joint``)
        whose closed pairs all slip, the ones that start slipping (or reverse) one way and these the other way: a
        joint sliding both ways at once, its friction forces cancelling. Collective."""
        ring = joint >= 0
        slips = ring & (self.state == SLIP)
        kept = slips & (previous.state == SLIP) & (previous.sign == self.sign)
        closed = ring & (self.state != OPEN)
        up, down = slips & (self.sign > 0), slips & (self.sign < 0)
        counts = joint_counts(joint, (closed, up, down, up & ~kept, down & ~kept), comm)
        total, n_up, n_down, new_up, new_down = counts
        all_slip = (total > 0) & (n_up + n_down == total)
        old_down = all_slip & (new_up == n_up) & (new_up > 0) & (new_down == 0) & (n_down > 0)  # new +, old -
        old_up = all_slip & (new_down == n_down) & (new_down > 0) & (new_up == 0) & (n_up > 0)  # new -, old +
        at = np.maximum(joint, 0)
        return ring & kept & ((down & old_down[at]) | (up & old_up[at]))


def joint_counts(joint: np.ndarray, masks: tuple[np.ndarray, ...], comm: MPI.Comm) -> np.ndarray:
    """For each local pair mask, the number of its pairs per ring joint over all ranks ((masks, joints); ids
    ``joint``, the arch-fill interface's negative id left out). Collective."""
    ring = joint >= 0
    n = comm.allreduce(int(joint.max(initial=-1)) + 1, op=MPI.MAX)
    return comm.allreduce(np.stack([np.bincount(joint[ring & m], minlength=n) for m in masks]))


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


@dataclass
class CoulombJoints:
    """Unilateral contact with Coulomb friction at every pair (module docstring), with the Alart-Curnier constants
    ``c`` (N/m per pair), the Coulomb coefficients ``mu`` and a hysteresis ``force_tol`` (N) against chattering.

    A joint law is one object with three jobs: :meth:`classify` (the active set the complementarity functions
    propose), :meth:`residual` (zero iff the law holds) and :meth:`rows` / :meth:`rhs` (its linear equations for an
    active set). Another law (e.g. crushing) is another object with the same methods."""

    mu: np.ndarray
    c: np.ndarray
    force_tol: float

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
        was_closed = prev.state != OPEN
        closed = np.where(was_closed, sig_n >= -tol, sig_n > tol)
        excess = np.abs(sig_t) - self.mu * np.maximum(sig_n, 0.0)
        was_slip = prev.state == SLIP
        sign = np.sign(sig_t).astype(np.int8)
        reversed_slip = was_slip & (sign != prev.sign)
        slip = np.where(was_slip & ~reversed_slip, excess > -tol, excess > tol)
        state = np.where(~closed, OPEN, np.where(slip, SLIP, STICK)).astype(np.int8)
        violation = np.where(closed != was_closed, np.abs(sig_n), np.abs(excess))
        return ContactState(state, np.where(state == SLIP, sign, 0).astype(np.int8)), violation

    def residual(self, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray) -> np.ndarray:
        """Alart-Curnier residual (N) per pair: zero iff eqs. (1)-(6) hold."""
        sig_n = np.maximum(lam[:, 0] - self.c * d[:, 0], 0.0)
        sig_t = lam[:, 1] - self.c * (d[:, 1] - slip_ref)
        return np.column_stack([lam[:, 0] - sig_n, lam[:, 1] - np.clip(sig_t, -self.mu * sig_n, self.mu * sig_n)])

    def rows(self, active: ContactState) -> LawRows:
        """The law's rows for an active set: closed pairs keep d_n (open ones carry lam_n = 0), sticking pairs keep
        d_t, sliding pairs carry lam_t = s mu lam_n (open ones lam_t = 0)."""
        closed, stick = active.state != OPEN, active.state == STICK
        return LawRows(closed.astype(float), stick.astype(float), (~closed).astype(float), (~stick).astype(float),
                       -self.mu * active.sign * (active.state == SLIP))

    def rhs(self, active: ContactState, slip_ref: np.ndarray, ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Right-hand sides (r_n, r_t) of the rows: a closed pair's gap and a sticking pair's slip stay those of the
        last converged step, d = G u + ``ground`` (the imposed ground movement, m, (m, 2))."""
        return (np.where(active.state != OPEN, -self.c * ground[:, 0], 0.0),
                np.where(active.state == STICK, self.c * (slip_ref - ground[:, 1]), 0.0))
