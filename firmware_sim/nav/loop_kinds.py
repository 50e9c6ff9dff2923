"""What the callers of the compiled loop (:func:`firmware_sim.nav.driver.run_loops`) hand it and do
after it, without compiling anything: the sequences it runs, its empty register block, and the
caller's part of a completed alignment (:func:`finish_alignment`)."""

from __future__ import annotations

import numpy as np

from protocol.ids import NR_IMUS

from .ins import InsWork, alignment_quaternion

__all__ = ["ALIGNMENT", "FULL_RATE_INS", "HEIGHT_AFTER_OUTPUT", "NO_SAMPLES", "TRACKING", "TRACKING_HEIGHT",
           "finish_alignment"]

#: The sequences the compiled loop runs: step-wise tracking (0x34), the initial alignment, the
#: full-rate INS (0x33), and tracking with HEIGHT_COMPENSATION.
TRACKING, ALIGNMENT, FULL_RATE_INS, TRACKING_HEIGHT = 1, 2, 3, 4
#: Not a sequence: HEIGHT_COMPENSATION alone, of the loop of TRACKING_HEIGHT in which a step ended
#: (the caller runs it after that loop's STATE_OUTPUT_IF).
HEIGHT_AFTER_OUTPUT = 5
#: An empty register block: the caller has read the loop's sample itself.
NO_SAMPLES = np.zeros((0, NR_IMUS, 6), dtype=np.int16)


def finish_alignment(work: InsWork, quaternion: np.ndarray) -> None:
    """After the compiled loop ran the alignment: the attitude of an alignment it completed, from
    the reference (*work*: the module's INS work, *quaternion*: its QUATERNION state)."""
    if work.attitude_due[0]:
        work.attitude_due[0] = False
        quaternion[...] = alignment_quaternion(work.align_mean.copy())
