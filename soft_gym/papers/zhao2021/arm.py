"""zhao2021's arm as an :class:`~soft_gym.robots.spec.ArmSpec` preset: two thread-limited
segments hanging from their base (Zhao et al. 2021, Section II-A, Table I), fitted to the poses
of the paper's experiments (:mod:`soft_gym.papers.zhao2021.arm_fit`). The paper's chamber
numbering and key-point frame are in :mod:`soft_gym.papers.zhao2021.frames`.
"""

from __future__ import annotations

import dataclasses
import math

from soft_gym.robots.spec import ArmSpec, SegmentSpec

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
                  "mass are not stated; fitted jointly (soft_gym.papers.zhao2021.arm_fit, "
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
