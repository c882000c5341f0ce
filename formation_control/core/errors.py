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
The package's errors: the two every floor raises, defined here, and where the others live.

Defined here (``core``, so every floor may raise them; ``formation-control`` prints their
message and exits 2):

- :class:`ScenarioError` (ValueError): a scenario parameter is missing, unknown or out of its
  range; the message names the parameter and the range.
- :class:`UsageError` (ValueError): a command, file or argument that is not a scenario
  parameter is unusable.

The eleven others, each beside what raises it:

- ``core.stability.DivergenceError`` (ScenarioError): the integration of a run diverged
  (non-finite or exploding state), with the vehicle, the time and the likely cause.
- ``core.graphs.GraphError``, ``core.flowfields.FlowfieldError`` and
  ``core.aircraft.AircraftError`` (ValueError): a communication graph, a flowfield or an
  aircraft that cannot be built from its parameters; the scenario's checks raise each again
  as a ScenarioError.
- ``core.steering.NoLagLimit`` (ScenarioError): an actuator lag asked of a steering law that
  has no derived lag limit; the message names the law.
- ``sim.sweep.SweepError`` (ValueError): a sweep that cannot be planned or resumed (the CLI
  raises it again as a UsageError).
- ``bags.playback.BagError`` (ValueError): a bag that cannot be replayed: missing, not a
  bag, truncated or corrupt (``play`` exits 2).
- ``bags.repair.Truncated`` (Exception): a record of an MCAP file cut short or malformed;
  inside ``repair`` only, which stops reading there.
- ``ops.security.SecurityError`` (ValueError): a TLS fleet's settings or environment that
  cannot be used (exit 2).
- ``ros.bag.RecordError`` (RuntimeError): a bag that could not be created or written.
- ``ros.fits._Short`` (Exception): the bytes end before the message does; inside
  ``ros.fits`` only.
"""
from typing import NoReturn


class ScenarioError(ValueError):
    """A scenario parameter is missing, unknown or out of its allowed range."""


class UsageError(ValueError):
    """A command, file or argument that is not a scenario parameter is unusable (the reason)."""


def refuse(name: str, value: object, allowed: str) -> NoReturn:
    """Raise the ScenarioError of parameter ``name`` = ``value``, with the values it may take."""
    raise ScenarioError(f"parameter '{name}' = {value!r} is invalid: {allowed}")
