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

"""
The Foxglove layout of a fleet, built with ``foxglove.layouts``.

``foxglove/formation_control.json`` (installed to ``share/formation_control/foxglove/``) is
what :func:`layout_json` returns (``formation-control layout`` prints it; a test checks the
file is up to date). Left: a top-down 3D panel in ``map`` with the live view's scene
(``/formation/scene``) and the RViz markers of a bag (``/formation/markers``). Right: plots of
|p|, V_c, the centre spread and the speed error, and the diagnostics.
"""
import json

from formation_control.ros import interface as itf
import foxglove.layouts as fl

SCENE, MARKERS, METRICS = itf.SCENE_TOPIC, itf.MARKERS_TOPIC, itf.METRICS_TOPIC
DIAGNOSTICS = itf.DIAGNOSTICS_TOPIC
PLOTS = (('order_parameter', '|p| (order parameter)', 0.0, 1.0),
         ('lyapunov', 'V_c (composite Lyapunov value)', 0.0, None),
         ('centre_spread', 'centre spread (m), circular', 0.0, None),
         ('speed_error', 'speed error (m/s), rigid bodies', 0.0, None))
"""(metric, title, y min, y max) of each plot: metrics of :data:`interface.METRIC_DOC`."""


def _plot(metric, title, low, high):
    series = fl.PlotSeries(value=f'{METRICS}.{metric}', label=metric,
                           timestamp_method='receiveTime')
    return fl.PlotPanel(title=title, config=fl.PlotConfig(
        paths=[series], min_y_value=low, max_y_value=high, show_legend=False,
        x_axis_val='timestamp'))


def _scene_panel():
    camera = fl.ThreeDeeCameraState(perspective=False, distance=20.0, phi=0.0,
                                    target=(0.0, 0.0, 0.0))
    return fl.ThreeDeePanel(title='fleet (map)', config=fl.ThreeDeeConfig(
        fixed_frame='map', follow_tf='map', follow_mode='follow-none', camera_state=camera,
        topics={SCENE: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                MARKERS: fl.BaseRendererRosMarkerTopicSettings(visible=True)},
        layers={'grid': fl.BaseRendererGridLayerSettings()}))


def _column(items):
    return fl.SplitContainer(direction='column', items=[
        fl.SplitItem(proportion=1, content=item) for item in items])


def layout():
    """Build the fleet's Foxglove layout: a ``foxglove.layouts.Layout``."""
    plots = [_plot(*spec) for spec in PLOTS]
    diagnostics = fl.DiagnosticsSummaryPanel(
        title='diagnostics', config=fl.DiagnosticsSummaryConfig(topic_to_render=DIAGNOSTICS,
                                                                sort_by_level=True))
    return fl.Layout(content=fl.SplitContainer(direction='row', items=[
        fl.SplitItem(proportion=3, content=_scene_panel()),
        fl.SplitItem(proportion=2, content=_column(plots + [diagnostics]))]))


def layout_json():
    """Return the layout as the indented JSON of ``foxglove/formation_control.json``."""
    return json.dumps(json.loads(layout().to_json()), indent=2, sort_keys=True) + '\n'
