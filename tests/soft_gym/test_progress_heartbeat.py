"""soft_gym._progress.heartbeat: a bar keeps being redrawn while one long step runs."""

from __future__ import annotations

import io
import time

import pytest
from tqdm import tqdm

from soft_gym._progress import heartbeat

pytestmark = pytest.mark.smoke


def test_a_long_step_keeps_redrawing_its_bar_and_the_thread_stops_with_the_block():
    stream = io.StringIO()
    bar = tqdm(total=2, desc="long", file=stream, mininterval=0.0)
    drawn_before = stream.getvalue().count("\r")
    with heartbeat(bar, period_s=0.1):
        time.sleep(0.65)  # one step that would otherwise print nothing
        bar.update()
    redraws = stream.getvalue().count("\r") - drawn_before
    after = stream.getvalue()
    time.sleep(0.3)
    bar.close()
    assert redraws >= 4  # about six redraws in 0.65 s at 0.1 s, one for the update
    assert stream.getvalue().startswith(after)  # nothing redrawn once the block ended ...
    assert stream.getvalue()[len(after):].count("\r") <= 1  # ... but the close


def test_a_disabled_bar_gets_no_thread_and_a_bad_period_is_refused():
    bar = tqdm(total=1, disable=True)
    with heartbeat(bar, period_s=0.01):
        time.sleep(0.05)
    with pytest.raises(ValueError, match="period_s must be a positive number"):
        with heartbeat(tqdm(total=1, file=io.StringIO()), period_s=0):
            pass
