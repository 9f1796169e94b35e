"""The simulator interface: all that the env, sensors, loads, tasks, procedures and baselines may use.

A physics engine joins the project by implementing :class:`Simulator` (the arm: commands, state,
loads, stepping) and :class:`World` (the bodies around the arm and the cameras that look at them),
and registering a factory in :data:`soft_gym.engines.ENGINES`. The PyBullet engine,
:class:`soft_gym.engines.pybullet.ArmSimulator`, is the reference and the default. Nothing outside
``soft_gym/engines/`` calls an engine's own API or reads a simulator attribute that is not named
here; ``tests/test_architecture.py`` checks both (docs/architecture.md, "The simulator
interface").

Conventions: SI units (m, s, kg, N, Pa; rad), the arm's base frame (z along the unbent arm, the
mount decides only the gravity vector), quaternions as (x, y, z, w), chambers in segment order
(segment ``k`` owns chambers ``3k .. 3k+2`` at ``2 pi i / 3``), links from the base to the tip.
"""

from __future__ import annotations

from typing import Any, Protocol, Sequence, runtime_checkable

import numpy as np

from soft_gym.robots.spec import ArmSpec


class Load(Protocol):
    """What the simulator expects of a scenario element (see :mod:`soft_gym.scenarios`)."""

    def attach(self, sim: "Simulator") -> None: ...

    def update(self, sim: "Simulator", time_s: float) -> None: ...

    def reset(self, sim: "Simulator") -> None: ...

    def detach(self, sim: "Simulator") -> None: ...

    def peak_load_n(self, gravity_m_s2: float) -> float: ...


