"""The frozen-capacity collapse of rigid blocks touching at points (bridgefem.limit.contacts) against closed forms:
a block on the ground pushed sideways slides at the sum of its contacts' capacities or overturns about its toe."""
import numpy as np
import pytest

from bridgefem.limit.contacts import PointContacts, frozen_contact_collapse

WIDTH, HEIGHT, WEIGHT, ARM = 1.0, 2.0, 10.0, 2.0  # m, m, N, m: the push's height above the base


def block(pairs: int = 2) -> PointContacts:
    """A block WIDTH x HEIGHT on the ground at ``pairs`` contact points along its base, its weight at its centroid
    (the reference point), a unit horizontal push at height ARM (the live load)."""
    ref = np.array([[WIDTH / 2, HEIGHT / 2]])
    x = np.linspace(0.0, WIDTH, pairs)
    up, along = np.tile([0.0, 1.0], (pairs, 1)), np.tile([1.0, 0.0], (pairs, 1))
    return PointContacts(ref, np.array([[0.0, -WEIGHT, 0.0]]), np.array([[1.0, 0.0, -(ARM - HEIGHT / 2)]]),
                         np.column_stack([x, np.zeros(pairs)]), up, along, np.full(pairs, -1), np.zeros(pairs, int))


@pytest.mark.parametrize("pairs", [2, 5])
def test_sliding_at_the_capacities(pairs):
    """Capacities below the overturning push: the block slides at their sum, every pair sliding, none opening, every
    shear at its capacity against the slip."""
    capacity = np.full(pairs, 0.2)
    out = frozen_contact_collapse(block(pairs), capacity)
    assert out.level == pytest.approx(capacity.sum(), rel=1e-9)
    assert out.sliding.all() and not out.opening.any()
    assert np.allclose(out.forces[:, 1], -capacity)  # the ground holds the block back
    assert (out.slip > 0).all()
    assert out.dissipation(capacity).sum() == pytest.approx(out.level, rel=1e-9)  # the push's unit work dissipated
    assert out.shortfall(out.forces, capacity) == pytest.approx(np.zeros(pairs), abs=1e-12)
    half = out.forces * [1.0, 0.5]
    assert out.shortfall(half, capacity) == pytest.approx(0.5 * out.dissipation(capacity))
    assert out.shortfall(-out.forces, capacity) == pytest.approx(2 * out.dissipation(capacity))


def test_overturning_about_the_toe():
    """Capacities above it: the block overturns about its toe at W (WIDTH / 2) / ARM, its heel opening, the toe
    carrying the whole weight; nothing slides."""
    out = frozen_contact_collapse(block(), np.full(2, 100.0))
    assert out.level == pytest.approx(WEIGHT * WIDTH / 2 / ARM, rel=1e-9)
    assert out.opening.tolist() == [True, False] and not out.sliding.any()
    assert out.forces[:, 0] == pytest.approx([0.0, WEIGHT], abs=1e-9)


def test_no_admissible_state():
    """A weight the contacts cannot hold (a block hanging from a ceiling: the ground's normals pointing down) has no
    optimum."""
    contacts = block()
    hanging = PointContacts(contacts.ref, contacts.dead, contacts.live, contacts.point, -contacts.normal,
                            contacts.tangent, contacts.left, contacts.right)
    assert frozen_contact_collapse(hanging, np.full(2, 1.0)).level is None
