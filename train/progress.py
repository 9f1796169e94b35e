"""The training progress bar: steps done, their rate and the time left, on standard error,
refreshed at least every second whether the output is a terminal, a pipe or a log file.

stable-baselines3's own bar (``learn(progress_bar=True)``) draws with ``rich``, which shows
nothing until the run ends when its output is not a terminal (CI, ``> train.log``); this bar is
plain ``tqdm``, which writes as it goes.
"""

from __future__ import annotations

import sys

from stable_baselines3.common.callbacks import BaseCallback
from tqdm.auto import tqdm

REFRESH_S = 1.0
"""Longest wait between two redraws of the bar while steps come in (s)."""


class StepProgress(BaseCallback):
    """A ``tqdm`` bar over the environment steps of one ``learn`` call.

    Args:
        total_steps: the steps this ``learn`` call will take (its ``total_timesteps``; a
            resumed run adds them to the steps it has done).
        description: the bar's label (the algorithm and env).
    """

    def __init__(self, total_steps: int, description: str = "training") -> None:
        super().__init__()
        self.total_steps = int(total_steps)
        self.description = description
        self.bar: tqdm | None = None
        self._start = 0

    def _on_training_start(self) -> None:
        self._start = self.model.num_timesteps
        self.bar = tqdm(total=self.total_steps, desc=self.description, unit="step",
                        mininterval=REFRESH_S, file=sys.stderr, dynamic_ncols=True)

    def _on_step(self) -> bool:
        if self.bar is not None:
            self.bar.update(self.model.num_timesteps - self._start - self.bar.n)
        return True

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
