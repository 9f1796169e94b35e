"""The arms of the four papers as :class:`ArmSpec` presets.

Dimensions come from the papers (docs/architecture.md, "Presets"); values the papers do not state
are chosen here, written down in each preset's ``notes`` and calibrated against what the paper
reports (``python -m soft_gym.demo`` prints the figures).

Integration trade-off (``bench/integration_tradeoff.py``, ``bench/env_speed.py``). The joint
springs are integrated semi-implicitly in joint space (``ArmSimulator._update_implicit_gains``),
so no step size is unstable; the step is chosen for accuracy. Measured on wang2023 (physics only,
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

from soft_gym.robots.spec import ArmSpec, SegmentSpec

_WANG_SEGMENT = SegmentSpec(
    length_m=0.090, outer_radius_m=0.010, chamber_offset_m=5.1e-3, chamber_area_m2=1.6e-5,
    youngs_modulus_pa=90e3, density_kg_m3=1070.0, n_links=4, p_max_pa=125e3,
    bending_stiffening=1.5, axial_stiffening=2.0, damping_ratio=0.3, extra_tip_mass_kg=0.006)

WANG2023 = ArmSpec(
    name="wang2023", segments=(_WANG_SEGMENT,), mount="hanging",
    pneumatic_time_constant_s=0.12, control_period_s=0.05, physics_dt_s=2.5e-3,
    actuation_update_s=0.01,
    description=("Wang et al. 2023: single 90 mm segment, OD 20 mm, chambers at d = 5.1 mm, "
                 "Ecoflex-30, camera + LED tip cap, 20 Hz control."),
    notes={"youngs_modulus_pa": "Ecoflex 00-30 small-strain modulus ~70-100 kPa; 90 kPa chosen",
           "chamber_area_m2": "bore of ~2.3 mm radius, fits between d = 5.1 mm and the 10 mm wall",
           "p_max_pa": "not stated (stepper-driven cylinders); chosen so one chamber at p_max "
                       "moves the tip ~40 mm from rest as the paper reports",
           "extra_tip_mass_kg": "camera + LED tip cap, 6 g assumed"})

_ZHAO_SEGMENT = SegmentSpec(
    length_m=0.150, outer_radius_m=0.0175, chamber_offset_m=9.0e-3, chamber_area_m2=5.0e-5,
    youngs_modulus_pa=103e3, poisson_ratio=0.48, density_kg_m3=1070.0, n_links=4,
    p_max_pa=80e3, bending_stiffening=1.0, axial_stiffening=2.0, damping_ratio=0.3,
    extra_tip_mass_kg=0.010)

ZHAO2021 = ArmSpec(
    name="zhao2021", segments=(_ZHAO_SEGMENT, _ZHAO_SEGMENT), mount="hanging",
    pneumatic_time_constant_s=0.2, control_period_s=0.05, physics_dt_s=2.5e-3,
    actuation_update_s=0.01,
    description=("Zhao et al. 2021: two 150 mm segments, OD 35 mm, silicone E = 15 psi, "
                 "nu = 0.48, 1.07 g/cm^3, 0-0.8 bar, 3 strain gauges per segment."),
    notes={"chamber_offset_m": "not stated; 9 mm", "chamber_area_m2": "not stated; 50 mm^2",
           "extra_tip_mass_kg": "10 g end plate / connector per segment assumed"})

_ZOU_SEGMENT = SegmentSpec(
    length_m=0.077, outer_radius_m=0.016, chamber_offset_m=0.010, chamber_area_m2=7.0e-5,
    youngs_modulus_pa=250e3, axial_modulus_pa=15e3, density_kg_m3=400.0, n_links=4,
    p_max_pa=300e3, bending_stiffening=0.5, axial_stiffening=0.42, max_extension_ratio=4.0,
    max_bend_per_m_rad=60.0, damping_ratio=0.3, extra_tip_mass_kg=0.010)

ZOU2022 = ArmSpec(
    name="zou2022", segments=(_ZOU_SEGMENT,), mount="hanging",
    pneumatic_time_constant_s=0.25, control_period_s=0.05, physics_dt_s=1.25e-3,
    actuation_update_s=0.01,
    description=("Zou et al. 2022: one extensible segment of three pressurised artificial muscles "
                 "(77-252 mm), 0-3 bar, cable encoders on the chamber lengths, stereo camera."),
    notes={"axial_modulus_pa": "PMA bundle: low effective axial modulus so 3 bar in all muscles "
                               "extends the 77 mm segment towards ~250 mm",
           "density_kg_m3": "braided sleeves + latex tubes are mostly air; 400 kg/m^3 effective"})

_HO_SEGMENT = SegmentSpec(
    length_m=0.0775, outer_radius_m=0.0135, chamber_offset_m=7.0e-3, chamber_area_m2=1.07e-4,
    youngs_modulus_pa=450e3, axial_modulus_pa=1.2e6, density_kg_m3=1070.0, n_links=4,
    p_max_pa=330e3, p_pre_pa=40e3,
    bending_stiffening=0.5, axial_stiffening=2.0, damping_ratio=0.3, extra_tip_mass_kg=0.0)

HO2018 = ArmSpec(
    name="ho2018", segments=(_HO_SEGMENT, _HO_SEGMENT), mount="upright",
    pneumatic_time_constant_s=0.1, control_period_s=0.05, physics_dt_s=2.5e-3,
    actuation_update_s=0.01,
    description=("Ho et al. 2018: two segments standing upright (base below, EM coil on the tip), "
                 "155 mm total, OD 27 mm, Dragon Skin 10, body mass 41.7 g, ~100 deg bending per "
                 "segment in any direction, 0.04 MPa pre-pressure, EM tracker."),
    notes={"mount": "upright as in the paper's Figs. 1(d) and 3: gravity compresses the arm and "
                    "tips it further as it bends",
           "chamber_area_m2": "107 mm^2 per chamber, so that with 1070 kg/m^3 the body weighs "
                              "41.7 g as the paper states",
           "youngs_modulus_pa": "450 kPa effective bending modulus (Dragon Skin 10 ~150-180 kPa "
                                "solid, stiffened by the fibre-wound, pre-pressurised chambers): "
                                "upright, the arm's own weight is 0.18 of its self-weight "
                                "buckling load, the 14.2 g tip 0.19 and the full 30 g fluid tip "
                                "0.41 of the tip buckling load, so the loads deform a bent arm "
                                "markedly (up to ~2x its compliance) without collapsing a "
                                "straight one. At 80 kPa the straight arm fell over under the "
                                "14.2 g tip; at 300 kPa the 30 g tip (0.86 of buckling) made it "
                                "seven times softer, which no controller in the paper faced",
           "axial_modulus_pa": "1.2 MPa effective (the helical fibres carry the axial load): the "
                               "0.04 MPa pre-pressure lengthens the 155 mm arm to ~161 mm",
           "p_max_pa": "chosen so one chamber at p_max bends its segment 97-104 deg upright (the "
                       "paper: 'up to 100 deg' per segment); the paper drives volumes and states "
                       "no pressure",
           "pneumatic_time_constant_s": "0.1 s: stepper-driven cylinders displace the chamber "
                                        "volume directly, so the chamber follows the command "
                                        "within a few control steps",
           "action": "the paper drives chamber volumes with stepper-driven cylinders; here the "
                     "action is the chamber pressure. A closed volume makes the chamber stiffer "
                     "against loads (a load that bends the arm raises the pressure on one side), "
                     "so the simulated arm yields more to a tip load at the same command than "
                     "the paper's; the learners see pressures where the paper's saw volumes"})

PRESETS: dict[str, ArmSpec] = {spec.name: spec for spec in (WANG2023, ZHAO2021, ZOU2022, HO2018)}


def get_preset(name: str) -> ArmSpec:
    """Return the preset called ``name`` (one of :data:`PRESETS`)."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {sorted(PRESETS)}, got {name!r}")
    return PRESETS[name]
