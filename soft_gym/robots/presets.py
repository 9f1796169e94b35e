"""The arms of the four papers as :class:`ArmSpec` presets.

Dimensions come from the papers (docs/architecture.md, "Presets"); values the papers do not state
are chosen here, written down in each preset's ``notes`` and calibrated against what the paper
reports (``python -m soft_gym.demo`` prints the figures).

Integration trade-off (``bench/integration_tradeoff.py``, ``bench/env_speed.py``). The joint
springs are integrated semi-implicitly in joint space (``ArmSimulator._update_implicit_gains``),
so they set no step limit, and substeps are split while the arm whips (``ArmSimulator.
_refinement_for``); the step is chosen for accuracy. Measured on wang2023 (physics only,
commands held 0.5 s, deviation from the same run at a 4x smaller step; static errors with gravity
and stiffening off):

    links  dt ms  control steps/s  dyn. dev. mm  arc err % L  F L^3/3EI err %
      3    2.5         1578           0.30          0.24           5.6
      4    1.25         847           0.15          0.13           3.1
      4    2.5         1392           0.30          0.13           3.1
      4    5.0         2256           0.59          0.13           3.1
      6    2.5         1091           0.31          0.06           1.4
      8    2.5          862           0.31          0.03           0.8

(``python bench/integration_tradeoff.py``, version 0.2.0 with the end stops, on the 2-core
development machine while another process ran: steps per second are a lower bound.)

Four links per segment at 2.5 ms meet the 0.5 mm accuracy bound with margin, keep the beam
errors well inside the 2 % (arc) and 15 % (deflection) tolerances, and leave time for the env.
zou2022 extends to 3.3 times its length and whips far; it runs at 1.25 ms (0.4 mm). An explicit
spring chain would need about 0.5 ms at four links (measured: it diverges at 1 ms for ho2018).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from soft_gym.robots.spec import ArmSpec, CylinderSpec, SegmentSpec

_WANG_SEGMENT = SegmentSpec(
    length_m=0.090, outer_radius_m=0.010, chamber_offset_m=5.1e-3, chamber_area_m2=1.6e-5,
    youngs_modulus_pa=90e3, density_kg_m3=1070.0, n_links=4, p_max_pa=125e3,
    bending_stiffening=1.5, axial_stiffening=2.0, damping_ratio=0.3, extra_tip_mass_kg=0.006)

WANG2023 = ArmSpec(
    name="wang2023", segments=(_WANG_SEGMENT,), mount="hanging",
    pneumatic_time_constant_s=0.12, control_period_s=0.05, physics_dt_s=2.5e-3,
    actuation_update_s=0.01, mujoco_physics_dt_s=1.25e-3,
    description=("Wang et al. 2023: single 90 mm segment, OD 20 mm, chambers at d = 5.1 mm, "
                 "Ecoflex-30, camera + LED tip cap, 20 Hz control."),
    notes={"youngs_modulus_pa": "Ecoflex 00-30 small-strain modulus ~70-100 kPa; 90 kPa chosen",
           "chamber_area_m2": "bore of ~2.3 mm radius, fits between d = 5.1 mm and the 10 mm wall",
           "p_max_pa": "not stated (stepper-driven cylinders); chosen so one chamber at p_max "
                       "moves the tip ~40 mm from rest as the paper reports",
           "extra_tip_mass_kg": "camera + LED tip cap, 6 g assumed"})

_ZHAO_PROXIMAL = SegmentSpec(
    length_m=0.1009, outer_radius_m=0.0175, chamber_offset_m=0.01181,
    chamber_area_m2=math.pi * 3.61e-3**2, youngs_modulus_pa=103e3, poisson_ratio=0.48,
    density_kg_m3=1070.0, n_links=4, p_max_pa=80e3, bending_stiffening=1.0, axial_stiffening=0.0,
    max_extension_ratio=2.0, thread_length_m=0.150, chamber_area_growth=3.96,
    chamber_area_growth_exponent=6.0, damping_ratio=0.3, extra_tip_mass_kg=0.008)
_ZHAO_DISTAL = dataclasses.replace(_ZHAO_PROXIMAL, chamber_area_growth=3.22,
                                   chamber_area_growth_exponent=5.79)

ZHAO2021 = ArmSpec(
    name="zhao2021", segments=(_ZHAO_PROXIMAL, _ZHAO_DISTAL), mount="hanging",
    pneumatic_time_constant_s=0.2, control_period_s=0.05, physics_dt_s=2.5e-3,
    actuation_update_s=0.01, mujoco_physics_dt_s=1.25e-3,
    description=("Zhao et al. 2021: two segments held to at most 150 mm each by a central "
                 "inextensible thread (101 mm at rest), OD 35 mm, silicone E = 15 psi, "
                 "nu = 0.48, 1.07 g/cm^3, 0-0.8 bar, 3 strain gauges per segment."),
    notes={"fit": "rest length, chamber offset and bore, the bores' growth law and the rings' "
                  "mass are not stated; fitted jointly (soft_gym.procedures.zhao2021_arm_fit, "
                  "ZHAO2021_ARM_FIT; docs/architecture.md, \"zhao2021 arm fit\") so that the "
                  "resting arm holds every pose of the paper's experiments: the start (40, 20, "
                  "300) mm free and with the swaying 119 g block (0.0 / 0.1 mm off), the goal "
                  "(-50, 70, 210) mm free and with 50, 75 and 100 g (0.0-0.8 mm), and twelve "
                  "points of the 100 mm circle at z = 260.4 mm free and carrying 263 g "
                  "(under 0.1 mm)",
           "calibration": "Table III pressures (paper order 0, 0.5, 0.6, 0.8, 0.7, 0 bar): key "
                          "points P1..P6 within 2.8, 9.6, 17.2, 19.8, 26.7, 60.3 mm of the "
                          "paper's (RMS 29.3 mm). The goal with 100 g conflicts with Table III: "
                          "fitted to Table III with every other pose (the starts, the circle "
                          "with 263 g) the key points reach RMS 6.7 mm but the goal stays 23-34 "
                          "mm out of reach with 0-100 g (ZHAO2021_TABLE3_FIT); with the goal "
                          "free, RMS 12.2 mm; with 100 g, 27-29 mm from every start tried. "
                          "Holding the paper's goal needs segment 1 to curl with 100 g where "
                          "Table III has it nearly straight at 0.5-0.6 bar, so the fit chose "
                          "the experiments",
           "thread_length_m": "zhao2021 Section II-A: an inextensible thread at the centre of "
                              "the end rings limits each segment to 150 mm; the segment shortens "
                              "freely and cannot lengthen past it",
           "length_m": "rest length not stated; 100.9 mm, fitted: 0.8 bar stretches the "
                       "segment to its 150 mm thread (the start point needs both taut)",
           "axial_stiffening": "0: the thread, not the silicone's stiffening, ends the stretch",
           "chamber_area_m2": "not stated; 40.9 mm^2 at rest (bore radius 3.61 mm) at "
                              "d = 11.81 mm (chamber_offset_m): 2.1 mm of wall outside, "
                              "13.2 mm between bores, 8.2 mm around the thread; fitted",
           "chamber_area_growth": "not stated; segment 1 3.96 with exponent 6.0, segment 2 3.22 "
                                  "with 5.79 (each segment is wound with its own nylon "
                                  "thread): a wound bore (Section II-A) that hardly grows to "
                                  "0.5 bar (+ 24 % and + 21 % of its area) and balloons "
                                  "between the windings above it, to 5.0 and 4.2 times its "
                                  "area at 0.8 bar, more than the body's cross-section holds "
                                  "as a round bore: the fit pushes it to the edge of its "
                                  "range, part of the conflict above",
           "youngs_modulus_pa": "15 psi = 103 kPa (zhao2021 Table I), for bending and axial strain",
           "bending_stiffening": "1.0 (the fit hardly depends on it: bending strain is small)",
           "max_extension_ratio": "2.0: only bounds the thread (thread_length_m <= 2 length_m); "
                                  "the thread sets the longest length",
           "extra_tip_mass_kg": "8 g PLA ring per segment end (zhao2021 Table I: rings and "
                                "fixator, 1.29 g/cm^3): fitted, at the top of the 3-8 g range "
                                "of 2.5-6.5 mm thick 35 mm rings",
           "paper_frame": "see ZHAO2021_PAPER_CHAMBERS and paper_point_from_base: the paper's "
                          "chambers run clockwise where ours run counter-clockwise, segment 2's "
                          "numbering starts one chamber (120 deg) on, and the paper's axes are "
                          "ours turned 172.4 deg about z, origin 9.9 mm above the silicone "
                          "base (fitted)"})

ZHAO2021_PAPER_CHAMBERS = (0, 2, 1, 5, 3, 4)
"""Paper regulator (0-based: zhao2021's chambers 1-6 are 0-5) that drives each of our chambers.

Our chamber ``i`` of a segment sits at ``sigma_i = 2 pi i / 3`` counter-clockwise from +x (seen
from the base looking along +z, towards the tip). The assignment best reproducing Table III is:
segment 1 ours (0, 1, 2) = paper (1, 3, 2), segment 2 ours (0, 1, 2) = paper (6, 4, 5), i.e.
the paper numbers clockwise, and its segment 2 starts one chamber further round than its
segment 1: on the arm fitted to Table III alone, turning segment 2's numbering by another
120 deg either way raised the key points' RMS error from ~7 mm to 20-25 mm, and two other
assignments fitted as well as this one (RMS 7.24, 7.24 and 7.26 mm with the frame angle fitted
to each): the data cannot tell them apart, and the first is kept."""

ZHAO2021_PAPER_FRAME_DEG = 172.4
"""The paper's x axis is our x axis turned by this angle about +z (deg), fitted to Table III."""

ZHAO2021_PAPER_ORIGIN_Z_M = 0.0099
"""Our base (the first silicone station) lies this far along the paper's +z below its origin O
(m): the base ring. The paper's arm is 310 mm long with its rings (zhao2021 Section VI-E) where
the threads allow 300 mm, so up to 10 mm of rigid ring; 9.9 mm are put at the base, fitted with
the arm (soft_gym.procedures.zhao2021_arm_fit) within that range (Section VI-C's start point
(40, 20, 300) mm is 303 mm from O, and Section VI-C's disturbed tip (19.8, 10.2, 303.6) mm
304 mm, beyond 300 mm of threads alone)."""


def paper_pressures_to_chambers(paper_pa: np.ndarray) -> np.ndarray:
    """zhao2021's six regulator pressures (its order, Pa) as our chamber pressures (Pa)."""
    paper = np.asarray(paper_pa, dtype=float)
    if paper.shape != (6,):
        raise ValueError(f"paper_pa must have shape (6,), got {paper.shape}")
    return paper[list(ZHAO2021_PAPER_CHAMBERS)]


def paper_point_from_base(point_m: np.ndarray, frame_deg: float = ZHAO2021_PAPER_FRAME_DEG,
                          origin_z_m: float = ZHAO2021_PAPER_ORIGIN_Z_M) -> np.ndarray:
    """A point in our zhao2021 base frame (m) in the paper's key-point frame (m).

    Both z axes run from the base towards the tip (the paper's key points have z = 0 at O and
    248.5 mm at the tip); the paper's x axis is ours turned by ``frame_deg`` (default
    ``ZHAO2021_PAPER_FRAME_DEG``) about z, and its origin lies ``origin_z_m`` (default
    ``ZHAO2021_PAPER_ORIGIN_Z_M``) before our base along z. Works on ``(..., 3)`` arrays.
    """
    angle = np.radians(frame_deg)
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(point_m, dtype=float)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.stack([c * x - s * y, s * x + c * y, z + origin_z_m], axis=-1)


def base_point_from_paper(point_m: np.ndarray, frame_deg: float = ZHAO2021_PAPER_FRAME_DEG,
                          origin_z_m: float = ZHAO2021_PAPER_ORIGIN_Z_M) -> np.ndarray:
    """A point in the paper's key-point frame (m) in our zhao2021 base frame (m) (the inverse of
    :func:`paper_point_from_base`)."""
    angle = np.radians(frame_deg)
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(point_m, dtype=float)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.stack([c * x + s * y, -s * x + c * y, z - origin_z_m], axis=-1)


_ZOU_SEGMENT = SegmentSpec(
    length_m=0.077, outer_radius_m=0.016, chamber_offset_m=0.010, chamber_area_m2=7.0e-5,
    youngs_modulus_pa=250e3, axial_modulus_pa=15e3, density_kg_m3=400.0, n_links=4,
    p_max_pa=300e3, bending_stiffening=0.5, axial_stiffening=0.42, max_extension_ratio=4.0,
    max_bend_per_m_rad=60.0, damping_ratio=0.3, extra_tip_mass_kg=0.010, torsion=True,
    braid_twist_m=2.5e-3)

ZOU2022 = ArmSpec(
    name="zou2022", segments=(_ZOU_SEGMENT,), mount="hanging",
    pneumatic_time_constant_s=0.25, control_period_s=0.05, physics_dt_s=1.25e-3,
    actuation_update_s=0.01,
    description=("Zou et al. 2022: one extensible segment of three pressurised artificial muscles "
                 "(77-252 mm), 0-3 bar, cable encoders on the chamber lengths, stereo camera."),
    notes={"axial_modulus_pa": "PMA bundle: low effective axial modulus so 3 bar in all muscles "
                               "extends the 77 mm segment towards ~250 mm",
           "density_kg_m3": "braided sleeves + latex tubes are mostly air; 400 kg/m^3 effective",
           "braid_twist_m": "assumed unbalanced braid, 2.5 mm lever: the paper's arm 'twists into "
                            "complex 3D curves' as it bends (zou2022 Section 3, Fig. 8), which "
                            "is why CC (RSES) fails there. The twist grows with the summed "
                            "pressure: 0.60 rad at 1/1/1 bar, 0.90 rad at 1/2.5/1 bar, 1.55 rad "
                            "(0.39 rad per link, inside the torsion joints' 0.5 rad) at 3 bar in "
                            "every muscle. Straight, the twist leaves the backbone unchanged; bent, "
                            "it turns the bending plane along the arm"})

_HO_SEGMENT = SegmentSpec(
    length_m=0.0775, outer_radius_m=0.0135, chamber_offset_m=8.0e-3,
    chamber_area_m2=math.pi * 4.5e-3**2, central_cavity_radius_m=2.5e-3,
    youngs_modulus_pa=450e3, axial_modulus_pa=1.2e6, density_kg_m3=1070.0, n_links=4,
    p_max_pa=430e3, p_pre_pa=40e3,
    bending_stiffening=0.5, axial_stiffening=2.0, damping_ratio=0.3, extra_tip_mass_kg=0.0)

HO2018 = ArmSpec(
    name="ho2018", segments=(_HO_SEGMENT, _HO_SEGMENT), mount="upright",
    pneumatic_time_constant_s=0.1, control_period_s=0.05, physics_dt_s=2.5e-3,
    actuation_update_s=0.01, mujoco_physics_dt_s=2.5e-3 / 3,
    description=("Ho et al. 2018: two segments standing upright (base below, EM coil on the tip), "
                 "155 mm total, OD 27 mm, Dragon Skin 10 (body 60.0 g from the material; the "
                 "paper weighs 41.7 g), ~100 deg bending per segment in any direction, 0.04 MPa "
                 "pre-pressure, EM tracker."),
    notes={"mujoco_physics_dt_s": "0.83 ms: the upright arm swings the most; at 2.5 ms the MuJoCo "
                                  "engine's tip strays 1.1-1.8 mm from a 4x finer step, at 0.83 "
                                  "ms 0.38-0.60 mm (PyBullet at 2.5 ms: 1.4-2.3 mm)",
           "mount": "upright as in the paper's Figs. 1(d) and 3: gravity compresses the arm and "
                    "tips it further as it bends",
           "chamber_area_m2": "a cross-section a moulded 27 mm arm can have: three round, "
                              "fibre-wound bores of 4.5 mm radius (63.6 mm^2) at 8.0 mm from the "
                              "axis around a 2.5 mm central cavity (Section 2.1: the proximal "
                              "segment's centre cavity carries the distal segment's three tubes, "
                              "assumed 1.6 mm OD), leaving 1.0 mm outer and inner walls and 4.9 mm between "
                              "bores (SegmentSpec.wall_thickness_m)",
           "density_kg_m3": "Dragon Skin 10's 1.07 g/cm^3: the body's mass follows from the "
                            "material, 30.0 g per segment, 60.0 g in all. The paper states "
                            "41.71 g (Section 3.5.2), which 155 mm of 27 mm silicone reaches only "
                            "with 56 % of the section hollow: 107 mm^2 bores with 0.45 mm walls "
                            "between them and no central cavity. No layout with walls of 1 mm "
                            "and the tube cavity comes near it (the thinnest, above, weighs "
                            "60.0 g); the paper's figure may leave out parts of the arm or weigh "
                            "a shorter body, and the arm here keeps the material's mass",
           "youngs_modulus_pa": "450 kPa effective bending modulus (Dragon Skin 10 ~150-180 kPa "
                                "solid, stiffened by the fibre-wound, pre-pressurised chambers): "
                                "upright, the arm's own weight is 0.21 of its self-weight "
                                "buckling load (7.84 EI / L^3), the 14.2 g tip 0.16 and the full "
                                "30 g fluid tip 0.34 of the tip buckling load (pi^2 EI / (4 "
                                "L^2)), so the loads deform a bent arm markedly without "
                                "collapsing a straight one",
           "axial_modulus_pa": "1.2 MPa effective (the helical fibres carry the axial load)",
           "p_max_pa": "chosen so one chamber at p_max bends its segment about 100 deg as the "
                       "paper's ('up to 100 deg' per segment), upright under its own weight: "
                       "104.5 deg for the proximal segment and 94.3 deg for the distal one "
                       "(93 deg each weightless), the angle being how far the backbone's tangent "
                       "turns from the segment's base to its end (Simulator."
                       "segment_bend_angles_rad, the CC angle kappa L). The paper drives "
                       "volumes and states no pressure",
           "pneumatic_time_constant_s": "0.1 s: stepper-driven cylinders displace the chamber "
                                        "volume directly, so the chamber follows the command "
                                        "within a few control steps",
           "action": "the paper drives chamber volumes with stepper-driven cylinders; here the "
                     "action is the chamber pressure. A closed volume makes the chamber stiffer "
                     "against loads (a load that bends the arm raises the pressure on one side), "
                     "so the simulated arm yields more to a tip load at the same command than "
                     "the paper's; the learners see pressures where the paper's saw volumes"})

PRESETS: dict[str, ArmSpec] = {spec.name: spec for spec in (WANG2023, ZHAO2021, ZOU2022, HO2018)}

HO2018_CYLINDERS = CylinderSpec(bore_area_m2=math.pi * 0.010**2, max_stroke_m=0.0616,
                                dead_volume_m3=2.0e-6)
"""ho2018's stepper-driven cylinders (Section 3.1), one per chamber: a 20 mm bore, 61.6 mm of
stroke (19.4 mL), 2 mL of dead volume. The paper states no bore, stroke or tubing; these are
assumed (:data:`CYLINDER_NOTES`)."""

CYLINDERS: dict[str, CylinderSpec] = {"ho2018": HO2018_CYLINDERS}
"""The presets whose papers drive chamber volumes, and their cylinders
(:func:`volume_actuated`)."""

CYLINDER_NOTES: dict[str, dict[str, str]] = {"ho2018": {
    "cylinders": "ho2018 Section 3.1 drives each chamber's volume with a stepper-driven cylinder "
                 "(a closed volume: a load that shortens a chamber raises its pressure). Assumed, "
                 "the paper stating no bore, stroke or tubing: a 20 mm bore (a 30 mL syringe's) and "
                 "2 mL of dead volume (about 1 m of 1.6 mm tubing); the stroke, 61.6 mm, is the "
                 "longest that keeps a chamber of the straight arm at rest (78.9 mm, 5.0 mL) "
                 "within p_max = 430 kPa from the 0.04 MPa pre-pressure, so the preset's pressure "
                 "range is the cylinders' range at rest. A bent chamber is longer, so one "
                 "cylinder at full stroke bends its segment less than p_max does",
    "action": "the paper's: each action drives a cylinder's stroke, [-1, 1] to [0, 61.6 mm]; "
              "the chamber pressure follows from the gas law with the chamber's present length"}}
"""Where :data:`CYLINDERS`' numbers come from, merged into the volume-actuated arm's notes."""


def volume_actuated(spec: ArmSpec) -> ArmSpec:
    """``spec`` driven by cylinder volumes as its paper did (ho2018 Section 3.1): its preset's
    :data:`CYLINDERS` set as :attr:`ArmSpec.cylinders`, the notes told. A spec that already has
    cylinders is returned as it is.

    Raises:
        ValueError: a preset whose paper drives pressures (no entry in :data:`CYLINDERS`).
    """
    if spec.cylinders is not None:
        return spec
    if spec.name not in CYLINDERS:
        raise ValueError(f"actuation='volume' needs an arm with cylinders (ArmSpec.cylinders) or "
                         f"a preset whose paper drives volumes, one of {sorted(CYLINDERS)}, got "
                         f"{spec.name!r}")
    return dataclasses.replace(spec, cylinders=CYLINDERS[spec.name],
                               notes={**spec.notes, **CYLINDER_NOTES[spec.name]})


def get_preset(name: str) -> ArmSpec:
    """Return the preset called ``name`` (one of :data:`PRESETS`)."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {sorted(PRESETS)}, got {name!r}")
    return PRESETS[name]
