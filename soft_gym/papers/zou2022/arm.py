"""zou2022's arm as an :class:`~soft_gym.robots.spec.ArmSpec` preset: one extensible segment of
three pressurised artificial muscles hanging from its base (Zou et al. 2022, Section 2).
"""

from __future__ import annotations

from soft_gym.robots.spec import ArmSpec, SegmentSpec

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
