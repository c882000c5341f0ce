# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""The frames a viewer draws in: map, the world frame and each vehicle's base frame."""
import cmath
import math

from formation_control.view import frames, picture
import numpy as np
import pytest


def _picture(positions, headings):
    return picture.Picture(7, np.asarray(positions), np.asarray(headings), None,
                           [[z] for z in positions], [])


def _rotate(q, z):
    """Rotate the planar vector z by the unit quaternion q = (x, y, z, w) about z."""
    assert q[0] == q[1] == 0
    return z * cmath.exp(2j * math.atan2(q[2], q[3]))


def test_each_vehicle_base_frame_sits_at_its_pose_in_the_world_frame():
    pic = _picture([1 + 2j, -3 + 0.5j], [0.3, -2.5])
    got = frames.fleet_transforms(pic, 'map', 'vehicle_{id}/base_link')
    assert [(t.parent, t.child) for t in got] == [('map', 'vehicle_1/base_link'),
                                                  ('map', 'vehicle_2/base_link')]
    for t, z, theta in zip(got, pic.positions, pic.headings):
        assert complex(*t.translation[:2]) == pytest.approx(z) and t.translation[2] == 0
        assert sum(c * c for c in t.rotation) == pytest.approx(1.0)
        assert _rotate(t.rotation, 1) == pytest.approx(cmath.exp(1j * theta))


def test_map_is_there_above_another_world_frame():
    got = frames.fleet_transforms(_picture([0j], [0.0]), 'odom', 'b{id}')
    assert [(t.parent, t.child) for t in got] == [('map', 'odom'), ('odom', 'b1')]
    assert got[0].translation == (0.0, 0.0, 0.0) and got[0].rotation == (0.0, 0.0, 0.0, 1.0)


@pytest.mark.parametrize('world, static', [('map', []), ('odom', [('map', 'odom')])])
def test_the_static_frames_and_the_vehicles_make_the_fleet_tree(world, static):
    pic = _picture([1j, 2 + 0j], [0.5, 1.0])
    assert [(t.parent, t.child) for t in frames.static_transforms(world)] == static
    moving = frames.vehicle_transforms(pic, world, 'b{id}')
    assert [(t.parent, t.child) for t in moving] == [(world, 'b1'), (world, 'b2')]
    assert frames.static_transforms(world) + moving == frames.fleet_transforms(pic, world, 'b{id}')
