"""Resources: envs made and closed give back their memory, file descriptors and PyBullet clients,
and the library prints nothing on standard output.

Memory is the process's resident set size (``/proc/self/statm``, Linux only); the bounds sit well
between the leak-free growth (allocator noise, under 0.05 MB per cycle) and the leak these tests
guard against (PyBullet keeping every mesh list handed to ``createVisualShape``: 0.6 MB per
camera scene, :data:`soft_gym.engines.pybullet.scene._MESHES_GIVEN`).
"""

from __future__ import annotations

import gc
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pybullet
import pytest
from pybullet_utils import bullet_client

import soft_gym  # noqa: F401  (registers the environment ids)
from soft_gym.engines.pybullet.quiet_import import c_stdout_silenced
from soft_gym.engines.pybullet.scene import build_scene

REPO = Path(__file__).resolve().parents[2]

linux_only = pytest.mark.skipif(not os.path.exists("/proc/self/statm"),
                                reason="reads /proc/self (Linux)")


def _rss_mb() -> float:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def _growth_mb_per_cycle(cycle, warmup: int, cycles: int) -> float:
    for _ in range(warmup):
        cycle()
    gc.collect()
    start = _rss_mb()
    for _ in range(cycles):
        cycle()
    gc.collect()
    return (_rss_mb() - start) / cycles


@linux_only
def test_building_the_camera_scene_again_keeps_no_memory():
    """The scene of a new client (one per env) costs no memory once the client is gone; before
    the mesh lists were shared, each build kept 0.6 MB."""

    def cycle():
        with c_stdout_silenced():
            client = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
        build_scene(client, 0.2, seed=0)
        client.disconnect()

    assert _growth_mb_per_cycle(cycle, warmup=3, cycles=15) < 0.1


@linux_only
@pytest.mark.slow
def test_fused_envs_made_and_closed_keep_no_memory():
    """A fused wang2023 env (camera, scene, FBG, vision, F-emp) made, stepped and closed over and
    over: under 0.15 MB per cycle (0.56-0.65 MB per cycle with the mesh leak)."""

    def cycle():
        env = gym.make("SoftArmTrackWang2023-v0", feedback="fused")
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        env.close()

    assert _growth_mb_per_cycle(cycle, warmup=4, cycles=16) < 0.15


@linux_only
@pytest.mark.parametrize("feedback", ["ground_truth", "fused"])
def test_closed_envs_return_file_descriptors_and_pybullet_clients(feedback):
    def cycle() -> int:
        env = gym.make("SoftArmTrackWang2023-v0", feedback=feedback)
        env.reset(seed=0)
        env.step(env.action_space.sample())
        client_id = env.unwrapped.sim.client._client
        assert pybullet.getConnectionInfo(client_id)["isConnected"]
        env.close()
        return client_id

    cycle()  # first use: imports, calibration cache files
    gc.collect()
    fds = _open_fds()
    closed = [cycle() for _ in range(4)]
    gc.collect()
    assert _open_fds() <= fds
    assert not any(pybullet.getConnectionInfo(i)["isConnected"] for i in closed)


_MAKE_AND_STEP = """
import gymnasium as gym
import soft_gym
for feedback in ("ground_truth", "fused"):
    env = gym.make("SoftArmTrackWang2023-v0", feedback=feedback)
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    env.close()
"""


def test_the_library_prints_nothing_on_stdout():
    """Importing soft_gym, making and stepping envs writes nothing to stdout (PyBullet's
    ``pybullet build time`` and ``argv[0]=`` included) and no banner to stderr, while real
    errors still reach stderr."""
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run([sys.executable, "-c", _MAKE_AND_STEP], capture_output=True,
                            cwd=REPO, env=environment, timeout=300)
    assert result.returncode == 0, result.stderr.decode()
    assert result.stdout == b""
    assert b"pybullet build time" not in result.stderr
    assert b"argv[0]" not in result.stderr
    failing = subprocess.run(
        [sys.executable, "-c", "import soft_gym, sys; sys.stderr.write('real error')"],
        capture_output=True, cwd=REPO, env=environment, timeout=120)
    assert failing.stdout == b"" and failing.stderr == b"real error"


def test_silenced_stdout_keeps_python_output_and_is_restored(capfd):
    with c_stdout_silenced():
        os.write(1, b"from C\n")
        print("from Python")
    os.write(1, b"after\n")
    out, _ = capfd.readouterr()
    assert "from C" not in out
    assert "from Python" in out and "after" in out
