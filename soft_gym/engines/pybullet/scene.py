"""The feature-rich scene the eye-in-hand camera looks at (wang2023, Section IV-B and Fig. 6).

Wang et al. 2023 validate ORB-SLAM2 "in a LEGO-constructed scenario" seen by an endoscopic tip
camera with an 8-150 mm depth of field; in the undisturbed period "around 600 features" are found
in each frame (Section IV-C1). :func:`build_scene` puts a comparable scene in front of the
simulated tip camera:

* a ground of square tiles perpendicular to the arm axis, ``ground_distance_m`` (default 60 mm)
  beyond the resting tip along +z (the arm hangs along +z from the base at the origin). Each tile
  shows a different window of a ``pybullet_data`` texture (the lettered UV grid, the maze, the
  shapes sheet, the colour chart), rotated and scaled at random, so the ground does not repeat;
* LEGO-like blocks standing on the ground: coloured boxes of varied size, some textured, some
  with studs, and a few of ``pybullet_data``'s Duplo bricks, all placed from ``seed``;
* a large outer floor (a coarse colour chart) framing the tiles, so an oblique view of a bent
  arm still sees ground out to the horizon.

Everything is visual only by default (no collision shape), so the scene never touches the arm
and costs the physics nothing. With ``collide=True`` the blocks and ground get collision boxes;
they stay beyond the tip's reach as long as the arm does not extend more than
``ground_distance_m - max_block_height_m`` past its rest length.
"""

from __future__ import annotations

import hashlib
import math
import os

import numpy as np
import pybullet
import pybullet_data

from soft_gym._validation import require_non_negative, require_positive

_TILE_TEXTURES = {"uvmap.png": (0.15, 0.3), "heightmaps/Maze.png": (0.15, 0.3),
                  "cube.png": (0.25, 0.5), "colors16.png": (0.5, 1.0)}
"""``pybullet_data`` textures the ground tiles are cut from, with the range of the texture's width
one tile shows: TinyRenderer samples textures without mipmaps, so a tile shows a window whose
detail is a few pixels wide at the camera's working distance rather than aliased texels."""

_BLOCK_COLOURS = np.array([
    [0.85, 0.10, 0.10], [0.10, 0.35, 0.85], [0.95, 0.80, 0.10], [0.10, 0.60, 0.20],
    [0.95, 0.95, 0.95], [0.15, 0.15, 0.15], [0.60, 0.20, 0.70], [0.95, 0.45, 0.70],
    [0.30, 0.75, 0.90], [0.55, 0.35, 0.15]])
"""LEGO-like brick colours (RGB 0..1)."""


_MESHES_GIVEN: dict[bytes, tuple[list, list, list | None, list | None]] = {}
"""Mesh data already given to PyBullet's ``createVisualShape``, by content.

PyBullet (3.2.x) takes a reference to the ``vertices``, ``indices``, ``uvs`` and ``normals``
sequences of a mesh, and to every vertex's, uv's and normal's own list, and never gives them
back: each scene built anew would keep its mesh lists alive for the life of the process (about
0.6 MB per camera env made and closed). Handing over the objects of the first mesh with the same
content instead keeps one copy per distinct mesh (the camera's scene is the same in every env of
a seed), and the lists built meanwhile are freed as usual."""


def _mesh_visual(client, vertices: list, indices: list, uvs: list | None = None,
                 normals: list | None = None, **options) -> int:
    """``client.createVisualShape(GEOM_MESH, ...)`` of the mesh, with :data:`_MESHES_GIVEN`."""
    digest = hashlib.blake2b(digest_size=20)
    for part in (vertices, indices, uvs, normals):
        data = np.asarray([] if part is None else part, dtype=float)
        digest.update(repr(data.shape).encode())
        digest.update(data.tobytes())
    vertices, indices, uvs, normals = _MESHES_GIVEN.setdefault(
        digest.digest(), (vertices, indices, uvs, normals))
    mesh = {"vertices": vertices, "indices": indices}
    if uvs is not None:
        mesh["uvs"] = uvs
    if normals is not None:
        mesh["normals"] = normals
    return client.createVisualShape(pybullet.GEOM_MESH, **mesh, **options)


def _texture_path(name: str) -> str:
    return os.path.join(pybullet_data.getDataPath(), name)


