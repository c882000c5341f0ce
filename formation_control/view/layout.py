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
The Foxglove layout of a fleet, built with ``foxglove.layouts``, in two formats.

``foxglove/formation_control.json`` (the Foxglove app's format) and
``foxglove/formation_control.classic.json`` (Foxglove Studio 1.x and Lichtblick: the same
layout by :mod:`formation_control.view.classic`), installed to
``share/formation_control/foxglove/``, are what :func:`layout_json` returns for a fleet in ``/``
with the world frame ``map`` (``formation-control layout --format foxglove|classic`` prints them;
a test checks the files are up to date). Left: a top-down 3D panel in the world frame with the
live view's scene (``/formation/scene``) and the RViz markers (``/formation/markers``; the live
view serves both, a bag records the markers). Right: plots of |p|, V_c, the centre spread and
the speed error, and the diagnostics. A plot names its metric by field
(``/formation/metrics.order_parameter``): a field of the live view's JSON channel and of the
formation_control_msgs/FormationMetrics a bag holds, so the same layout plots both. The topics
are the absolute names a fleet's namespace gives (``formation-control layout --namespace
/fleet_a``: ``/fleet_a/formation/metrics``).
"""
from collections.abc import Sequence
import json

from formation_control.core.errors import UsageError
from formation_control.protocol import names
from formation_control.protocol.node_parameters import WORLD_FRAME
from formation_control.view.classic import classic
import foxglove.layouts as fl

FILES = {'foxglove': 'formation_control.json', 'classic': 'formation_control.classic.json'}
"""The installed layout of each format, in ``share/formation_control/foxglove/``."""

PLOTS = (('order_parameter', '|p| (order parameter)', 0.0, 1.0),
         ('lyapunov', 'V_c (composite Lyapunov value)', 0.0, None),
         ('centre_spread', 'centre spread (m), circular', 0.0, None),
         ('speed_error', 'speed error (m/s), rigid bodies', 0.0, None))
"""(metric, title, y min, y max) of each plot: metrics of :data:`interface.METRIC_DOC`."""


def _plot(metrics: str, metric: str, title: str, low: float,
          high: float | None) -> fl.PlotPanel:
    series = fl.PlotSeries(value=f'{metrics}.{metric}', label=metric, enabled=True,
                           timestamp_method='receiveTime')
    return fl.PlotPanel(title=title, config=fl.PlotConfig(
        paths=[series], min_y_value=low, max_y_value=high, show_legend=False,
        x_axis_val='timestamp'))


def _scene_panel(prefix: str, frame: str) -> fl.ThreeDeePanel:
    camera = fl.ThreeDeeCameraState(perspective=False, distance=10.0, phi=0.0, theta_offset=0.0,
                                    target=(0.0, 0.0, 0.0))
    frames = fl.BaseRendererSceneSettings(transforms=fl.BaseRendererTransforms(
        show_label=False, axis_size=0.3))
    return fl.ThreeDeePanel(title=f'fleet ({frame})', config=fl.ThreeDeeConfig(
        fixed_frame=frame, follow_tf=frame, follow_mode='follow-none', camera_state=camera,
        scene=frames,
        topics={prefix + names.SCENE_TOPIC: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                prefix + names.MARKERS_TOPIC: fl.BaseRendererRosMarkerTopicSettings(
                    visible=True)},
        layers={'grid': fl.BaseRendererGridLayerSettings()}))


def _column(items: Sequence[fl.PlotPanel | fl.DiagnosticsSummaryPanel]) -> fl.SplitContainer:
    return fl.SplitContainer(direction='column', items=[
        fl.SplitItem(proportion=1, content=item) for item in items])


def layout(namespace: str = '/', world_frame: str = WORLD_FRAME) -> fl.Layout:
    """Build the Foxglove layout of the fleet in ``namespace``: a ``foxglove.layouts.Layout``."""
    prefix = names.namespace_prefix(namespace)
    plots = [_plot(prefix + names.METRICS_TOPIC, *spec) for spec in PLOTS]
    diagnostics = fl.DiagnosticsSummaryPanel(
        title='diagnostics', config=fl.DiagnosticsSummaryConfig(
            topic_to_render=names.DIAGNOSTICS_TOPIC, sort_by_level=True))
    return fl.Layout(content=fl.SplitContainer(direction='row', items=[
        fl.SplitItem(proportion=3, content=_scene_panel(prefix, world_frame)),
        fl.SplitItem(proportion=2, content=_column(plots + [diagnostics]))]))


def layout_json(namespace: str = '/', world_frame: str = WORLD_FRAME,
                fmt: str = 'foxglove') -> str:
    """
    Return the layout as indented JSON in the format ``fmt``, one of :data:`FILES`.

    ``foxglove`` is the Foxglove app's format, ``classic`` the one of Foxglove Studio 1.x and
    Lichtblick (:func:`~formation_control.view.classic.classic` of the same layout). The
    defaults give the installed files.
    """
    if fmt not in FILES:
        raise UsageError(f"layout format {fmt!r}: one of {', '.join(FILES)}")
    text = json.loads(layout(namespace, world_frame).to_json())
    return json.dumps(classic(text) if fmt == 'classic' else text, indent=2,
                      sort_keys=True) + '\n'
