"""ho2018's arm as an :class:`~soft_gym.robots.spec.ArmSpec` preset: two segments standing
upright, EM coil on the tip (Ho et al. 2018, Section 2.1), and the stepper-driven cylinders that
drive its chamber volumes (Section 3.1; ``actuation="volume"``).
"""

from __future__ import annotations

import math

from soft_gym.robots.spec import ArmSpec, CylinderSpec, SegmentSpec

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


HO2018_CYLINDERS = CylinderSpec(bore_area_m2=math.pi * 0.010**2, max_stroke_m=0.0616,
                                dead_volume_m3=2.0e-6)
"""ho2018's stepper-driven cylinders (Section 3.1), one per chamber: a 20 mm bore, 61.6 mm of
stroke (19.4 mL), 2 mL of dead volume. The paper states no bore, stroke or tubing; these are
assumed (:data:`HO2018_CYLINDER_NOTES`)."""

HO2018_CYLINDER_NOTES: dict[str, str] = {
    "cylinders": "ho2018 Section 3.1 drives each chamber's volume with a stepper-driven cylinder "
                 "(a closed volume: a load that shortens a chamber raises its pressure). Assumed, "
                 "the paper stating no bore, stroke or tubing: a 20 mm bore (a 30 mL syringe's) and "
                 "2 mL of dead volume (about 1 m of 1.6 mm tubing); the stroke, 61.6 mm, is the "
                 "longest that keeps a chamber of the straight arm at rest (78.9 mm, 5.0 mL) "
                 "within p_max = 430 kPa from the 0.04 MPa pre-pressure, so the preset's pressure "
                 "range is the cylinders' range at rest. A bent chamber is longer, so one "
                 "cylinder at full stroke bends its segment less than p_max does",
    "action": "the paper's: each action drives a cylinder's stroke, [-1, 1] to [0, 61.6 mm]; "
              "the chamber pressure follows from the gas law with the chamber's present length"}
"""Where :data:`HO2018_CYLINDERS`' numbers come from, merged into the volume-actuated arm's
notes."""
