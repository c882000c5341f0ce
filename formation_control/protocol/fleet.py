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
The plant's fleet: the sampled-data loop of the offline simulator driven command by command.

The ``plant`` node holds each vehicle's latest command here, and :class:`FleetPlant` holds them
over the integration steps (:class:`simulator.Stepper`), records every ``record_dt``
(:class:`simulator.Recorder`) and stops a vehicle whose state turns non-finite: frozen at its
last finite state, zero command, no more odometry; the others go on.
:func:`stability.likely_cause` names why.

The stepper's plant backend (:mod:`backends`) integrates. Aircraft (``plant_backend: jsbsim``,
a backend that :attr:`~backends.PlantBackend.takes_demand`) take either: the law's command
(:meth:`FleetPlant.set_command`, its autopilot demand :func:`aircraft.turn_demand` of the state
at the hold, as the offline simulator) or the autopilot demand itself
(:meth:`FleetPlant.set_demand`, what the plant node reads on ``cmd_vel``), which is held as
sent and recorded as the law's input it stands for against the yaw rate of the odometry last
sent (:meth:`~backends.PlantBackend.law_input`).
"""
from __future__ import annotations

from typing import Any

from formation_control.core import stability
from formation_control.core.geometry import BoolArray, ComplexArray, IntArray, RealArray
from formation_control.core.models import ROW_OMEGA, ROW_THETA, ROW_U, ROW_V
from formation_control.core.parameters import Scenario
from formation_control.protocol.messages import odom_values
from formation_control.sim.simulator import Recorder, Run, Stepper
import numpy as np
from numpy.typing import ArrayLike


class FleetPlant:
    """
    Held commands, integration and record of a scenario's fleet.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario (model, fleet size, periods, duration).

    Attributes
    ----------
    n : int
        Index of the control period under way (simulated time ``n * dt_control``).
    pending : (2, N) float
        The latest command of each vehicle, held from the next period boundary (or step).
    stopped : (N,) bool
        Vehicles stopped by a non-finite state.
    estimates : (T, N) complex or None
        The flow estimates the vehicles sent for each recorded step (NaN: not heard), once one
        is heard.
    demand : (2, N) float
        Aircraft: the autopilot demand each vehicle sent (airspeed, turn rate); NaN: that of
        its ``pending`` command.
    told_rate : (N,) float
        The yaw rate of the odometry last sent to each vehicle (rad/s).

    """

    def __init__(self, sc: Scenario) -> None:
        self.sc = sc
        self.stepper = Stepper(sc)
        self.recorder = Recorder(sc)
        self.n = 0
        self.pending = np.zeros((2, sc.num_vehicles))
        self.stopped = np.zeros(sc.num_vehicles, bool)
        self.estimates: ComplexArray | None = None
        self.demand = np.full((2, sc.num_vehicles), np.nan)
        self.told_rate = self.stepper.X[ROW_OMEGA].copy()

    @property
    def X(self) -> RealArray:
        """(6, N) state of the fleet."""
        return self.stepper.X

    @property
    def time(self) -> float:
        """Return the simulated time of the period under way (s)."""
        return self.n * self.sc.dt_control

    def local_flow(self) -> ComplexArray:
        """Return the flowfield at each vehicle now, (N,) complex (m/s, world frame)."""
        return self.stepper.local_flow()

    def odometry(self, which: IntArray) -> list[tuple[tuple[float, ...], RealArray]]:
        """
        Return the odometry of the vehicles ``which``: their ODOM_FIELDS and water velocity.

        Each as :func:`messages.odom_values` writes it and the (6,) column whose u, v the
        water_velocity message carries: of the true state, or with sensors
        (:mod:`sensors`) of what each vehicle measures, the sample the simulator commands from.
        """
        out = self._odometry(which)
        for i, (values, _) in zip(which, out):
            self.told_rate[i] = values[-1]
        return out

    def _odometry(self, which: IntArray) -> list[tuple[tuple[float, ...], RealArray]]:
        stepper = self.stepper
        if stepper.sensors is None:
            X, flow = stepper.X, stepper.true_flow()
            return [(odom_values(X[:, i], flow[i]), X[:, i]) for i in which]
        seen = stepper.sample()
        out = []
        for i in which:
            column = seen.X[:, i].copy()
            body = seen.v_ground[i] * np.exp(-1j * column[ROW_THETA])
            column[ROW_U], column[ROW_V] = body.real, body.imag
            water = column.copy()
            water[ROW_U], water[ROW_V] = seen.water[:, i]
            out.append((odom_values(column, 0.0), water))
        return out

    def true_flow(self) -> ComplexArray:
        """Return the flow each vehicle moves in now, gusts included, (N,) complex (m/s)."""
        return self.stepper.true_flow()

    def next_period(self) -> None:
        """Go on to the next control period (lockstep, once one is integrated)."""
        self.n += 1

    def reach_tick(self, tick: int) -> None:
        """Real time: the period under way is the one of integration step ``tick``."""
        self.n = tick // self.sc.substeps

    def set_command(self, i: int, u: ArrayLike) -> None:
        """Hold ``u`` (2,) as vehicle index ``i``'s command from the next step on."""
        self.pending[:, i] = u
        self.demand[:, i] = np.nan

    def set_demand(self, i: int, demand: ArrayLike) -> None:
        """
        Hold an aircraft's autopilot ``demand`` (airspeed m/s, turn rate rad/s) from the next step.

        Vehicle index ``i``'s command becomes the law's input it stands for, against the yaw
        rate it was last told (:func:`aircraft.law_input`), for the record. A backend that
        takes no demand raises ValueError (:meth:`backends.PlantBackend.law_input`).
        """
        law_input = self.stepper.backend.law_input(self.told_rate[[i]],
                                                   np.asarray(demand, float)[:, None])
        self.demand[:, i] = demand
        self.pending[:, i] = law_input[:, 0]

    def hold(self, off: BoolArray, boundary: bool) -> bool:
        """
        Hold the pending commands (zero for the vehicles ``off`` and the stopped ones).

        At a period ``boundary`` the state and held command are recorded, and the run ends once
        the last period is recorded.

        Returns
        -------
        bool
            False when the run is over (nothing more to integrate).

        """
        off = np.asarray(off) | self.stopped
        self.pending[:, off] = 0.0
        self.demand[:, off] = np.nan
        held = self.stepper.hold(self.pending, self.demand)
        if boundary:
            self.recorder.record(self.n, self.stepper.X, held, channels=self.stepper.channels)
            if self.n >= self.recorder.steps:
                return False
        return True

    def integrate(self, steps: int | None = None) -> IntArray:
        """
        Integrate one control period (or ``steps`` integration steps) with the held commands.

        Returns
        -------
        (k,) int
            Indices of the vehicles whose state diverged in this integration (non-finite or
            exploding, :func:`stability.diverging`): they are stopped at their last state
            before it.

        """
        before = self.stepper.X
        with np.errstate(invalid='ignore', over='ignore'):  # a vehicle diverging
            after = self.stepper.advance(steps)              # a new array
        bad = stability.diverging(after) & ~self.stopped
        self.stopped |= bad
        after[:, self.stopped] = before[:, self.stopped]
        return np.flatnonzero(bad)

    def estimate(self, i: int, n: int, value: complex) -> None:
        """Keep the flow a vehicle estimates at step n (complex m/s); ``i`` is its index."""
        if self.recorder.keeps(n):
            if self.estimates is None:
                self.estimates = np.full((self.recorder.size, self.sc.num_vehicles),
                                         complex(np.nan, np.nan))
            self.estimates[self.recorder.index(n), i] = value

    def run(self, meta: dict[str, Any]) -> Run:
        """
        Return the recorded :class:`simulator.Run`, with ``meta`` (mode, wall time, ...).

        With the vehicles' flow estimates, its ``flow_hat`` holds them at the recorded steps.
        """
        run = self.recorder.run()
        run.meta = meta
        if self.estimates is not None:
            run.flow_hat = self.estimates[:self.recorder.count]
        return run
