"""The arm's chain as a MuJoCo model: the same bodies as the PyBullet arm, with its springs native.

Built from :class:`~soft_gym.robots.chain.Chain` (as the PyBullet arm is), as MJCF text compiled
in memory, the chain hanging from the world at the origin (no geom collides; a batch of arms is
one model per arm, :mod:`soft_gym.engines.mujoco.stepping`):

- every sub-link is a body with its one joint (hinge for the bends and the torsion, slide for the
  axial joint), its mass, principal inertia and centre of mass exactly as the chain gives them;
- each joint's secant strain stiffening ``k0 (1 + beta s^2 q^2) q`` is MuJoCo's polynomial joint
  stiffness ``k0 q + k0 beta s^2 q^3`` (``stiffness="k0 0 k0 beta s^2"``), its
  stiffness-proportional damping ``tau_d k0`` the joint damping (integrated implicitly by the
  ``implicitfast`` integrator);
- each end stop (:class:`~soft_gym.robots.stops.EndStops`: stiffness ramping from 0 to ``K`` over
  the band ``b``, then constant) is a pair of one-sided fixed tendons on the joint with
  dead-band springs: ``K d^2 / (2 b)`` from the band's start, minus ``K (d - b)^2 / (2 b)`` from
  its end, whose sum is the stop's ``K (d - b / 2)`` beyond the band (exactly C1, as the stop);
- the chamber pressures' moments and the held external forces enter as applied forces at every
  actuation update (:mod:`soft_gym.engines.mujoco.simulator`).

The stop tendons cost about 40 % of a substep and act only in the last quarter of a joint's
range, so a second model without them carries the arm while every joint stays well inside its
free range (the two give the same bits there: a dead-band spring adds an exact zero).

docs/architecture.md, "The MuJoCo engine".
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from soft_gym.robots.chain import AXIAL, JOINT_AXES, Chain
from soft_gym.robots.spec import ArmSpec

INTEGRATOR = "implicitfast"
"""MuJoCo's integrator for the arm: semi-implicit in the joint damping, which keeps the stiff
link-local modes bounded at the presets' physics steps."""


@dataclass
class ArmModel:
    """A compiled MuJoCo model of one arm, and where its parts are.

    Attributes:
        model: the ``mujoco.MjModel`` (its ``qpos`` / ``qvel`` are the chain's joints, in order).
        body_ids: (n_joints,) body id of each sub-link.
        station_body_ids: (n_stations,) body id of each link's body sub-link.
    """

    model: mujoco.MjModel
    body_ids: np.ndarray
    station_body_ids: np.ndarray


def _numbers(values) -> str:
    """Numbers as MJCF text, to full double precision."""
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _chain_bodies(chain: Chain, spec: ArmSpec) -> str:
    """The nested ``<body>`` elements of the arm's chain."""
    links = chain.sub_links
    k0 = 1.0 / chain.compliance
    cubic = k0 * chain.stiffening * chain.strain_scale ** 2
    damping = chain.damping_time_s * k0
    opened, closing = [], []
    for i, kind in enumerate(links.kinds):
        joint_type = "slide" if kind == AXIAL else "hinge"
        geom = ""
        if links.is_body(i):
            segment = spec.segments[links.segments[i]]
            half = 0.5 * segment.link_length_m
            geom = (f'<geom type="cylinder" size="{_numbers([segment.outer_radius_m, half])}" '
                    f'pos="0 0 {half!r}" contype="0" conaffinity="0" group="1" mass="0"/>')
        opened.append(
            f'<body name="l{i}" pos="{_numbers(links.positions[i])}">'
            f'<inertial pos="{_numbers(links.inertial_positions[i])}" '
            f'mass="{float(links.masses[i])!r}" diaginertia="{_numbers(links.inertias[i])}"/>'
            f'<joint name="j{i}" type="{joint_type}" axis="{_numbers(JOINT_AXES[kind])}" '
            f'stiffness="{_numbers([k0[i], 0.0, cubic[i]])}" damping="{float(damping[i])!r}" '
            f'springref="0" armature="0" limited="false"/>{geom}')
        closing.append("</body>")
    return "".join(opened) + "".join(reversed(closing))


def _stop_tendons(chain: Chain) -> str:
    """Four one-sided dead-band tendon springs per joint: the end stops (see the module)."""
    stops = chain.end_stops()
    start_low, band_low, start_high, band_high = stops.bands()
    far = 1e3  # m or rad: the other end of each dead band, never reached
    tendons = []
    for i in range(chain.n_joints):
        k = stops.stiffness[i]
        sides = (
            ("uh", -far, start_high[i], k / (2 * band_high[i])),
            ("ue", -far, start_high[i] + band_high[i], -k / (2 * band_high[i])),
            ("lh", start_low[i], far, -k / (2 * band_low[i])),
            ("le", start_low[i] - band_low[i], far, k / (2 * band_low[i])),
        )
        for name, low, high, quadratic in sides:
            tendons.append(
                f'<fixed name="{name}{i}" stiffness="{_numbers([0.0, quadratic])}" '
                f'springlength="{_numbers([low, high])}">'
                f'<joint joint="j{i}" coef="1"/></fixed>')
    return "".join(tendons)


def arm_model_xml(spec: ArmSpec, chain: Chain, physics_dt_s: float, stops: bool = True) -> str:
    """MJCF text of the arm (see the module); ``stops=False`` leaves the end stops' tendons out
    (the model for an arm whose joints are all in their free range)."""
    bodies = _chain_bodies(chain, spec)
    tendons = _stop_tendons(chain) if stops else ""
    return (
        f'<mujoco model="{spec.name}">'
        f'<compiler angle="radian" inertiafromgeom="false" autolimits="false"/>'
        f'<option timestep="{physics_dt_s!r}" integrator="{INTEGRATOR}" gravity="0 0 0">'
        f'<flag contact="disable"/></option>'
        f'<worldbody>{bodies}</worldbody><tendon>{tendons}</tendon></mujoco>')


def build_arm_model(spec: ArmSpec, chain: Chain, physics_dt_s: float,
                    stops: bool = True) -> ArmModel:
    """Compile the MuJoCo model of the arm ``spec`` (chain ``chain``) at the physics step
    ``physics_dt_s`` (s), with the end stops' tendons or (``stops=False``) without."""
    model = mujoco.MjModel.from_xml_string(arm_model_xml(spec, chain, physics_dt_s, stops))
    body_ids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"l{i}")
                         for i in range(chain.n_joints)])
    return ArmModel(model, body_ids, body_ids[chain.station_link])
