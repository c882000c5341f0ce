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


"""Symmetric patterns through ROS: vehicles need only what they hear and the ids' slots."""
from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.protocol import names
from formation_control.ros import interface as itf
from formation_control.sim import metrics
from formation_control_msgs.msg import FormationMetrics
import pytest
from rosutil import CONFIG, metric_values
from runs import assert_equal_runs, offline_run


@pytest.mark.parametrize('name, overrides', [
    ('particle_circular_splay', ['duration:=3.0']),
    ('rigid_circular_splay', ['duration:=3.0']),
    ('particle_circular_splay', ['graph:=random', 'graph_degree:=3.0', 'graph_seed:=1',
                                 'pattern:=symmetric', 'pattern_M:=4', 'duration:=3.0']),
])
def test_lockstep_pattern_fleet_equals_the_offline_simulator(nodes, tmp_path, name, overrides):
    cfg = CONFIG / f'{name}.yaml'
    offline = offline_run(cfg, overrides)
    assert offline.sc.pattern != 'none'
    assert_equal_runs(nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides), offline)


def test_monitor_publishes_the_phase_moments_and_the_separation(nodes, tmp_path):
    cfg = CONFIG / 'particle_circular_splay.yaml'
    box = nodes.collect(FormationMetrics, names.METRICS_TOPIC, itf.STREAM_QOS)
    nodes.monitor('period:=0.1')
    run = nodes.lockstep_run(cfg, tmp_path / 'run.npz', 'duration:=2.0')
    assert nodes.spin_until(lambda: box, timeout=20)
    values = metric_values(box[-1])
    wanted = [f'phase_order_{m}' for m in range(1, 7)] + ['min_separation']
    assert set(wanted) <= set(values)
    assert 'phase_order_7' not in values                    # m = 1..floor(N/2)
    for m in range(1, 7):
        assert 0 <= values[f'phase_order_{m}'] <= 1 / m + 1e-12
    assert 0 < values['min_separation'] < 10
    ctrl = Controller(scenario.load(cfg))
    final = metrics.snapshot(ctrl, run.X[-1], run.U[-1]).values()
    assert values['phase_order_1'] == pytest.approx(final['phase_order_1'], abs=1e-2)
