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

"""The package's errors: one for a scenario parameter, one for any other misuse."""
from typing import NoReturn


class ScenarioError(ValueError):
    """A scenario parameter is missing, unknown or out of its allowed range."""


class UsageError(ValueError):
    """A command, file or argument that is not a scenario parameter is unusable (the reason)."""


def refuse(name: str, value: object, allowed: str) -> NoReturn:
    """Raise the ScenarioError of parameter ``name`` = ``value``, with the values it may take."""
    raise ScenarioError(f"parameter '{name}' = {value!r} is invalid: {allowed}")
