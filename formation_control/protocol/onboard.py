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
One vehicle's own controller: its view of itself, and its command from what it heard.

The simulator steps the whole fleet at once (:class:`sim.onboard.OnboardStep`); a vehicle node
commands itself with an :class:`Onboard`, the same step for one vehicle, on the view of the
vehicles it hears. It commands with the flow it has: told (``flow_source: known``) or its own
estimate (:class:`estimation.FlowEstimator`, ``estimated``). A measurement that comes on a second
topic (the local flow, the through-water velocity) is paired with the odometry of the same
stamp (:class:`Pairing`). In real time it predicts its state over its measured delay
(:class:`Delay`).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from formation_control.core.control import Controller
from formation_control.core.geometry import BoolArray, ComplexArray, RealArray
from formation_control.core.laws import View
from formation_control.core.models import ROW_U, ROW_V
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
from formation_control.protocol import names
from formation_control.protocol.messages import state_from_odom_values, ViewRow
from formation_control.sim.backends import backend_of
from formation_control.sim.onboard import OnboardStep
import numpy as np


DELAY_GAIN = 0.1
"""Real time: the weight of each new delay, odometry handed to the node -> command sent (at most
a period), in the running mean the vehicle predicts its state over, with half a period and half
an integration step (the plant applies a command from its next step), before it computes its
command. The stamp -> command latency is not used: a simulated plant that slips behind the wall
clock makes it grow without being a delay in simulated time."""


class Delay:
    """
    How far ahead a vehicle predicts its sampled state: its measured delay and the plant's wait.

    Real time only: each command adds the node's own delay (odometry in -> command out) to a
    running mean (:data:`DELAY_GAIN`), a delay clipped to the control ``period``; ``wait`` is
    added (half an integration step: the plant applies a command from its next step). In
    lockstep nothing is added and :attr:`ahead` stays 0.
    """

    def __init__(self, period: float, wait: float = 0.0, gain: float = DELAY_GAIN) -> None:
        self.period, self.wait, self.gain = period, wait, gain
        self.mean = 0.0

    def add(self, seconds: float) -> None:
        """Take one measured delay (s) into the running mean."""
        self.mean += self.gain * (min(seconds, self.period) - self.mean)

    @property
    def ahead(self) -> float:
        """Return the seconds from the sample to the time its command acts."""
        return self.mean + self.wait


def needs_second_sensor(sc: Scenario) -> str | None:
    """
    Return which per-step message a vehicle pairs with its odometry: 'flow', 'water' or None.

    A known flow that is not uniform comes with each odometry ('flow'); an estimating rigid
    body needs its through-water velocity ('water'); a known uniform flow is latched once and
    a particle knows its own through-water velocity (None).
    """
    if sc.flow_source == 'known':
        return None if sc.flow_model == 'uniform' else 'flow'
    return 'water' if vehicle_model(sc.model).rigid else None


def vehicle_topics(sc: Scenario) -> tuple[str, ...]:
    """
    Return the topics of each vehicle k a fleet flying ``sc`` publishes (``vehicle_k/<name>``).

    Always its odometry, formation state and command; ``flow`` when the flow is known (latched
    or with each odometry), ``water_velocity`` when it pairs its odometry with it
    (:func:`needs_second_sensor`), ``cmd_vel`` when its plant flies an autopilot demand.
    """
    extra = {'flow': sc.flow_source == 'known',
             'water_velocity': needs_second_sensor(sc) == 'water',
             'cmd_vel': backend_of(sc).takes_demand}
    return tuple(t for t in names.VEHICLE_TOPICS if extra.get(t, True))


def sampled_state(second: str | None, values: Sequence[float], other: Any, flow: complex,
                  model: str) -> tuple[RealArray, complex]:
    """
    Return the state column (6,) of an odometry's ODOM_FIELDS ``values``, and its flow.

    ``second`` is :func:`needs_second_sensor`'s answer; ``other`` the second sensor's value:
    the local flow ('flow') or the through-water velocity (u, v) ('water'); ``flow`` the
    flow the vehicle knows otherwise.
    """
    flow = other if second == 'flow' else flow
    X = state_from_odom_values(values, flow, model)
    if second == 'water':
        X[ROW_U], X[ROW_V] = other
    return X, flow


