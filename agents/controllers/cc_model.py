"""Constant-curvature model-based tip controller of Wang et al. 2023 (wang2023, Section III-A).

Each control step, with feedback tip position ``p`` and next target ``p*``:

* desired displacement ``dp* = p* - p``;
* chamber-length change ``du = J^+ dp* + (1 - J^+ J) beta (u0 - u)`` (eq. (25)), ``J`` the CC
  Jacobian of the tip position with respect to the chamber lengths (eqs. (19)-(24); the
  convention-free form of :mod:`soft_gym.kinematics`, which has no singularity at the straight
  pose) and the null-space term pulling towards the rest lengths ``u0``;
* model lengths ``u <- u + K_p du`` (eq. (26));
* actuation ``p_i = p_pre + alpha_i (u_i - u0_i)`` (eq. (27)): a deliberately *linear*
  length-to-pressure map. The gains ``alpha_i`` are estimated at start-up from small actuation
  probes, as a lab would (:meth:`CCModelController.calibrate`): each chamber in turn is
  pressurised a little, the tip displacement is read from the feedback pose, mapped to chamber
  lengths through ``J^+`` at the rest pose, and ``alpha_i = dp / du_i``.

Calibration happens on the first :meth:`~CCModelController.predict` unless
:meth:`~CCModelController.calibrate` was called before: the probes then run on a private copy of
the env (``gymnasium.make(env.spec)``: the same id and keyword arguments, closed afterwards), so
the controlled env, its episode and its random state are left as they were, and a plain
``obs -> predict -> step`` loop works as with an SB3 model. :meth:`~CCModelController.calibrate`
called directly probes the controlled env itself and leaves it reset.

Several segments (ho2018, zhao2021): the Jacobian of eqs. (19)-(24) chains the segments'
frames (:func:`soft_gym.kinematics.cc_jacobian`, ``3 x 3 n_segments``), eq. (25)'s
pseudo-inverse then spreads the tip displacement over all chambers and its null-space term
resolves the redundancy towards the rest lengths, and eq. (27) keeps one gain per chamber. Only
the probes need more than the paper says. The pseudo-inverse of the whole ``3 x 6`` Jacobian
gives the least-norm length change, which spreads a probe of one chamber over both segments;
and a soft two-segment arm swings far out of the Jacobian's linear range under a probe
(ho2018's proximal probe lengthens its chamber 8 mm and moves the tip 96 mm sideways and 36 mm
down, where the rest-pose Jacobian reads a 30 mm *shortening*). A probe changes only its own
segment's lengths, so those three lengths are fitted to the measured tip displacement through
the CC forward map itself (:func:`soft_gym.kinematics.cc_tip_pose`, nonlinear least squares
from the rest lengths), the other segments held at rest. One-segment arms keep the paper's
mapping through the rest-pose Jacobian's inverse (on wang2023 the two differ: 14.8 vs 10.8 MPa/m,
the probe reaching beyond the linear range there too, and the paper's gains are what its
controller was tuned with).

An extensible segment (zou2022, ``length_map="modal"``, its default there): eq. (27) gives each
chamber one gain, which ties the pressure that extends the segment to the pressure that bends
it. zou2022's artificial muscles are far softer in extension than in bending, so gains probed at
rest are right for the one and several times too small for the other where the arm works. The
modal map (:mod:`agents.controllers.modal_map`) gives the mean chamber length and the
differences from it a gain each, probed at several extensions (:meth:`CCModelController.
calibrate_modal`); eqs. (25)-(26) are unchanged.

Pressures cannot go below the pre-pressure or above ``p_max``: the model lengths are kept
consistent with the saturated pressures (anti-windup), so the integrator of eq. (26) does not
wind up.
Where every chamber stays saturated for a second of control steps, the target is out of the
model's reach and the controller says so once
(:class:`~agents.controllers.saturation.InfeasibleTargetWarning`, naming the target and the
bounds).

The pressures become actions through the env's own map (:class:`soft_gym.robots.actuation.
Actuation`), in either action mode: ``"absolute"`` or ``"delta"`` (there the controller keeps the
command it has sent, which starts at the pre-pressure, so every action it returns must be stepped
and :meth:`~CCModelController.reset` called after each env reset, as :mod:`eval.runner` does).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable, TypeVar

import gymnasium as gym
import numpy as np
from scipy.optimize import least_squares

from agents.controllers.modal_map import ModalLengthMap
from agents.controllers.saturation import SaturationWatch
from agents.policies.base import BaselinePolicy, PolicyRefusal, require_soft_arm_env
from soft_gym._validation import (require_integer, require_non_negative, require_number,
                                  require_positive)
from soft_gym.kinematics import cc_jacobian, cc_tip_pose
from soft_gym.robots.actuation import Actuation

T = TypeVar("T")

LENGTH_MAPS = ("chamber", "modal")
# arms whose default length-to-pressure map is the modal one (see agents.controllers.modal_map):
# zou2022's muscles extend 3.3-fold and are ~17 times stiffer in bending than in extension
MODAL_ARMS = ("zou2022",)
# common-pressure levels of the modal probes, as fractions of p_max - p_pre
MODAL_LEVELS = (0.0, 0.25, 0.5, 0.75)


class CCModelController(BaselinePolicy):
    """CC model-based controller (wang2023 eqs. (19)-(27)).

    Args:
        env: the environment it controls (reads its arm spec, observation layout and action
            mode: ``action_mode`` ``"absolute"`` or ``"delta"`` with its ``delta_fraction``).
        kp: proportional gain ``K_p`` of eq. (26) (paper: 0.04-0.10).
        null_space_gain: ``beta`` of eq. (25).
        probe_fraction: probe pressure as a fraction of ``p_max - p_pre``.
        probe_steps: control steps each probe is held before the pose is read.
        damping: damping of the pseudo-inverse ``J^T (J J^T + damping^2 I)^-1`` (m).
        controlled_axes: task-space axes under control. wang2023 controls x and y only (its arm
            barely extends, so its workspace is a thin curved surface) and leaves the chambers'
            common mode to the null-space term of eq. (25); this simulated arm extends ~20 mm, and
            the planar paths need z as well, so the default controls all three.
        length_map: the length-to-pressure map: ``"chamber"``, eq. (27)'s one gain per chamber
            probed at rest (the paper); ``"modal"``, separate extension and bending gains probed
            at several extensions (:mod:`agents.controllers.modal_map`; one-segment arms only);
            ``None``: ``"modal"`` on the arms of :data:`MODAL_ARMS` (zou2022), else
            ``"chamber"``.
    """

    name = "cc_model"

    def __init__(self, env, kp: float = 0.06, null_space_gain: float = 0.1,
                 probe_fraction: float = 0.3, probe_steps: int = 30,
                 damping: float = 1e-4, controlled_axes: tuple[int, ...] = (0, 1, 2),
                 length_map: str | None = None) -> None:
        unwrapped = require_soft_arm_env(env, self.name)
        self.kp = require_positive("kp", kp)
        self.null_space_gain = require_non_negative("null_space_gain", null_space_gain)
        self.probe_fraction = require_number("probe_fraction", probe_fraction)
        if not 0.0 < self.probe_fraction <= 1.0:  # NaN fails too
            raise ValueError(f"probe_fraction must be in (0, 1], got {probe_fraction!r}")
        self.probe_steps = require_integer("probe_steps", probe_steps, 1)
        self.damping = require_positive("damping", damping)
        self.controlled_axes = _axes(controlled_axes)
        self.env = unwrapped
        spec = self.env.arm
        for part in ("pose", "target"):
            if part not in self.env.obs_parts:
                raise PolicyRefusal(f"the env's obs must include {part!r} for {self.name}, got "
                                    f"{self.env.obs_parts!r}")
        self.actuation = Actuation.of_env(self.env)
        self.d = spec.chamber_offset_m
        self.p_low, self.p_high = spec.p_pre_pa, spec.p_max_pa
        self._command = self.actuation.initial_command_pa.copy()
        self.rest_lengths = np.repeat([s.length_m for s in spec.segments], 3).astype(float)
        self.length_map = _length_map(length_map, spec)
        self.alpha: np.ndarray | None = None
        self.modal_map: ModalLengthMap | None = None
        self.lengths = self.rest_lengths.copy()
        self.saturation = SaturationWatch(self.name, self.p_low, self.p_high,
                                          steps=max(1, round(1.0 / spec.control_period_s)))

    # ------------------------------------------------------------------ calibration
    def calibrate(self, seed: int = 0, env=None) -> np.ndarray:
        """Estimate ``alpha`` (Pa/m) with one small probe per chamber (eq. (27)).

        Args:
            seed: seed of the probed env's first reset, so that the probes' sensor noise, and
                hence ``alpha``, are reproducible.
            env: the env to probe: ``None`` for the controlled env, which is stepped
                (``2 probe_steps`` control steps per chamber) and left reset (``env.reset()``,
                unseeded); or a copy of it, with the same observation layout and action mode
                (what :meth:`predict` does on first use, see the module docstring).

        Returns:
            ``alpha`` (Pa/m), one gain per chamber; the controller's episode state is reset.
            With ``length_map="modal"`` the probes are :meth:`calibrate_modal`'s instead and
            ``alpha`` holds the modal map's bending gain at rest, the same for every chamber.
        """
        env = self.env if env is None else env
        if self.length_map == "modal":
            self.modal_map = self.calibrate_modal(seed=seed, env=env)
            rest_gain = self.modal_map.bending_gains_pa_m[0]
            self.alpha = np.full(len(self.rest_lengths), rest_gain)
            return self.alpha
        paper_probes = len(self.rest_lengths) == 3  # one segment: eq. (27)'s rest Jacobian
        if paper_probes:
            jacobian_inverse = self._pseudo_inverse(cc_jacobian(self.rest_lengths, self.d))
        alpha = np.empty(len(self.rest_lengths))
        for chamber in range(len(alpha)):
            env.reset(seed=seed if chamber == 0 else None)
            self._command = self.actuation.initial_command_pa.copy()
            observation = None
            for _ in range(self.probe_steps):
                observation, *_ = env.step(self._action_for(self.p_low))
            start = self._pose(observation)
            pressures = self.p_low.copy()
            pressures[chamber] += self.probe_fraction * (self.p_high[chamber] - self.p_low[chamber])
            for _ in range(self.probe_steps):
                observation, *_ = env.step(self._action_for(pressures))
            displacement = self._pose(observation) - start
            if paper_probes:
                length_change = (jacobian_inverse @ displacement)[chamber]
            else:
                segment, own = divmod(chamber, 3)
                length_change = self.segment_length_change(segment, displacement)[own]
            if length_change <= 1e-7:
                raise self._unresponsive(f"probe of chamber {chamber} gave no lengthening "
                                         f"({length_change:.2e} m)")
            alpha[chamber] = (pressures[chamber] - self.p_low[chamber]) / length_change
        env.reset()
        self.reset()
        self.alpha = alpha
        return alpha

    def calibrate_modal(self, seed: int = 0, env=None) -> ModalLengthMap:
        """Probe the :class:`~agents.controllers.modal_map.ModalLengthMap` of a one-segment arm.

        One probing sequence from rest, ``probe_steps`` control steps per hold, the pose read at
        the end of each. At each level of :data:`MODAL_LEVELS` every chamber is held at the
        common pressure ``p_pre + level (p_max - p_pre)``; the tip's displacement from rest,
        fitted through the CC forward map to the chamber lengths, gives the level's extension
        (their mean). Then each chamber in turn gets ``probe_fraction / 2`` of its range on top
        of the common pressure (less where that would pass ``p_max``), the previous one back at
        it; each hold's displacement from the previous hold is fitted to length changes from the
        previous hold's lengths, and the bending gain is the least-squares ratio of the
        differential pressure changes (each less their mean) to the differential length
        changes. The env is reset first (seeded with ``seed``) and at the end.

        Raises:
            ValueError: the levels gave no increasing extension, or the probes no bending.
        """
        env = self.env if env is None else env
        span = self.p_high - self.p_low
        env.reset(seed=seed)
        self._command = self.actuation.initial_command_pa.copy()
        rest_pose = self._hold(env, self.p_low)
        means, commons, gains = [], [], []
        for level in MODAL_LEVELS:
            base = self.p_low + level * span
            pose = rest_pose if level == 0.0 else self._hold(env, base)
            lengths = self.rest_lengths + self.segment_length_change(0, pose - rest_pose)
            means.append(lengths.mean())
            commons.append(base.mean())
            pressures, work, squares = base, 0.0, 0.0
            for chamber in range(len(base)):
                probe = base.copy()
                probe[chamber] += min(0.5 * self.probe_fraction, 1.0 - level) * span[chamber]
                probe_pose = self._hold(env, probe)
                change = self.segment_length_change(0, probe_pose - pose, start_lengths=lengths)
                pressure_change = probe - pressures
                differential_length = change - change.mean()
                work += (pressure_change - pressure_change.mean()) @ differential_length
                squares += differential_length @ differential_length
                pose, lengths, pressures = probe_pose, lengths + change, probe
            if work <= 0.0 or squares <= 1e-14:
                raise self._unresponsive(
                    f"the modal probes at level {level} gave no bending (differential length "
                    f"change {np.sqrt(squares):.2e} m)")
            gains.append(work / squares)
        env.reset()
        self.reset()
        if not np.all(np.diff(means) > 0.0):
            raise self._unresponsive(
                f"the modal probes' common pressures gave no increasing extension (mean chamber "
                f"lengths {np.round(means, 5).tolist()} m at levels {list(MODAL_LEVELS)})")
        return ModalLengthMap(np.array(means), np.array(commons), np.array(gains))

    def _unresponsive(self, what: str) -> ValueError:
        """The error of a calibration whose probes did not move the feedback pose: it names the
        env's feedback source (an error of the run, not a refusal of the arm)."""
        return ValueError(f"{what}: the pose of feedback {self.env.feedback!r} does not respond "
                          f"to actuation, so {self.name} cannot calibrate from it (give it "
                          "another feedback source, or lift the condition that blinds this one)")

    def _hold(self, env, pressures_pa: np.ndarray) -> np.ndarray:
        """Command ``pressures_pa`` for ``probe_steps`` control steps; the feedback tip (m)."""
        observation = None
        for _ in range(self.probe_steps):
            observation, *_ = env.step(self._action_for(pressures_pa))
        return self._pose(observation)

    def segment_length_change(self, segment: int, displacement_m: np.ndarray,
                              start_lengths: np.ndarray | None = None) -> np.ndarray:
        """The length changes (m) of ``segment``'s three chambers that move the CC model's tip by
        ``displacement_m`` (m) from its pose at ``start_lengths`` (m; default: the rest
        lengths), the other segments held: nonlinear least squares on
        :func:`~soft_gym.kinematics.cc_tip_pose` (see the module docstring)."""
        start = self.rest_lengths if start_lengths is None else np.asarray(start_lengths, float)
        start_tip = cc_tip_pose(start, self.d)[0]
        chambers = slice(3 * segment, 3 * segment + 3)

        def residual(change: np.ndarray) -> np.ndarray:
            lengths = start.copy()
            lengths[chambers] += change
            return cc_tip_pose(lengths, self.d)[0] - start_tip - displacement_m

        def jacobian(change: np.ndarray) -> np.ndarray:
            lengths = start.copy()
            lengths[chambers] += change
            return cc_jacobian(lengths, self.d)[:, chambers]

        # keeps every trial length at least half the rest length
        shortest = start[chambers] - 0.5 * self.rest_lengths[chambers]
        # gtol too: at scipy's default 1e-8 the fit could stop 0.2 um off the displacement
        fit = least_squares(residual, np.zeros(3), jac=jacobian, bounds=(-shortest, np.inf),
                            xtol=1e-12, ftol=1e-12, gtol=1e-12)
        return fit.x

    def calibrate_on_copy(self, seed: int = 0) -> np.ndarray:
        """:meth:`calibrate` on a private copy of the controlled env, made with
        ``gymnasium.make(env.spec)`` (same id and keyword arguments) and closed afterwards; the
        controlled env is not touched.

        Raises:
            ValueError: the controlled env was not made by ``gymnasium.make`` (it has no
                ``spec`` to copy); call :meth:`calibrate` on it before :meth:`predict`.
        """
        if self.env.spec is None:
            raise ValueError(
                "env has no spec (it was not made by gymnasium.make), so the controller cannot "
                "calibrate on a copy of it: call calibrate() before predict() (it probes this "
                "env and resets it)")
        copy = gym.make(self.env.spec)
        try:
            return self.calibrate(seed=seed, env=copy)
        finally:
            copy.close()

    # ------------------------------------------------------------------ control
    def reset(self) -> None:
        """Start of an episode (after the env's reset): rest lengths, command at pre-pressure."""
        self.lengths = self.rest_lengths.copy()
        self._command = self.actuation.initial_command_pa.copy()
        self.saturation.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """The action for ``observation`` (SB3's signature); calibrates first if it has not
        been (on a private copy of the env, see :meth:`calibrate_on_copy`)."""
        observation = self.check_observation(observation)  # before any state changes
        if self.alpha is None:
            self.calibrate_on_copy()
        position, target = self._pose(observation), self._next_target(observation)
        command = self.compensate(position, target - position)
        self.lengths = self.lengths + self.kp * self.length_step(position, position + command)
        wanted = self.model_pressures(self.lengths)
        self.saturation.observe(wanted, target)
        pressures = np.clip(wanted, self.p_low, self.p_high)
        # anti-windup: the model lengths follow what the saturated pressures can produce
        self.lengths = self.model_lengths(pressures)
        return self._action_for(pressures), state

    def model_pressures(self, lengths_m: np.ndarray) -> np.ndarray:
        """Eq. (27), or the modal map: the pressures (Pa, not clipped) for chamber lengths (m)."""
        if self.modal_map is not None:
            return self.modal_map.pressures(lengths_m)
        return self.p_low + self.alpha * (lengths_m - self.rest_lengths)

    def model_lengths(self, pressures_pa: np.ndarray) -> np.ndarray:
        """The inverse of :meth:`model_pressures`: chamber lengths (m) for pressures (Pa)."""
        if self.modal_map is not None:
            return self.modal_map.lengths(pressures_pa)
        return self.rest_lengths + (pressures_pa - self.p_low) / self.alpha

    def compensate(self, position: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The displacement handed to eq. (25) for the desired one (m); the pure model passes it
        through, the hybrid controller adds its learned error (eq. (29))."""
        return desired

    def length_step(self, position: np.ndarray, target: np.ndarray) -> np.ndarray:
        """``du`` of eq. (25) for the desired displacement ``target - position`` (m)."""
        axes = list(self.controlled_axes)
        jacobian = cc_jacobian(self.lengths, self.d)[axes]
        inverse = self._pseudo_inverse(jacobian)
        null_space = np.eye(len(self.lengths)) - inverse @ jacobian
        return inverse @ (target - position)[axes] + null_space @ (
            self.null_space_gain * (self.rest_lengths - self.lengths))

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps({
            "name": self.name, "kp": self.kp, "null_space_gain": self.null_space_gain,
            "probe_fraction": self.probe_fraction, "probe_steps": self.probe_steps,
            "damping": self.damping, "controlled_axes": list(self.controlled_axes),
            "length_map": self.length_map,
            "alpha": None if self.alpha is None else self.alpha.tolist(),
            "modal_map": None if self.modal_map is None else self.modal_map.to_dict(),
        }, indent=2))

    @classmethod
    def load(cls, path: str | Path, env=None) -> "CCModelController":
        """Read a controller written by :meth:`save` for ``env``; a missing, corrupt or foreign
        file is refused with one ``ValueError`` naming the path and what is wrong."""
        require_soft_arm_env(env, cls.name)
        data = read_settings(path, cls.name)
        alpha, modal_map = data.pop("alpha"), data.pop("modal_map", None)
        controller = _build_from_file(path, cls.name, lambda: cls(env, **data))
        controller.restore_calibration(path, alpha, modal_map)
        return controller

    def restore_calibration(self, path: str | Path, alpha: Any, modal_map: Any) -> None:
        """Set the saved gains ``alpha`` and modal map read from ``path`` (checked: ``None`` or
        valid, and the modal map present exactly when ``length_map`` is ``"modal"`` and the
        controller is calibrated); ``ValueError`` naming the file otherwise."""
        self.alpha = _saved_alpha(path, alpha, len(self.rest_lengths))
        if (modal_map is not None) != (self.length_map == "modal" and self.alpha is not None):
            raise ValueError(f"controller file {str(path)!r}: modal_map must be given exactly "
                             f"when length_map is 'modal' and alpha is not null, got length_map "
                             f"{self.length_map!r} and modal_map {modal_map!r}")
        try:
            self.modal_map = None if modal_map is None else ModalLengthMap.from_dict(modal_map)
        except ValueError as error:
            raise ValueError(f"controller file {str(path)!r}: invalid modal_map ({error})") \
                from None

    # ------------------------------------------------------------------ helpers
    def _action_for(self, pressures_pa: np.ndarray) -> np.ndarray:
        """The action (float32) commanding ``pressures_pa`` (Pa) in the env's action mode; in
        delta mode it moves the command as far towards them as one step can, and the command
        this action gives (the env's own map) is kept for the next step."""
        action = self.actuation.action(pressures_pa, self._command)
        self._command = self.actuation.pressure(action, self._command)
        return action

    def _pseudo_inverse(self, jacobian: np.ndarray) -> np.ndarray:
        return jacobian.T @ np.linalg.inv(jacobian @ jacobian.T
                                          + self.damping**2 * np.eye(len(jacobian)))

    def _pose(self, observation) -> np.ndarray:
        return np.asarray(self.env.observation_part(observation, "pose"), dtype=float)[:3]

    def _next_target(self, observation) -> np.ndarray:
        return np.asarray(self.env.observation_part(observation, "target"), dtype=float)[3:6]


def _length_map(value: Any, spec) -> str:
    """``length_map`` checked, ``None`` resolved for the arm ``spec`` (see the class)."""
    if value is None:
        return "modal" if spec.name in MODAL_ARMS else "chamber"
    if not isinstance(value, str) or value not in LENGTH_MAPS:
        raise ValueError(f"length_map must be one of {LENGTH_MAPS} or None, got {value!r}")
    if value == "modal" and len(spec.segments) != 1:
        raise PolicyRefusal(f"length_map 'modal' is for one-segment arms; the {spec.name} arm has "
                            f"{len(spec.segments)} segments (use 'chamber')")
    return value


def _axes(value: Any) -> tuple[int, ...]:
    """``controlled_axes`` checked: distinct integers from (0, 1, 2) (no bools or floats)."""
    allowed = f"a non-empty sequence of distinct axes from (0, 1, 2), got {value!r}"
    if not isinstance(value, (tuple, list, np.ndarray)):
        raise ValueError(f"controlled_axes must be {allowed}")
    axes = tuple(value)
    if (not axes or len(set(axes)) != len(axes)
            or any(isinstance(a, (bool, np.bool_)) or not isinstance(a, (int, np.integer))
                   or a not in (0, 1, 2) for a in axes)):
        raise ValueError(f"controlled_axes must be {allowed}")
    return tuple(int(a) for a in axes)


def read_json_object(path: str | Path, name: str, content: str = "JSON object") -> dict:
    """The JSON object in ``path`` (a ``name`` controller's file); ``ValueError`` naming the
    file where it is missing, not JSON or not an object (``content``: what it should hold)."""
    path = Path(path)
    what = f"{name} controller file {str(path)!r}"
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"{what} does not exist") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{what} is not readable JSON ({type(error).__name__}: {error})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what} must hold a {content}, got {type(data).__name__}")
    return data


