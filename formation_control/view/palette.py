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


"""The colours of the fleet's pictures (RViz markers and the Foxglove scene), as RGBA in 0..1."""

HEADING = (0.1, 0.3, 0.9, 1.0)
VELOCITY = (0.9, 0.1, 0.1, 1.0)
TRAIL = (0.4, 0.4, 0.4, 0.8)
CENTRE = (0.1, 0.7, 0.2, 1.0)
TARGET = (1.0, 0.6, 0.0, 0.8)
LINK = (0.5, 0.2, 0.7, 0.6)
LABEL = (0.0, 0.0, 0.0, 1.0)
DISC = ((0.1, 0.7, 0.2, 0.25), (1.0, 0.6, 0.0, 0.45), (0.9, 0.1, 0.1, 0.6))
"""Each vehicle's safety disc by its separation level: ok, within 2 d_min of a neighbour
(warn), within d_min (error), as the monitor's diagnostics grade them."""
