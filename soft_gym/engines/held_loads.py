"""Loads every engine holds the same way: the table of held external forces, the tip payloads by
key and the arm's load capacity.

A held force (docs/architecture.md, "Held external forces") acts on one of the arm's links at a
point in the link's frame until it is replaced or set to zero; each engine turns the table into
its own applied forces (:class:`soft_gym.engines.pybullet.external_loads.HeldForces`, the MuJoCo
simulator's actuation update).
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from soft_gym.robots.chain import Chain
from soft_gym.robots.spec import MAX_LOAD_TO_WEIGHT, ArmSpec
from soft_gym.scenarios.loads import heaviest_total_load_n


class HeldForceTable:
    """Forces held on the arm's links until replaced or set to zero, by key.

    Args:
        chain: the arm's chain (its links' sub-link indices and rest lengths).

    Attributes:
        forces: key -> (sub-link index, force (N, base frame), point of action (m, link frame)).
        off_body: keys of the forces on the tip cap rather than on the body's surface.
    """

    def __init__(self, chain: Chain) -> None:
        self.chain = chain
        self.forces: dict[str, tuple[int, np.ndarray, np.ndarray]] = {}
        self.off_body: set[str] = set()

    def set(self, key: str, link: int, force_n: np.ndarray,
            local_point_m: tuple[float, float, float] | None = None,
            on_body: bool = True) -> None:
        """Hold ``force_n`` (N, base frame) on the arm's ``link`` (0 at the base, negative
        counts from the tip) at ``local_point_m`` (m, link frame; default the middle of the
        link); a zero force removes the key. ``on_body=False`` marks a force on the tip cap."""
        link = int(self.chain.station_link[link])
        force = np.asarray(force_n, dtype=float)
        if not np.any(force):
            self.forces.pop(key, None)
            self.off_body.discard(key)
            return
        if on_body:
            self.off_body.discard(key)
        else:
            self.off_body.add(key)
        if local_point_m is None:
            local_point_m = (0.0, 0.0, 0.5 * self._link_length(link))
        self.forces[key] = (int(link), force, np.asarray(local_point_m, dtype=float))

    def clear(self) -> None:
        """Remove every held force."""
        self.forces.clear()
        self.off_body.clear()

    def resolved(self) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
        """``(sub-link, force (N, base frame), point (m, link frame))`` of every held force."""
        yield from self.forces.values()

    def body_forces(self) -> Iterator[tuple[int, np.ndarray]]:
        """``(sub-link, force (N, base frame))`` of every force pressing on the body's surface
        (not on the tip cap)."""
        body_forces = {key for key in self.forces if key not in self.off_body}
        for key in body_forces:
            link, force, _ = self.forces[key]
            yield link, force

    def body_forces_per_link(self, n_links: int) -> np.ndarray:
        """The forces on the body's surface summed per link (N, base frame), (n_links, 3)."""
        forces = np.zeros((n_links, 3))
        index_of_link = {int(link): i for i, link in enumerate(self.chain.station_link)}
        for link, force in self.body_forces():
            i = index_of_link.get(link)
            if i is not None:
                forces[i] += force
        return forces

    def _link_length(self, link: int) -> float:
        """Rest length (m) of the arm link carried by sub-link ``link`` (0 for a joint-only
        sub-link)."""
        matches = np.nonzero(self.chain.station_link == link)[0]
        return float(self.chain.station_rest_length[matches[0]]) if len(matches) else 0.0


def carry_tip_payload(held: HeldForceTable, centre_of_mass_m: np.ndarray, tip_length_m: float,
                      payload_kg: float, gravity: np.ndarray) -> np.ndarray:
    """Carry a point mass at the tip as both engines do (docs/architecture.md, "Tip payloads and
    the mass matrix"): its mass sits at the tip link's centre of mass ``c`` (m, link frame), which
    the engine keeps where it is, so the link's inertia about ``c`` gains ``m r^2`` about the
    transverse axes (``r`` from ``c`` to the tip, ``tip_length_m`` along the link), and a held
    force couple (``m g`` at the tip, ``-m g`` at ``c``) moves the weight's line of action to the
    tip without changing the net force.

    Sets the couple on ``held`` and returns the principal inertia to add (kg m^2, (3,)).
    """
    tip_point = np.array([0.0, 0.0, tip_length_m])
    lever_m = np.linalg.norm(tip_point - centre_of_mass_m)
    weight = payload_kg * gravity
    held.set("payload_tip", -1, weight, tuple(tip_point), on_body=False)
    held.set("payload_com", -1, -weight, tuple(centre_of_mass_m), on_body=False)
    return payload_kg * lever_m**2 * np.array([1.0, 1.0, 0.0])


def require_load_capacity(spec: ArmSpec, loads: list, load, gravity: np.ndarray) -> None:
    """Refuse ``load`` if with ``loads`` it would weigh or push more than the arm bears.

    Raises:
        ValueError: naming the arm, its capacity (:attr:`~soft_gym.robots.spec.ArmSpec.max_load_n`)
            and the total.
    """
    total = heaviest_total_load_n(loads + [load], float(np.linalg.norm(gravity)))
    if total > spec.max_load_n * (1 + 1e-9):
        raise ValueError(
            f"scenario loads must total at most {spec.max_load_n:.3g} N on the "
            f"{spec.name} arm (max_load_n: {MAX_LOAD_TO_WEIGHT[spec.mount]:g}x its "
            f"{spec.mass_kg * 1e3:.0f} g weight), got {total:.3g} N with {load!r}")


def update_payload(masses: dict[str, float], key: str, mass_kg: float) -> bool:
    """Set the payload ``key`` to ``mass_kg`` (kg; 0 removes it) in ``masses``; whether anything
    changed (a key that already carries that mass, or a removed key that was absent, is not)."""
    if mass_kg == 0.0:
        return masses.pop(key, None) is not None
    if masses.get(key) == mass_kg:
        return False
    masses[key] = mass_kg
    return True
