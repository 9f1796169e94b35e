"""wang2023's visual-disturbance protocols as fault presets: the moving obstacle of Fig. 6 and the
varying lighting of Fig. 7 (``faults="wang2023_occlusion"`` / ``"wang2023_lighting"``)."""

from __future__ import annotations

from soft_gym._validation import require_in_range, require_positive
from soft_gym.sensors.faults import LEDGlare, LowLight, MovingOccluder, VisualFault


def wang2023_occlusion(time_scale: float = 1.0, coverage: float = 0.6, sweep_s: float = 3.0,
                       cover_s: float = 2.0, period_s: float = 6.0) -> list[VisualFault]:
    """The moving-obstacle run of wang2023 Fig. 6 (200 s; times multiplied by ``time_scale``).

    0-100 s undisturbed (①); 100-160 s a hand partly shielding the view while moving (②/③, up
    to ``coverage`` of the view); 160-200 s a hand covering the whole view for ``cover_s``
    (~2 s) once every ``period_s`` (④). ``sweep_s``, ``cover_s`` and ``period_s`` are
    durations of the hand's motion and are not scaled.
    """
    scale = require_positive("time_scale", time_scale)
    return [MovingOccluder(mode="partial", start_s=100.0 * scale, end_s=160.0 * scale,
                           strength=coverage, sweep_s=sweep_s),
            MovingOccluder(mode="full", start_s=160.0 * scale, end_s=200.0 * scale,
                           strength=1.0, cover_s=cover_s, period_s=period_s)]


def wang2023_lighting(time_scale: float = 1.0, weak: float = 0.7) -> list[VisualFault]:
    """The varying-lighting run of wang2023 Fig. 7 (200 s; times multiplied by ``time_scale``).

    Ordinary light (①), then weak light (②): the light falls gradually from 25 s to ``weak`` at
    50 s and stays until 75 s; complete darkness during 75-150 s (steps 1500-3000); ordinary
    light again with a moving LED shining at the camera from 150 to 200 s (③).
    """
    scale = require_positive("time_scale", time_scale)
    weak = require_in_range("weak", weak, 0.0, 1.0)
    schedule = [(25.0 * scale, 0.0), (50.0 * scale, weak), (75.0 * scale, weak),
                (75.0 * scale, 1.0), (150.0 * scale, 1.0)]
    return [LowLight(start_s=25.0 * scale, end_s=150.0 * scale, strength=schedule),
            LEDGlare(start_s=150.0 * scale, end_s=200.0 * scale, strength=1.0)]
