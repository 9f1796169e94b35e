"""A single-core FBG fiber wound helically on the arm's surface (wang2023, Section II-C, IV-A).

Geometry (Wang et al. 2023, Section IV-A and Fig. 2): one fiber carrying ``n`` gratings
(17 gratings, 6 mm long, 20 mm apart along the fiber) is wound as a helix of pitch ``P`` (turns
about 16.5 mm apart along the arm) at radius ``r`` (the 10 mm outer radius) on the 90 mm body.
The helix angle ``a`` between the fiber and the arm axis obeys ``tan a = 2 pi r / P`` (75.3 deg for
the default), so a step ``dl`` along the fiber advances the arc position by ``dl cos a``.

Strain model (docs/architecture.md, "FBG fiber"; after Xu et al. 2016, wang2023 ref. [24]). At a
surface
point at arc position ``s`` and angle ``psi`` (a material angle, measured in the cross-section's
own frame from its local ``+x`` axis) the axial surface strain of a bent and stretched rod is

    eps_z(s, psi) = eps_axial(s) - r (kx(s) cos psi + ky(s) sin psi)

which is ``eps_axial - kappa r cos(psi - phi)`` written without ``phi`` (smooth through the straight
pose). The curvature vector ``(kx, ky)`` points toward the bending direction (towards the centre of
curvature, :mod:`soft_gym.kinematics`), so the surface on the inside of the bend (``psi = phi``) is
shortened and the surface on the outside of the bend (``psi = phi + pi``) is *stretched* along the
axis. With uniaxial stress the hoop strain is ``-nu eps_z`` and the shear strain from a twist rate
``tau`` is ``gamma = r tau``; projected on the fiber direction this gives the fiber strain

    eps_f = eps_z (cos^2 a - nu sin^2 a) + h r tau sin a cos a                           (F1)

with ``h = +1`` for a right-handed helix (``psi`` grows with ``s``) and ``-1`` otherwise. Note the
sign of the bracket: it is negative above the "magic" angle ``tan^2 a = 1 / nu`` (55 deg for
``nu = 0.48``), so the default, mostly circumferential winding (``a = 75 deg``) reads the axial
strain with factor ``cos^2 a - nu sin^2 a = -0.385``: a grating on the outside of the bend, where
the surface is stretched along the axis, is shortened along the fiber because the hoop contraction
dominates. (F1) is averaged over each grating's length with Gauss-Legendre points along the
fiber, interpolating the simulator's curvature profile linearly between backbone vertices.

Gratings are fixed to the material: their arc positions are *rest* (material) arc positions from
the arm base and the per-vertex curvatures of :meth:`ArmSimulator.curvature_profile` are read at
the vertices' rest arc positions (within a link the stretch is uniform, so this is the same linear
interpolation as along the current arc). The simulator expresses each vertex's curvature in the
material frame at that vertex (the frame rotates with the torsion joints), so the material angles
``psi_j`` need no twist correction.

Wavelength (Wang et al. 2023, Section II-A, the wavelength-shift vector ``lambda(k)``):

    dl_j = l0 (1 - p_e) t eps_j + k_T dT + noise                                          (F2)

with ``l0 = 1550 nm``, ``p_e = 0.21`` (1.22 pm per microstrain), ``t`` a strain-transfer factor
(``t = 1``: the fiber follows the surface; :class:`FBGFiber` defaults to 2e-3), ``dT`` a common
temperature change and
white Gaussian noise (default 1 pm; wang2023 Appendix reports a mean static noise of 0.9 pm and at
most 4 pm).

Contact (Wang et al. 2023, Section IV-F1, Table III and Appendix Table VII): a force pressing on a
fiber-covered link strains the gratings under it. The force on link ``l`` from
:meth:`ArmSimulator.link_contact_forces` is taken to press on the gratings of that link that face
it: grating ``j`` with outward surface normal ``n_j`` receives the pressing force
``f_j = max(0, -F_l . n_j)`` and the extra strain ``c f_j`` with ``c = contact_strain_per_n``
(tensile: the fiber is pushed into the soft substrate and stretched into the dent). The default
``c = 0.011 / N`` is chosen so that a 0.2 N push on a grating facing it gives 2.2e-3 of strain, the
fiber strain of a 3 deg bend of the 90 mm wang2023 arm (``kappa = 0.58 1/m``,
``0.385 kappa r = 2.2e-3``), and a ~2 N finger push about half the strain of the ~60 deg full bend,
as Table VII reports for the unprotected fiber (46-58 % of the sensing range).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from gymnasium import spaces

from soft_gym._validation import require_non_negative, require_positive
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.base import Sensor

LAMBDA0_NM = 1550.0
"""Bragg wavelength ``l0`` of the gratings (nm), C-band (docs/architecture.md, "FBG fiber")."""

PHOTOELASTIC = 0.21
"""Effective photo-elastic coefficient ``p_e`` of silica fiber."""

_TEMPERATURE_LIMIT_C = 50.0
"""The temperature change is clipped to +-50 degC (keeps the readings inside the space)."""

_CONTACT_FORCE_BOUND_N = 10.0
"""Pressing force used to size the observation space (readings beyond the space are clipped)."""


def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def gauss_points(n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes on [-1, 1] and weights normalised to sum 1."""
    nodes, weights = np.polynomial.legendre.leggauss(n_points)
    return nodes, weights / weights.sum()