def _tile_mesh(centres: np.ndarray, half_size: float, scale_range: tuple[float, float],
               rng: np.random.Generator) -> tuple[list, list, list, list]:
    """Vertices, indices, uvs and normals of square tiles at ``centres`` (z = 0 plane) facing -z.

    Each tile maps a random window of its texture: offset in [0, 1), ``scale_range`` texture
    widths per tile, rotated by a multiple of 90 deg. Textures wrap in PyBullet's renderers.
    """
    vertices, indices, uvs, normals = [], [], [], []
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    for centre in centres:
        base = len(vertices)
        scale = rng.uniform(*scale_range)
        offset = rng.uniform(0.0, 1.0, size=2)
        turns = int(rng.integers(0, 4))
        rotation = np.array([[0, -1], [1, 0]], dtype=float)
        uv_corners = np.linalg.matrix_power(rotation, turns) @ (0.5 * corners.T)
        for corner, uv in zip(corners, uv_corners.T):
            vertices.append([centre[0] + half_size * corner[0], centre[1] + half_size * corner[1],
                             0.0])
            uvs.append((offset + scale * (uv + 0.5)).tolist())
            normals.append([0.0, 0.0, -1.0])
        # wound so that the front face looks towards -z (towards the arm and its camera)
        indices += [base, base + 2, base + 1, base, base + 3, base + 2]
    return vertices, indices, uvs, normals