class Pairing:
    """
    The odometry of one step held until the second sensor's message of the same stamp.

    Either may come first (two topics); a newer stamp on either side drops the older one.
    """

    def __init__(self) -> None:
        self.odom: tuple[int, Any] | None = None
        self.other: tuple[int, Any] | None = None

    def add_odometry(self, ns: int, values: Any) -> tuple[int, Any, Any] | None:
        """Hold odometry ``values`` of stamp ns; return (ns, values, other) once paired."""
        self.odom = (ns, values)
        return self._pair()

    def add_other(self, ns: int, value: Any) -> tuple[int, Any, Any] | None:
        """Hold the second sensor's ``value`` of stamp ns; return the pair once paired."""
        self.other = (ns, value)
        return self._pair()

    def _pair(self) -> tuple[int, Any, Any] | None:
        if self.odom is None or self.other is None or self.odom[0] != self.other[0]:
            return None
        pair = (*self.odom, self.other[1])
        self.odom = None
        return pair


class Onboard:
    """
    The controller of one vehicle of scenario ``sc``: the onboard step of one vehicle.

    It is :class:`sim.onboard.OnboardStep` of shape (1,), the step the simulator takes for the
    whole fleet at once, fed what the vehicle measures.

    Attributes
    ----------
    step : sim.onboard.OnboardStep
        Its step: the state ``step.X`` (6, 1) its next command is computed for (its latest
        sampled state predicted to the middle of the hold), the input ``step.U`` (2, 1) it
        holds (its last command).
    sampled : (6, 1) float or None
        Its latest sampled state; None before its first odometry.
    speed_dot : float
        Its own s' (m/s^2) at the predicted state.

    """

    def __init__(self, sc: Scenario) -> None:
        self.step = OnboardStep(sc, (1,))
        self.sampled: RealArray | None = None
        self.speed_dot = 0.0

    @property
    def ctrl(self) -> Controller:
        """Return its controller."""
        return self.step.ctrl

    @property
    def flow(self) -> ComplexArray:
        """Return the flow it commands with, (1,) complex (m/s, map frame): told or estimated."""
        return np.asarray(self.step.flow)

    @property
    def predicted(self) -> RealArray:
        """Return the state (6, 1) it commands for; raises RuntimeError before :meth:`observe`."""
        if self.step.X is None:
            raise RuntimeError('observe a state before commanding')
        return self.step.X

    def retune(self, sc: Scenario) -> None:
        """Take the gains of ``sc`` (changed at run time); the PI integrator carries on."""
        self.step.retune(sc)

    def observe(self, X: RealArray, flow: complex | None = None, v_ground: complex | None = None,
                delay: float = 0.0) -> ViewRow:
        """
        Note the vehicle's sampled state and return what it tells its neighbours.

        Parameters
        ----------
        X : (6,) float
            State x, y, theta, omega, u, v (m, m, rad, rad/s, m/s, m/s).
        flow : complex, optional
            The known local flow (m/s, map frame); the scenario's uniform flow by default;
            ignored by an estimating vehicle.
        v_ground : complex, optional
            The measured ground velocity (m/s, map frame), which an estimating vehicle needs.
        delay : float, optional
            Seconds from the sample to the time its command acts (real time); 0 in lockstep.

        Returns
        -------
        tuple
            ``(r, phase, rate, speed)`` of its particle view at the predicted state (complex m,
            rad, rad/s, m/s).

        """
        step = self.step
        self.sampled = sampled = np.asarray(X, float)[:, None]
        if step.estimator is None:
            told = np.array(np.broadcast_to(step.ctrl.flow(flow), (1,)))
        else:
            told = step.estimate(sampled, np.full(1, v_ground))
        view = step.observe(sampled, told, delay)
        self.speed_dot = float(view.speed_dot[0])
        return view.r[0], view.phase[0], view.rate[0], view.speed[0]

    def command(self, view: View, own: int, members: BoolArray) -> tuple[RealArray, bool]:
        """
        Compute the vehicle's input from the view of the ``members`` it hears.

        Parameters
        ----------
        view : laws.View
            The particle view of the members (this vehicle at index ``own``).
        own : int
            This vehicle's index in ``view``.
        members : (N,) bool
            The fleet's vehicles in the view.

        Returns
        -------
        (u, saturated) : ((2,) float, bool)
            The input column (:func:`control.command_limits` applied) and whether it sits on a
            limit.

        """
        U = self.step.command(view, [own], members)
        return U[:, 0], bool(self.ctrl.saturated(U)[0])
