"""The training bar is seen while training runs, also when the output is a pipe (CI, a log
file): stable-baselines3's rich bar showed nothing there until the run ended."""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TOTAL = 3072


def _timed_chunks(stream) -> list[tuple[float, bytes]]:
    """Read ``stream`` to its end, noting when each chunk arrived (s, monotonic)."""
    chunks = []
    while True:
        chunk = stream.read1(4096) if hasattr(stream, "read1") else stream.read(4096)
        if not chunk:
            return chunks
        chunks.append((time.monotonic(), chunk))


def test_training_shows_its_steps_as_they_come_through_a_pipe(tmp_path):
    command = [sys.executable, "-m", "train", "--algo", "ppo", "--env", "SoftArmTrackWang2023-v0",
               "--env-kwargs", "feedback=ground_truth", "speed_m_s=0.02", "--timesteps",
               str(TOTAL), "--hyperparams", "n_steps=512", "batch_size=64", "n_epochs=1",
               "--curve-freq", "0", "--eval-freq", "0", "--checkpoint-freq", "0",
               "--out", str(tmp_path)]
    process = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE)
    chunks: list[tuple[float, bytes]] = []
    reader = threading.Thread(target=lambda: chunks.extend(_timed_chunks(process.stderr)))
    reader.start()
    assert process.wait(timeout=600) == 0
    ended = time.monotonic()
    reader.join()
    # every count the bar showed, with when it arrived: "1024/3072"
    seen = [(at, int(done)) for at, chunk in chunks
            for done in re.findall(rf"(\d+)/{TOTAL}\b".encode(), chunk)]
    during = sorted({done for at, done in seen if 0 < done < TOTAL and at < ended})
    assert len(during) >= 2, seen  # the bar moved while training ran, not only at the end
    assert seen and max(done for _, done in seen) == TOTAL
