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
The live view in a real browser, as a user of Foxglove Studio or Lichtblick sees it.

Foxglove Studio's open-source web bundle (``@foxglove/studio-base`` 1.48.0, npm, with React 17)
is mounted by a host page of ours (test/browser/index.html: an in-memory layout store holding
``foxglove/formation_control.classic.json``) in headless Chromium (Debian's), driven over the
DevTools protocol by playwright-core (test/browser/drive.js), connected with
``?ds=foxglove-websocket&ds.url=ws://127.0.0.1:PORT`` (the ``foxglove.websocket.v1``
subprotocol) to ``formation-control swarm config/rigid_circular.yaml --foxglove PORT --mode
realtime`` (stopped when the test ends). The app must list every channel with its schema and no
problem, draw data in each plot and the five vehicles in the 3D panel. The screenshot stays in
build/browser/app.png. ``make setup-browser`` installs chromium and the npm packages;
without them the test skips and says which is missing.
"""
import functools
import http.server
import json
import os
from pathlib import Path
import shutil
import socket
import subprocess
import threading
import time

from formation_control.view import layout
import matplotlib.image
import numpy as np
import pytest
from rosutil import CONFIG

ROOT = Path(__file__).resolve().parents[2]
BROWSER = ROOT / 'test' / 'browser'
ARTEFACTS = ROOT / 'build' / 'browser'
CHROMIUM = shutil.which('chromium') or '/usr/bin/chromium'
NODE = shutil.which('node')
MODULES = [BROWSER / 'node_modules' / m for m in (
    '@foxglove/studio-base/assets/index.js', 'react/umd/react.production.min.js',
    'react-dom/umd/react-dom.production.min.js', 'playwright-core/package.json')]


def _missing():
    if NODE is None:
        return 'node is not installed'
    if not os.access(CHROMIUM, os.X_OK):
        return 'chromium is not installed'
    absent = [str(m.relative_to(BROWSER)) for m in MODULES if not m.exists()]
    return f'the npm packages of test/browser are not installed ({absent[0]})' if absent else None


pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(_missing() is not None,
                                 reason=f'{_missing()}: run make setup-browser')]

CHANNELS = {'/formation/scene': 'foxglove.SceneUpdate',
            '/formation/metrics': 'formation_control.Metrics',
            '/diagnostics': 'diagnostic_msgs/msg/DiagnosticArray',
            '/formation/markers': 'visualization_msgs/msg/MarkerArray',
            '/tf': 'tf2_msgs/msg/TFMessage'}
SCENE = 'fleet (map)'
PLOTS = [title for _, title, _, _ in layout.PLOTS]
NUM_VEHICLES = 5


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _wait_listening(port, proc, timeout=60.0):
    end = time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < end:
        with socket.socket() as s:
            if s.connect_ex(('127.0.0.1', port)) == 0:
                return
        time.sleep(0.1)
    raise AssertionError(f'the live view did not listen on {port}')


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _panel(image, box):
    """Return the pixels of a panel's box in the screenshot (integer RGB)."""
    x, y, w, h = (int(round(box[k])) for k in ('x', 'y', 'width', 'height'))
    return (image[y:y + h, x:x + w, :3] * 255).astype(int)


def _blobs(mask, least=10):
    """Count the 8-connected regions of a boolean image with ``least`` pixels or more."""
    todo = set(zip(*np.nonzero(mask)))
    sizes = []
    while todo:
        stack = [todo.pop()]
        sizes.append(0)
        while stack:
            i, j = stack.pop()
            sizes[-1] += 1
            for near in ((i + a, j + b) for a in (-1, 0, 1) for b in (-1, 0, 1)):
                if near in todo:
                    todo.remove(near)
                    stack.append(near)
    return sum(size >= least for size in sizes)


def _heading_arrows(pixels):
    """Count the blobs of the heading arrows' blue (palette.HEADING, shaded), not the grid's."""
    r, g, b = np.moveaxis(pixels, -1, 0)
    return _blobs((r < 90) & (g < 110) & (b > 170))


def _plotted(pixels):
    """Count the pixels of a plotted series (line, points): blue, where axes and grid are grey."""
    r, g, b = np.moveaxis(pixels, -1, 0)
    return int(((b - r > 60) & (b - g > 20)).sum())


@pytest.fixture
def site():
    """Serve the source tree (the host page, its packages, the layout) on a loopback port."""
    server = http.server.ThreadingHTTPServer(
        ('127.0.0.1', 0), functools.partial(_Quiet, directory=str(ROOT)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f'http://127.0.0.1:{server.server_address[1]}'
    server.shutdown()
    thread.join()
    server.server_close()


def test_studio_lists_the_channels_plots_the_metrics_and_draws_the_fleet(ros, site):
    port = _free_port()
    swarm = ros.procs.start('formation-control', 'swarm', CONFIG / 'rigid_circular.yaml',
                            '--foxglove', port, '--mode', 'realtime', '--duration', '600')
    _wait_listening(port, swarm)
    url = (f'{site}/test/browser/index.html?ds=foxglove-websocket&ds.url=ws://127.0.0.1:{port}'
           f'&layoutId=formation_control&layout=/foxglove/{layout.FILES["classic"]}')
    if ARTEFACTS.exists():
        shutil.rmtree(ARTEFACTS)
    ARTEFACTS.mkdir(parents=True)
    run = subprocess.run([NODE, 'drive.js', url, CHROMIUM, str(ARTEFACTS),
                          json.dumps(list(CHANNELS)), json.dumps([SCENE, *PLOTS]), '90'],
                         cwd=BROWSER, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    seen = json.loads(run.stdout)
    assert seen['listed'], f"not all of {list(CHANNELS)} listed:\n{seen['text'][:2000]}"
    for topic, schema in CHANNELS.items():
        assert f'{topic}\n{schema}' in seen['text']
    assert 'No problems found' in seen['problems'], seen['problems'][:2000]
    assert not [e for e in seen['errors'] if 'Failed to load resource' not in e], seen['errors']
    assert [url.rsplit('/', 1)[1] for url in seen['failed']] in ([], ['favicon.ico'])
    assert 'formation_control/formation' in seen['text']          # the diagnostics panel
    image = matplotlib.image.imread(ARTEFACTS / 'app.png')
    boxes = seen['panels']
    assert all(boxes[title] for title in [SCENE, *PLOTS]), boxes
    for title in PLOTS:
        assert _plotted(_panel(image, boxes[title])) > 50, f'nothing plotted in {title!r}'
    assert _heading_arrows(_panel(image, boxes[SCENE])) >= NUM_VEHICLES
