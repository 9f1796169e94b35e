"""The arm's chain as a MuJoCo model: the same bodies as the PyBullet arm, with its springs native.

Built from :class:`~soft_gym.robots.chain.Chain` (as the PyBullet arm is), as MJCF text compiled
in memory, one arm or ``n_arms`` side by side in one model (a batch, each arm's chain hanging from
the world at the origin; the arms never touch: no geom collides):

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
    """A compiled MuJoCo model of ``n_arms`` copies of one arm, and where each arm's parts are.

    Attributes:
        model: the ``mujoco.MjModel``.
        n_arms: arms in the model.
        n_joints: joints of one arm (its ``qpos`` / ``qvel`` block is ``n_joints`` long).
        body_ids: (n_arms, n_joints) body id of each sub-link.
        station_body_ids: (n_arms, n_stations) body id of each link's body sub-link.
        stop_tendons: (4, n_joints) tendon ids of arm 0's stops (upper start, upper end, lower
            start, lower end); arm ``a``'s are offset by ``a * 4 * n_joints``.
    """

    model: mujoco.MjModel
    n_arms: int
    n_joints: int
    body_ids: np.ndarray
    station_body_ids: np.ndarray
    stop_tendons: np.ndarray


def _numbers(values) -> str:
    """Numbers as MJCF text, to full double precision."""
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _chain_bodies(chain: Chain, arm: int, spec: ArmSpec) -> str:
    """The nested ``<body>`` elements of one arm's chain (arm index ``arm`` names them)."""
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
            f'<body name="a{arm}_l{i}" pos="{_numbers(links.positions[i])}">'
            f'<inertial pos="{_numbers(links.inertial_positions[i])}" '
            f'mass="{float(links.masses[i])!r}" diaginertia="{_numbers(links.inertias[i])}"/>'
            f'<joint name="a{arm}_j{i}" type="{joint_type}" axis="{_numbers(JOINT_AXES[kind])}" '
            f'stiffness="{_numbers([k0[i], 0.0, cubic[i]])}" damping="{float(damping[i])!r}" '
            f'springref="0" armature="0" limited="false"/>{geom}')
        closing.append("</body>")
    return "".join(opened) + "".join(reversed(closing))


def _stop_tendons(chain: Chain, arm: int) -> str:
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
                f'<fixed name="a{arm}_{name}{i}" stiffness="{_numbers([0.0, quadratic])}" '
                f'springlength="{_numbers([low, high])}">'
                f'<joint joint="a{arm}_j{i}" coef="1"/></fixed>')
    return "".join(tendons)


def arm_model_xml(spec: ArmSpec, chain: Chain, physics_dt_s: float, n_arms: int = 1,
                  stops: bool = True) -> str:
    """MJCF text of ``n_arms`` copies of the arm (see the module); ``stops=False`` leaves the
    end stops' tendons out (the model for an arm whose joints are all in their free range)."""
    bodies = "".join(_chain_bodies(chain, arm, spec) for arm in range(n_arms))
    tendons = "".join(_stop_tendons(chain, arm) for arm in range(n_arms)) if stops else ""
    return (
        f'<mujoco model="{spec.name}">'
        f'<compiler angle="radian" inertiafromgeom="false" autolimits="false"/>'
        f'<option timestep="{physics_dt_s!r}" integrator="{INTEGRATOR}" gravity="0 0 0">'
        f'<flag contact="disable"/></option>'
        f'<worldbody>{bodies}</worldbody><tendon>{tendons}</tendon></mujoco>')


def build_arm_model(spec: ArmSpec, chain: Chain, physics_dt_s: float,
                    n_arms: int = 1, stops: bool = True) -> ArmModel:
    """Compile the MuJoCo model of ``n_arms`` copies of the arm ``spec`` (chain ``chain``) at the
    physics step ``physics_dt_s`` (s), with the end stops' tendons or (``stops=False``) without."""
    model = mujoco.MjModel.from_xml_string(arm_model_xml(spec, chain, physics_dt_s, n_arms,
                                                         stops))
    n = chain.n_joints
    body_ids = np.array([[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"a{arm}_l{i}")
                          for i in range(n)] for arm in range(n_arms)])
    stations = body_ids[:, chain.station_link]
    stop_tendons = np.arange(4 * n).reshape(n, 4).T if stops else np.zeros((4, 0), dtype=int)
    return ArmModel(model, n_arms, n, body_ids, stations, stop_tendons)
