"""The MuJoCo engine's world: the arm alone, without bodies beside it or cameras.

:class:`MujocoWorld` is ``sim.world`` of
:class:`~soft_gym.engines.mujoco.simulator.MujocoArmSimulator`. The env refuses what needs it
before any work (a swaying mass, an obstacle rod, the eye-in-hand camera, the stereo pair,
``render()``; :func:`soft_gym.engines.require_engine_features`); a direct call says the same.
"""

from __future__ import annotations

from typing import Any, NoReturn


def _refuse(feature: str) -> NoReturn:
    raise ValueError(f"{feature} is not available on the mujoco engine (it simulates the arm "
                     "alone: no bodies beside it, no cameras): use engine='pybullet'")


class MujocoWorld:
    """No bodies beside the arm and no cameras: every method refuses, naming the feature."""

    def add_body(self, shape: str, **options: Any) -> int:
        _refuse(f"a body beside the arm ({shape!r})")

    def remove_body(self, body: int) -> None:
        _refuse("a body beside the arm")

    def set_body_pose(self, body: int, *args: Any) -> None:
        _refuse("a body beside the arm")

    def stop_body(self, body: int) -> None:
        _refuse("a body beside the arm")

    def body_position(self, body: int) -> Any:
        _refuse("a body beside the arm")

    def ignore_arm_collisions(self, body: int) -> None:
        _refuse("a body beside the arm")

    def tether_to_tip(self, body: int, offset_m: Any) -> int:
        _refuse("a tether to the tip")

    def set_tether_force(self, tether: int, max_force_n: float) -> None:
        _refuse("a tether to the tip")

    def remove_tether(self, tether: int) -> None:
        _refuse("a tether to the tip")

    def build_scene(self, arm_length_m: float, **options: Any) -> list[int]:
        _refuse("the camera's scene")

    def render(self, width: int, height: int, *args: Any, **kwargs: Any) -> Any:
        _refuse("rendering")

    def render_camera(self, intrinsics: Any, *args: Any) -> Any:
        _refuse("a camera frame")

    def hide_all_but(self, keep: list[int]) -> list:
        _refuse("rendering")

    def unhide(self, hidden: list) -> None:
        _refuse("rendering")

    @property
    def arm_body(self) -> int:
        return 0