def build_scene(client, arm_length_m: float, *, seed: int | np.random.Generator = 0,
                ground_distance_m: float = 0.06, tile_size_m: float = 0.03,
                tiled_half_size_m: float = 0.18, floor_half_size_m: float = 1.5,
                n_blocks: int = 18, block_region_half_m: float = 0.10,
                max_block_height_m: float = 0.012, n_duplo: int = 2,
                collide: bool = False) -> list[int]:
    """Build the eye-in-hand camera's scene in ``client`` and return the new body ids.

    Args:
        client: a PyBullet ``BulletClient`` (the simulator's ``sim.client``).
        arm_length_m: rest length of the arm (m); the resting tip is at ``(0, 0, arm_length_m)``.
        seed: seed or generator for the tile windows and block placement (the scene is the
            robot's surroundings and stays fixed, so it does not use the episode's generator).
        ground_distance_m: distance from the resting tip to the ground along +z (m); wang2023's
            camera has an 8-150 mm depth of field, 40-80 mm keeps the scene sharp and near.
        tile_size_m: side of one textured ground tile (m).
        tiled_half_size_m: half side of the tiled area around the arm axis (m).
        floor_half_size_m: half side of the outer floor (m).
        n_blocks: number of box bricks within ``block_region_half_m`` of the axis.
        block_region_half_m: half side of the square in which the blocks stand (m).
        max_block_height_m: tallest brick, studs included (m); must be below
            ``ground_distance_m``.
        n_duplo: number of ``pybullet_data`` Duplo bricks (``lego/lego.obj``) added.
        collide: give the ground and blocks collision shapes (default: visual only).

    Returns:
        The ids of all bodies created: tiles, floor, bricks and their studs.
    """
    require_positive("arm_length_m", arm_length_m)
    require_positive("ground_distance_m", ground_distance_m)
    require_positive("tile_size_m", tile_size_m)
    require_positive("tiled_half_size_m", tiled_half_size_m)
    require_positive("floor_half_size_m", floor_half_size_m)
    require_non_negative("block_region_half_m", block_region_half_m)
    require_positive("max_block_height_m", max_block_height_m)
    for name, value in (("n_blocks", n_blocks), ("n_duplo", n_duplo)):
        if not isinstance(value, (int, np.integer)) or value < 0:
            raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
    if max_block_height_m <= 2 * _STUD_HEIGHT_M:
        raise ValueError(f"max_block_height_m must be > {2 * _STUD_HEIGHT_M} (two stud heights), "
                         f"got {max_block_height_m!r}")
    if max_block_height_m >= ground_distance_m:
        raise ValueError(f"max_block_height_m must be < ground_distance_m={ground_distance_m}, "
                         f"got {max_block_height_m!r}")
    if floor_half_size_m < tiled_half_size_m:
        raise ValueError(f"floor_half_size_m must be >= tiled_half_size_m={tiled_half_size_m}, "
                         f"got {floor_half_size_m!r}")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    ground_z = float(arm_length_m + ground_distance_m)
    bodies: list[int] = []
    textures: dict[str, int] = {}

    def texture(name: str) -> int:
        if name not in textures:
            textures[name] = client.loadTexture(_texture_path(name))
        return textures[name]

    # --- textured tiles: each tile goes to one of the texture meshes at random ---------------
    n_side = max(1, int(math.ceil(2 * tiled_half_size_m / tile_size_m)))
    half_tile = 0.5 * tile_size_m
    coordinates = (np.arange(n_side) - 0.5 * (n_side - 1)) * tile_size_m
    centres = np.array([[x, y] for y in coordinates for x in coordinates])
    texture_of_tile = rng.integers(0, len(_TILE_TEXTURES), size=len(centres))
    for k, (texture_name, scale_range) in enumerate(_TILE_TEXTURES.items()):
        mine = centres[texture_of_tile == k]
        if len(mine) == 0:
            continue
        vertices, indices, uvs, normals = _tile_mesh(mine, half_tile, scale_range, rng)
        visual = _mesh_visual(client, vertices, indices, uvs, normals)
        body = client.createMultiBody(0.0, -1, visual, [0.0, 0.0, ground_z])
        client.changeVisualShape(body, -1, rgbaColor=[1, 1, 1, 1],
                                 textureUniqueId=texture(texture_name))
        bodies.append(body)
    if collide:
        half = n_side * half_tile
        shape = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[half, half, 0.001])
        bodies.append(client.createMultiBody(0.0, shape, -1, [0.0, 0.0, ground_z + 0.001]))

    # --- outer floor: four plain quads framing the tiles (no overdraw: TinyRenderer's cost is
    # about proportional to the screen area of the triangles it fills) -------------------------
    inner, outer = n_side * half_tile, floor_half_size_m
    if outer > inner:
        middle, width = 0.5 * (inner + outer), 0.5 * (outer - inner)
        frame = (((0.0, middle), (outer, width)), ((0.0, -middle), (outer, width)),
                 ((middle, 0.0), (width, inner)), ((-middle, 0.0), (width, inner)))
        for centre, (hx, hy) in frame:
            vertices = [[-hx, -hy, 0.0], [hx, -hy, 0.0], [hx, hy, 0.0], [-hx, hy, 0.0]]
            # a coarse colour chart: one texture repeat per 0.2 m, features for oblique views
            uvs = [[(v[0] + centre[0]) / 0.2, (v[1] + centre[1]) / 0.2] for v in vertices]
            visual = _mesh_visual(client, vertices, [0, 2, 1, 0, 3, 2], uvs,
                                  [[0.0, 0.0, -1.0]] * 4)
            collision = client.createCollisionShape(
                pybullet.GEOM_BOX, halfExtents=[hx, hy, 0.001],
                collisionFramePosition=[0, 0, 0.001]) if collide else -1
            body = client.createMultiBody(0.0, collision, visual, [centre[0], centre[1], ground_z])
            client.changeVisualShape(body, -1, rgbaColor=[0.8, 0.8, 0.8, 1.0],
                                     textureUniqueId=texture("colors16.png"))
            bodies.append(body)

    # --- bricks: boxes standing on the ground (towards -z), some with studs ----------------
    cube_texture = texture("cube.png")
    studs: dict[int, list] = {}
    for _ in range(n_blocks):
        size_x, size_y = rng.uniform(0.008, 0.032, size=2)
        height = rng.uniform(0.3, 1.0) * (max_block_height_m - _STUD_HEIGHT_M)  # studs on top
        x, y = rng.uniform(-block_region_half_m, block_region_half_m, size=2)
        yaw = rng.uniform(0.0, math.pi)
        colour_index = rng.integers(0, len(_BLOCK_COLOURS))
        colour = _BLOCK_COLOURS[colour_index]
        half = [size_x / 2, size_y / 2, height / 2]
        visual = client.createVisualShape(pybullet.GEOM_BOX, halfExtents=half,
                                          rgbaColor=[*colour, 1.0])
        collision = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half) if collide \
            else -1
        orientation = pybullet.getQuaternionFromEuler([0.0, 0.0, yaw])
        body = client.createMultiBody(0.0, collision, visual, [x, y, ground_z - height / 2],
                                      orientation)
        if rng.uniform() < 0.3:
            client.changeVisualShape(body, -1, rgbaColor=[1, 1, 1, 1],
                                     textureUniqueId=cube_texture)
        bodies.append(body)
        if rng.uniform() < 0.5:
            studs.setdefault(int(colour_index), []).extend(
                _stud_centres(x, y, yaw, size_x, size_y, ground_z - height))
    for colour_index, centres in sorted(studs.items()):
        bodies.append(_stud_body(client, np.array(centres), 0.85 * _BLOCK_COLOURS[colour_index]))

    # --- Duplo bricks from pybullet_data (lego/lego.obj: 0.317 x 0.23 x 0.3175 mesh units, the
    # studs along the mesh's +y), scaled down, studs turned towards -z (the camera) -----------
    for _ in range(n_duplo):
        x, y = rng.uniform(-block_region_half_m, block_region_half_m, size=2)
        scale = rng.uniform(0.6, 1.0) * max_block_height_m / 0.24
        colour = _BLOCK_COLOURS[rng.integers(0, len(_BLOCK_COLOURS))]
        visual = client.createVisualShape(
            pybullet.GEOM_MESH, fileName=_texture_path("lego/lego.obj"),
            meshScale=[scale] * 3, rgbaColor=[*colour, 1.0])
        yaw = rng.uniform(0.0, 2 * math.pi)
        orientation = pybullet.getQuaternionFromEuler([-math.pi / 2, 0.0, yaw])
        bodies.append(client.createMultiBody(0.0, -1, visual, [x, y, ground_z - 1e-4],
                                             orientation))
    return bodies


