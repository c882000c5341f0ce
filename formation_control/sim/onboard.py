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
The onboard step of the vehicles: observe, predict, view, command.

Each control period a vehicle takes the flow it has (told, or its estimate,
:meth:`OnboardStep.estimate`), filters its sampled state (``position_filter``), predicts it to
the middle of the hold (:meth:`control.Controller.predict`) and shares the particle view of it
(:meth:`OnboardStep.observe`); from the views it hears it computes its command and holds it
(:meth:`OnboardStep.command`). The arrays have any vehicle shape: the offline simulator steps
a fleet (N,) or a batch (B, N) at once (:class:`simulator.Stepper`), a vehicle node itself (1,)
(:class:`onboard.Onboard`), with the same numbers.
"""
from __future__ import annotations

from formation_control.core.control import Controller
from formation_control.core.estimation import FlowEstimator
from formation_control.core.geometry import BoolArray, ComplexArray, RealArray
from formation_control.core.laws import Index, View
from formation_control.core.navigation import flow_input, PositionFilter
from formation_control.core.parameters import Scenario
import numpy as np


class OnboardStep:
    """
    The controllers of vehicles of ``shape`` (N,), (B, N) or (1,).

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario.
    shape : tuple of int
        The vehicles' shape.

    Attributes
    ----------
    ctrl : control.Controller
        Their controller.
    U : ndarray, shape (2,) + shape
        The inputs they hold (their last commands), which the prediction and the full law's
        view read.
    X : ndarray, shape (6,) + shape, or None
        The states their next commands are computed for (:meth:`observe`).
    flow : complex or ndarray of complex, shape ``shape``
        The flow they command with (m/s, map frame): the known local flow or the estimate.
    ahead : complex or ndarray of complex
        That flow carried to ``X`` (:meth:`control.Controller.flow_ahead`).
    estimator : estimation.FlowEstimator or None
        Their flow estimator (``flow_source: estimated``).
    navigator : navigation.PositionFilter or None
        Their position filter (``position_filter: kalman``).

    """

    def __init__(self, sc: Scenario, shape: tuple[int, ...]) -> None:
        self.ctrl = Controller(sc)
        self.U: RealArray = np.zeros((2,) + shape)
        self.X: RealArray | None = None
        self.flow: complex | ComplexArray = np.full(shape, complex(sc.flow_c))
        self.ahead: complex | ComplexArray = self.flow
        self.estimator = FlowEstimator(sc, shape) if sc.flow_source == 'estimated' else None
        self.navigator = PositionFilter(sc, self.ctrl.still) \
            if sc.position_filter == 'kalman' else None

    def retune(self, sc: Scenario) -> None:
        """Take the gains of ``sc`` (changed at run time); the PI integrator carries on."""
        integral = self.ctrl.integral
        self.ctrl = Controller(sc)
        self.ctrl.integral = integral
        if self.estimator is not None:
            self.estimator.retune(sc)

    def estimate(self, X: RealArray, v_ground: ComplexArray,
                 near: ComplexArray | None = None) -> ComplexArray:
        """
        Update the flow estimates from the measured states and ground velocities; return them.

        Parameters
        ----------
        X : ndarray, shape (6,) + shape
            The measured states.
        v_ground : ndarray of complex, shape ``shape``
            The measured ground velocities (m/s, map frame); with the position filter its
            estimator takes the filter's velocities (:func:`navigation.flow_input`).
        near : ndarray of complex, optional
            The neighbours' mean estimate (``flow_consensus``).

        Returns
        -------
        ndarray of complex, shape ``shape``
            A copy of the estimates (:meth:`estimation.FlowEstimator.update`).

        """
        if self.estimator is None:
            raise RuntimeError('the vehicles are told the flow (flow_source: known)')
        ground, v_rel = flow_input(self.navigator, X, v_ground, self.U)
        return self.estimator.update(X, ground, near, v_rel).copy()

    def observe(self, X: RealArray, flow: complex | ComplexArray,
                delay: float = 0.0) -> View:
        """
        Take the sampled states and the flow the vehicles have; return their particle view.

        Parameters
        ----------
        X : ndarray, shape (6,) + shape
            The sampled (measured) states.
        flow : complex or ndarray of complex
            The flow each vehicle has at its sample (m/s).
        delay : float, optional
            Seconds from the sample to the time the command acts (real time); 0 in lockstep.

        Returns
        -------
        laws.View
            The view of the states :meth:`control.Controller.predict` gives (kept in ``X``),
            filtered first with the position filter.

        """
        self.flow = flow
        if self.navigator is not None:
            X = self.navigator.update(X, self.U, flow)
        self.X = self.ctrl.predict(X, self.U, flow, delay)
        self.ahead = self.ctrl.flow_ahead(X, flow, delay)
        return self.ctrl.view(self.X, self.U[1], self.ahead)

    def command(self, view: View, idx: Index = slice(None),
                members: BoolArray | None = None) -> RealArray:
        """
        Return the commands of the vehicles ``idx`` from ``view``, and hold them.

        ``view`` holds the vehicles heard (``members`` of the fleet, by default all); the
        commands are :meth:`control.Controller.command` at the predicted states.
        """
        if self.X is None:
            raise RuntimeError('observe a state before commanding')
        U = self.ctrl.command(view, self.X, idx, members=members, flow=self.ahead)
        self.U = U.copy()
        return U
