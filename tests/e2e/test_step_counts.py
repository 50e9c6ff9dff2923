"""The host's "steps with motion" count the walker's steps, by the same rule on both sides.

The module also sends a step packet at every INS reset while the wearer stands
still; :func:`hostlib.track.steps.is_motion_step` leaves those out. Summed from the
wire of a batch replay, the count must equal the ground truth's count of moves
from one rest of the foot to the next (:func:`firmware_sim.app.demo.true_motion_steps`),
for plain walking, turns on the spot, side steps and stairs. Running is the
exception the firmware makes: a reset needs 0.75 s since the last one, and a
runner's strides are shorter, so two strides share one step packet.
"""

from __future__ import annotations

import pytest

from firmware_sim.app.batch import run_replay
from firmware_sim.app.demo import true_motion_steps
from firmware_sim.sensors.imu_array import make_source
from hostlib.files.replay import replay_capture


def summed(name: str, tmp_path):
    source = make_source(name, seed=1)
    wire = tmp_path / f"{name}.bin"
    wire.write_bytes(run_replay(source, announce=None))
    track, _stats = replay_capture(wire)
    return track, true_motion_steps(source.truth)


@pytest.mark.parametrize("name", ["walk", "turn_on_spot", "side_steps", "back_steps", "stairs_up"])
def test_steps_with_motion_equal_the_walkers_steps(name, tmp_path):
    track, walker = summed(name, tmp_path)
    assert track.motion_steps == walker > 0
    assert len(track) > track.motion_steps, "the resets while standing are step packets, not steps"


def test_a_runner_takes_more_steps_than_the_module_reports(tmp_path):
    track, walker = summed("run", tmp_path)
    assert track.motion_steps < walker, "strides closer than 0.75 s share one reset"