_STUD_PITCH_M, _STUD_RADIUS_M, _STUD_HEIGHT_M = 0.008, 0.0024, 0.0017
"""LEGO stud pitch, radius and height (m)."""


def _stud_centres(x: float, y: float, yaw: float, size_x: float, size_y: float,
                  top_z: float) -> list[list[float]]:
    """Centres of the studs' top faces on a brick (8 mm pitch), in the world frame (m)."""
    nx = max(1, int(size_x // _STUD_PITCH_M))
    ny = max(1, int(size_y // _STUD_PITCH_M))
    c, s = math.cos(yaw), math.sin(yaw)
    centres = []
    for i in range(nx):
        for j in range(ny):
            u = (i - 0.5 * (nx - 1)) * _STUD_PITCH_M
            v = (j - 0.5 * (ny - 1)) * _STUD_PITCH_M
            centres.append([x + c * u - s * v, y + s * u + c * v, top_z - _STUD_HEIGHT_M])
    return centres


def _stud_body(client, centres: np.ndarray, colour: np.ndarray, sides: int = 8) -> int:
    """One visual-only body holding octagonal studs at ``centres`` (their faces towards -z).

    One mesh per colour keeps TinyRenderer's per-object and per-triangle cost low (a PyBullet
    cylinder is tessellated far finer than a 10-pixel stud needs).
    """
    angles = 2 * np.pi * (np.arange(sides) + 0.5) / sides
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1) * _STUD_RADIUS_M
    vertices, indices, normals = [], [], []
    for centre in centres:
        # top face (towards -z): a fan around the centre
        top = len(vertices)
        vertices.append(centre.tolist())
        normals.append([0.0, 0.0, -1.0])
        for px, py in ring:
            vertices.append([centre[0] + px, centre[1] + py, centre[2]])
            normals.append([0.0, 0.0, -1.0])
        for k in range(sides):
            a, b = top + 1 + k, top + 1 + (k + 1) % sides
            indices += [top, b, a]
        # sides: one quad per edge, normals outwards
        for k in range(sides):
            k2 = (k + 1) % sides
            mid = 0.5 * (angles[k] + angles[k2] + (2 * np.pi if k2 == 0 else 0.0))
            normal = [math.cos(mid), math.sin(mid), 0.0]
            base = len(vertices)
            for (px, py), dz in ((ring[k], 0.0), (ring[k2], 0.0), (ring[k2], _STUD_HEIGHT_M),
                                 (ring[k], _STUD_HEIGHT_M)):
                vertices.append([centre[0] + px, centre[1] + py, centre[2] + dz])
                normals.append(normal)
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    visual = _mesh_visual(client, vertices, indices, normals=normals, rgbaColor=[*colour, 1.0])
    return client.createMultiBody(0.0, -1, visual, [0.0, 0.0, 0.0])
