"""wang2023's arm as an :class:`~soft_gym.robots.spec.ArmSpec` preset: one 90 mm Ecoflex-30
segment hanging from its base, camera and LED cap on the tip (Wang et al. 2023, Section II).

Dimensions come from the paper (docs/architecture.md, "Presets"); values it does not state are
chosen here and written down in the preset's ``notes``.
"""

from __future__ import annotations

from soft_gym.robots.spec import ArmSpec, SegmentSpec

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
