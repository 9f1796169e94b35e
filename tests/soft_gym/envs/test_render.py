"""Third-person rendering: framing, overlay placement, untouched physics, videos, frame rate."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import soft_gym
from soft_gym.envs.rendering import BACKGROUND, TARGET
from soft_gym.robots import PRESETS
from soft_gym.scenarios.loads import FillingLoad, Push, SwayingMass

SIZE = (160, 120)


def _env(preset: str, **kwargs):
    kwargs.setdefault("feedback", "ground_truth")
    return gym.make("SoftArmReach-v0", preset=preset, render_mode="rgb_array", **kwargs)


def test_target_marker_sits_where_the_target_projects():
    """The current target's dot is centred on the target's projection (within 1 px)."""
    env = _env("wang2023", render_size=SIZE)
    env.reset(seed=3)
    unwrapped = env.unwrapped
    renderer = unwrapped.make_renderer()
    # a reachable target far from the resting tip, drawn alone
    tips = unwrapped.task.targets
    target = tips[np.argmax(np.linalg.norm(tips - unwrapped.sim.tip_pose()[0], axis=1))]
    frame = renderer.render(unwrapped.sim, target_m=target)
    marker = np.all(frame == TARGET, axis=-1)
    marker[:30] = False  # the legend's dot, top right
    rows, cols = np.nonzero(marker)
    assert len(rows) > 0
    expected = renderer.camera.project(target)
    assert abs(cols.mean() - expected[0]) <= 1.0 and abs(rows.mean() - expected[1]) <= 1.0
    env.close()


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_projection_matches_the_rendered_arm_and_arm_fills_the_frame(preset):
    """Projected backbone points land on the arm in PyBullet's image (same matrices), and the
    background colour covers less than 70 % of the frame, extended or bent."""
    env = _env(preset)
    env.reset(seed=0)
    unwrapped = env.unwrapped
    n = env.action_space.shape[0]
    for action in (-np.ones(n), np.r_[1.0, -1.0, -1.0, -np.ones(n - 3)]):
        for _ in range(10):
            env.step(action.astype(np.float32))
        frame = env.render()
        assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8
        background = np.all(frame == BACKGROUND, axis=-1).mean()
        assert background < 0.7, f"{preset}: {background:.0%} background"
        _, mask = unwrapped._renderer.scene(unwrapped.sim)
        backbone = unwrapped.sim.backbone()[1:]
        pixels = np.round(unwrapped._renderer.camera.project(backbone)).astype(int)
        inside = ((pixels[:, 0] >= 0) & (pixels[:, 0] < 320) & (pixels[:, 1] >= 0)
                  & (pixels[:, 1] < 240))
        assert inside.all(), f"{preset}: the arm leaves the frame"
        assert mask[pixels[:, 1], pixels[:, 0]].mean() > 0.9
    env.close()


def test_rendering_leaves_the_physics_bit_identical():
    """The same seed and actions give the same tip positions with and without a render per
    step, loads drawn included."""
    def run(render: bool) -> list[np.ndarray]:
        scenario = [SwayingMass(mass_kg=0.005), FillingLoad(start_s=0.0, rate_kg_s=0.01),
                    Push(force_n=(0.05, 0.0, 0.0), start_s=0.1, ramp_s=0.1, end_s=None)]
        env = _env("wang2023", render_size=SIZE, scenario=scenario, episode_steps=30)
        env.reset(seed=7)
        rng = np.random.default_rng(1)
        tips = []
        for _ in range(12):
            action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            _, _, _, _, info = env.step(action)
            tips.append(info["tip_position_m"])
            if render:
                env.render()
        env.close()
        return tips

    np.testing.assert_array_equal(np.array(run(True)), np.array(run(False)))


def test_render_off_returns_none_and_builds_nothing():
    env = gym.make("SoftArmReach-v0", feedback="ground_truth")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.render() is None and env.unwrapped._renderer is None
    env.close()


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_render_fps_is_the_control_rate(preset):
    env = gym.make("SoftArmReach-v0", preset=preset, feedback="ground_truth")
    assert env.metadata["render_fps"] == 1.0 / PRESETS[preset].control_period_s
    assert env.unwrapped.metadata["render_fps"] == 1.0 / PRESETS[preset].control_period_s
    env.close()


def test_record_video_works_on_every_id(tmp_path):
    pytest.importorskip("moviepy", reason="gymnasium's RecordVideo writes with moviepy")
    from gymnasium.wrappers import RecordVideo

    ids = [env_id for env_id in gym.envs.registry if "SoftArm" in env_id]
    assert sorted(ids) == sorted(soft_gym.registered_ids())
    for env_id in ids:
        kwargs = {"episode_steps": 4} if "Reach" in env_id else {}
        env = gym.make(env_id, render_mode="rgb_array", feedback="ground_truth",
                       render_size=(64, 48), **kwargs)
        folder = tmp_path / env_id
        env = RecordVideo(env, str(folder), episode_trigger=lambda episode: True,
                          video_length=4, disable_logger=True)
        env.reset(seed=0)
        for _ in range(4):
            env.step(env.action_space.sample())
        env.close()
        videos = list(folder.glob("*.mp4"))
        assert videos and videos[0].stat().st_size > 0, env_id


# ---------------------------------------------------------------------- sensor panels
def test_camera_panel_sits_beside_the_scene_and_shows_the_faulted_frame():
    """``render_frame(env, ("scene", "camera"))``: the scene view unchanged on the left, the
    eye-in-hand frame scaled to its height on the right; complete darkness makes that panel dark
    and leaves the scene as it was."""
    from soft_gym.envs.rendering import render_frame

    frames = {}
    for faults in (None, {"name": "low_light", "strength": 1.0}):
        env = _env("wang2023", render_size=SIZE, sensors=("image",), faults=faults)
        env.reset(seed=0)
        env.step(np.zeros(env.action_space.shape, np.float32))
        frame = render_frame(env, ("scene", "camera"))
        camera = env.unwrapped.measurement["image"]
        width = SIZE[0] + round(camera.shape[1] * SIZE[1] / camera.shape[0])
        assert frame.shape == (SIZE[1], width, 3) and frame.dtype == np.uint8
        np.testing.assert_array_equal(frame[:, :SIZE[0]], env.render())
        assert render_frame(env, ("scene",)).shape == (SIZE[1], SIZE[0], 3)
        frames[faults is None] = frame
        env.close()
    np.testing.assert_array_equal(frames[True][:, :SIZE[0]], frames[False][:, :SIZE[0]])
    # the middle rows, between the text bands
    rows = slice(SIZE[1] // 4, SIZE[1] // 2)
    clear = frames[True][rows, SIZE[0]:].mean()
    dark = frames[False][rows, SIZE[0]:].mean()
    assert clear > 80 and dark < 15, (clear, dark)


def test_stereo_panel_shows_both_images_and_the_som_centreline():
    """A stereo env gets the left and right images beside the scene, each at the scene's height,
    with the SOM nodes that zou2022's shape estimator found drawn on them."""
    from soft_gym.envs.rendering import ESTIMATE, render_frame

    env = _env("zou2022", render_size=SIZE, feedback="stereo")
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, np.float32))
    unwrapped = env.unwrapped
    reading = unwrapped.measurement["stereo"]
    side = round(reading["left"].shape[1] * SIZE[1] / reading["left"].shape[0])
    frame = render_frame(env)
    assert frame.shape == (SIZE[1], SIZE[0] + 2 * side, 3)
    som = unwrapped.estimate.details["som_px"]
    factor = SIZE[1] / reading["left"].shape[0]
    for k, name in enumerate(("left", "right")):
        panel = frame[:, SIZE[0] + k * side:SIZE[0] + (k + 1) * side]
        node = np.round((som[name][len(som[name]) // 2] + 0.5) * factor - 0.5).astype(int)
        assert np.array_equal(panel[node[1], node[0]], ESTIMATE), name
    env.close()


def test_panels_work_without_render_mode_and_refuse_what_is_not_there():
    """An env made without ``render_mode`` still gives the same scene view; unknown panels and a
    camera panel on an env without a camera sensor raise ``ValueError``."""
    from soft_gym.envs.rendering import default_panels, render_frame

    plain = gym.make("SoftArmReach-v0", feedback="ground_truth", render_size=SIZE)
    rendering = _env("wang2023", render_size=SIZE)
    for env in (plain, rendering):
        env.reset(seed=4)
        env.step(np.full(env.action_space.shape, 0.5, np.float32))
    assert default_panels(plain) == ("scene",)
    np.testing.assert_array_equal(render_frame(plain, ("scene",)), rendering.render())
    with pytest.raises(ValueError, match="camera"):
        render_frame(plain, ("scene", "camera"))
    for panels in (("scene", "thermal"), (), "scene", ("scene", "scene")):
        with pytest.raises(ValueError, match="panels"):
            render_frame(plain, panels)
    plain.close()
    rendering.close()


def test_hidden_bodies_are_restored_and_the_camera_sees_the_same():
    """The scene view hides the camera's scenery only for its own render: the eye-in-hand frame
    is the same before and after it, and so are the bodies' colours."""
    env = _env("wang2023", render_size=SIZE, sensors=("image",))
    env.reset(seed=0)
    unwrapped = env.unwrapped
    client = unwrapped.sim.client
    bodies = [client.getBodyUniqueId(i) for i in range(client.getNumBodies())]
    colours = [[shape[7] for shape in client.getVisualShapeData(body)] for body in bodies]
    camera = unwrapped.sensors["image"]
    before = camera.sample(unwrapped.sim)
    env.render()
    assert [[shape[7] for shape in client.getVisualShapeData(body)] for body in bodies] == colours
    np.testing.assert_array_equal(camera.sample(unwrapped.sim), before)
    env.close()