def rest_vertex_arcs(spec: ArmSpec) -> np.ndarray:
    """Rest (material) arc position of every backbone vertex from the base (m), (n_links + 1,)."""
    lengths = np.concatenate([[s.link_length_m] * s.n_links for s in spec.segments])
    return np.r_[0.0, np.cumsum(lengths)]


def segment_bounds(spec: ArmSpec) -> np.ndarray:
    """Rest arc position of every segment boundary (m), shape (n_segments + 1,)."""
    return np.r_[0.0, np.cumsum([s.length_m for s in spec.segments])]


def locate(vertex_arc_m: np.ndarray, arc_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Link index and fraction ``u`` in [0, 1] along that link of every arc position.

    Positions outside the backbone are clamped to the first / last link (extrapolation is never
    used: layouts are checked to lie on the arm).
    """
    n_links = len(vertex_arc_m) - 1
    link = np.clip(np.searchsorted(vertex_arc_m, arc_m, side="right") - 1, 0, n_links - 1)
    start = vertex_arc_m[link]
    fraction = np.clip((arc_m - start) / (vertex_arc_m[link + 1] - start), 0.0, 1.0)
    return link, fraction


def surface_bending_matrix(vertex_arc_m: np.ndarray, arc_m: np.ndarray, psi_rad: np.ndarray,
                           coefficient: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Linear map from the vertex curvatures to weighted surface projections.

    Returns ``B`` of shape (n_out, 2 (n_links + 1)) with ``B @ curvature.ravel()`` equal to
    ``sum_q weights[q] coefficient[j, q] (kx(s_jq) cos psi_jq + ky(s_jq) sin psi_jq)`` where
    ``kx, ky`` are linearly interpolated between vertices and ``arc_m, psi_rad, coefficient`` have
    shape (n_out, n_q).
    """
    n_out, n_q = arc_m.shape
    n_vertices = len(vertex_arc_m)
    link, u = locate(vertex_arc_m, arc_m)
    rows = np.repeat(np.arange(n_out), n_q)
    scale = (coefficient * weights[None, :]).ravel()
    c, s = np.cos(psi_rad).ravel(), np.sin(psi_rad).ravel()
    matrix = np.zeros((n_out, n_vertices, 2))
    for vertex, share in ((link.ravel(), 1.0 - u.ravel()), (link.ravel() + 1, u.ravel())):
        np.add.at(matrix, (rows, vertex, 0), scale * share * c)
        np.add.at(matrix, (rows, vertex, 1), scale * share * s)
    return matrix.reshape(n_out, 2 * n_vertices)


def link_matrix(vertex_arc_m: np.ndarray, arc_m: np.ndarray, coefficient: np.ndarray,
                weights: np.ndarray) -> np.ndarray:
    """Linear map (n_out, n_links) from a per-link quantity to ``sum_q w_q c_jq x[link(s_jq)]``."""
    n_out, n_q = arc_m.shape
    link, _ = locate(vertex_arc_m, arc_m)
    matrix = np.zeros((n_out, len(vertex_arc_m) - 1))
    rows = np.repeat(np.arange(n_out), n_q)
    np.add.at(matrix, (rows, link.ravel()), (coefficient * weights[None, :]).ravel())
    return matrix


@dataclass(frozen=True)
class FBGGeometry:
    """Where a :class:`FBGLayout` puts its gratings on one arm (the result of ``layout.resolve``).

    Per grating ``j`` and quadrature point ``q`` along it (shape (n_gratings, n_points)):

    Attributes:
        arc_m: rest arc position from the arm base (m).
        psi_rad: material angle on the surface ``psi0 + h 2 pi s / P`` (rad).
        radius_m: fiber radius from the axis (m).
        helix_angle_rad: angle ``a`` between fiber and axis, ``tan a = 2 pi r / P`` (rad).
        poisson_ratio: ``nu`` of the segment under the point.
        weights: quadrature weights (n_points,), summing to 1.
        center_arc_m: rest arc position of each grating's centre (m), (n_gratings,).
        center_psi_rad: angle of each grating's centre (rad), (n_gratings,).
        covered_m: ``(start, end)`` rest arc range the fiber covers (m).
        handedness: ``+1`` right-handed helix, ``-1`` left-handed.
    """

    arc_m: np.ndarray
    psi_rad: np.ndarray
    radius_m: np.ndarray
    helix_angle_rad: np.ndarray
    poisson_ratio: np.ndarray
    weights: np.ndarray
    center_arc_m: np.ndarray
    center_psi_rad: np.ndarray
    covered_m: tuple[float, float]
    handedness: float

    @property
    def n_gratings(self) -> int:
        return int(self.arc_m.shape[0])

    @property
    def axial_factor(self) -> np.ndarray:
        """``cos^2 a - nu sin^2 a`` of (F1), shape (n_gratings, n_points)."""
        a = self.helix_angle_rad
        return np.cos(a) ** 2 - self.poisson_ratio * np.sin(a) ** 2

    @property
    def twist_factor(self) -> np.ndarray:
        """``h r sin a cos a`` of (F1) (m), shape (n_gratings, n_points)."""
        a = self.helix_angle_rad
        return self.handedness * self.radius_m * np.sin(a) * np.cos(a)


@dataclass(frozen=True)
class FBGLayout:
    """Layout of a helically wound single-core FBG fiber (defaults: wang2023 Section IV-A).

    Attributes:
        n_gratings: number of gratings (>= 1); wang2023 uses 17.
        grating_length_m: length of one grating along the fiber (m, > 0); 6 mm.
        spacing_m: centre-to-centre distance of adjacent gratings along the fiber
            (m, >= grating_length_m); 20 mm.
        pitch_m: axial distance between adjacent helix turns (m, > 0); ~16.5 mm.
        radius_m: fiber radius from the arm axis (m, > 0); ``None`` uses the outer radius of the
            segment under each grating.
        psi0_rad: helix phase: the fiber's angle at arc position 0 (the arm base), so that
            ``psi(s) = psi0 + h 2 pi s / pitch``.
        start_m: rest arc position of the first grating's centre, from the arm base (m); ``None``
            centres the grating array on the fiber-covered part.
        segments: indices of the (contiguous) segments the fiber is wound on; ``None`` = all.
        right_handed: helix handedness (``psi`` grows with ``s`` when true).
        n_points: Gauss-Legendre points per grating for the average over its length (1-16).
    """

    n_gratings: int = 17
    grating_length_m: float = 6e-3
    spacing_m: float = 20e-3
    pitch_m: float = 16.5e-3
    radius_m: float | None = None
    psi0_rad: float = 0.0
    start_m: float | None = None
    segments: tuple[int, ...] | None = None
    right_handed: bool = True
    n_points: int = 4

    def __post_init__(self) -> None:
        if not _is_int(self.n_gratings) or self.n_gratings < 1:
            raise ValueError(f"n_gratings must be an integer >= 1, got {self.n_gratings!r}")
        require_positive("grating_length_m", self.grating_length_m)
        require_positive("spacing_m", self.spacing_m)
        if self.spacing_m < self.grating_length_m:
            raise ValueError(f"spacing_m must be >= grating_length_m={self.grating_length_m} "
                             f"(gratings cannot overlap), got {self.spacing_m!r}")
        require_positive("pitch_m", self.pitch_m)
        if self.radius_m is not None:
            require_positive("radius_m", self.radius_m)
        if not np.isfinite(self.psi0_rad):
            raise ValueError(f"psi0_rad must be a finite number, got {self.psi0_rad!r}")
        if self.start_m is not None:
            require_non_negative("start_m", self.start_m)
        if self.segments is not None:
            segments = tuple(self.segments)
            if (not segments or not all(_is_int(k) and k >= 0 for k in segments)
                    or list(segments) != list(range(segments[0], segments[0] + len(segments)))):
                raise ValueError("segments must be None or a non-empty run of consecutive segment "
                                 f"indices >= 0 (e.g. (0, 1)), got {self.segments!r}")
            object.__setattr__(self, "segments", tuple(int(k) for k in segments))
        if not _is_int(self.n_points) or not 1 <= self.n_points <= 16:
            raise ValueError(f"n_points must be an integer in [1, 16], got {self.n_points!r}")

    def resolve(self, spec: ArmSpec) -> FBGGeometry:
        """Place the gratings on ``spec``'s arm; raises ``ValueError`` if any grating would leave
        the fiber-covered part of the arm.

        The fiber coordinate ``lambda`` grows by ``ds / cos a`` per arc step ``ds`` (``a`` of the
        segment under it), so with equal radii the gratings' arc positions are
        ``s_j = s_0 + j spacing cos a`` (wang2023 default: ``cos a = 0.254``, 5.08 mm per grating,
        all 17 gratings spanning 82.8 mm of the 90 mm body).
        """
        n_seg = spec.n_segments
        covered = tuple(range(n_seg)) if self.segments is None else self.segments
        if covered[-1] >= n_seg:
            raise ValueError(f"segments must index this arm's {n_seg} segment(s) "
                             f"(0..{n_seg - 1}), got {self.segments!r}")
        bounds = segment_bounds(spec)
        radii = np.array([self.radius_m if self.radius_m is not None else s.outer_radius_m
                          for s in spec.segments])
        stretch = np.sqrt(1.0 + (2.0 * np.pi * radii / self.pitch_m) ** 2)  # fiber per arc, 1/cos a
        arc_knots = bounds[covered[0]:covered[-1] + 2]
        fiber_knots = np.r_[0.0, np.cumsum(np.diff(arc_knots) * stretch[list(covered)])]
        fiber_total = fiber_knots[-1]
        covered_m = (float(arc_knots[0]), float(arc_knots[-1]))

        half = 0.5 * self.grating_length_m
        span = (self.n_gratings - 1) * self.spacing_m
        if self.start_m is None:
            first = 0.5 * (fiber_total - span)
        else:
            if not covered_m[0] <= self.start_m <= covered_m[1]:
                raise ValueError(
                    f"start_m must lie on the fiber-covered part [{covered_m[0]:.4g}, "
                    f"{covered_m[1]:.4g}] m of the arm (segments {covered}), got {self.start_m!r}")
            first = float(np.interp(self.start_m, arc_knots, fiber_knots))
        centers = first + self.spacing_m * np.arange(self.n_gratings)
        tolerance = 1e-12
        low, high = centers - half, centers + half
        bad = np.flatnonzero((low < -tolerance) | (high > fiber_total + tolerance))
        if bad.size:
            j = int(bad[0])
            arc = self._fiber_to_arc(np.array([low[j], high[j]]), fiber_knots, arc_knots)
            raise ValueError(
                f"FBG layout does not fit: with n_gratings={self.n_gratings}, "
                f"spacing_m={self.spacing_m}, grating_length_m={self.grating_length_m}, "
                f"pitch_m={self.pitch_m} and start_m={self.start_m}, grating {j} would span "
                f"fiber [{low[j]:.4g}, {high[j]:.4g}] m (arc [{arc[0]:.4g}, {arc[1]:.4g}] m), "
                f"beyond the fiber-covered part: fiber [0, {fiber_total:.4g}] m = arc "
                f"[{covered_m[0]:.4g}, {covered_m[1]:.4g}] m (segments {covered}); allowed: all "
                f"gratings within that range")

        nodes, weights = gauss_points(self.n_points)
        fiber = centers[:, None] + half * nodes[None, :]
        arc = np.interp(fiber, fiber_knots, arc_knots)
        segment = np.clip(np.searchsorted(bounds, arc, side="right") - 1, 0, n_seg - 1)
        radius = radii[segment]
        helix = np.arctan(2.0 * np.pi * radius / self.pitch_m)
        nu = np.array([s.poisson_ratio for s in spec.segments])[segment]
        handedness = 1.0 if self.right_handed else -1.0
        psi = self.psi0_rad + handedness * 2.0 * np.pi * arc / self.pitch_m
        center_arc = np.interp(centers, fiber_knots, arc_knots)
        center_psi = self.psi0_rad + handedness * 2.0 * np.pi * center_arc / self.pitch_m
        return FBGGeometry(arc_m=arc, psi_rad=psi, radius_m=radius, helix_angle_rad=helix,
                           poisson_ratio=nu, weights=weights, center_arc_m=center_arc,
                           center_psi_rad=center_psi, covered_m=covered_m, handedness=handedness)

    @staticmethod
    def _fiber_to_arc(fiber: np.ndarray, fiber_knots: np.ndarray,
                      arc_knots: np.ndarray) -> np.ndarray:
        """Arc position of fiber coordinates, extrapolated linearly beyond the covered part."""
        arc = np.interp(fiber, fiber_knots, arc_knots)
        slope_low = (arc_knots[1] - arc_knots[0]) / (fiber_knots[1] - fiber_knots[0])
        slope_high = (arc_knots[-1] - arc_knots[-2]) / (fiber_knots[-1] - fiber_knots[-2])
        arc = np.where(fiber < 0.0, arc_knots[0] + slope_low * fiber, arc)
        return np.where(fiber > fiber_knots[-1],
                        arc_knots[-1] + slope_high * (fiber - fiber_knots[-1]), arc)


def fbg_strain(vertex_arc_m: np.ndarray, curvatures: np.ndarray, axial_strains: np.ndarray,
               twist_rates: np.ndarray, geometry: FBGGeometry) -> np.ndarray:
    """Fiber strain of every grating, eq. (F1) of this module averaged over the grating length.

    Implements docs/architecture.md, "FBG fiber", for the helical fiber of wang2023 (Section IV-A,
    Fig. 3: the strain pattern's amplitude follows the curvature, its phase the bending
    direction).

    Args:
        vertex_arc_m: arc positions of the backbone vertices (m), (n_links + 1,), in the same
            (rest, material) coordinate as ``geometry.arc_m`` (see :func:`rest_vertex_arcs`).
        curvatures: curvature vector ``(kx, ky)`` at every vertex (1/m), (n_links + 1, 2), read
            with linear interpolation between vertices.
        axial_strains: axial strain of every link, (n_links,).
        twist_rates: twist rate of every link (rad/m), (n_links,).
        geometry: the resolved layout (:meth:`FBGLayout.resolve`).

    Returns:
        Strain along the fiber at each grating (dimensionless), (n_gratings,); contact and
        strain transfer are not included (see :class:`FBGFiber`).
    """
    vertex_arc_m = np.asarray(vertex_arc_m, dtype=float)
    curvatures = np.asarray(curvatures, dtype=float)
    axial_strains = np.asarray(axial_strains, dtype=float)
    twist_rates = np.asarray(twist_rates, dtype=float)
    n_vertices = vertex_arc_m.shape[0]
    if vertex_arc_m.ndim != 1 or n_vertices < 2 or np.any(np.diff(vertex_arc_m) <= 0):
        raise ValueError("vertex_arc_m must be a strictly increasing 1-D array of >= 2 arc "
                         f"positions, got {vertex_arc_m.tolist()}")
    if curvatures.shape != (n_vertices, 2):
        raise ValueError(f"curvatures must have shape {(n_vertices, 2)}, got {curvatures.shape}")
    for name, value in (("axial_strains", axial_strains), ("twist_rates", twist_rates)):
        if value.shape != (n_vertices - 1,):
            raise ValueError(f"{name} must have shape {(n_vertices - 1,)}, got {value.shape}")
    s = geometry.arc_m
    kx = np.interp(s, vertex_arc_m, curvatures[:, 0])
    ky = np.interp(s, vertex_arc_m, curvatures[:, 1])
    link, _ = locate(vertex_arc_m, s)
    psi = geometry.psi_rad
    axial = axial_strains[link] - geometry.radius_m * (kx * np.cos(psi) + ky * np.sin(psi))
    strain = axial * geometry.axial_factor + geometry.twist_factor * twist_rates[link]
    return strain @ geometry.weights


class FBGFiber(Sensor):
    """Wavelength shifts (nm) of the gratings of a helically wound FBG fiber (wang2023).

    Reading: float32 array (n_gratings,), eq. (F2) of this module, clipped to :meth:`space`
    (the interrogator's range).

    Args:
        layout: the fiber layout (default: wang2023's 17 gratings).
        rate_hz: samples per second (wang2023: FBG interrogation at 100-3000 Hz); ``None`` samples
            at every read.
        noise_std_nm: white wavelength noise (nm, >= 0); 1 pm as in wang2023's Appendix.
        strain_transfer: fraction ``t`` of the surface strain that reaches the fiber core (> 0).
            The default 2e-3 reproduces wang2023's measured range (0-0.158 nm over its spiral
            exploration): the fiber is bonded to the silicone through a compliant adhesive and
            coating, so little of the rubber's strain (several % at full bending) reaches the
            glass; with ``t = 1`` the shifts would reach ~100 nm, beyond silica's strength.
        contact_strain_per_n: fiber strain per newton of force pressing on a grating
            (1/N, >= 0); see the module docstring for the calibration.
        temperature_coefficient_nm_per_c: ``k_T`` (nm/degC, >= 0), ~10 pm/degC for bare silica.
        temperature_drift_c_per_sqrt_s: random-walk intensity of the common temperature change
            (degC/sqrt(s), >= 0); 0 (default) disables it.
        temperature_schedule: optional ``dT(time_s)`` in degC added to the random walk.
        lambda0_nm: Bragg wavelength ``l0`` (nm).
        photoelastic: ``p_e`` in [0, 1).
        spec: optional arm to check the layout against now (otherwise at the first read).
    """

    def __init__(self, layout: FBGLayout | None = None, rate_hz: float | None = 100.0,
                 noise_std_nm: float = 1e-3, strain_transfer: float = 2e-3,
                 contact_strain_per_n: float = 0.011,
                 temperature_coefficient_nm_per_c: float = 0.010,
                 temperature_drift_c_per_sqrt_s: float = 0.0,
                 temperature_schedule: Callable[[float], float] | None = None,
                 lambda0_nm: float = LAMBDA0_NM, photoelastic: float = PHOTOELASTIC,
                 spec: ArmSpec | None = None) -> None:
        super().__init__("fbg", rate_hz)
        if layout is not None and not isinstance(layout, FBGLayout):
            raise ValueError(f"layout must be an FBGLayout or None, got {type(layout).__name__}")
        self.layout = layout if layout is not None else FBGLayout()
        self.noise_std_nm = require_non_negative("noise_std_nm", noise_std_nm)
        self.strain_transfer = require_positive("strain_transfer", strain_transfer)
        self.contact_strain_per_n = require_non_negative("contact_strain_per_n",
                                                         contact_strain_per_n)
        self.temperature_coefficient_nm_per_c = require_non_negative(
            "temperature_coefficient_nm_per_c", temperature_coefficient_nm_per_c)
        self.temperature_drift_c_per_sqrt_s = require_non_negative(
            "temperature_drift_c_per_sqrt_s", temperature_drift_c_per_sqrt_s)
        if temperature_schedule is not None and not callable(temperature_schedule):
            raise ValueError("temperature_schedule must be None or a callable time_s -> degC, "
                             f"got {temperature_schedule!r}")
        self.temperature_schedule = temperature_schedule
        self.lambda0_nm = require_positive("lambda0_nm", lambda0_nm)
        if not np.isfinite(photoelastic) or not 0.0 <= photoelastic < 1.0:
            raise ValueError(f"photoelastic must be within [0, 1), got {photoelastic!r}")
        self.photoelastic = float(photoelastic)
        self._spec: ArmSpec | None = None
        self._drift_c = 0.0
        self._drift_time_s: float | None = None
        if spec is not None:
            self._bind(spec)

    # ------------------------------------------------------------------ geometry
    @property
    def nm_per_strain(self) -> float:
        """Wavelength shift per unit fiber strain ``l0 (1 - p_e)`` (nm)."""
        return self.lambda0_nm * (1.0 - self.photoelastic)

    def geometry(self, spec: ArmSpec) -> FBGGeometry:
        """The layout resolved on ``spec`` (cached for the last arm)."""
        self._bind(spec)
        return self._geometry

    def _bind(self, spec: ArmSpec) -> None:
        """Resolve the layout on ``spec`` and precompute the linear strain maps."""
        if spec is self._spec:
            return
        geometry = self.layout.resolve(spec)
        vertices = rest_vertex_arcs(spec)
        g = geometry
        self._bend = surface_bending_matrix(vertices, g.arc_m, g.psi_rad,
                                            -g.radius_m * g.axial_factor, g.weights)
        self._axial = link_matrix(vertices, g.arc_m, g.axial_factor, g.weights)
        self._twist = link_matrix(vertices, g.arc_m, g.twist_factor, g.weights)
        self._grating_link, _ = locate(vertices, g.center_arc_m)
        self._normals_local = np.stack([np.cos(g.center_psi_rad), np.sin(g.center_psi_rad),
                                        np.zeros(g.n_gratings)], axis=1)
        # bound of the reading: largest strain the joint limits allow, plus contact and heat
        extension = max(max(s.max_extension_ratio - 1.0, 0.4) for s in spec.segments)
        kappa = max(s.max_bend_per_m_rad for s in spec.segments)
        tau = max(0.5 / s.link_length_m for s in spec.segments)  # torsion joint limit 0.5 rad
        strain = float(np.max(np.abs(g.axial_factor) * (extension + kappa * g.radius_m)
                              + np.abs(g.twist_factor) * tau))
        strain += self.contact_strain_per_n * _CONTACT_FORCE_BOUND_N
        self._bound_nm = np.float32(
            1.5 * self.nm_per_strain * self.strain_transfer * strain
            + self.temperature_coefficient_nm_per_c * _TEMPERATURE_LIMIT_C
            + 10.0 * self.noise_std_nm + 1e-3)
        self._geometry = geometry
        self._spec = spec

    # ------------------------------------------------------------------ readings
    def strain(self, sim) -> np.ndarray:
        """Noise-free fiber strain of every grating (bending, stretch, twist and contact),
        before the strain transfer factor, float64 (n_gratings,)."""
        self._bind(sim.spec)
        _, curvature = sim.curvature_profile()
        strain = (self._bend @ curvature.ravel() + self._axial @ sim.link_axial_strains()
                  + self._twist @ sim.link_twist_rates())
        if self.contact_strain_per_n > 0.0:
            strain += self.contact_strain_per_n * self._pressing_forces(sim)
        return strain

    def _pressing_forces(self, sim) -> np.ndarray:
        """Force (N) pressing radially on each grating from the contact forces on its link.

        A grating belongs to the link holding its centre; its outward normal is taken in that
        link's frame at the grating's material angle (the twist inside the link is neglected).
        """
        forces = sim.link_contact_forces()
        loaded = np.flatnonzero(np.any(forces != 0.0, axis=1))
        pressing = np.zeros(self._geometry.n_gratings)
        if loaded.size == 0:
            return pressing
        on_loaded = np.isin(self._grating_link, loaded)
        if not np.any(on_loaded):
            return pressing
        links = np.unique(self._grating_link[on_loaded])
        rotations = sim.link_rotations(links)
        for link, rotation in zip(links, rotations):
            gratings = np.flatnonzero(self._grating_link == link)
            normals = self._normals_local[gratings] @ rotation.T  # outward normals, base frame
            pressing[gratings] = np.maximum(0.0, -(normals @ forces[link]))
        return pressing

    def temperature_change_c(self, sim) -> float:
        """Common temperature change ``dT`` (degC) at ``sim.time_s``: random walk + schedule."""
        time_s = float(sim.time_s)
        if self.temperature_drift_c_per_sqrt_s > 0.0:
            if self._drift_time_s is None or time_s < self._drift_time_s:
                self._drift_time_s = time_s
            dt = time_s - self._drift_time_s
            if dt > 0.0:
                self._drift_c += (self.temperature_drift_c_per_sqrt_s * math.sqrt(dt)
                                  * float(self.rng.standard_normal()))
                self._drift_c = float(np.clip(self._drift_c, -_TEMPERATURE_LIMIT_C,
                                              _TEMPERATURE_LIMIT_C))
            self._drift_time_s = time_s
        change = self._drift_c
        if self.temperature_schedule is not None:
            change += float(self.temperature_schedule(time_s))
        return float(np.clip(change, -_TEMPERATURE_LIMIT_C, _TEMPERATURE_LIMIT_C))

    def sample(self, sim) -> np.ndarray:
        """Wavelength shifts (nm), eq. (F2), float32 (n_gratings,)."""
        shift = self.nm_per_strain * self.strain_transfer * self.strain(sim)
        if self.temperature_coefficient_nm_per_c > 0.0 and (
                self.temperature_drift_c_per_sqrt_s > 0.0 or self.temperature_schedule is not None):
            shift += self.temperature_coefficient_nm_per_c * self.temperature_change_c(sim)
        if self.noise_std_nm > 0.0:
            shift += self.noise_std_nm * self.rng.standard_normal(shift.shape[0])
        return np.clip(shift, -self._bound_nm, self._bound_nm).astype(np.float32)

    def reset(self, sim, rng: np.random.Generator) -> None:
        """Start an episode: new noise generator, temperature back to the reference."""
        super().reset(sim, rng)
        self._drift_c = 0.0
        self._drift_time_s = None

    def space(self, sim) -> spaces.Box:
        """Box of the wavelength shifts (nm), symmetric, sized from the joint limits."""
        self._bind(sim.spec)
        n = self._geometry.n_gratings
        return spaces.Box(-self._bound_nm, self._bound_nm, shape=(n,), dtype=np.float32)
