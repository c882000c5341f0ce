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
Scenarios: one ROS 2 parameter file drives the offline simulator and the ROS nodes alike.

:func:`load` reads a scenario file and :func:`resolve` validates its values: the parameter
table's own check (:mod:`parameters`), then each feature's, ``check(sc) -> notes`` (refusing
with a ScenarioError that names the parameter, or returning warnings), all before anything
runs. :func:`initial_state` draws the fleet's start.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from os import PathLike
from typing import Any

from formation_control.core import (aircraft, flow, formations, parameters, safety, sensors,
                                    separation, steering, world)
from formation_control.core.errors import ScenarioError
from formation_control.core.geometry import RealArray
from formation_control.core.models import ROW_U, ROW_V
from formation_control.core.parameters import (coerce, DEFAULTS, INIT_ARRAYS, PARAMETER_NAMES,
                                               parse_override, read_params, Scenario)
from formation_control.core.stability import hold_fallback, step_warnings
from formation_control.core.vehicles import vehicle_model
import numpy as np

CHECKS: tuple[Callable[[Scenario], tuple[str, ...]], ...] = (
    parameters.check, steering.check, formations.check, flow.check, sensors.check, world.check,
    aircraft.check, separation.check, safety.check)
"""The checks :func:`resolve` runs, in order: the table's, then each feature's."""


def practical(sc: Scenario) -> bool:
    """Return whether the convergence test is the band test (band, or auto with the world on)."""
    return sc.convergence == 'band' or (sc.convergence == 'auto' and (
        world.active(sc) or sensors.active(sc)))


def resolve(params: Mapping[str, Any]) -> Scenario:
    """
    Build a validated scenario from parameter values.

    Parameters
    ----------
    params : dict
        Parameter name -> value, as a parameter file or ROS gives them (lists for pairs and
        arrays); names left out take the defaults of :data:`parameters.PARAMETERS`, K that of the
        formation (-1 parallel, 1 circular); an aircraft's turn_lag 0 its own
        (:func:`aircraft.tuned`).

    Returns
    -------
    Scenario
        With ``warnings``: the notes of the checks (:data:`CHECKS`) that do not refuse, and
        of the steps (:func:`stability.step_warnings`).

    Raises
    ------
    ScenarioError
        An unknown name, a value of the wrong type or outside its allowed values, or
        parameters that do not fit together; the message names the parameter.

    """
    unknown = sorted(set(params) - set(PARAMETER_NAMES))
    if unknown:
        raise ScenarioError(parameters.unknown(unknown))
    values = {k: coerce(k, v) for k, v in params.items()}
    sc = replace(DEFAULTS, **values)
    if 'K' not in values:
        sc = replace(sc, K=formations.default_K(sc.formation))
    sc = aircraft.tuned(sc)
    notes = tuple(note for check in CHECKS for note in check(sc))
    hold, fallback = hold_fallback(sc)
    if fallback:
        sc, notes = replace(sc, hold_prediction=hold), notes + (fallback,)
    return replace(sc, warnings=notes + tuple(step_warnings(sc)))


def load(path: str | PathLike[str], overrides: Iterable[str] = (), **values: Any) -> Scenario:
    """
    Read, override and validate a scenario.

    Parameters
    ----------
    path : str or path-like
        A ROS 2 parameter file (``/**: ros__parameters: ...``).
    overrides : iterable of str, optional
        ``name:=value`` strings (YAML values, as ``ros2 run -p`` takes them), applied in order.
    **values
        Parameter values applied last; None values are ignored (unset options).

    Returns
    -------
    Scenario
        :func:`resolve` of the result.

    Raises
    ------
    UsageError
        The file cannot be read or is not a parameter file.
    ScenarioError
        :func:`resolve` refuses it.

    """
    params = read_params(path)
    params.update(parse_override(o) for o in overrides)
    params.update({k: v for k, v in values.items() if v is not None})
    return resolve(params)


def initial_state(sc: Scenario) -> RealArray:
    """
    Return the initial state of the fleet.

    Parameters
    ----------
    sc : Scenario
        The scenario (num_vehicles, seed, init_box, init_* arrays, model, u0).

    Returns
    -------
    ndarray, shape (6, N)
        Rows of :mod:`models`: the explicit ``init_*`` arrays where given, else the thesis'
        random draw, seeded by ``seed``: positions uniform in the init_box square centred on
        the origin (m), headings uniform on the circle (rad), turning rates zero, u = u0 (rigid
        bodies), v = 0. Particles always have u = 1, v = 0.

    """
    n = sc.num_vehicles
    rng = np.random.default_rng(sc.seed)
    half = 0.5 * sc.init_box
    model = vehicle_model(sc.model)
    speed = model.speed(sc.u0)
    drawn = (rng.uniform(-half, half, n), rng.uniform(-half, half, n),
             rng.uniform(-np.pi, np.pi, n), np.zeros(n), np.full(n, speed), np.zeros(n))
    X = np.array(drawn)
    for row, name in enumerate(INIT_ARRAYS):
        if getattr(sc, name):
            X[row] = getattr(sc, name)
    if model.particle:
        X[ROW_U], X[ROW_V] = 1.0, 0.0
    return X
