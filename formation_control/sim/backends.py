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
Plant backends: what integrates the fleet between commands, chosen once by name.

The offline simulator's :class:`simulator.Stepper` (and through it the plant node's
:class:`fleet.FleetPlant`) holds each period's inputs on a backend and advances it. Three are
in :data:`BACKENDS`, chosen by :func:`backend_of`:

- ``native``: the nominal model, :func:`models.integrate` (RK4, compiled in a uniform flow);
- ``world``: the native plant with any part of :class:`world.World` on (model mismatch,
  actuators, gusts; :func:`world.active`), one :meth:`world.World.step` per integration step,
  recording each vehicle's gust (:data:`world.GUST_CHANNELS`) when gusts blow;
- ``jsbsim``: JSBSim aircraft under their autopilot (:class:`aircraft.Fleet`), which hold an
  autopilot demand (airspeed, turn rate) and record :data:`aircraft.CHANNELS`.

A new backend is one class here and its entry in the table.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, ClassVar

from formation_control.core import aircraft
from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import integrate, Plant, ROW_OMEGA
from formation_control.core.parameters import Scenario
from formation_control.core.world import active, GUST_CHANNELS, World
import numpy as np

AIRCRAFT_SPREAD_TOL = 0.05
"""Circular, jsbsim: the centre spread a converged fleet stays below, as a share of the radius."""


class PlantBackend(ABC):
    """
    What integrates a fleet (6, N) or a batch of fleets (6, B, N) with the inputs held.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario.
    X0 : ndarray, shape (6, ...)
        The initial state asked for.
    plant : models.Plant
        The nominal plant (the scenario's model and flowfield).
    seeds : sequence of int, optional
        The seed of each fleet of a batch (its random draws); ``sc.seed`` by default.

    Attributes
    ----------
    X0 : ndarray, shape (6, ...)
        The state the backend starts from (an aircraft's after its trim).
    plant : models.Plant
        The nominal plant.
    takes_demand : bool
        Whether it holds an autopilot demand (:meth:`law_input`): the plant node then reads
        ``cmd_vel``, else the law's command ``cmd``.
    mismatched : bool
        Whether its vehicles may be unlike their model: a fleet of a study that diverges in
        it is an outcome, not an error (:class:`simulator.Outcome`).

    """

    takes_demand: ClassVar[bool] = False
    mismatched: ClassVar[bool] = False

    def __init__(self, sc: Scenario, X0: RealArray, plant: Plant,
                 seeds: Sequence[int] | None = None) -> None:
        self.sc, self.X0, self.plant = sc, X0, plant

    def hold(self, X: RealArray, U: RealArray, demand: RealArray | None = None) -> None:
        """
        Hold the inputs ``U`` (2, ...) from the state ``X`` over the next steps.

        ``demand`` (2, ...): the autopilot demand of a backend that :attr:`takes_demand` (NaN:
        that of ``U``); ignored by the others.
        """

    @abstractmethod
    def advance(self, X: RealArray, U: RealArray, step: int, steps: int) -> RealArray:
        """Return the state ``steps`` integration steps on from ``X`` at step ``step``."""

    @property
    def channels(self) -> dict[str, RealArray]:
        """Return what it records beside the state now, arrays of ``X.shape[1:]`` ({}: none)."""
        return {}

    def true_flow(self, flow: ComplexArray) -> ComplexArray:
        """Return the flow the vehicles move in, given the flowfield's ``flow`` at them (m/s)."""
        return flow

    @property
    def gusts(self) -> bool:
        """Return whether gusts the vehicles are not told blow on top of the flowfield."""
        return False

    def law_input(self, omega: RealArray, demand: RealArray) -> RealArray:
        """Return the law's input (2, n) an autopilot ``demand`` stands for at yaw rate omega."""
        raise ValueError(f"parameter 'plant_backend' = {self.sc.plant_backend!r}: the plant "
                         "takes the law's command (cmd), an autopilot demand (cmd_vel) needs "
                         'jsbsim')

    @classmethod
    def spread_tol(cls, sc: Scenario, tol: float) -> float:
        """Return the centre spread (m) a converged circle stays below: ``tol`` by default."""
        return tol

    @classmethod
    def held(cls, sc: Scenario, t: RealArray, X: RealArray,
             channels: dict[str, RealArray]) -> dict[str, Any]:
        """Return what a run's vehicles held beside the formation ({}: nothing to hold)."""
        return {}