@runtime_checkable
class World(Protocol):
    """Rigid bodies beside the arm and cameras rendering the scene (``sim.world``).

    Body ids are the engine's; a body made in one world means nothing in another.
    """

    def add_body(self, shape: str, *, position_m: Sequence[float],
                 quaternion: Sequence[float] | None = None,
                 axis_angle: tuple[Sequence[float], float] | None = None, mass_kg: float = 0.0,
                 rgba: Sequence[float] = (0.7, 0.7, 0.7, 1.0), collide: bool = True,
                 **size: Any) -> int:
        """A new body: ``"sphere"`` (``radius_m``), ``"box"`` (``half_extents_m``) or
        ``"cylinder"`` (``radius_m``, ``length_m``); returns its id."""

    def remove_body(self, body: int) -> None: ...

    def set_body_pose(self, body: int, position_m: Sequence[float],
                      quaternion: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> None: ...

    def stop_body(self, body: int) -> None: ...

    def body_position(self, body: int) -> np.ndarray: ...

    def ignore_arm_collisions(self, body: int) -> None: ...

    def tether_to_tip(self, body: int, offset_m: np.ndarray) -> int:
        """Pin ``body`` at ``offset_m`` (m) from the tip; returns the tether's id."""

    def set_tether_force(self, tether: int, max_force_n: float) -> None: ...

    def remove_tether(self, tether: int) -> None: ...

    def build_scene(self, arm_length_m: float, **options: Any) -> list[int]:
        """The eye-in-hand camera's textured surroundings; returns their body ids."""

    def render(self, width: int, height: int, view: list[float], projection: list[float],
               light_direction: Sequence[float], *,
               segmentation: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """RGB (uint8 (H, W, 3)), the raw depth buffer and, if asked, each pixel's body id."""

    def render_camera(self, intrinsics: Any, rotation: np.ndarray, position: np.ndarray,
                      light_direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A pinhole camera's RGB frame and metric depth (m) from a world-from-camera pose."""

    def hide_all_but(self, keep: list[int]) -> list[tuple[int, int, list[float]]]: ...

    def unhide(self, hidden: list[tuple[int, int, list[float]]]) -> None: ...

    @property
    def arm_body(self) -> int: ...


@runtime_checkable
class Simulator(Protocol):
    """One soft arm, its pneumatics and the loads on it, in one engine.

    Attributes:
        features: what the engine offers beyond the arm (``"bodies"``, ``"rendering"``,
            ``"batched"``; see :data:`soft_gym.engines.ENGINE_FEATURES`), as a class attribute.
        spec: the arm (:class:`~soft_gym.robots.spec.ArmSpec`).
        world: the bodies and cameras around the arm (:class:`World`).
        loads: the attached scenario elements, in the order added.
        time_s: simulated time since the last reset or :meth:`restart_clock` (s).
        physics_dt_s: the physics step (s).
        gravity: gravity in the base frame (m/s^2, (3,)).
    """

    features: frozenset[str]
    spec: ArmSpec
    world: World
    loads: list
    time_s: float
    physics_dt_s: float
    gravity: np.ndarray

    # ------------------------------------------------------------------ commands and stepping
    def set_pressures(self, pressures_pa: np.ndarray) -> None:
        """Command chamber pressures (Pa, (n_chambers,)); the supply's lag follows. Refused
        (``ValueError``) on a volume-actuated arm (``spec.cylinders`` set)."""

    def set_cylinder_strokes(self, strokes_m: np.ndarray) -> None:
        """Command the cylinders' strokes (m, (n_chambers,), each in ``[0, max_stroke_m]``) of a
        volume-actuated arm (``spec.cylinders`` set; ho2018 Section 3.1); the chamber pressures
        follow from the gas law. Refused (``ValueError``) on a pressure-actuated arm."""

    def step_physics(self, seconds: float) -> None:
        """Advance by ``seconds`` (rounded to whole physics steps)."""

    def reset(self, pressure_pa: np.ndarray | None = None, settle_s: float = 0.0) -> None:
        """The arm at rest (straight, or in the shape ``pressure_pa`` holds), then settled."""

    def restart_loads(self) -> None:
        """Every load back to its state at time 0."""

    def restart_clock(self) -> None:
        """Simulated time back to 0 where the arm is."""

    def close(self) -> None: ...

    # ------------------------------------------------------------------ state
    @property
    def pressures_pa(self) -> np.ndarray:
        """Chamber pressures now (Pa, (n_chambers,))."""

    @property
    def cylinder_strokes_m(self) -> np.ndarray | None:
        """The cylinders' strokes now (m, (n_chambers,)); ``None`` on a pressure-actuated arm."""

    @property
    def n_links(self) -> int:
        """Links of the discretised backbone."""

    @property
    def link_rest_lengths_m(self) -> np.ndarray:
        """Every link's rest length (m, (n_links,))."""

    def tip_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and quaternion (x, y, z, w)."""

    def backbone(self) -> np.ndarray:
        """The base and every link's distal end (m, (n_links + 1, 3))."""

    def chamber_lengths(self) -> np.ndarray:
        """Chamber lengths (m, (n_chambers,))."""

    def segment_bend_angles_rad(self) -> np.ndarray:
        """Each segment's bending angle (rad, (n_segments,)): the backbone tangent's turn from
        the segment's base to its end."""

    def joint_positions(self) -> np.ndarray:
        """The engine's generalised coordinates (rad or m)."""

    def link_rotations(self, links: np.ndarray) -> np.ndarray:
        """World-from-link rotations of ``links`` ((len(links), 3, 3))."""

    def curvature_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """Arc position (m) and curvature vector (1/m) at every backbone vertex."""

    def link_axial_strains(self) -> np.ndarray:
        """Every link's axial strain ((n_links,))."""

    def link_twists(self) -> np.ndarray:
        """Every link's twist angle (rad, (n_links,))."""

    def link_twist_rates(self) -> np.ndarray:
        """Every link's twist rate (rad/m, (n_links,))."""

    def link_contact_forces(self) -> np.ndarray:
        """The force pressing on every link's surface from outside (N, (n_links, 3))."""

    # ------------------------------------------------------------------ loads and parameters
    def set_gravity(self, vector_m_s2: np.ndarray) -> None: ...

    def apply_tip_force(self, force_n: np.ndarray) -> None:
        """Hold a force (N) on the tip until changed."""

    def set_external_force(self, key: str, link: int, force_n: np.ndarray,
                           local_point_m: tuple[float, float, float] | None = None,
                           on_body: bool = True) -> None:
        """Hold a force (N) on the arm's ``link`` (negative counts from the tip)."""

    def set_tip_payload(self, key: str, mass_kg: float) -> None:
        """Carry a point mass (kg) at the tip under ``key``."""

    @property
    def tip_payload_kg(self) -> float: ...

    def add_load(self, load: Load) -> None: ...

    def clear_loads(self) -> None: ...

    def set_stiffness_scale(self, scale: float) -> None:
        """Scale the arm's stiffness (domain randomisation)."""

    def set_time_constant_scale(self, scale: float) -> None:
        """Scale the pneumatic lag (domain randomisation)."""


SIMULATOR_NAMES: frozenset[str] = frozenset(
    [*Simulator.__annotations__, *(attribute for attribute in vars(Simulator)
                                   if not attribute.startswith("_"))])
"""Every attribute and method of :class:`Simulator` (the architecture test allows these)."""

WORLD_NAMES: frozenset[str] = frozenset(attribute for attribute in vars(World)
                                        if not attribute.startswith("_"))
"""Every method of :class:`World`."""
