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

The simulator commands the whole fleet with one :class:`control.Controller`; a vehicle node
commands itself with an :class:`Onboard`, which calls the same controller on the view of the
vehicles it hears.
"""
from formation_control.core.control import Controller
import numpy as np


class Onboard:
    """
    The controller of one vehicle of scenario ``sc``.

    Attributes
    ----------
    X : (6, 1) float or None
        The state its next command is computed for: its latest sampled state predicted to the
        middle of the hold (:meth:`control.Controller.predict`); None before its first odometry.
    U_held : (2, 1) float
        The input it holds (its last command), which the prediction and the full law's view
        read.
    speed_dot : float
        Its own s' (m/s^2) at :attr:`X`.

    """

    def __init__(self, sc):
        self.ctrl = Controller(sc)
        self.X = None
        self.U_held = np.zeros((2, 1))
        self.speed_dot = 0.0

    def retune(self, sc):
        """Take the gains of ``sc`` (changed at run time); the PI integrator carries on."""
        integral = self.ctrl.integral
        self.ctrl = Controller(sc)
        self.ctrl.integral = integral

    def observe(self, X, delay=0.0):
        """
        Note the vehicle's sampled state and return what it tells its neighbours.

        Parameters
        ----------
        X : (6,) float
            State x, y, theta, omega, u, v (m, m, rad, rad/s, m/s, m/s).
        delay : float, optional
            Seconds from the sample to the time its command acts (real time); 0 in lockstep.

        Returns
        -------
        tuple
            ``(r, phase, rate, speed)`` of its particle view at :attr:`X` (complex m, rad,
            rad/s, m/s).

        """
        self.X = self.ctrl.predict(np.asarray(X, float)[:, None], self.U_held, delay)
        view = self.ctrl.view(self.X, self.U_held[1])
        self.speed_dot = float(view.speed_dot[0])
        return view.r[0], view.phase[0], view.rate[0], view.speed[0]

    def command(self, view, own, members):
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
        U = self.ctrl.command(view, self.X, [own], members=members)
        self.U_held = U.copy()
        return U[:, 0], bool(self.ctrl.saturated(U)[0])