class Native(PlantBackend):
    """The nominal model, integrated by :func:`models.integrate`."""

    def hold(self, X: RealArray, U: RealArray, demand: RealArray | None = None) -> None:
        """Hold ``U``; the first-order turn rate is the state omega, so it is written into X."""
        if self.plant.model.first_order:
            X[ROW_OMEGA] = U[1]

    def advance(self, X: RealArray, U: RealArray, step: int, steps: int) -> RealArray:
        """Return :func:`models.integrate` of ``steps`` steps from time ``step dt``."""
        dt = self.sc.dt_integration
        return integrate(X, U, dt, steps, self.plant, step * dt)


class NativeInWorld(PlantBackend):
    """
    The native plant in the world: true vehicles, actuators and gusts (:class:`world.World`).

    Attributes
    ----------
    world : world.World
        What it integrates.

    """

    mismatched = True

    def __init__(self, sc: Scenario, X0: RealArray, plant: Plant,
                 seeds: Sequence[int] | None = None) -> None:
        super().__init__(sc, X0, plant)
        self.world = World(sc, X0.shape[1:], seeds)

    def advance(self, X: RealArray, U: RealArray, step: int, steps: int) -> RealArray:
        """Return the state after ``steps`` :meth:`world.World.step`, each at its own time."""
        for n in range(step, step + steps):
            X = self.world.step(X, U, n * self.sc.dt_integration)
        return X

    def true_flow(self, flow: ComplexArray) -> ComplexArray:
        """Return ``flow`` and each vehicle's gust (m/s)."""
        return flow + self.world.gust

    @property
    def channels(self) -> dict[str, RealArray]:
        """Return each vehicle's gust now (:data:`world.GUST_CHANNELS`; {} without gusts)."""
        if not self.gusts:
            return {}
        return dict(zip(GUST_CHANNELS, (self.world.gust.real.copy(), self.world.gust.imag.copy())))

    @property
    def gusts(self) -> bool:
        """Return whether the world's gusts blow."""
        return bool(self.world.streams)


class JSBSim(PlantBackend):
    """
    JSBSim aircraft under their autopilot (:class:`aircraft.Fleet`), docs/aircraft.md.

    Attributes
    ----------
    fleet : aircraft.Fleet
        The aircraft.

    """

    takes_demand = True

    def __init__(self, sc: Scenario, X0: RealArray, plant: Plant,
                 seeds: Sequence[int] | None = None) -> None:
        self.fleet = aircraft.Fleet(sc, X0)
        super().__init__(sc, self.fleet.X.copy(), plant)

    def hold(self, X: RealArray, U: RealArray, demand: RealArray | None = None) -> None:
        """Hold the autopilot ``demand``; where NaN (or none), :func:`aircraft.turn_demand`."""
        own = aircraft.turn_demand(self.sc, X, U)
        self.fleet.hold(own if demand is None else
                        np.where(np.isnan(demand), own, demand))

    def advance(self, X: RealArray, U: RealArray, step: int, steps: int) -> RealArray:
        """Return the aircraft's state ``steps`` steps on (:meth:`aircraft.Fleet.advance`)."""
        return self.fleet.advance(step * self.sc.dt_integration, steps)

    @property
    def channels(self) -> dict[str, RealArray]:
        """Return :data:`aircraft.CHANNELS` now."""
        return self.fleet.channels

    def law_input(self, omega: RealArray, demand: RealArray) -> RealArray:
        """Return :func:`aircraft.law_input`."""
        return aircraft.law_input(self.sc, omega, demand)

    @classmethod
    def spread_tol(cls, sc: Scenario, tol: float) -> float:
        """Return :data:`AIRCRAFT_SPREAD_TOL` of the radius ``1 / |omega0|`` (m)."""
        return AIRCRAFT_SPREAD_TOL / abs(sc.omega0)

    @classmethod
    def held(cls, sc: Scenario, t: RealArray, X: RealArray,
             channels: dict[str, RealArray]) -> dict[str, Any]:
        """Return :func:`aircraft.held`: a run that left its airspeed or altitude band fails."""
        return aircraft.held(sc, t, X, channels['altitude']) if 'altitude' in channels else {}


BACKENDS: dict[str, type[PlantBackend]] = {'native': Native, 'world': NativeInWorld,
                                           'jsbsim': JSBSim}
"""The plant backends by name."""


def backend_of(sc: Scenario) -> type[PlantBackend]:
    """
    Return the backend of a scenario: its ``plant_backend``, or ``world`` when any part is on.

    The world's parts are native only (:mod:`scenario` refuses them with jsbsim).
    """
    return BACKENDS['world' if active(sc) else sc.plant_backend]