def read_settings(path: str | Path, name: str) -> dict[str, Any]:
    """The settings a controller's :meth:`~CCModelController.save` wrote to the JSON file
    ``path``, less their ``"name"`` (which must be ``name``); ``ValueError`` naming the file
    where it is missing, not JSON, not a mapping, or another controller's."""
    what = f"{name} controller file {str(path)!r}"
    data = read_json_object(path, name, "JSON object of settings")
    saved_name = data.pop("name", None)
    if saved_name != name:
        found = "no controller name" if saved_name is None else f"a {saved_name!r} controller"
        raise ValueError(f"{what} holds {found}, not the settings of a {name} controller")
    if "alpha" not in data:
        raise ValueError(f"{what} has no 'alpha' entry (the calibrated gains or null)")
    return data


def _build_from_file(path: str | Path, name: str, build: Callable[[], T]) -> T:
    """``build()``, with a ``ValueError`` or ``TypeError`` (an unknown or bad setting) raised as
    one ``ValueError`` naming the file the settings came from."""
    try:
        return build()
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} controller file {str(path)!r} holds invalid settings "
                         f"({error})") from None


def _saved_alpha(path: str | Path, alpha: Any, n_chambers: int) -> np.ndarray | None:
    """The saved gains ``alpha`` (Pa/m) checked: ``None`` (not calibrated) or ``n_chambers``
    finite numbers > 0; ``ValueError`` naming the file otherwise."""
    if alpha is None:
        return None
    ok = isinstance(alpha, list) and len(alpha) == n_chambers and all(
        isinstance(a, (int, float)) and not isinstance(a, bool) for a in alpha)
    array = np.array(alpha, dtype=float) if ok else None
    if array is None or not np.all(np.isfinite(array)) or not np.all(array > 0):
        raise ValueError(f"controller file {str(path)!r}: alpha must be null or {n_chambers} "
                         f"finite gains > 0 (Pa/m), got {alpha!r}")
    return array
